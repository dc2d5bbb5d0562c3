"""Two runs of a case compared: what differs between their results, byte for byte.

`tunnelquake compare A B` (A and B: results folders, or the case files whose results they hold)
compares every results_<condition>.h5 dataset and attribute (the bytes as stored), the monitors' CSV
files and the report, leaving out what is not a result: the /timings group, attributes that hold
wall-clock seconds (names ending in `_s`) or the run's own paths (`input`, `mesh`), report lines that
quote wall-clock figures, and the results folder's own path where the report names it. Two
results files (`.h5`) are compared alone; a results file and a folder, against the folder's file
of that name. A folder that a run is writing, or a file a solver holds, is refused naming them.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: report lines that carry wall-clock time (not results)
_REPORT_NOT_RESULTS = re.compile(r"wall[- ]clock|wall time|coupled wall|elapsed|run time|steps/s|\bETA\b",
                                 re.IGNORECASE)


def _not_a_result(name: str) -> bool:
    """Attributes that hold wall-clock figures or the run's own paths."""
    return name.endswith("_s") or name in ("input", "mesh")


def _bytes(v) -> bytes:
    """A value as bytes: numbers as stored, strings by their text (not their object pointers)."""
    a = np.asarray(v)
    if a.dtype.kind == "O":
        return repr([x.decode() if isinstance(x, bytes) else str(x) for x in a.reshape(-1)]).encode()
    return a.tobytes()


class CompareError(Exception):
    """What keeps two runs from being compared (a folder being written, a file that does not open);
    the message names it and what to do."""


def _open(path: Path):
    """A results file opened for reading, or CompareError saying why it cannot be."""
    import h5py

    path = Path(path)
    try:
        return h5py.File(path, "r")
    except OSError as e:
        text = str(e)
        if isinstance(e, BlockingIOError) or "unable to lock file" in text:
            raise CompareError(f"{path} is locked by the process writing it (a solver still running): compare it "
                               "once its run has ended") from None
        if not path.is_file():
            raise CompareError(f"{path}: no such file") from None
        raise CompareError(f"{path} does not open as an HDF5 results file ({text.splitlines()[0][:200]})") from None


def results_differences(a_path: Path, b_path: Path) -> list[str]:
    """Every dataset and attribute that differs between two results files (bytes compared); /timings
    (wall times, steps of this process) left out. Empty when they are equal. CompareError when one
    of them cannot be opened."""
    import contextlib

    import h5py

    out: list[str] = []
    with contextlib.ExitStack() as stack:
        a = stack.enter_context(_open(a_path))
        b = stack.enter_context(_open(b_path))

        def attrs(name, x, y):
            for k in sorted(set(x.attrs) | set(y.attrs)):
                if _not_a_result(k):
                    continue
                if k not in x.attrs or k not in y.attrs:
                    out.append(f"{name} attr {k}: only in one")
                elif _bytes(x.attrs[k]) != _bytes(y.attrs[k]):
                    out.append(f"{name} attr {k}: {x.attrs[k]!r} != {y.attrs[k]!r}")

        names_a, names_b = [], []
        a.visit(names_a.append)
        b.visit(names_b.append)
        keep = [n for n in names_a if not n.startswith("timings")]
        if sorted(keep) != sorted(n for n in names_b if not n.startswith("timings")):
            out.append(f"objects differ: {sorted(set(names_a) ^ set(names_b))[:10]}")
        attrs("/", a, b)
        for n in keep:
            if n not in b:
                continue
            x, y = a[n], b[n]
            attrs(n, x, y)
            if isinstance(x, h5py.Dataset):
                if x.shape != y.shape or x.dtype != y.dtype:
                    out.append(f"{n}: shape {x.shape} {x.dtype} != {y.shape} {y.dtype}")
                elif _bytes(x[()]) != _bytes(y[()]):
                    out.append(f"{n}: values differ (largest difference {_largest_difference(x[()], y[()])})")
    return out


def _largest_difference(x, y) -> str:
    """The largest absolute difference of two numeric arrays, and its share of the first's largest |value|."""
    try:
        fx, fy = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        return "not numbers"
    d = float(np.nanmax(np.abs(fx - fy), initial=0.0))
    scale = float(np.nanmax(np.abs(fx), initial=0.0))
    return f"{d:.3g}, {d / scale:.3g} of the largest |value|" if scale > 0 else f"{d:.3g}"


def _report_lines(path: Path) -> list[str]:
    """The report's lines that are results: the run's own folder written as <run>, wall-clock lines left out."""
    folder = str(path.parent.resolve())
    return [ln.replace(folder, "<run>") for ln in path.read_text(encoding="utf-8").splitlines()
            if not _REPORT_NOT_RESULTS.search(ln)]


@dataclass
class Comparison:
    """The outcome: the files compared and, per file, what differs."""
    compared: list[str] = field(default_factory=list)
    differences: dict[str, list[str]] = field(default_factory=dict)
    only_in_one: list[str] = field(default_factory=list)

    @property
    def equal(self) -> bool:
        return bool(self.compared) and not self.differences and not self.only_in_one


def results_folder(p: Path) -> Path:
    """A results folder given itself or the case file (or case folder) whose results it holds."""
    p = Path(p)
    if p.is_dir() and any(p.glob("results_*.h5")):
        return p
    case = p / "case.yaml" if p.is_dir() else p
    if case.is_file():
        from .case import CaseError, load_case
        from .case_file import screen_case_file

        problem = screen_case_file(case)
        if problem is None:
            try:
                return load_case(case).output_dir
            except CaseError as e:
                problem = str(e)
        raise FileNotFoundError(f"{p}: neither a results folder (results_<condition>.h5), a results file (.h5) nor a "
                                f"case file that loads: {problem}")
    raise FileNotFoundError(f"{p}: neither a results folder (results_<condition>.h5) nor a case file")


def _is_h5(p: Path) -> bool:
    """Whether `p` is a file that starts with HDF5's signature (a results file given by its path)."""
    try:
        with open(p, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


def _not_being_written(folder: Path) -> None:
    """CompareError when a tunnelquake command holds `folder` (a run writing its results)."""
    from .runlock import describe, holder

    who = holder(folder)
    if who is not None:
        raise CompareError(f"{folder} is being written by a running tunnelquake command ({describe(who)}): its results "
                           "are not final; compare once it has ended")


def compare_runs(a: Path, b: Path) -> Comparison:
    """Compare two results folders: results files, monitors' CSV files and the report. Two results
    files are compared alone; a results file and a folder: the file against the folder's file of
    that name (or the file a case writes there)."""
    a, b = Path(a), Path(b)
    if _is_h5(a) or _is_h5(b):
        files = [p if _is_h5(p) else None for p in (a, b)]
        other = next(p for p in files if p is not None).name
        pair = [p if p is not None else results_folder(q) / other for p, q in zip(files, (a, b), strict=True)]
        for p in pair:
            _not_being_written(p.parent)
        c = Comparison(compared=[other if pair[0].name == pair[1].name else f"{pair[0].name} / {pair[1].name}"])
        diff = results_differences(pair[0], pair[1])
        if diff:
            c.differences[c.compared[0]] = diff
        return c
    a, b = results_folder(a), results_folder(b)
    for folder in (a, b):
        _not_being_written(folder)
    c = Comparison()
    patterns = ("results_*.h5", "monitors_*.csv", "report.md")
    for pattern in patterns:
        names_a = {p.name for p in a.glob(pattern)}
        names_b = {p.name for p in b.glob(pattern)}
        c.only_in_one += sorted(names_a ^ names_b)
        for name in sorted(names_a & names_b):
            c.compared.append(name)
            if name.endswith(".h5"):
                diff = results_differences(a / name, b / name)
            elif name.endswith(".csv"):
                diff = [] if (a / name).read_bytes() == (b / name).read_bytes() else ["bytes differ"]
            else:
                import difflib

                la, lb = _report_lines(a / name), _report_lines(b / name)
                changed = [ln for ln in difflib.unified_diff(la, lb, lineterm="", n=0)
                           if ln[:1] in "+-" and not ln.startswith(("+++", "---"))]
                diff = changed[:20] + ([f"... {len(changed) - 20} more changed lines"] if len(changed) > 20 else [])
            if diff:
                c.differences[name] = diff
    return c
