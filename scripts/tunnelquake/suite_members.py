"""A record suite's members: their case files, whether each has finished, their peaks combined
into the design value, and the suite's report. The records, the `suite:` keys and the scaling are
in suite.py.

Combination (`combine`)
  EN 1998-1:2004 §4.3.3.4.3(3): with at least 7 time-history analyses the mean of each response
  quantity is the design value; with fewer, the most unfavourable (the maximum of the peaks). ASCE
  7-10 §16.1.4 has the same threshold; ASCE 7-16 §16.2.2 asks 11 records and uses their mean.
  `auto` applies the 7-record rule; `mean` and `max` force one.
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .suite import (
    MEAN_FROM,
    MemberRecord,
    expand_records,
    plot_periods,
    read_member,
    response_spectrum,
    scale_factors,
    scaling_periods,
    target_spectrum,
)


# ----------------------------------------------------------------------------------------------
# Member cases
# ----------------------------------------------------------------------------------------------
def _plain(x):
    """A YAML tree of LineDicts and LineLists as plain dicts and lists (for yaml.safe_dump)."""
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_plain(v) for v in x]
    return x


def raw_case(path: Path, variant: str | None):
    """The case file as written, with the variant's keys laid over it, without `variants:`."""
    from .case import _merge, _variants
    from .schema import load_yaml

    raw = load_yaml(Path(path).read_text())
    variants = _variants(raw, str(path))
    return _merge(raw, variants[variant]) if variant else raw


@dataclass
class Member:
    name: str
    record: MemberRecord
    factor: float
    pga: float
    case_file: Path
    case_text: str
    extra: dict = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        return self.case_file.parent


def suite_dir(case) -> Path:
    return case.output_dir


def members_dir(case) -> Path:
    return suite_dir(case) / "members"


def plan_members(case) -> list[Member]:
    """The members of the suite of `case` and the text of each member's case file (not written)."""
    import yaml

    d = case.data
    records, problems = expand_records(d["suite"], case.dir)
    if problems:
        raise ValueError("; ".join(f"{k} = {v!r}: {p}" for k, v, p in problems))
    factors, pgas = scale_factors(records, d)
    base = _plain(raw_case(case.path, case.variant))
    base.pop("suite", None)
    out = []
    for rec, f, pga in zip(records, factors, pgas, strict=True):
        body = dict(base)
        body["name"] = f"{d['name']}/{rec.name}"
        gm = dict(body.get("ground_motion") or {})
        gm.update({"source": "file", "file": str(rec.path), "format": rec.format, "units": rec.units,
                   "if_missing": "error", "pga": f"{float(pga)!r} m/s^2"})
        output = dict(body.get("output") or {})
        output["directory"] = "."
        body["ground_motion"], body["output"] = gm, output
        folder = members_dir(case) / rec.name
        head = (f"# Member '{rec.name}' of the record suite of {case.path}"
                f"{f' (variant {case.variant})' if case.variant else ''}, written by `tunnelquake run`.\n"
                f"# Record {rec.path} ({rec.units}, direction {rec.direction}), scaled by {f:.6g}.\n")
        if rec.direction == "-x":
            flipped = folder / "record_reversed.txt"
            gm.update({"file": flipped.name, "format": "two_column", "units": "m/s^2"})
        text = head + yaml.safe_dump(body, sort_keys=False, default_flow_style=False, width=100)
        out.append(Member(rec.name, rec, f, pga, folder / "case.yaml", text))
    from .sanity import member_warnings

    for w in member_warnings(out):  # a scaled PGA no key states: said wherever the members are planned
        print(f"warning: {w}", file=sys.stderr)
    return out


def write_member(m: Member) -> None:
    """Write the member's case file (and, for direction -x, its reversed record) unless identical."""
    m.folder.mkdir(parents=True, exist_ok=True)
    if m.record.direction == "-x":
        rec = read_member(m.record)
        rows = "\n".join(f"{i * rec.dt!r} {float(a)!r}" for i, a in enumerate(rec.acc))
        text = f"# {m.record.path} reversed (-x), m/s^2\n{rows}\n"
        target = m.folder / "record_reversed.txt"
        if not target.is_file() or target.read_text() != text:
            target.write_text(text)
    if not m.case_file.is_file() or m.case_file.read_text() != m.case_text:
        m.case_file.write_text(m.case_text)


def member_conditions(case) -> list[str]:
    from .scene import plan

    return [c for c, _ in plan(case)]


#: a member's state file in its folder (name, status, rc, wall time), written by the run that runs it
STATE = "member.json"


def read_state(folder: Path) -> dict:
    """A member's state ({} when it has none or it cannot be read)."""
    try:
        return json.loads((Path(folder) / STATE).read_text())
    except (OSError, ValueError):
        return {}


def member_finished(m: Member, conditions: list[str]) -> bool:
    """Whether the member ran to the end from this very case file: its case file unchanged and
    each condition's results file with status 'completed'."""
    import h5py

    if not m.case_file.is_file() or m.case_file.read_text() != m.case_text:
        return False
    for cond in conditions:
        res = m.folder / f"results_{cond}.h5"
        try:
            with h5py.File(res, "r") as f:
                status = f.attrs.get("status", b"")
        except OSError:
            return False
        if (status.decode() if isinstance(status, bytes) else str(status)) != "completed":
            return False
    return True


# ----------------------------------------------------------------------------------------------
# Combination and report
# ----------------------------------------------------------------------------------------------
def combination_rule(rule: str, n: int) -> str:
    """'mean' or 'max' for `n` members under `rule` (auto: mean from MEAN_FROM members on)."""
    if rule == "auto":
        return "mean" if n >= MEAN_FROM else "max"
    return rule


def most_severe_is_smallest(quantity: str) -> bool:
    """Whether the quantity's most severe value is its smallest: a signed minimum (the most
    compressive principal stress `min_sigma1`, the most negative thrust `min_N`, the smallest
    hydraulic-jacking ratio `min_jacking_ratio`): every quantity named min_*. The others are
    largest when most severe."""
    return quantity.startswith("min_")


def combine(values, rule: str, quantity: str = "") -> float:
    """The design value of one quantity from the members' peaks, under the resolved rule: their
    mean, or the most severe member's value, the sign of the quantity respected (the smallest of a
    signed minimum: -397, -355, -305 kPa combine to -397)."""
    v = np.asarray(values, float)
    if rule == "mean":
        return float(np.mean(v))
    return float(np.min(v)) if most_severe_is_smallest(quantity) else float(np.max(v))


#: how the suite report shows each quantity: (label, unit, SI value x scale = shown)
SHOWN = {"max_ux": ("max |u_x|", "mm", 1e3), "max_uy": ("max |u_y|", "mm", 1e3), "max_uz": ("max |u_z|", "mm", 1e3),
         "max_tension": ("max σ3", "MPa", 1e-6), "min_sigma1": ("min σ1", "MPa", 1e-6),
         "max_damage": ("max D", "", 1.0), "hydrodynamic_pressure_peak": ("peak |p_dyn|", "MPa", 1e-6),
         "max_N": ("max N", "kN/m", 1e-3), "min_N": ("min N", "kN/m", 1e-3),
         "max_M": ("max M", "kN·m/m", 1e-3), "min_M": ("min M", "kN·m/m", 1e-3),
         "max_V": ("max V", "kN/m", 1e-3), "min_V": ("min V", "kN/m", 1e-3),
         "max_crack_width": ("max crack width", "mm", 1e3), "min_jacking_ratio": ("min σ_min / p_w", "", 1.0)}


def shown(q: str) -> tuple[str, str, float]:
    """(label, unit, scale) of a quantity; a utilisation `utilisation: <check>` is dimensionless."""
    if q in SHOWN:
        return SHOWN[q]
    return q, "", 1.0


def lining_peaks(folder: Path, conditions: list[str], results: dict) -> dict:
    """{condition: {quantity: value}} of a member's lining: N, M, V extremes (N tension positive, M
    with tension at the inner face), each check's largest utilisation, the largest crack width and
    the smallest hydraulic-jacking ratio, from the member's own case file and results
    (design.lining); {} when the member has no ring forces. The seismic design situation's forces
    (design.seismic_situation) are the ones combined."""
    from .case import CaseError, load_case
    from .design.lining import lining_design

    try:
        case = load_case(folder / "case.yaml")
    except (CaseError, OSError):
        return {}
    res = [results[c] for c in conditions if c in results]
    design = lining_design(case, res) if res else None
    if design is None:
        return {}
    out: dict = {}
    for c in design.conditions:
        q = {}
        for name in ("N", "M", "V"):
            hi, lo = c.combined[name]
            q[f"max_{name}"], q[f"min_{name}"] = hi.value, lo.value
        for check, e in c.utilisation.items():
            if check != "cracking" and np.isfinite(e.value):
                q[f"utilisation: {check}"] = e.value
        if c.crack:
            q["max_crack_width"] = max(e.value for e in c.crack.values())
        jack = [j for j in (design.jacking.get(c.condition) or {}).values() if not isinstance(j, str)]
        if jack:
            q["min_jacking_ratio"] = min(j.ratio for j in jack)
        out[c.condition] = q
    return out


def _quantities(pk: dict) -> list[str]:
    """The design quantities of a peak table: every value except the times of the peaks."""
    return [q for q in pk if not q.startswith("t_") and not q.endswith("_time")]


def member_peaks(folder: Path, conditions: list[str]) -> dict:
    """{condition: {monitor: {quantity: peak}}} of a member's completed conditions."""
    from . import post as P

    out, done = {}, {}
    for cond in conditions:
        res_file = folder / f"results_{cond}.h5"
        if not res_file.is_file():
            continue
        res = P.read_condition(res_file, cond)
        if not res.complete:
            continue
        done[cond] = res
        out[cond] = {mon: {q: pk[q] for q in _quantities(pk)} for mon, pk in P.peaks(res).items()}
    for cond, q in lining_peaks(folder, conditions, done).items():
        out[cond][LINING] = q
    return out


#: the suite tables' row of the lining's design quantities (beside the monitors)
LINING = "lining (design)"


def combined_table(peaks: dict[str, dict], rule: str) -> tuple[dict, str, int]:
    """From {member: {cond: {monitor: {q: v}}}} the combined {cond: {monitor: {q: v}}} over the
    members that have each value, the rule applied and the number of members combined."""
    members = [m for m in peaks if peaks[m]]
    used = combination_rule(rule, len(members))
    out: dict = {}
    for m in members:
        for cond, mons in peaks[m].items():
            for mon, qs in mons.items():
                for q in qs:
                    out.setdefault(cond, {}).setdefault(mon, {}).setdefault(q, None)
    for cond, mons in out.items():
        for mon, qs in mons.items():
            for q in qs:
                vals = [peaks[m][cond][mon][q] for m in members
                        if cond in peaks[m] and mon in peaks[m][cond] and q in peaks[m][cond][mon]]
                vals = [v for v in vals if v == v]
                qs[q] = combine(vals, used, q) if vals else float("nan")
    return out, used, len(members)


def _fmt(v: float, scale: float = 1.0) -> str:
    return "n/a" if v != v else f"{v * scale:.4g}"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fig_spectra(members: list[Member], case, out: Path) -> tuple[Path, dict]:
    """The scaled records' 5 %-damped spectra, their mean and the target; returns the figure and
    the spectra {T, members: {name: Sa}, mean, target}."""
    from .case import load_case
    from .motion import from_case

    s = case.data["suite"]
    T = plot_periods(s)
    spectra, on_range = {}, []
    for m in members:
        mc = load_case(m.case_file)
        motion, _ = from_case(mc.data["ground_motion"], mc.dir)
        acc = motion.ax * (2.0 if motion.convention == "outcrop" else 1.0)
        spectra[m.name] = response_spectrum(acc, motion.dt, T)
        if s["periods"]:
            on_range.append(response_spectrum(acc, motion.dt, scaling_periods(s)))
    mean = np.mean(list(spectra.values()), axis=0)
    target = target_spectrum(s, T)
    range_mean = np.mean(on_range, axis=0) if on_range else None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for name, sa in spectra.items():
        ax.plot(T[1:], sa[1:], lw=0.8, alpha=0.7, label=name)
    ax.plot(T[1:], mean[1:], lw=2.2, color="k", label=f"mean of {len(spectra)}")
    if target is not None:
        ax.plot(T[1:], target[1:], lw=1.8, ls="--", color="tab:red", label="target")
        if s["scaling"] == "spectrum" and s["fraction"] < 1:
            ax.plot(T[1:], s["fraction"] * target[1:], lw=1.0, ls=":", color="tab:red",
                    label=f"{s['fraction']:g} x target")
    if s["periods"]:
        ax.axvspan(*s["periods"], color="0.9", zorder=0, label="[T1, T2]")
    ax.set_xscale("log")
    ax.set_xlabel("period T (s)")
    ax.set_ylabel("Sa, 5 % damped (m/s$^2$)")
    ax.set_title("Scaled records' pseudo-acceleration spectra")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out, {"T": T, "members": spectra, "mean": mean, "target": target, "range_mean": range_mean}


def fig_spread(peaks: dict, combined: dict, rule: str, out: Path) -> Path | None:
    """Each member's peak of every (monitor, quantity) divided by the combined value, one panel a
    condition: the spread of the suite around its design value."""
    conds = list(combined)
    if not conds:
        return None
    plt = _plt()
    fig, axes = plt.subplots(len(conds), 1, figsize=(9, 3.2 * len(conds)), squeeze=False)
    names = list(peaks)
    for ax, cond in zip(axes[:, 0], conds, strict=True):
        labels = []
        for mon, qs in combined[cond].items():
            for q, v in qs.items():
                if not v or v != v:
                    continue
                x = len(labels)
                labels.append(f"{mon}\n{q}")
                for j, m in enumerate(names):
                    val = peaks[m].get(cond, {}).get(mon, {}).get(q)
                    if val is not None and val == val:
                        ax.plot(x + 0.06 * (j - (len(names) - 1) / 2), val / v, "o", ms=4,
                                color=f"C{j % 10}", label=m if x == 0 else None)
        ax.axhline(1.0, color="k", lw=1)
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(labels, fontsize=6, rotation=60, ha="right")
        ax.set_ylabel(f"peak / {rule}")
        ax.set_title(f"{cond}: members' peaks against the combined value ({rule})", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=4)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def write_report(case, members: list[Member], states: dict[str, dict] | None = None) -> Path:
    """suite_report.md (and suite_peaks.csv, figures/suite_spectra.png, figures/suite_spread.png)
    in the suite's results folder, from what the members' results hold."""
    import csv

    s = case.data["suite"]
    conds = member_conditions(case)
    folder = suite_dir(case)
    figs = folder / "figures"
    states = states or {}
    peaks = {m.name: member_peaks(m.folder, conds) for m in members}
    full = {n: p for n, p in peaks.items() if all(c in p for c in conds)}
    combined, rule, n_used = combined_table(full, s["combine"])
    lines = [f"# Record suite: {case.data['name']}", ""]
    lines.append(f"- {len(members)} members x {len(conds)} condition(s) ({', '.join(conds)}); members' results in "
                 f"`members/<name>/`")
    what = {"pga": "each processed record scaled to its PGA",
            "spectrum": (f"amplitude scaling to the target over T = {s['periods'][0]:g}-{s['periods'][1]:g} s: "
                         f"each record's log-fit, then one factor for the set so the mean is at least "
                         f"{s['fraction']:g} x the target over the range and touches it") if s["periods"] else "",
            "none": "none (the records as processed)"}[s["scaling"]]
    lines.append(f"- scaling: {what}")
    why = (f"{'at least' if n_used >= MEAN_FROM else 'fewer than'} {MEAN_FROM} members (EN 1998-1 §4.3.3.4.3(3))"
           if s["combine"] == "auto" else "set by suite.combine")
    lines.append(f"- combination: **{rule}** over the {n_used} member(s) with every condition completed ({why})")
    missing = [m.name for m in members if m.name not in full]
    if missing:
        lines.append(f"- **not combined** (a condition not completed): {', '.join(missing)}")
    lines += ["", "## Members", "", "| member | record | direction | scale factor | PGA (m/s², g) | status | wall (s) |",
              "|---|---|---|---|---|---|---|"]
    for m in members:
        st = states.get(m.name, {})
        status = "completed" if m.name in full else st.get("status", "not run")
        wall = st.get("wall_s")
        lines.append(f"| {m.name} | `{m.record.path.name}` | {m.record.direction} | {m.factor:.4g} | {m.pga:.4g}, {m.pga / 9.80665:.3g} g | "
                     f"{status} | {'' if wall is None else f'{wall:.1f}'} |")
    rows = []
    for cond in combined:
        lines += ["", f"## Peaks: {cond}", ""]
        for mon, qs in combined[cond].items():
            qn = list(qs)
            head = [f"{shown(q)[0]} ({shown(q)[1]})" if shown(q)[1] else shown(q)[0] for q in qn]
            lines += [f"### {mon}", "", "| member | " + " | ".join(head) + " |", "|---" * (len(qn) + 1) + "|"]
            for name in full:
                vals = [full[name][cond].get(mon, {}).get(q, float("nan")) for q in qn]
                lines.append(f"| {name} | " + " | ".join(_fmt(v, shown(q)[2]) for q, v in zip(qn, vals, strict=True))
                             + " |")
                rows += [(name, cond, mon, q, v) for q, v in zip(qn, vals, strict=True)]
            lines.append(f"| **{rule}** | " + " | ".join(f"**{_fmt(qs[q], shown(q)[2])}**" for q in qn) + " |")
            rows += [(f"combined_{rule}", cond, mon, q, qs[q]) for q in qn]
            lines.append("")
    lines.append(f"Quantities as in each member's report.md (σ3 the most tensile principal stress, σ1 the most "
                 f"compressive, tension positive; N tension positive, M with tension at the inner face; the lining's "
                 f"forces those of the seismic design situation). **{rule}**: "
                 + ("the members' mean." if rule == "mean" else "the most severe member's value: the largest, and for "
                    "a minimum (min σ1, min N, min M, min V, min σ_min / p_w) the smallest.")
                 + " All values in SI: `suite_peaks.csv`.")
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "suite_peaks.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["member", "condition", "monitor", "quantity", "value"])
        w.writerows([(a, b, c, q, repr(v)) for a, b, c, q, v in rows])
    lines += ["", "## Spectra", ""]
    try:
        fig, sp = fig_spectra(members, case, figs / "suite_spectra.png")
    except Exception as e:  # noqa: BLE001 - the tables stand without the figure
        lines.append(f"(not drawn: {type(e).__name__}: {e})")
    else:
        lines.append(f"![spectra](figures/{fig.name})")
        if sp["target"] is not None and s["periods"]:
            T = scaling_periods(s)
            ratio = sp["range_mean"] / target_spectrum(s, T)
            lines += ["", f"Mean over the target on [{s['periods'][0]:g}, {s['periods'][1]:g}] s: lowest "
                      f"{ratio.min():.3f}, highest {ratio.max():.3f} (5 % damping)."]
    spread = fig_spread(full, combined, rule, figs / "suite_spread.png")
    if spread is not None:
        lines += ["", "## Spread", "", f"![spread](figures/{spread.name})"]
    out = folder / "suite_report.md"
    out.write_text("\n".join(lines) + "\n")
    return out
