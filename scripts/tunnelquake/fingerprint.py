"""The input fingerprint of a condition: every case key that shaped its results, with its value,
by group (docs/formats.md "Input fingerprint", docs/user_guide.md "Resuming a run").

`tunnelquake run` writes it into the condition's solid_input.h5 (root attribute
`input_fingerprint`), from which tq-solid copies it into the results file and its digest into each
restart checkpoint's manifest (`inputs`); the water's tqInterface writes the digest into each
fluid-<window>.bin. `run --resume` keeps a completed condition, or continues from a checkpoint, only
when the digest is today's; `post` refuses results whose fingerprint differs from the case, naming
the key. The post-only keys (group `design`) are not part of it: `post` records those it used in
<results>/post_inputs.json and says which changed since the last report.

The groups: geometry (geometry, mesh, layers), solid material (materials, interface, in_situ,
stages, damping), water, coupling, record (ground_motion, its record files by their contents),
time and output (time; output's monitors, sampling and snapshots), and design (design,
output.displacement_reference, reference: read by `post` only, so a change re-posts freely).
Keys that do not change a result (names, folders, the checkpoint interval, thread and rank counts,
the coupling's timeout and transport, the water's log) are left out."""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

from .schema import NEUTRAL

VERSION = 1
ATTR = "input_fingerprint"

#: the group of each top-level case section; a section not named here nor in NOT_SHAPING goes to
#: the group "other" (so a section added to the case's schema is in the fingerprint until placed)
SECTION_GROUPS = {
    "geometry": "geometry", "mesh": "geometry", "layers": "geometry", "geology": "geometry",
    "materials": "solid material", "interface": "solid material", "in_situ": "solid material",
    "stages": "solid material", "damping": "solid material", "fault_offset": "solid material",
    "lining_joints": "solid material",
    "water": "water",
    "coupling": "coupling",
    "ground_motion": "record", "incident_wave": "record",
    "time": "time and output", "output": "time and output",
    "design": "design", "reference": "design",
}

#: top-level sections that shape no result: names, which conditions run (each has its own
#: fingerprint), a suite's members (each a case of its own), thread and rank counts
NOT_SHAPING = {"name", "description", "conditions", "suite", "parallel", "variants"}

#: keys read by `post` only: a change re-posts the same results
POST_ONLY = "design"

#: keys inside the sections above that shape no result (left out), and keys of another group
LEFT_OUT = {"output.directory", "output.allow_outside", "output.checkpoint_interval", "coupling.timeout",
            "coupling.transport", "water.log", "water.log_interval"}
MOVED = {"output.displacement_reference": "design", "lining_joints.allowed_opening": "design"}

#: design sections the analysis itself reads when a region's model takes them (a reinforced_concrete
#: lining is built from the concrete and the bars the design check reads): then they shape results
ANALYSIS_DESIGN = {"reinforced_concrete": ("design.concrete.", "design.reinforcement.")}


def _key_group(key: str, group: str, analysis_design: tuple[str, ...]) -> str:
    """The group a key counts in: its section's, moved (MOVED), or 'solid material' for a design key
    the analysis reads."""
    if key.startswith(analysis_design):
        return "solid material"
    return MOVED.get(key, group)


#: the water keys the static_water condition reads (its hydrostatic load); dynamic_water reads them all
STATIC_WATER_KEYS = {"water.density", "water.head"}


def _flatten(prefix: str, value, out: dict) -> None:
    if isinstance(value, dict):
        for k in sorted(value):
            _flatten(f"{prefix}.{k}", value[k], out)
    else:
        out[prefix] = json.dumps(value, sort_keys=True, default=str)


def _file_digest(path: Path) -> str:
    try:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return json.dumps(f"sha256 {h.hexdigest()[:16]}")
    except OSError:
        return json.dumps("missing")


def _digest(keys: dict) -> str:
    return hashlib.sha256(json.dumps(keys, sort_keys=True).encode()).hexdigest()


def condition_inputs(case, cond: str, post_only: bool = False) -> dict:
    """The fingerprint of condition `cond` of a loaded case: {"digest", "version", "condition",
    "groups": {group: digest}, "keys": {key: [group, value as JSON]}}, of the keys that shape its
    results; with `post_only` of the design group's keys alone (what `post` reads)."""
    keys: dict[str, list[str]] = {}
    models = {m.get("model") for m in (case.data.get("materials") or {}).values() if isinstance(m, dict)}
    analysis_design = tuple(p for model in sorted(models & ANALYSIS_DESIGN.keys()) for p in ANALYSIS_DESIGN[model])
    for section in case.data:
        group = SECTION_GROUPS.get(section, "other")
        if section in NOT_SHAPING or case.data[section] is None:
            continue
        if section in NEUTRAL and case.data[section].get(NEUTRAL[section][0]) == NEUTRAL[section][1]:
            continue
        if cond == "no_water" and group in ("water", "coupling"):
            continue
        if cond == "static_water" and group == "coupling":
            continue
        flat: dict[str, str] = {}
        _flatten(section, case.data[section], flat)
        if section == "time":  # the level this condition steps with, whether given once or per condition
            from .case import subcycling_levels

            flat = {k: v for k, v in flat.items() if not k.startswith("time.subcycling.")}
            flat["time.subcycling"] = json.dumps(subcycling_levels(case.data, cond))
        for key, value in flat.items():
            if key in NEUTRAL and json.loads(value) == NEUTRAL[key]:
                continue
            if key in LEFT_OUT or (cond == "static_water" and group == "water" and key not in STATIC_WATER_KEYS):
                continue
            key_group = _key_group(key, group, analysis_design)
            if (key_group == POST_ONLY) != post_only:
                continue
            if section in ("ground_motion", "incident_wave") and key.endswith(".file") and json.loads(value):
                value = _file_digest(case.dir / json.loads(value))  # the record, wherever it lies
            keys[key] = [key_group, value]
    groups: dict[str, dict] = {}
    for key, (group, value) in keys.items():
        groups.setdefault(group, {})[key] = value
    return {"digest": _digest({k: v for d in groups.values() for k, v in d.items()}), "version": VERSION,
            "condition": cond,
            "groups": {g: _digest(d) for g, d in sorted(groups.items())}, "keys": keys}


def to_text(fp: dict) -> str:
    """The fingerprint as written (JSON, its digest first)."""
    return json.dumps(fp, separators=(",", ":"))


def from_text(text) -> dict | None:
    """A fingerprint read back (bytes or str), or None when absent or not one."""
    if text is None:
        return None
    if isinstance(text, bytes):
        text = text.decode(errors="replace")
    try:
        fp = json.loads(str(text))
    except ValueError:
        return None
    return fp if isinstance(fp, dict) and isinstance(fp.get("keys"), dict) and "digest" in fp else None


def read_results(path: Path) -> dict | None:
    """The fingerprint a results file (or a checkpoint's copy of one) carries, or None."""
    import h5py

    from . import children

    try:
        with children.FORK_LOCK, h5py.File(path, "r") as f:
            return from_text(f.attrs.get(ATTR))
    except OSError:
        return None


@dataclass(frozen=True)
class Change:
    group: str
    key: str
    old: str | None  # the value as JSON, None: the key was absent
    new: str | None

    def __str__(self) -> str:
        def show(v):
            if v is None:
                return "(absent)"
            x = json.loads(v)
            return f"{x:g}" if isinstance(x, float) else json.dumps(x) if not isinstance(x, str) else x
        return f"{self.key} {show(self.old)} -> {show(self.new)} ({self.group})"


def changes(old: dict, new: dict) -> list[Change]:
    """The keys whose value differs between two fingerprints, result-shaping groups first."""
    ok, nk = old.get("keys", {}), new.get("keys", {})
    out = []
    for key in sorted(set(ok) | set(nk)):
        o, n = ok.get(key), nk.get(key)
        if (o and o[1]) != (n and n[1]):
            out.append(Change((n or o)[0], key, o and o[1], n and n[1]))
    return sorted(out, key=lambda c: (c.group == POST_ONLY, c.group, c.key))


def say_changes(cs: list[Change], limit: int = 3) -> str:
    """The first `limit` changes in words, and how many more."""
    text = "; ".join(str(c) for c in cs[:limit])
    return text + (f"; and {len(cs) - limit} more" if len(cs) > limit else "")


class InputsChanged(Exception):
    """`post` refused: a results file was computed with other inputs than the case gives now."""


#: what `post` records of the post-only keys it used, in the results folder
POST_RECORD = "post_inputs.json"


def check_post(case) -> list[str]:
    """Before `post`: each planned condition's results file against today's case. Raises
    InputsChanged naming the key(s) and the fix when a key that shapes the results changed since
    they were computed. Returns the report's lines on what post can only note: results without a
    fingerprint, and the post-only (design) keys changed since the last report."""
    from .scene import plan

    lines: list[str] = []
    refused: list[str] = []
    variant = f" --variant {case.variant}" if case.variant else ""
    for cond, _ in plan(case):
        res = case.output_dir / f"results_{cond}.h5"
        if not res.is_file():
            continue
        old = read_results(res)
        if old is None:
            lines.append(f"- {res.name} carries no input fingerprint (written by an earlier tunnelquake): it cannot "
                         "be shown to be of this case's inputs")
            continue
        cs = changes(old, condition_inputs(case, cond))
        if cs:
            refused.append(f"{res.name} was computed with other inputs than the case gives now: {say_changes(cs)}")
        else:
            lines.append(f"- {res.name}: computed with this case's inputs ({len(old['keys'])} keys, input "
                         f"fingerprint {old['digest'][:12]})")
    if refused:
        raise InputsChanged("; ".join(refused) + ". The report would put these results beside today's inputs. Fix: "
                            f"run the changed condition(s) again (`tunnelquake run {case.path}{variant} --resume` "
                            "runs again what changed and keeps the rest), or restore the key(s)")
    now = condition_inputs(case, "", post_only=True)
    try:
        last = from_text((case.output_dir / POST_RECORD).read_text())
    except OSError:
        last = None
    if last is not None:
        cs = changes(last, now)
        if cs:
            lines.append(f"- Design settings changed since the last report (this one uses today's): {say_changes(cs, 8)}")
    return lines


def record_post(case) -> None:
    """After `post` wrote its report: the post-only keys it used (compared with at the next post)."""
    from .files import atomic_path

    text = to_text(condition_inputs(case, "", post_only=True))
    with atomic_path(case.output_dir / POST_RECORD, len(text)) as tmp:
        tmp.write_text(text)
