"""Post's per-condition work done early, on the core that a finished path of conditions leaves idle.

`tunnelquake run` runs its coupled condition beside the solid-only ones (launch.run_case). When one
path ends while the other still runs, its thread calls `EarlyPost.idle`: for each condition whose
solver completed (exit 0: its results file is whole and no longer written), it reads the results
file, writes the condition's monitors CSV and ParaView files into a staging folder of the results
folder, and computes the condition's own design quantities (design.lining.condition_parts); it also
imports what post draws with (matplotlib, the design figures).

post_case then takes, for each condition whose results file is the one read here (same inode,
modification time and size), the staged values instead of computing them again and moves the staged
files into place (os.replace) where it would have written them. Everything that compares conditions
(every figure of the report, the design summary, report.md) is made by post as before, from the same
data, so every output is the same file either way. Nothing staged is seen before post moves it: a run
stopped, or a post refused (other inputs), leaves the outputs as a post without early work would.
The staging folder is emptied when early work starts and removed at the end of every post; a file
staged but not used is recomputed by post as before (any failure here is left to post to meet and
report)."""
from __future__ import annotations

import os
import shutil
import threading
from dataclasses import dataclass, field
from pathlib import Path

from . import children

#: the staging folder, in the results folder (the same file system: a rename puts a file in place)
STAGING = ".post-early"


def signature(path: Path) -> tuple | None:
    """(inode, modification time in ns, size) of a file, None when it is not there."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


def discard(out: Path) -> None:
    """Remove the staging folder of the results folder `out` (whatever an earlier run left)."""
    shutil.rmtree(Path(out) / STAGING, ignore_errors=True)


@dataclass
class Staged:
    """One condition's work done early, valid for its results file while `signature` holds."""

    signature: tuple
    result: object  # post.ConditionResult
    monitors_csv: Path | None = None  # the staged monitors_<condition>.csv
    xdmf: tuple | None = None  # (staged .h5, staged .xdmf) or () when write_xdmf made none
    design: tuple | None = None  # (the dry static state it used, its condition_parts)


@dataclass
class EarlyPost:
    """The per-condition work of post for `case`, done beside a condition still running."""

    case: object
    staged: dict[str, Staged] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)
    imported: bool = False
    valid: dict[str, Staged] = field(default_factory=dict)  # what this post found unchanged

    @property
    def folder(self) -> Path:
        return self.case.output_dir / STAGING

    def idle(self, completed: list[str], first: list | None = None) -> None:
        """Called by a path of conditions that has ended while another still runs: run `first`'s
        functions (each once; e.g. the motion's figure), import post's modules, then stage each
        condition of `completed` (whose solver exited 0) not staged yet. Stops between steps
        once the run is being stopped."""
        with self.lock:
            while first:
                children.check()
                first.pop(0)()
            if not self.imported:
                children.check()
                _import_post()
                self.imported = True
            for cond in completed:
                if cond not in self.staged:
                    children.check()
                    self._stage(cond)

    def _stage(self, cond: str) -> None:
        from . import post as P

        if not self.staged:
            discard(self.case.output_dir)
        f = self.case.output_dir / f"results_{cond}.h5"
        before = signature(f)
        try:
            with children.FORK_LOCK:  # an HDF5 file is open (children.py)
                res = P.read_condition(f, cond, self.case.data["output"]["displacement_reference"])
        except (OSError, KeyError, ValueError, TypeError):
            return  # post reads it again and says why
        if before is None or signature(f) != before or not res.samples:
            return
        s = Staged(before, res)
        self.staged[cond] = s
        try:
            with children.FORK_LOCK:
                s.monitors_csv = P.monitors_csv(res, self.folder / f"monitors_{cond}.csv")
        except Exception:  # noqa: BLE001 - post writes it again and reports what it meets
            s.monitors_csv = None
        children.check()
        try:
            with children.FORK_LOCK:
                x = P.write_xdmf(res, self.folder / "paraview" / f"{cond}.xdmf")
            s.xdmf = () if x is None else (x.with_suffix(".h5"), x)
        except Exception:  # noqa: BLE001 - as above
            s.xdmf = None
        children.check()
        try:
            from .design.lining import condition_parts, static_state

            dry = None
            if cond != "no_water" and "no_water" in self.staged:
                with children.FORK_LOCK:
                    dry = static_state(Path(self.staged["no_water"].result.path),
                                       self.case.data["output"].get("monitors") or {})
            with children.FORK_LOCK:
                s.design = (dry, condition_parts(self.case, res, dry))
        except Exception:  # noqa: BLE001 - as above
            s.design = None
        children.say(f"post: {cond}'s monitors, ParaView file and design quantities made beside the running "
                     "condition(s)")

    # ---- what post_case asks ---------------------------------------------------------------------

    def result(self, cond: str, path: Path):
        """The staged ConditionResult of `cond` when `path` is the file read then; None otherwise
        (then nothing staged of `cond` is used)."""
        s = self.staged.get(cond)
        if s is None or signature(path) != s.signature or Path(s.result.path) != Path(path):
            return None
        self.valid[cond] = s
        return s.result

    def put_monitors(self, cond: str, target: Path) -> bool:
        """Move the staged monitors CSV of `cond` to `target`; False when there is none to move."""
        s = self.valid.get(cond)
        if s is None or s.monitors_csv is None:
            return False
        try:
            _replace(s.monitors_csv, target)
        except OSError:
            return False
        return True

    def put_xdmf(self, cond: str, target: Path):
        """Move the staged ParaView files of `cond` into place (the .h5, then the .xdmf naming it)
        and return drawing.Outcome as write_xdmf(target) would give; None when there are none."""
        from .drawing import Outcome

        s = self.valid.get(cond)
        if s is None or s.xdmf is None:
            return None
        if not s.xdmf:
            return Outcome(value=None)
        h5, xdmf = s.xdmf
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(h5, target.with_suffix(".h5"))
            os.replace(xdmf, target)
        except OSError:
            return None
        return Outcome(value=target)

    def design_parts(self) -> dict:
        """{condition: (dry static state, condition_parts)} of the conditions found unchanged."""
        return {c: s.design for c, s in self.valid.items() if s.design is not None}


def _replace(src: Path, target: Path) -> None:
    """Rename `src` over `target` and sync the folder (as files.atomic_path puts a file in place)."""
    import contextlib

    from .files import _fsync

    target.parent.mkdir(parents=True, exist_ok=True)
    os.replace(src, target)
    with contextlib.suppress(OSError):
        _fsync(target.parent)


def _import_post() -> None:
    """Import what post draws and computes with, so that post does not wait for it."""
    from . import paper, post, report  # noqa: F401
    from .design import figures, lining  # noqa: F401

    post._plt()
