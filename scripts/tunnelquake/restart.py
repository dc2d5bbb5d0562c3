"""Restart checkpoints of a run's conditions: where tq-solid writes them, their checksums verified,
the newest intact one, and what `run --resume` does with each condition (docs/user_guide.md
"Resuming a run", docs/formats.md "Restart checkpoints" and "Input fingerprint")."""
from __future__ import annotations

import json
import os
import sys
import zlib
from pathlib import Path

from . import children
from .scene import plan

#: the last key of a manifest: the CRC-32 of every byte before it
MANIFEST_CRC = '"manifest_crc32"'
#: the water checkpoint's trailer: input digest (64 bytes), TQFLSUM1, CRC-32 (4 bytes)
FLUID_TRAILER = 64 + 8 + 4
#: the water checkpoint's first 8 bytes: one rank's, and the decomposed water's (then its rank count)
FLUID_ONE, FLUID_RANKS = b"TQFLUID1", b"TQFLUIDR"


def checkpoint_dir(case, cond: str) -> Path:
    """Where tq-solid writes the condition's restart checkpoints (docs/formats.md "Restart checkpoints")."""
    return case.output_dir / cond / "checkpoint"


#: the sub-folder of a condition's checkpoint folder that holds the checkpoint a resume started from
#: until the condition completes (keep_resume_source); neither solver's retention looks into it
KEPT = "resumed-from"


def kept_dir(case, cond: str) -> Path:
    """Where the checkpoint a resume of the condition started from is kept (keep_resume_source)."""
    return checkpoint_dir(case, cond) / KEPT


def checkpoint_manifest(case, cond: str) -> dict | None:
    """The condition's newest intact restart checkpoint (its manifest, verified with its files), or None."""
    return intact_checkpoints(case, cond)[0]


def file_crc(path: Path) -> str:
    """The CRC-32 of a file (zlib's, 8 hex digits), as tq-solid and tqInterface write them."""
    crc = 0
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            crc = zlib.crc32(block, crc)
    return f"{crc:08x}"


def manifest_problem(text: str) -> str | None:
    """What is wrong with a manifest's text, or None: it must end with its `manifest_crc32` line,
    the CRC-32 of every byte before it (tq-solid's manifestProblem)."""
    k = text.rfind(MANIFEST_CRC)
    if k < 0:
        return ("it is cut short (no closing line)" if not text.endswith("}\n") else
                "it has no manifest_crc32 (written by a tq-solid without checkpoint checksums)")
    try:
        want = json.loads("{" + text[k:])["manifest_crc32"]
    except (ValueError, KeyError, TypeError):
        return "it is cut short"
    got = f"{zlib.crc32(text[:k].encode()):08x}"
    return None if got == want else f"its CRC-32 is {got} instead of the {want} it records"


def read_manifest(path: Path) -> tuple[dict | None, str | None]:
    """A checkpoint manifest and None, or None and why it cannot be used."""
    try:
        text = path.read_bytes().decode(errors="replace")
    except OSError as e:
        return None, f"it cannot be read ({e.strerror})"
    problem = manifest_problem(text)
    if problem is None:
        try:
            m = json.loads(text)
            if not isinstance(m, dict) or m.get("format") != "tunnelquake-checkpoint":
                problem = "it is not a checkpoint manifest"
            else:
                int(m["sequence"])
                return m, None
        except (ValueError, KeyError, TypeError):
            problem = "it is not a checkpoint manifest"
    return None, problem


def checkpoint_problem(folder: Path, m: dict) -> str | None:
    """Why the files a manifest names cannot be used (missing, another size, another CRC-32), or None."""
    for part in ("solid", "results"):
        try:
            path = folder / str(m[part])
            size = path.stat().st_size
            if size != int(m[f"{part}_bytes"]):
                return f"{path.name} is {size} bytes instead of {int(m[f'{part}_bytes'])} (cut short or damaged)"
            crc = file_crc(path)
        except FileNotFoundError:
            return f"{m[part]} is missing"
        except (OSError, KeyError, TypeError, ValueError) as e:
            return f"its {part} file cannot be checked ({e})"
        if crc != m.get(f"{part}_crc32"):
            return f"the CRC-32 of {path.name} is {crc} instead of {m.get(f'{part}_crc32')} (the file is damaged)"
    return None


def fluid_file(folder: Path, window: int) -> Path:
    return folder / f"fluid-{window:09d}.bin"


def fluid_problem(path: Path) -> tuple[str | None, str | None]:
    """The water's checkpoint file checked: (why it cannot be used or None, the input digest it carries).
    Its trailer: the digest (64 bytes), TQFLSUM1, the CRC-32 (u32, this machine's order) of all before."""
    try:
        data = path.read_bytes()
    except OSError as e:
        return f"{path.name} cannot be read ({e.strerror})", None
    if len(data) < 8 + FLUID_TRAILER or not data.startswith((FLUID_ONE, FLUID_RANKS)):
        return f"{path.name} is not a whole water checkpoint ({len(data)} bytes: cut short or damaged)", None
    body = len(data) - 4
    if data[body - 8:body] != b"TQFLSUM1":
        return f"{path.name} does not end with its checksum (cut short or damaged)", None
    want = int.from_bytes(data[body:], sys.byteorder)
    got = zlib.crc32(memoryview(data)[:body])
    if got != want:
        return f"the CRC-32 of {path.name} is {got:08x} instead of {want:08x} (the file is damaged)", None
    return None, data[body - 8 - 64:body - 8].decode(errors="replace").strip()


def fluid_ranks_of(path: Path) -> int | None:
    """The water's rank count that wrote its checkpoint `path` (1 for TQFLUID1; TQFLUIDR: the i64
    after the magic, this machine's order), or None when the file does not say."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return None
    if head.startswith(FLUID_ONE):
        return 1
    if head.startswith(FLUID_RANKS) and len(head) == 16:
        return int.from_bytes(head[8:], sys.byteorder, signed=True)
    return None


def fluid_ranks_problem(case, cond: str, point: dict) -> str | None:
    """Why the coupled condition cannot continue from its checkpoint `point` with the case's
    parallel.fluid_ranks: the water's checkpoint holds each rank's cells, so it resumes on the rank
    count that wrote it only. None when the counts agree (or the point has no water file)."""
    if not point.get("fluid"):
        return None
    written = fluid_ranks_of(Path(point["fluid"]))
    now = int(case.data["parallel"]["fluid_ranks"])
    if written is None or written == now:
        return None
    return (f"{cond}: its restart checkpoint at t = {float(point['time']):.6g} s ({Path(point['fluid']).name} in "
            f"{Path(point['fluid']).parent}) holds the water on {written} rank(s), and the case has "
            f"parallel.fluid_ranks: {now}; a decomposed water's checkpoint is its ranks' cells, resumed on the "
            f"rank count that wrote it. Fix: set parallel.fluid_ranks: {written} to resume it, or run without "
            f"--resume to compute {cond} again from the start")


class Choice(str):
    """What `run --resume` does with a condition ('completed', 'checkpoint' or 'start', compared as
    a string), with `notes` (why, in words) and `point` (the checkpoint's manifest, for 'checkpoint')."""

    notes: list[str]
    point: dict | None

    @classmethod
    def make(cls, what: str, notes: list[str] | None = None, point: dict | None = None) -> Choice:
        c = cls(what)
        c.notes, c.point = list(notes or []), point
        return c


def condition_choice(case, cond: str, parts) -> Choice:
    """What `run --resume` does with one condition, from its results' and checkpoints' input
    fingerprints (tunnelquake.fingerprint) and checksums: a completed condition is kept only when it
    was computed with today's inputs (the post-only keys aside), a checkpoint is continued from only
    when it is intact and of today's inputs; otherwise the condition runs from the start, and the
    notes say why (the keys changed, the files damaged)."""
    from . import fingerprint as F

    now = F.condition_inputs(case, cond)
    res = case.output_dir / f"results_{cond}.h5"
    if results_status(res) == "completed":
        old = F.read_results(res)
        if old is None:
            return Choice.make("start", [f"{res.name} carries no input fingerprint (written by an earlier "
                                         "tunnelquake): it cannot be shown to be of today's inputs, so it runs again"])
        if old["digest"] == now["digest"]:
            return Choice.make("completed")
        return Choice.make("start", [f"{res.name} was computed with other inputs: {F.say_changes(F.changes(old, now))}; "
                                     "it runs again"])
    point, damaged = intact_checkpoints(case, cond, coupled="fluid" in parts)
    notes = [f"damaged checkpoint in {checkpoint_dir(case, cond)}: {d}" for d in damaged]
    if point is None:
        if damaged:
            notes.append("no intact checkpoint is left: it runs from the start")
        return Choice.make("start", notes)
    if damaged:
        notes.append(f"falls back to the newest intact checkpoint, {point['sequence']} (t = {float(point['time']):.6g} s)")
    if point.get("inputs") != now["digest"]:
        old = F.read_results(checkpoint_dir(case, cond) / str(point["results"]))
        why = (F.say_changes(F.changes(old, now)) if old is not None else
               "it carries no input fingerprint (written by an earlier tunnelquake)")
        return Choice.make("start", notes + [f"its checkpoint was written with other inputs: {why}; it runs from "
                                             "the start"])
    return Choice.make("checkpoint", notes, point)


def intact_checkpoints(case, cond: str, coupled: bool | None = None) -> tuple[dict | None, list[str]]:
    """The newest checkpoint of the condition whose manifest and files (coupled: and the water's
    fluid-<window>.bin) pass their checksums, with `fluid` added when coupled; and the damage met on
    the way, one line each ('checkpoint 3: the CRC-32 of solid-000003.bin is ... instead of ...')."""
    main = checkpoint_dir(case, cond)
    if coupled is None:
        coupled = "fluid" in dict(plan(case)).get(cond, ())
    manifests: list[tuple[int, bool, str, dict]] = []
    damaged: list[str] = []
    # the checkpoint folder's own, then the one a resume started from (kept_dir), after the folder's
    # own of the same sequence
    for kept, where in ((False, main), (True, main / KEPT)):
        for path in sorted(where.glob("checkpoint*.json")):
            m, problem = read_manifest(path)
            if m is None:
                damaged.append(f"{path.relative_to(main)} is damaged: {problem}")
            else:
                manifests.append((int(m["sequence"]), kept, path.name, m))  # tq-solid reads checkpoint.json
                # by --resume alone, checkpoint-<n>.json by --resume --resume-sequence n (resume_args)
    seen: set[tuple[int, bool]] = set()
    for seq, kept, name, m in sorted(manifests, key=lambda x: (-x[0], x[1], x[2] == "checkpoint.json")):
        if (seq, kept) in seen:
            continue
        seen.add((seq, kept))
        folder = main / KEPT if kept else main
        m = {**m, "manifest": name, "kept": kept}
        problem = checkpoint_problem(folder, m)
        if problem is not None:
            damaged.append(f"checkpoint {seq}{' (kept)' if kept else ''}: {problem}")
            continue
        if not coupled:
            return m, damaged
        try:
            fluid = fluid_file(folder, int(m["window"]))
        except (KeyError, TypeError, ValueError):
            damaged.append(f"checkpoint {seq}: its manifest names no coupling window")
            continue
        if not fluid.is_file():
            continue  # the water had not written its side of this window yet
        problem, digest = fluid_problem(fluid)
        if problem is not None:
            damaged.append(f"checkpoint {seq}: {problem}")
            continue
        if digest != (m.get("inputs") or ""):
            damaged.append(f"checkpoint {seq}: {fluid.name} carries input fingerprint {digest[:12]}, the solid's "
                           f"{str(m.get('inputs'))[:12]}: the two sides are of different runs")
            continue
        return {**m, "fluid": str(fluid)}, damaged
    return None, damaged


def _link(src: Path, dst: Path) -> None:
    """dst made the same file as src: a hard link (the solvers replace a checkpoint file by renaming a
    new one over it, never write into it), or a copy where the file system has no links."""
    import shutil

    dst.unlink(missing_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def keep_resume_source(case, cond: str, point: dict) -> dict:
    """Before a resume continues from the intact checkpoint `point` (intact_checkpoints): its files (the
    solid's state and results copy, its manifest, coupled the water's fluid-<window>.bin) are kept in
    kept_dir until the condition completes, and put back into the checkpoint folder when the point was
    the kept one. tq-solid keeps only its last two checkpoints and the water its last two windows, so
    without this the resume's source went once the resumed run had written two newer ones, and a second
    failure that damaged those could no longer fall back to it. Returns the point as the solvers are to
    read it: from the checkpoint folder, its numbered manifest (resume_args)."""
    main, kept = checkpoint_dir(case, cond), kept_dir(case, cond)
    src = kept if point.get("kept") else main
    seq = int(point["sequence"])
    numbered = f"checkpoint-{seq:06d}.json"
    names = [(str(point["manifest"]), numbered), (str(point["solid"]), str(point["solid"])),
             (str(point["results"]), str(point["results"]))]
    if point.get("fluid"):
        names.append((Path(point["fluid"]).name, Path(point["fluid"]).name))
    if point.get("kept"):
        for name, as_name in names:
            _link(src / name, main / as_name)
    else:
        old = [p for p in kept.iterdir()] if kept.is_dir() else []
        kept.mkdir(exist_ok=True)
        for p in old:  # the source of an earlier resume: an older checkpoint of the same run
            if p.is_file() and p.name not in {as_name for _, as_name in names}:
                p.unlink()
        for name, as_name in names:
            _link(main / name, kept / as_name)
    out = {**point, "manifest": numbered if point.get("kept") else point["manifest"], "kept": False}
    if point.get("fluid"):
        out["fluid"] = str(main / Path(point["fluid"]).name)
    return out


def forget_resume_source(case, cond: str) -> None:
    """The checkpoint a resume started from is dropped: the condition completed (its results are whole),
    or it starts afresh (tq-solid clears the checkpoint folder then)."""
    import shutil

    shutil.rmtree(kept_dir(case, cond), ignore_errors=True)


def resume_args(point: dict) -> list[str]:
    """tq-solid's arguments to resume from the intact checkpoint `point` through the manifest that
    was verified (the numbered one, or checkpoint.json when the numbered one is damaged)."""
    if point.get("manifest") == "checkpoint.json":
        return ["--resume"]
    return ["--resume", "--resume-sequence", str(int(point["sequence"]))]


def coupled_resume_point(case, cond: str) -> dict | None:
    """The last coupling window for which both sides of a coupled condition wrote a whole restart
    checkpoint that passes its checksums: the solid's manifest of it (checkpoint-<n>.json) with
    `fluid` added, the water's fluid-<window>.bin beside it; None when there is none."""
    return intact_checkpoints(case, cond, coupled=True)[0]


def results_status(res: Path) -> str | None:
    """The status attribute of a results file (None when there is no readable file)."""
    import h5py

    try:
        with children.FORK_LOCK, h5py.File(res, "r") as f:
            status = f.attrs.get("status", "")
    except OSError:
        return None
    return status.decode() if isinstance(status, bytes) else str(status)


def resume_plan(case) -> tuple[dict[str, str], str | None, bool]:
    """What `run --resume` does with each planned condition: 'completed' (kept as it is),
    'checkpoint' (tq-solid continues from its last restart checkpoint) or 'start' (no checkpoint:
    from the beginning); then why there is nothing to resume (None when there is) and whether the
    run starts afresh (no checkpoint anywhere, nothing completed: a requeued job killed before its
    first checkpoint) rather than keeping a finished run. Each value is a Choice whose notes say why
    a condition runs again (its inputs changed, its checkpoints are damaged)."""
    what: dict[str, str] = {}
    for cond, parts in plan(case):
        what[cond] = condition_choice(case, cond, parts)
    variant = f" --variant {case.variant}" if case.variant else ""
    if what and all(v == "completed" for v in what.values()):
        return what, (f"nothing to resume: every condition in {case.output_dir} completed ({', '.join(what)}); "
                      f"the results are kept as they are (`tunnelquake post {case.path}{variant}` reports them, "
                      f"`tunnelquake run {case.path}{variant}` without --resume runs them again)"), False
    if "checkpoint" not in what.values() and "completed" not in what.values() and not any(
            getattr(v, "notes", None) for v in what.values()):
        interval = float(case.data["output"]["checkpoint_interval"])
        why = ("output.checkpoint_interval is 0: no checkpoint is written" if interval <= 0 else
               f"a run writes its first after output.checkpoint_interval = {interval:g} s of shaking")
        return what, (f"nothing to resume in {case.output_dir}: no condition has a restart checkpoint ({why}) and "
                      "none completed: starting afresh"), True
    return what, None, False
