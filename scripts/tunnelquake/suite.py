"""Record suites: one case run under a set of ground-motion records, and the design value combined
from the members' peaks.

The case file's `suite:` section lists the records (files, or folder globs, each with its units),
how each is scaled, and the rule that combines the members' results. Each record makes one
*member*: a case of its own, written as `<results>/members/<name>/case.yaml`, that is the suite's
case with `ground_motion.file` set to the record and `ground_motion.pga` set to the scaled record's
peak, so the single-run machinery (`tunnelquake run`) runs each member unchanged.

Scaling (amplitude only: the record's shape is kept)
  pga        each processed record (window, low-pass, baseline as `ground_motion` says) is scaled to
             the PGA `suite.pga` (or the record's own `pga`, or `ground_motion.pga`).
  spectrum   two steps (ASCE 7-16 C16.2.3): each record is first scaled by f_i, the geometric mean
             of target / Sa_i over the period grid of [T1, T2] (its best log-fit to the target);
             then the whole set by one factor c so that the mean of the scaled spectra, at its
             lowest against the target over [T1, T2], is `fraction` x the target: the mean lies on or
             above fraction x target over the range and touches it.
  none       the records as processed.
The target is a table of (T, Sa) points (linear between them) or the EN 1998-1 type 1 elastic
spectrum (§3.2.2.2, Table 3.2: ground types A-E, 5 % damping, eta = 1) for a design ground
acceleration ag on type A ground (ag = gamma_I agR).

Spectra are 5 %-damped pseudo-accelerations Sa = w^2 max|u| of the linear SDOF
u'' + 2 zeta w u' + w^2 u = -a_g(t), integrated exactly for an excitation linear between samples
(Nigam & Jennings 1969; Chopra, Dynamics of Structures, §5.2), the step of the record itself.

The members' cases, their peaks, the combination and the report: suite_members.py.
"""
from __future__ import annotations

import glob as _glob
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import units as U
from .schema import Choice, ListOf, Number, Section, Text, Tuple

#: members needed for the mean (EN 1998-1 §4.3.3.4.3(3), ASCE 7-10 §16.1.4)
MEAN_FROM = 7
#: damping ratio of the spectra
DAMPING = 0.05
#: periods (s) of the spectra figure and of the scaling grid
SCALING_POINTS = 60
UNITS = ("g", "m/s^2", "cm/s^2", "gal")
#: EN 1998-1 Table 3.2, type 1 spectrum: S, T_B, T_C, T_D (s)
EC8_TYPE1 = {"A": (1.0, 0.15, 0.4, 2.0), "B": (1.2, 0.15, 0.5, 2.0), "C": (1.15, 0.20, 0.6, 2.0),
             "D": (1.35, 0.20, 0.8, 2.0), "E": (1.4, 0.15, 0.5, 2.0)}


# ----------------------------------------------------------------------------------------------
# The case file's keys
# ----------------------------------------------------------------------------------------------
def _check_record(r, path, raw, ctx):
    if (r["file"] is None) == (r["glob"] is None):
        ctx.error(path, dict(raw), "needs exactly one of 'file' and 'glob'",
                  "write 'file: <record>' for one record or 'glob: <folder>/*.AT2' for every match", raw.line)


def _check_suite(s, path, raw, ctx):
    lines = getattr(raw, "key_lines", {})
    if s["records"] is None:
        if raw:
            ctx.error(f"{path}.records", None, "is missing: a suite needs its records",
                      "add 'records:' with '- {file: <record>, units: g}' entries", raw.line)
        return
    if s["scaling"] == "spectrum":
        if s["periods"] is None:
            ctx.error(f"{path}.periods", None, "is required by scaling: spectrum",
                      "add 'periods: [T1, T2]', the structure's period range in s", lines.get("scaling"))
            return
        t1, t2 = s["periods"]
        if s["target"] == "ec8_type1" and s["ec8"]["ag"] is None:
            ctx.error(f"{path}.ec8.ag", None, "is required by target: ec8_type1",
                      "add 'ec8: {ag: 0.25 g, ground_type: B}' (ag = importance factor x reference PGA on rock)",
                      lines.get("target") or lines.get("scaling"))
        if s["target"] == "table":
            tp, sa = s["table"]["periods"], s["table"]["sa"]
            tl = lines.get("table") or lines.get("target")
            if tp is None or sa is None or len(tp) != len(sa) or len(tp) < 2:
                ctx.error(f"{path}.table", None, "needs 'periods' and 'sa' lists of the same length (2 or more)",
                          "write 'table: {periods: [0.1 s, 0.5 s, 2 s], sa: [0.6 g, 0.6 g, 0.15 g]}'", tl)
            elif any(b <= a for a, b in zip(tp, tp[1:], strict=False)):
                ctx.error(f"{path}.table.periods", tp, "must be increasing", "list the periods from short to long",
                          tl)
            elif t1 < tp[0] or t2 > tp[-1]:
                ctx.error(f"{path}.periods", s["periods"],
                          f"reaches outside the target table ({tp[0]:g} s to {tp[-1]:g} s)",
                          "extend the table or narrow the period range", lines.get("periods"))


def suite_section() -> Section:
    record = Section(checks=[_check_record], fields={
        "file": Text(doc="a record file, relative to the case file"),
        "glob": Text(doc="a folder glob relative to the case file (e.g. records/*.AT2): one member per matching "
                         "file, in name order"),
        "units": Choice(choices=UNITS, required=True, doc="units of the record's values (for every file of a glob)"),
        "format": Choice(choices=("auto", "at2", "two_column"), default="auto"),
        "name": Text(doc="the member's name (its results subfolder); default: the file's name without its "
                         "extension (not with glob)"),
        "direction": Choice(choices=("x", "-x"), default="x",
                            doc="the record's horizontal motion along +x, or reversed (-x); the vertical follows "
                                "as ground_motion.vertical_ratio x the horizontal"),
        "pga": Number(dim=U.ACCELERATION, min=0.0, min_open=True, unit_required=True, unit_example="'0.3 g'",
                      doc="scaling pga: this member's PGA with its unit (default suite.pga)"),
    })
    return Section(doc="a set of records run as one job, one member per record (docs/user_guide.md \"Record "
                       "suites\")", checks=[_check_suite], fields={
        "records": ListOf(item=record, min_length=1,
                          doc="the records: entries '{file: ..., units: g}' or '{glob: 'dir/*.AT2', units: g}'"),
        "scaling": Choice(choices=("pga", "spectrum", "none"), default="pga",
                          doc="pga: each record to a PGA; spectrum: amplitude scaling of the set to the target "
                              "spectrum over [T1, T2]; none: as processed"),
        "pga": Number(dim=U.ACCELERATION, min=0.0, min_open=True, unit_required=True, unit_example="'0.3 g'",
                      doc="scaling pga: the PGA of every record with its unit (default ground_motion.pga)"),
        "periods": Tuple(item=Number(dim=U.TIME, min=0.0, min_open=True), increasing=True,
                         doc="scaling spectrum: [T1, T2], the period range the mean spectrum must cover, s "
                             "(EN 1998-1: 0.2 T1 to 2 T1)"),
        "target": Choice(choices=("ec8_type1", "table"), default="ec8_type1",
                         doc="the target spectrum: EN 1998-1 type 1 elastic spectrum (suite.ec8) or a table "
                             "(suite.table)"),
        "ec8": Section(fields={
            "ag": Number(dim=U.ACCELERATION, min=0.0, min_open=True, unit_required=True, unit_example="'0.25 g'",
                         doc="design ground acceleration on type A ground, ag = gamma_I agR, with its unit"),
            "ground_type": Choice(choices=tuple(EC8_TYPE1), default="B", doc="EN 1998-1 Table 3.2 ground type"),
        }),
        "table": Section(fields={
            "periods": ListOf(item=Number(dim=U.TIME, min=0.0), doc="periods of the target's points, s"),
            "sa": ListOf(item=Number(dim=U.ACCELERATION, min=0.0),
                         doc="the target's 5 %-damped pseudo-accelerations at those periods, m/s^2"),
        }),
        "fraction": Number(min=0.0, min_open=True, max=1.0, default=1.0,
                           doc="scaling spectrum: the mean spectrum's lowest ratio to the target over [T1, T2] "
                               "(1: ASCE 7-10 §16.1.3.1; 0.9: EN 1998-1 §3.2.3.1.2(4), ASCE 7-16 §16.2.3.1)"),
        "combine": Choice(choices=("auto", "mean", "max"), default="auto",
                          doc="design value from the members' peaks: auto = mean with 7 members or more, else "
                              "the maximum (EN 1998-1 §4.3.3.4.3(3))"),
        "workers": Number(integer=True, min=0, default=0,
                          doc="members run at once by `tunnelquake run` (--workers overrides); 0: the cores "
                              "// the cores one member uses"),
        "slurm_time": Number(dim=U.TIME, min=60.0, default=None, why="Slurm counts time limits in whole minutes",
                             doc="the time limit of each Slurm array task (`run --slurm`: #SBATCH --time, rounded up "
                                 "to whole minutes), s; default: 2 x check's run-time estimate of a member + 10 min "
                                 "(docs/user_guide.md \"Record suites\")"),
    })


# ----------------------------------------------------------------------------------------------
# Records and members
# ----------------------------------------------------------------------------------------------
@dataclass
class MemberRecord:
    """One member's record before scaling: where it is and how to read and turn it."""

    name: str
    path: Path
    units: str
    format: str
    direction: str
    pga: float | None
    key: str  # the case-file key it comes from, e.g. suite.records[2]


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "record"


def expand_records(suite: dict, case_dir: Path) -> tuple[list[MemberRecord], list[tuple[str, str, str]]]:
    """The suite's members, in order, and the problems found (key, value, problem): a file not
    there, a glob that matches nothing, two members of one name."""
    from .motion import resolve_path

    out: list[MemberRecord] = []
    problems: list[tuple[str, str, str]] = []
    for i, r in enumerate(suite["records"]):
        key = f"suite.records[{i}]"
        if r["file"] is not None:
            p = resolve_path(r["file"], case_dir)
            if not p.is_file():
                problems.append((f"{key}.file", r["file"], f"file not found ({p})"))
                continue
            paths = [p]
        else:
            pattern = str(resolve_path(r["glob"], case_dir))
            paths = sorted(Path(x) for x in _glob.glob(pattern) if Path(x).is_file())
            if not paths:
                problems.append((f"{key}.glob", r["glob"], f"matches no file ({pattern})"))
                continue
        for p in paths:
            name = _safe(r["name"] if r["name"] and len(paths) == 1 else p.stem)
            out.append(MemberRecord(name, p, r["units"], r["format"], r["direction"], r["pga"], key))
    seen: dict[str, str] = {}
    for m in out:
        if m.name in seen:
            problems.append((f"{m.key}.name", m.name, f"two members are named '{m.name}' ({seen[m.name]} and "
                                                      f"{m.path})"))
        seen.setdefault(m.name, str(m.path))
    return out, problems


def processed(rec, gm: dict, pga: float | None = None) -> np.ndarray:
    """The record as the case processes it (window, low-pass, baseline; scaled to `pga` when given),
    as recorded at the surface (before the outcrop convention halves it), with its polarity."""
    from .motion import process

    m = process(rec, duration=gm["duration"], cutoff=gm["cutoff_frequency"], baseline=gm["baseline_correction"],
                pga=pga, vertical_ratio=gm["vertical_ratio"], convention=gm["convention"])
    return m.ax * (2.0 if m.convention == "outcrop" else 1.0)


def read_member(m: MemberRecord):
    from .motion import read_record

    rec = read_record(m.path, m.format, m.units)
    if m.direction == "-x":
        rec.acc = -rec.acc
    return rec


def suite_checks(d: dict, raw, filename: str, warnings: list[str]) -> list:
    """What `tunnelquake check` says about a suite beyond its keys: every record there, readable
    in its units and long enough for ground_motion.duration, a PGA for scaling pga."""
    from .motion import MotionError, check_moves, check_window
    from .schema import Issue

    section = raw.get("suite") if isinstance(raw.get("suite"), dict) else {}
    recs = section.get("records") if isinstance(section, dict) else None

    def line(key: str):
        m = re.match(r"suite\.records\[(\d+)\]\.?(\w*)", key)
        if m and isinstance(recs, list) and int(m.group(1)) < len(recs):
            r = recs[int(m.group(1))]
            return getattr(r, "key_lines", {}).get(m.group(2)) or getattr(r, "line", None)
        return getattr(section, "key_lines", {}).get(key.split(".")[1]) if "." in key else None

    issues = []
    members, problems = expand_records(d["suite"], Path(filename.split(" (variant")[0]).parent)
    fixes = {"file": "give the record's path relative to the case file",
             "glob": "give a glob relative to the case file that matches the records, e.g. records/*.AT2",
             "name": "give each record its own name ('name:') or rename the files"}
    for key, value, problem in problems:
        issues.append(Issue(key, value, problem, fixes[key.rsplit(".", 1)[1]], line(key)))
    s = d["suite"]
    gm = d["ground_motion"]
    for key in ("second_horizontal", "vertical"):
        if gm[key]["file"] is not None:
            issues.append(Issue(f"ground_motion.{key}.file", gm[key]["file"],
                                "a record suite runs one horizontal record per member; this record would be paired "
                                "with every member alike",
                                "remove it (the vertical follows each member as ground_motion.vertical_ratio x it)",
                                getattr(raw.get("ground_motion"), "key_lines", {}).get(key)))
    for m in members:
        try:
            rec = read_member(m)
            check_window(rec.npts, rec.dt, gm["duration"], gm["cutoff_frequency"], str(m.path))
            check_moves(rec.acc, rec.dt, gm["duration"], str(m.path))
        except MotionError as e:
            index = int(re.search(r"\[(\d+)\]", m.key).group(1))
            k = f"{m.key}.{'file' if s['records'][index]['file'] is not None else 'glob'}"
            issues.append(Issue(k, str(m.path), f"cannot be used: {e.problem}",
                                (e.fix or "check the record and its units").rstrip("."), line(k)))
        if s["scaling"] == "pga" and m.pga is None and s["pga"] is None and gm["pga"] is None:
            issues.append(Issue("suite.pga", None, "scaling pga needs a PGA",
                                "add 'pga: <value>' to suite (or to the record), or set ground_motion.pga",
                                line("suite.scaling")))
            break
    if s["scaling"] != "pga" and gm["pga"] is not None:
        warnings.append(f"ground_motion.pga {gm['pga']:g} m/s^2 is not used: suite.scaling is {s['scaling']}, and "
                        "each member's PGA follows from it")
    if len(members) < MEAN_FROM and s["combine"] == "mean":
        warnings.append(f"suite.combine: mean with {len(members)} members: EN 1998-1 §4.3.3.4.3 takes the mean "
                        f"only from {MEAN_FROM} records on (the maximum with fewer)")
    return issues


# ----------------------------------------------------------------------------------------------
# Spectra, target and scaling
# ----------------------------------------------------------------------------------------------
def response_spectrum(acc, dt: float, periods, damping: float = DAMPING) -> np.ndarray:
    """Pseudo-acceleration spectrum Sa(T) = w^2 max|u| of u'' + 2 zeta w u' + w^2 u = -acc(t), from
    rest, with acc linear between its samples: the exact recurrence of Nigam & Jennings (Chopra
    Table 5.2.1), evaluated for all periods at once. T = 0 gives the peak |acc|."""
    acc = np.asarray(acc, float)
    T = np.atleast_1d(np.asarray(periods, float))
    out = np.empty(T.size)
    rigid = T <= 0
    out[rigid] = np.max(np.abs(acc)) if acc.size else 0.0
    if rigid.all():
        return out
    z = damping
    w = 2.0 * np.pi / T[~rigid]
    r = math.sqrt(1.0 - z * z)
    wd = w * r
    e, s, c = np.exp(-z * w * dt), np.sin(wd * dt), np.cos(wd * dt)
    k = w * w
    q = z / r
    a11 = e * (q * s + c)
    a12 = e * s / wd
    b1 = (2 * z / (w * dt) + e * (((1 - 2 * z * z) / (wd * dt) - q) * s - (1 + 2 * z / (w * dt)) * c)) / k
    b2 = (1 - 2 * z / (w * dt) + e * ((2 * z * z - 1) / (wd * dt) * s + 2 * z / (w * dt) * c)) / k
    a21 = -e * (w / r) * s
    a22 = e * (c - q * s)
    c1 = (-1 / dt + e * ((w / r + z / (dt * r)) * s + c / dt)) / k
    c2 = (1 - e * (q * s + c)) / (k * dt)
    u = np.zeros_like(w)
    v = np.zeros_like(w)
    umax = np.zeros_like(w)
    p = -acc
    for i in range(acc.size - 1):
        u, v = a11 * u + a12 * v + b1 * p[i] + b2 * p[i + 1], a21 * u + a22 * v + c1 * p[i] + c2 * p[i + 1]
        np.maximum(umax, np.abs(u), out=umax)
    out[~rigid] = k * umax
    return out


def ec8_type1(periods, ag: float, ground_type: str) -> np.ndarray:
    """EN 1998-1 §3.2.2.2 horizontal elastic spectrum, type 1, 5 % damping (eta = 1), m/s^2."""
    S, tb, tc, td = EC8_TYPE1[ground_type]
    T = np.asarray(periods, float)
    base = ag * S * 2.5
    return np.where(T <= tb, ag * S * (1 + T / tb * 1.5),
                    np.where(T <= tc, base, np.where(T <= td, base * tc / np.maximum(T, 1e-12),
                                                     base * tc * td / np.maximum(T, 1e-12) ** 2)))


def target_spectrum(suite: dict, periods) -> np.ndarray | None:
    """The target Sa at `periods` (m/s^2), or None when the suite has no target."""
    if suite["target"] == "table" and suite["table"]["periods"] is not None:
        return np.interp(periods, suite["table"]["periods"], suite["table"]["sa"])
    if suite["target"] == "ec8_type1" and suite["ec8"]["ag"] is not None:
        return ec8_type1(periods, suite["ec8"]["ag"], suite["ec8"]["ground_type"])
    return None


def scaling_periods(suite: dict) -> np.ndarray:
    """The grid over [T1, T2] on which the scaled mean is held at or above the target."""
    t1, t2 = suite["periods"]
    return np.geomspace(t1, t2, SCALING_POINTS)


def plot_periods(suite: dict) -> np.ndarray:
    top = max(4.0, 2.0 * suite["periods"][1]) if suite["periods"] else 4.0
    return np.concatenate([[0.0], np.geomspace(0.02, top, 120)])


def spectrum_factors(spectra: np.ndarray, target: np.ndarray, fraction: float = 1.0) -> np.ndarray:
    """Amplitude factors for records whose spectra on the grid are the rows of `spectra`: each
    record's best log-fit to `target`, then one factor for the set so that min(mean / target) over
    the grid is `fraction`."""
    f = np.exp(np.mean(np.log(target[None, :] / spectra), axis=1))
    mean = np.mean(f[:, None] * spectra, axis=0)
    return f * (fraction * np.max(target / mean))


def scale_factors(members: list[MemberRecord], d: dict) -> tuple[list[float], list[float]]:
    """(factor, PGA of the scaled processed record) of each member."""
    s, gm = d["suite"], d["ground_motion"]
    accs = [processed(read_member(m), gm) for m in members]
    peaks = [float(np.max(np.abs(a))) for a in accs]
    if s["scaling"] == "pga":
        factors = [(m.pga or s["pga"] or gm["pga"]) / p for m, p in zip(members, peaks, strict=True)]
    elif s["scaling"] == "spectrum":
        T = scaling_periods(s)
        dts = [read_member(m).dt for m in members]
        spectra = np.array([response_spectrum(a, dt, T) for a, dt in zip(accs, dts, strict=True)])
        factors = list(spectrum_factors(spectra, target_spectrum(s, T), s["fraction"]))
    else:
        factors = [1.0] * len(members)
    factors = [float(f) for f in factors]
    return factors, [f * p for f, p in zip(factors, peaks, strict=True)]
