"""The comparison with the paper the example case reproduces (Liu, Zhang & Xiao 2021, *Numerical
Simulation Analysis of Combined Seismic Response for Rock-Lining-Water in Hydraulic Tunnel*, Shock
and Vibration, §3.3): its numbers, its monitors, its record and its findings, and the report
sections and figure marks that compare a run with them.

Everything specific to the paper lives here. The report and the figures of any other case name
none of it; a case asks for this comparison with `reference: {paper: liu2021}` (case.py), and
`applies(case_data)` says whether it did.

The report part: the §3.3 numbers value by value, the qualitative findings, each marked
reproduced / not reproduced / not computed, and a discussion of each difference written from
the measured numbers (nothing here is fixed text about the outcome).
"""
from __future__ import annotations

import math

import numpy as np

from .post import CONDITION_LABELS, CONTACT_STATES, ConditionResult, peaks

#: The papers a case may name under `reference.paper`.
PAPERS = ("liu2021",)
PAPER_DOC = ("compare the run with a published one in report.md and the figures: liu2021 = Liu, Zhang & "
             "Xiao 2021, §3.3 (the example case; needs its monitors top_arch, haunch, bottom_arch in the "
             "lining); absent: the report of the case alone")
#: What the figures' legends call the paper's values.
LABEL = "paper"
#: The unit of the paper's displacement figure (its Fig. 6).
DISPLACEMENT_UNIT = "cm"
#: The paper's monitors, from crown to invert, in its figures' order.
MONITORS = ("top_arch", "haunch", "bottom_arch")
#: The paper's figure numbers of the report's figures.
FIGURE_NUMBERS = {"fig03": 3, "fig05": 5, "fig06": 6, "fig07": 7, "fig08": 8, "fig09": 9, "fig10": 10}
#: The paper's record, as it names it (its version, filtering and baseline correction are not given).
RECORD = "'Imperial-Valley wave'"

#: The paper's §3.3 numbers (Liu, Zhang & Xiao 2021). Displacements in m, stresses/pressures in Pa.
PAPER = {
    "hydrodynamic_pressure_peak": {"top_arch": 0.256e6, "haunch": 0.466e6, "bottom_arch": 0.326e6},
    "hydrodynamic_pressure_peak_time": 5.2,
    "displacement_peak_time": 14.9,
    "tension_growth_end": 7.0,  # "at time 0~7 s ... increases rapidly to the maximum value"
    "lining_tensile_strength": 1.27e6,
    "initial_tension_with_water": 0.76e6,  # conditions 2 and 3: "about 0.76 MPa at time 0 s"
    "max_ux": {
        "no_water": {"top_arch": 0.0600, "haunch": 0.0619, "bottom_arch": 0.0588},
        "static_water": {"top_arch": 0.0600 - 0.0033, "haunch": 0.0619 - 0.0031, "bottom_arch": 0.0588 - 0.0027},
        "dynamic_water": {"top_arch": 0.0600 + 0.0031, "haunch": 0.0619 + 0.0060, "bottom_arch": 0.0588 + 0.0039},
    },
    "max_uz": {
        "no_water": {"top_arch": 0.0355, "haunch": 0.0374, "bottom_arch": 0.0386},
        "static_water": {"top_arch": 0.0355 - 0.0015, "haunch": 0.0374 - 0.0019, "bottom_arch": 0.0386 - 0.0017},
        "dynamic_water": {"top_arch": 0.0355 + 0.0019, "haunch": 0.0374 + 0.0024, "bottom_arch": 0.0386 + 0.0038},
    },
    "max_tension": {
        "no_water": {"top_arch": 0.65e6, "haunch": 1.09e6, "bottom_arch": 0.92e6},
        "static_water": {"top_arch": 0.80e6, "haunch": 0.88e6, "bottom_arch": 0.79e6},
        "dynamic_water": {"top_arch": 1.27e6, "haunch": 1.27e6, "bottom_arch": 1.27e6},
    },
}
#: A value is "reproduced" when ours is within this relative distance of the paper's.
TOLERANCE = 0.20
#: What the study of the paper's open choices (`tunnelquake bench --identify`, paper_study.py)
#: leaves beside the case file: every choice's §3.3 numbers and the identified set.
STUDY_FILE = "identified.json"
#: The example's variant with the identified set.
IDENTIFIED_VARIANT = "paper_identified"
#: Two runs' numbers closer than this (relative) count as the same in the comparison with the
#: identified set.
SAME = 0.005
#: The study's name of the example's own run.
EXAMPLE_RUN = "example: as cases/paper_tunnel"


def paper_numbers() -> dict[str, float]:
    """The paper's §3.3 numbers, one key each ('max_ux/no_water/top_arch', 'pressure/haunch',
    'pressure_time/haunch'; SI units): the 33 numbers a run is matched on."""
    out = {}
    for key in ("max_ux", "max_uz", "max_tension"):
        for cond, per in PAPER[key].items():
            for m in MONITORS:
                out[f"{key}/{cond}/{m}"] = per[m]
    for m in MONITORS:
        out[f"pressure/{m}"] = PAPER["hydrodynamic_pressure_peak"][m]
        out[f"pressure_time/{m}"] = PAPER["hydrodynamic_pressure_peak_time"]
    return out


def misfit(values: dict, keys: list[str] | None = None) -> float:
    """Σ ln²(ours/paper) over the §3.3 numbers (`keys`, default all 33); a number not computed
    counts 4 (a factor e²)."""
    target = paper_numbers()
    s = 0.0
    for k in keys or list(target):
        v, p = values.get(k), target[k]
        s += math.log(v / p) ** 2 if v is not None and np.isfinite(v) and v > 0 else 4.0
    return s


def within(values: dict, keys: list[str] | None = None) -> int:
    """How many of the §3.3 numbers (`keys`, default all 33) are within ±TOLERANCE of the paper's."""
    target = paper_numbers()
    return sum(1 for k in keys or list(target) if values.get(k) is not None and np.isfinite(values[k])
               and abs(values[k] / target[k] - 1) <= TOLERANCE)


def load_study(case_dir) -> dict | None:
    """The study's results beside the case file (STUDY_FILE), or None."""
    import json
    from pathlib import Path

    if not case_dir:
        return None
    f = Path(case_dir) / STUDY_FILE
    try:
        return json.loads(f.read_text())
    except (OSError, ValueError):
        return None


def applies(data: dict) -> bool:
    """Whether a case's validated data asks for the comparison with the paper."""
    return (data.get("reference") or {}).get("paper") in PAPERS


def pressure_marks() -> dict[str, tuple[float, float]]:
    """Marks of the hydrodynamic pressure figure: per paper monitor, (time s, peak Pa) of the paper."""
    t = PAPER["hydrodynamic_pressure_peak_time"]
    return {m: (t, p) for m, p in PAPER["hydrodynamic_pressure_peak"].items()}


def displacement_bars(condition: str, key: str) -> dict[str, float]:
    """Bars of the peak displacement figure: the paper's max_ux or max_uz (m) per monitor."""
    return dict(PAPER[key].get(condition, {}))


def figure_caption(key: str, caption: str) -> str:
    """A report figure's caption with the paper's figure number it redraws."""
    n = FIGURE_NUMBERS.get(key)
    return f"Fig. {n}: {caption}" if n else caption


def case_issues(data: dict, reference_line: int | None) -> list:
    """What a case that asks for the comparison must have: the paper's monitors."""
    from .schema import Issue

    if not applies(data):
        return []
    have = data["output"]["monitors"] or {}
    missing = [m for m in MONITORS if m not in have]
    if not missing:
        return []
    return [Issue("reference.paper", data["reference"]["paper"],
                  f"compares the monitors {', '.join(MONITORS)} with the paper's, and output.monitors has no "
                  f"{', '.join(missing)}",
                  f"add {', '.join(missing)} to output.monitors (on the lining, as in cases/paper_tunnel), or leave "
                  "reference out for the report of this case alone", reference_line)]


def monitor_in_rock_issue(data: dict, name: str, point, what: str, near, line: int | None):
    """The error for a paper monitor placed in the rock (the comparison reads it as the lining's),
    or None when the case does not compare with the paper or the monitor is not one of its."""
    from .schema import Issue

    if not applies(data) or name not in MONITORS:
        return None
    return Issue(f"output.monitors.{name}", point,
                 f"{what}, and the report compares {name} with the paper's lining values",
                 f"move it into the lining, e.g. {near} on its inner surface in the same direction, or give the "
                 f"rock point another name (the report reads {', '.join(MONITORS)} as the lining's)", line)


REPRODUCED, NOT_REPRODUCED, NOT_COMPUTED = "reproduced", "**not reproduced**", "not computed"
#: Sectors of the ring, degrees from the crown: the top and bottom arches and the haunches between.
CROWN_DEG, INVERT_DEG = 30.0, 150.0
#: D below this counts as no damage.
NO_DAMAGE = 1e-6

_QUANTITIES = {  # key: (label, unit, scale, paper time of the peak, figure)
    "hydrodynamic_pressure_peak": ("hydrodynamic pressure peak", "MPa", 1e-6,
                                   PAPER["hydrodynamic_pressure_peak_time"], "fig05"),
    "max_ux": ("max_ux", "cm", 100.0, PAPER["displacement_peak_time"], "fig06"),
    "max_uz": ("max_uz", "cm", 100.0, PAPER["displacement_peak_time"], "fig06"),
    "max_tension": ("max_tension", "MPa", 1e-6, PAPER["tension_growth_end"], "fig07"),
}


def verdict(ours: float, paper: float, t_end: float, t_paper: float) -> str:
    """reproduced within TOLERANCE; a peak already above the band stays above it (peaks only grow);
    otherwise a run that ended before the paper's peak time cannot tell yet."""
    if ours is None or not np.isfinite(ours):
        return NOT_COMPUTED
    r = ours / paper
    if r > 1 + TOLERANCE:
        return NOT_REPRODUCED
    if t_end < t_paper:
        return f"{NOT_COMPUTED} (run ends at {t_end:.2f} s, before the paper's {t_paper:g} s)"
    return REPRODUCED if abs(r - 1) <= TOLERANCE else NOT_REPRODUCED


class Comparison:
    """Collects rows and discussion items while the report is built."""

    def __init__(self, results: list[ConditionResult], figures: dict[str, str], context: dict):
        self.by = {r.condition: r for r in results}
        self.pk = {r.condition: peaks(r) for r in results}
        self.figures = figures  # key (fig05, ...) -> relative path, for the evidence column
        self.ctx = context
        self.rows: list[str] = []
        self.misses: dict[tuple[str, str], list[tuple[str, float, float]]] = {}
        self._sections: dict[str, dict] = {}
        self.study = load_study(context.get("case_dir"))
        self._numbers: dict | None = None  # numbers(), for the joint reach of the numbers outside the band

    def numbers(self) -> dict:
        """This run's §3.3 numbers under paper_numbers()' keys, with per condition its status and
        end, each monitor's σ3 at the seismic start and largest D, the section's largest D and the
        interface pairs that opened (in the haunch sectors): what the study tabulates."""
        out: dict = {}
        for cond, r in self.by.items():
            if not r.samples:
                continue
            pk = self.pk[cond]
            out[f"t_end/{cond}"], out[f"status/{cond}"] = r.t_end, r.status
            for m in MONITORS:
                for key in ("max_ux", "max_uz", "max_tension"):
                    out[f"{key}/{cond}/{m}"] = pk[m][key]
                out[f"sigma3_start/{cond}/{m}"] = float(r.monitors[m].principal[0, 2])
                out[f"max_damage_monitor/{cond}/{m}"] = pk[m].get("max_damage", math.nan)
                if cond == "dynamic_water":
                    out[f"pressure/{m}"] = pk[m].get("hydrodynamic_pressure_peak", math.nan)
                    out[f"pressure_time/{m}"] = pk[m].get("hydrodynamic_pressure_peak_time", math.nan)
            d, _ = self.max_damage(cond)
            out[f"max_damage/{cond}"] = d if d is not None else math.nan
            z = self.interface_zone(cond)
            if z is not None:
                out[f"opened/{cond}"], out[f"opened_haunch/{cond}"], out[f"pairs/{cond}"] = \
                    z["opened"], z["in_haunch"], z["n"]
        return out

    def fig(self, key: str) -> str:
        p = self.figures.get(key)
        return f"[{key}]({p})" if p else "—"

    def figs(self, *keys: str) -> str:
        return ", ".join(self.fig(k) for k in keys if k in self.figures) or "—"

    # -- numbers --------------------------------------------------------------------------------
    def value_rows(self) -> list[str]:
        lines = ["| quantity | condition | monitor | paper | ours | ours / paper | verdict | evidence |",
                 "|---|---|---|---|---|---|---|---|"]
        for key, (label, unit, scale, t_paper, fig) in _QUANTITIES.items():
            conds = ["dynamic_water"] if key == "hydrodynamic_pressure_peak" else list(CONDITION_LABELS)
            for cond in conds:
                for m in MONITORS:
                    p = (PAPER[key][m] if key == "hydrodynamic_pressure_peak" else PAPER[key][cond][m])
                    res = self.by.get(cond)
                    o = self.pk.get(cond, {}).get(m, {}).get(key) if res else None
                    if res is None:
                        v = f"{NOT_COMPUTED} (no results_{cond}.h5)"
                    elif o is None:
                        v = f"{NOT_COMPUTED} (not recorded in results_{cond}.h5)"
                    else:
                        v = verdict(o, p, res.t_end, t_paper)
                    os_ = "—" if o is None else f"{o * scale:.3g}"
                    ratio = "—" if o is None else f"{o / p:.2f}"
                    if o is not None and v == NOT_REPRODUCED:
                        self.misses.setdefault((key, cond), []).append((m, o, p))
                        v += self.reach(f"pressure/{m}" if key == "hydrodynamic_pressure_peak" else f"{key}/{cond}/{m}")
                    lines.append(f"| {label} ({unit}) | {cond} | {m} | {p * scale:.3g} | {os_} | {ratio} | {v} | "
                                 f"{self.fig(fig)} |")
            if key == "hydrodynamic_pressure_peak":
                lines += self._peak_time_rows()
        return lines + self._start_rows()

    def _start_rows(self) -> list[str]:
        """σ3 at the seismic start with the water's static pressure (the paper: about 0.76 MPa in
        conditions 2 and 3), per monitor."""
        p0 = PAPER["initial_tension_with_water"]
        out = []
        for cond in ("static_water", "dynamic_water"):
            res = self.by.get(cond)
            for m in MONITORS:
                if res is None or not res.samples or m not in res.monitors:
                    out.append(f"| σ3 at the seismic start (MPa) | {cond} | {m} | {p0 / 1e6:.2f} | — | — | "
                               f"{NOT_COMPUTED} | {self.fig('fig07')} |")
                    continue
                o = float(res.monitors[m].principal[0, 2])
                v = REPRODUCED if abs(o / p0 - 1) <= TOLERANCE else NOT_REPRODUCED
                if v == NOT_REPRODUCED:
                    v += self.reach(f"sigma3_start/{cond}/{m}", lambda x: abs(x / p0 - 1) <= TOLERANCE, p0)
                out.append(f"| σ3 at the seismic start (MPa) | {cond} | {m} | {p0 / 1e6:.2f} | {o / 1e6:.3g} | "
                           f"{o / p0:.2f} | {v} | {self.fig('fig07')} |")
        return out

    def _peak_time_rows(self) -> list[str]:
        out = []
        res = self.by.get("dynamic_water")
        tp = PAPER["hydrodynamic_pressure_peak_time"]
        for m in MONITORS:
            t = self.pk.get("dynamic_water", {}).get(m, {}).get("hydrodynamic_pressure_peak_time")
            if res is None or t is None:
                v, ts = NOT_COMPUTED, "—"
            elif res.t_end < tp:
                v, ts = f"{NOT_COMPUTED} (run ends at {res.t_end:.2f} s)", f"{t:.2f}"
            else:
                v, ts = (REPRODUCED if abs(t - tp) <= 0.5 else NOT_REPRODUCED), f"{t:.2f}"
                if v == NOT_REPRODUCED:
                    v += self.reach(f"pressure_time/{m}", lambda x: abs(x - tp) <= 0.5)
            out.append(f"| time of the pressure peak (s, ±0.5) | dynamic_water | {m} | {tp:g} | {ts} | — | {v} | "
                       f"{self.fig('fig05')} |")
        return out

    # -- damage and the interface ---------------------------------------------------------------
    def last_section(self, cond: str) -> dict | None:
        """Damage and interface state of the middle section at the last snapshot (cached)."""
        if cond in self._sections:
            return self._sections[cond]
        from .post import damage_section, interface_section, read_snapshot

        res = self.by.get(cond)
        out = None
        if res is not None and res.snapshots and res.mesh is not None:
            snap = read_snapshot(res, res.snapshots[-1][0])
            polys, d, elems = damage_section(res, snap)
            out = {"time": snap["time"], "damage": d, "elements": elems,
                   "interface": interface_section(res, snap)}
            if len(elems):
                out["radial"] = self._radial_damage(res, elems, d)
        self._sections[cond] = out
        return out

    @staticmethod
    def _radial_damage(res, elems, d):
        from .post import tunnel_centre

        c, conn = res.mesh["coordinates"], res.mesh["connectivity"]
        xc, zc = tunnel_centre(res)
        cen = c[conn[elems]].mean(axis=1)
        r = np.hypot(cen[:, 0] - xc, cen[:, 2] - zc)
        mid = 0.5 * (r.min() + r.max())
        inner, outer = d[r < mid], d[r >= mid]
        return (float(inner.mean()) if inner.size else float("nan"),
                float(outer.mean()) if outer.size else float("nan"))

    def max_damage(self, cond: str) -> tuple[float | None, str]:
        """Largest D of the lining: over the middle section at the last snapshot when there is one
        (damage does not heal), else over the monitors' histories."""
        sec = self.last_section(cond)
        if sec is not None and len(sec["damage"]):
            return float(np.max(sec["damage"])), f"middle section at t = {sec['time']:.2f} s"
        pk = self.pk.get(cond, {})
        vals = [v["max_damage"] for v in pk.values() if np.isfinite(v.get("max_damage", np.nan))]
        return (max(vals), "monitor histories") if vals else (None, "")

    def damage_rows(self) -> list[str]:
        lines = ["| where | paper | ours | verdict | evidence |", "|---|---|---|---|---|"]
        for cond in CONDITION_LABELS:
            res = self.by.get(cond)
            dmax, where = self.max_damage(cond) if res else (None, "")
            wet = cond == "dynamic_water"
            paper = "tensile damage in the lining" if wet else "no damage in the lining"
            if dmax is None:
                lines.append(f"| damage, {cond} | {paper} | — | {NOT_COMPUTED} | — |")
                continue
            has = dmax > NO_DAMAGE
            v = REPRODUCED if has == wet else NOT_REPRODUCED
            if not has and wet and res.t_end < 3.0:
                v = f"{NOT_COMPUTED} (run ends at {res.t_end:.2f} s; the paper's damage starts after 3 s)"
            d0 = [float(mo.extra["damage"][0]) for mo in res.monitors.values()
                  if mo.extra.get("damage") is not None and mo.extra["damage"].size]
            start = f"; at the seismic start the monitors have D ≤ {max(d0):.3g} (static stages)" if d0 else ""
            lines.append(f"| damage, {cond} | {paper} | max D = {dmax:.3g} ({where}){start} | {v} | "
                         f"{self.figs('fig08', 'fig09')} |")
            if v == NOT_REPRODUCED:
                self.misses.setdefault(("damage", cond), []).append(("lining", dmax, 0.0))
        pk = self.pk.get("dynamic_water", {})
        dm = {m: pk.get(m, {}).get("max_damage", np.nan) for m in MONITORS}
        if all(np.isfinite(list(dm.values()))) and max(dm.values()) > NO_DAMAGE:
            top = max(dm, key=dm.get)
            v = REPRODUCED if top == "haunch" else NOT_REPRODUCED
            ours = ", ".join(f"{m} {dm[m]:.3g}" for m in MONITORS)
        else:
            v, ours = NOT_COMPUTED + " (no damage at the monitors)" if all(np.isfinite(list(dm.values()))) \
                else NOT_COMPUTED, "—"
        lines.append(f"| damage at the monitors, dynamic_water | the haunch's the largest | {ours} | {v} | "
                     f"{self.fig('fig08')} |")
        sec = self.last_section("dynamic_water")
        if sec is not None and "radial" in sec and np.max(sec["damage"]) > NO_DAMAGE:
            di, do = sec["radial"]
            v = REPRODUCED if di > do else NOT_REPRODUCED
            lines.append(f"| damage across the lining, dynamic_water | larger at the water side than at the rock | "
                         f"mean D inner half {di:.3g}, outer half {do:.3g} | {v} | {self.fig('fig09')} |")
        else:
            lines.append("| damage across the lining, dynamic_water | larger at the water side than at the rock | — "
                         f"| {NOT_COMPUTED} (no damaged section snapshot) | {self.fig('fig09')} |")
        return lines

    def interface_zone(self, cond: str) -> dict | None:
        sec = self.last_section(cond)
        if sec is None or sec["interface"] is None:
            return None
        it = sec["interface"]
        a = np.abs(it["angle"])
        opened = it["failed"] | np.isin(it["state"], [CONTACT_STATES.index("separated"),
                                                       CONTACT_STATES.index("slipping")])
        haunch = (a >= CROWN_DEG) & (a <= INVERT_DEG)
        return {"time": sec["time"], "n": int(a.size), "opened": int(opened.sum()),
                "in_haunch": int((opened & haunch).sum()), "crown_invert_opened": int((opened & ~haunch).sum()),
                "crown_invert": int((~haunch).sum()),
                "angles": np.sort(it["angle"][opened])}

    def slip_rows(self) -> list[str]:
        lines = [f"| where | paper | ours (pairs of the middle section; haunch = {CROWN_DEG:g}°–{INVERT_DEG:g}° "
                 "from the crown) | verdict | evidence |", "|---|---|---|---|---|"]
        for cond in CONDITION_LABELS:
            z = self.interface_zone(cond)
            paper = ("separation and slip mainly at the haunches and their sides; top and bottom arches bonded"
                     if cond == "dynamic_water" else "(not given)")
            if z is None:
                lines.append(f"| separation/slip, {cond} | {paper} | — | {NOT_COMPUTED} | — |")
                continue
            ours = (f"{z['opened']} of {z['n']} pairs separated, slipping or with a failed bond at t = "
                    f"{z['time']:.2f} s; {z['in_haunch']} in the haunch sectors, {z['crown_invert_opened']} of "
                    f"{z['crown_invert']} at the top/bottom arches")
            if cond != "dynamic_water":
                v = "— (paper silent)"
            elif z["opened"] == 0:
                res = self.by[cond]
                v = (f"{NOT_COMPUTED} (run ends at {res.t_end:.2f} s)" if res.t_end < PAPER["tension_growth_end"]
                     else NOT_REPRODUCED)
            else:
                v = REPRODUCED if z["in_haunch"] >= 0.75 * z["opened"] else NOT_REPRODUCED
            if v == NOT_REPRODUCED:
                self.misses.setdefault(("slip", cond), []).append(("interface", z["opened"], z["n"]))
            lines.append(f"| separation/slip, {cond} | {paper} | {ours} | {v} | {self.fig('fig10')} |")
        return lines

    # -- findings -------------------------------------------------------------------------------
    def window(self, a: str, b: str) -> float:
        return min(self.by[a].t_end, self.by[b].t_end)

    def _compare(self, a: str, b: str, key: str) -> tuple[int, int, list[str], list[str]] | None:
        """Monitors where condition b's peak exceeds condition a's, over the time both runs cover:
        (count, of, details, monitors where b exceeds a)."""
        if a not in self.by or b not in self.by:
            return None
        w = self.window(a, b)
        pa, pb = peaks(self.by[a], w), peaks(self.by[b], w)
        n, det, up = 0, [], []
        for m in MONITORS:
            x, y = pa.get(m, {}).get(key), pb.get(m, {}).get(key)
            if x is None or y is None:
                return None
            if y > x:
                n += 1
                up.append(m)
            _, unit, scale, *_ = _QUANTITIES[key]
            det.append(f"{m} {x * scale:.3g} → {y * scale:.3g} {unit}")
        return n, len(MONITORS), det, up

    def findings_rows(self) -> list[str]:
        lines = ["| finding (paper §3.3, §4) | ours | verdict | evidence |", "|---|---|---|---|"]
        # 1. hydrostatic pressure restrains: condition 2 below condition 1 (paper: displacements at
        #    all monitors, tension "most of which decrease"); 2. hydrodynamic pressure increases the
        #    response: condition 3 above condition 1 everywhere.
        for name, b, text in (("hydrostatic", "static_water", "hydrostatic pressure restrains the lining: "
                               "condition (2) below (1)"),
                              ("hydrodynamic", "dynamic_water", "hydrodynamic pressure increases the response: "
                               "condition (3) above (1)")):
            parts, ok, computed, wrong = [], True, True, []
            for key in ("max_ux", "max_uz", "max_tension"):
                c = self._compare("no_water", b, key)
                if c is None:
                    computed = False
                    continue
                larger, of, det, up = c
                if name == "hydrostatic":
                    need = of if key != "max_tension" else 2
                    ok &= (of - larger) >= need
                    wrong += [f"{key} at {m}" for m in up]
                    parts.append(f"{key}: smaller at {of - larger} of {of} ({'; '.join(det)})")
                else:
                    ok &= larger == of
                    wrong += [f"{key} at {m}" for m in MONITORS if m not in up]
                    parts.append(f"{key}: larger at {larger} of {of} ({'; '.join(det)})")
            v = NOT_COMPUTED if not computed else (REPRODUCED if ok else NOT_REPRODUCED)
            note = f" (peaks over the {self.window('no_water', b):.2f} s both runs cover)" if computed else ""
            lines.append(f"| {text}{note} | {'<br>'.join(parts) or '—'} | {v} | {self.figs('fig06', 'fig07')} |")
            if v == NOT_REPRODUCED:
                self.misses[("finding", name)] = [(x, 0.0, 0.0) for x in wrong]
        # 3. the haunch is the weak part
        claims = []
        pk3 = self.pk.get("dynamic_water", {})
        hp = {m: pk3.get(m, {}).get("hydrodynamic_pressure_peak") for m in MONITORS}
        if all(v_ is not None for v_ in hp.values()):
            claims.append(("largest hydrodynamic pressure", max(hp, key=hp.get) == "haunch",
                           ", ".join(f"{m} {hp[m] / 1e6:.3g} MPa" for m in MONITORS)))
        for cond in CONDITION_LABELS:
            if cond in self.pk:
                t = {m: self.pk[cond].get(m, {}).get("max_tension", np.nan) for m in MONITORS}
                claims.append((f"largest tension, {cond}", max(t, key=t.get) == "haunch",
                               ", ".join(f"{m} {t[m] / 1e6:.3g} MPa" for m in MONITORS)))
        dm = {m: pk3.get(m, {}).get("max_damage", np.nan) for m in MONITORS}
        if pk3 and max(dm.values()) > NO_DAMAGE:
            claims.append(("largest damage", max(dm, key=dm.get) == "haunch",
                           ", ".join(f"{m} {dm[m]:.3g}" for m in MONITORS)))
        z = self.interface_zone("dynamic_water")
        if z is not None and z["opened"]:
            claims.append(("separation/slip at the haunches", z["in_haunch"] >= 0.75 * z["opened"],
                           f"{z['in_haunch']} of {z['opened']} opened pairs"))
        if claims:
            v = REPRODUCED if all(c[1] for c in claims) else NOT_REPRODUCED
            ours = "<br>".join(f"{name}: {'yes' if good else 'no'} ({det})" for name, good, det in claims)
        else:
            v, ours = NOT_COMPUTED, "—"
        lines.append(f"| the haunch is the weak part | {ours} | {v} | {self.figs('fig05', 'fig07', 'fig08', 'fig10')} |")
        if v == NOT_REPRODUCED:
            self.misses[("finding", "haunch")] = [(n, float(g), 0.0) for n, g, _ in claims]
        return lines

    # -- the study of the paper's open choices ---------------------------------------------------
    def study_runs(self) -> dict[str, dict]:
        """Every run of the study by name (the example, each choice, the identified set)."""
        st = self.study
        if not st:
            return {}
        runs = dict(st.get("choices") or {})
        if st.get("confirmed"):
            runs["the identified set"] = st["confirmed"]
        return runs

    def reach(self, key: str, tol=None, paper: float | None = None) -> str:
        """For a number outside the band: what the study's runs say of it (reach_text)."""
        p = paper if paper is not None else paper_numbers()[key]
        if self._numbers is None:
            self._numbers = self.numbers()
        text = reach_text(key, self.study_runs(), p, tol, self._numbers)
        return f" — {text}" if text else ""

    def measured(self, keys: list[str], least: float = 0.02) -> list[str]:
        """The study's measured effect of each choice on these numbers, the largest first: "with X
        instead of Y: a → b" (only choices that move one of them by `least` or more)."""
        st = self.study
        if not st:
            return ["no study of the paper's open choices beside the case file (`tunnelquake bench FOLDER --identify "
                    "--update-docs` writes it), so no measured effect of them"]
        ex = st["choices"].get(EXAMPLE_RUN, {})
        found = []
        for name, nums in st["choices"].items():
            if name == EXAMPLE_RUN:
                continue
            moves = []
            for k in keys:
                a, b = ex.get(k), nums.get(k)
                if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
                    continue
                moves.append((k, float(a), float(b)))
            if not moves:
                continue
            big = max(abs(b - a) / max(abs(a), 1e-30) for _, a, b in moves)
            if big < least:
                continue
            dim, _, level = name.partition(": ")
            was = (st.get("example_levels") or {}).get(dim, "the example's")
            found.append((big, f"with {dim} {level} instead of {was}: " + ", ".join(
                f"{short_label(k, keys)} {a * number_label(k)[2]:.3g} → {b * number_label(k)[2]:.3g}"
                f"{' ' + number_label(k)[1] if number_label(k)[1] else ''}" for k, a, b in moves)))
        if not found:
            return [f"no choice of the study moves these numbers by {100 * least:g} % or more"]
        return [t for _, t in sorted(found, key=lambda x: -x[0])]

    def reference_rows(self) -> list[str]:
        """Which displacement reference the paper's displacements match: the 18 numbers with each."""
        from .post import DISPLACEMENT_REFERENCES, REFERENCE_WORDS, displacement_against

        keys = [k for k in paper_numbers() if k.startswith(("max_ux", "max_uz"))]
        lines = ["| displacement reference | max u_x (1) top arch / haunch / bottom arch (cm) | max u_z (1) (cm) | "
                 "within ±20 % (of 18) | misfit Σ ln²(ours/paper) |", "|---|---|---|---:|---:|"]
        best = None
        for ref in DISPLACEMENT_REFERENCES:
            vals = {}
            for cond, r in self.by.items():
                if not r.samples:
                    continue
                for m in MONITORS:
                    u = displacement_against(r, m, ref) if m in r.monitors else None
                    if u is None:
                        continue
                    vals[f"max_ux/{cond}/{m}"] = float(np.abs(u[:, 0]).max())
                    vals[f"max_uz/{cond}/{m}"] = float(np.abs(u[:, 2]).max())
            if not vals:
                lines.append(f"| {REFERENCE_WORDS[ref]} | — (not recorded in these results) | — | — | — |")
                continue
            f = misfit(vals, keys)
            if best is None or f < best[1]:
                best = (ref, f)
            ux, uz = (" / ".join(f"{100 * vals.get(f'{c}/no_water/{m}', np.nan):.3g}" for m in MONITORS)
                      for c in ("max_ux", "max_uz"))
            lines.append(f"| {REFERENCE_WORDS[ref]} | {ux} | {uz} | {within(vals, keys)} | "
                         f"{f:.2f} |")
        p = paper_numbers()
        lines.append("| paper | " + " / ".join(f"{100 * p[f'max_ux/no_water/{m}']:.3g}" for m in MONITORS) + " | "
                     + " / ".join(f"{100 * p[f'max_uz/no_water/{m}']:.3g}" for m in MONITORS) + " | | |")
        if best:
            lines += ["", f"Measured: the paper's displacements match the **{best[0]}** reference (the smallest misfit over "
                      "its 18 displacement numbers, all three conditions)."]
        return lines

    def identified_rows(self) -> list[str]:
        """The identified set (its own report), or how this run differs from it and why."""
        st = self.study
        if not st:
            return ["No study of the paper's open choices beside the case file: run `tunnelquake bench FOLDER "
                    "--identify --update-docs` (docs/paper_reproduction.md)."]
        levels = st.get("levels") or {}
        was = st.get("example_levels") or {}
        changed = {d: lv for d, lv in levels.items() if lv}
        keys_txt = ", ".join(f"`{k}: {v}`" for k, v in (st.get("overrides") or {}).items()) or "none"
        if self.ctx.get("variant") == IDENTIFIED_VARIANT:
            lines = [f"This run is the identified set (`--variant {IDENTIFIED_VARIANT}`; study of {st.get('date', '?')}, "
                     f"docs/paper_reproduction.md): the example with {keys_txt}.", "",
                     "| open choice | the example | identified |", "|---|---|---|"]
            lines += [f"| {d} | {was.get(d, '?')} | {lv or 'unchanged'} |" for d, lv in levels.items()]
            mine = self.numbers()
            lines += ["", f"{within(mine)} of the 33 §3.3 numbers are within ±{100 * TOLERANCE:.0f} % of the paper's "
                      f"(misfit Σ ln² {misfit(mine):.2f}; the example's: "
                      f"{within(st['choices'].get(EXAMPLE_RUN, {}))}, {misfit(st['choices'].get(EXAMPLE_RUN, {})):.2f})."]
            return lines
        ident = st.get("confirmed")
        if not ident:
            return ["The identified set has not been run: `tunnelquake run cases/paper_tunnel --variant "
                    f"{IDENTIFIED_VARIANT}`."]
        mine = self.numbers()
        lines = [f"The identified set (`--variant {IDENTIFIED_VARIANT}`, docs/paper_reproduction.md) is this case with "
                 f"{keys_txt}. Each number here against its value in the identified set's run, and why: the study's "
                 "measured one-at-a-time effect of each choice the identified set changes.", "",
                 "| number | paper | this run | identified | identified / this | why (measured, one choice at a time) |",
                 "|---|---:|---:|---:|---:|---|"]
        p = paper_numbers()
        keys = list(p) + [f"sigma3_start/static_water/{m}" for m in MONITORS]
        ex = st["choices"].get(EXAMPLE_RUN, {})
        same = 0
        for k in keys:
            a, b = mine.get(k), ident.get(k)
            if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
                continue
            if abs(b - a) <= SAME * max(abs(a), abs(b)):
                same += 1
                continue
            text, unit, scale = number_label(k)
            why = []
            for d, lv in changed.items():
                nums = st["choices"].get(f"{d}: {lv}", {})
                x, y = ex.get(k), nums.get(k)
                if x is not None and y is not None and np.isfinite(x) and np.isfinite(y):
                    why.append(f"with {d} {lv} instead of {was.get(d, '?')}, {x * scale:.3g} → {y * scale:.3g}")
            ratio = f"{b / a:.2f}" if a else "—"
            pv = p.get(k, 0.76e6 if k.startswith("sigma3_start") else None)
            lines.append(f"| {text} ({unit}) | {pv * scale:.3g} | {a * scale:.3g} | {b * scale:.3g} | {ratio} | "
                         f"{'; '.join(why) or '—'} |")
        lines += ["", f"The other {same} numbers differ by less than {100 * SAME:g} %. Within ±{100 * TOLERANCE:.0f} % "
                  f"of the paper: {within(mine)} of 33 here, {within(ident)} in the identified set."]
        return lines

    def finding_in_study(self, name: str) -> str:
        """Which runs of the study the finding holds in (from their numbers)."""
        runs = self.study_runs()
        if not runs:
            return ""
        held = [n for n, v in runs.items() if finding_holds(v, name)]
        failed = [n for n, v in runs.items() if finding_holds(v, name) is False]
        return (f"over the study's runs it holds in {len(held)} of {len(held) + len(failed)}"
                + (f" ({', '.join(held)})" if held else "") + (f"; fails in {', '.join(failed)}" if failed and held else ""))

    def free_field_bound(self, key: str) -> str:
        """What water can change in an absolute displacement peak: the tunnel's displacement
        relative to the free field at its depth (all a lining's load can move), against the
        paper's change from condition (1) to (2) and (3)."""
        from .post import displacement_against

        c = 0 if key == "max_ux" else 2
        rel, absolute = [], []
        for r in self.by.values():
            for m in MONITORS:
                if r.samples and m in r.monitors:
                    u = displacement_against(r, m, "free_field")
                    if u is not None:
                        rel.append(float(np.abs(u[:, c]).max()))
                        absolute.append(float(np.abs(displacement_against(r, m, "absolute")[:, c]).max()))
        if not rel:
            return ""
        change = [abs(PAPER[key][cond][m] - PAPER[key]["no_water"][m]) for cond in ("static_water", "dynamic_water")
                  for m in MONITORS]
        return (f"what the water can move: the lining's displacement relative to the free field at its depth peaks at "
                f"{100 * min(rel):.3g}–{100 * max(rel):.3g} cm in these runs ({100 * max(rel) / min(absolute):.2g} % of "
                f"the absolute {100 * min(absolute):.3g}–{100 * max(absolute):.3g} cm: the tunnel moves with the ground). "
                f"The paper's water changes the absolute {key} by {100 * min(change):.2g}–{100 * max(change):.2g} cm from "
                f"condition (1), {min(change) / max(rel):.1f}–{max(change) / max(rel):.0f}× the whole of our relative "
                "displacement; a load on the lining's inner face cannot move the rock mass around it by that much")

    def pressure_spread(self) -> str:
        """How much the pressure peak varies round the ring: ours (this run and every study run)
        against the paper's."""
        p = PAPER["hydrodynamic_pressure_peak"]
        spread = lambda v: max(v) / min(v) if v and min(v) > 0 else math.nan  # noqa: E731
        mine = [self.pk.get("dynamic_water", {}).get(m, {}).get("hydrodynamic_pressure_peak") for m in MONITORS]
        text = (f"the pressure round the ring: the paper's peaks differ by max/min {spread(list(p.values())):.2f} (the "
                f"haunch's the largest)")
        if all(v is not None for v in mine):
            text += f", ours by {spread(mine):.3f}"
        runs = [[v.get(f"pressure/{m}") for m in MONITORS] for v in self.study_runs().values()]
        runs = [r for r in runs if all(x is not None and np.isfinite(x) for x in r)]
        if runs:
            s_ = [spread(r) for r in runs]
            text += (f" and by {min(s_):.3f}–{max(s_):.3f} in the study's {len(runs)} runs with water (the slice's "
                     "pressure is the water's breathing mode, nearly uniform round the ring)")
        lo, hi = max(p.values()) / (1 + TOLERANCE), min(p.values()) * (1 + TOLERANCE)
        if lo > hi:
            text += (f"; a uniform pressure within ±{100 * TOLERANCE:.0f} % of the paper's largest peak is at least "
                     f"{lo / 1e6:.3g} MPa, above {1 + TOLERANCE:g}× its smallest ({hi / 1e6:.3g} MPa): no uniform level "
                     "reaches all three")
        return text

    # -- discussion -----------------------------------------------------------------------------
    def discussion(self) -> list[str]:
        if not self.misses:
            return ["Every computed value is within the stated band of the paper's; nothing to discuss."]
        out = ["Each difference below is followed by what the study of the paper's open choices measured on the same "
               "numbers (docs/paper_reproduction.md; the example's value → the value with one choice changed). The "
               "slice stands for the paper's 3D block: the 80 m 3D model gives every monitored peak within 0.17 % of "
               "the slice (docs/benchmarks.md \"Slice against 3D\").", ""]
        for (key, cond), items in self.misses.items():
            out += self._discuss(key, cond, items)
        return out

    def _hydrostatic_cause(self) -> str:
        """The lining's tension at the seismic start with the water's static pressure, ours against
        the paper's "about 0.76 MPa at time 0 s" (conditions 2 and 3)."""
        vals = {c: max(float(mo.principal[0, 2]) for mo in self.by[c].monitors.values() if mo.principal.size)
                for c in ("static_water", "dynamic_water") if c in self.by and self.by[c].samples}
        p0 = PAPER["initial_tension_with_water"]
        if not vals:
            return "the hydrostatic pressure's static state: not recorded (no water condition ran)"
        txt = ", ".join(f"{c} {v / 1e6:.3g} MPa ({v / p0:.2f}× the paper's)" for c, v in vals.items())
        return (f"the static state the shaking starts from: the monitors' largest σ3 at the seismic start is {txt}, "
                f"against the paper's about {p0 / 1e6:.2f} MPa")

    def _short(self, cond: str, t_paper: float | None) -> list[str]:
        """Says so when this condition's run stopped early or before the paper's peak time."""
        res = self.by.get(cond)
        if res is None:
            return []
        if res.planned_end and res.t_end < res.planned_end - 1e-6:
            return [f"the {cond} run stops at {res.t_end:.2f} s of the planned {res.planned_end:g} s (status "
                    f"'{res.status}')" + (f"; the paper's value is at {t_paper:g} s" if t_paper else "")]
        if t_paper and res.t_end < t_paper:
            return [f"the {cond} run's computed window ends at {res.t_end:.2f} s, before the paper's {t_paper:g} s"]
        return []

    def _discuss(self, key, cond, items) -> list[str]:
        t_paper = _QUANTITIES[key][3] if key in _QUANTITIES else PAPER["tension_growth_end"]
        if key == "finding":
            short = sorted({s for c in CONDITION_LABELS for s in self._short(c, None)})
        else:
            short = self._short(cond, t_paper)
        if key in _QUANTITIES:
            label, unit, scale, t_paper, _ = _QUANTITIES[key]
            ratios = np.array([o / p for _, o, p in items])
            lo, hi = float(ratios.min()), float(ratios.max())
            side = "below" if hi < 1 else ("above" if lo > 1 else "on both sides of")
            head = (f"### {label}, {CONDITION_LABELS.get(cond, cond)}\n\n"
                    f"Ours / paper = {lo:.2f}–{hi:.2f} at {', '.join(m for m, *_ in items)}: {side} the paper's "
                    f"values (band ±{100 * TOLERANCE:.0f} %). ")
            if key in ("max_ux", "max_uz"):
                times = [self.pk[cond][m][f"t_{key}"] for m, *_ in items]
                head += (f"Our peaks are at t = {min(times):.2f}–{max(times):.2f} s, the paper's at "
                         f"{PAPER['displacement_peak_time']:g} s. ")
            st = PAPER["lining_tensile_strength"]
            if key == "max_tension":
                smax = max(o for _, o, _ in items)
                if all(o >= 0.99 * st for _, o, _ in items):
                    head += (f"Ours sit at the lining's tensile strength σt = {st / 1e6:.3g} MPa (the Mohr–Coulomb "
                             "tension cut-off caps σ3 there), so the ratio is σt over the paper's value. ")
                else:
                    head += (f"Our largest tension here is {smax / 1e6:.3g} MPa = {smax / st:.2f} of the lining's "
                             f"tensile strength {st / 1e6:.3g} MPa. ")
            nkey = "pressure" if key == "hydrodynamic_pressure_peak" else f"{key}/{cond}"
            why = self.measured([f"{nkey}/{m}" for m, *_ in items])
            if key == "max_tension" and cond != "no_water":
                why.insert(0, self._hydrostatic_cause())
            if key == "hydrodynamic_pressure_peak":
                why.append(self.pressure_spread())
            if key in ("max_ux", "max_uz") and cond != "no_water" and self.free_field_bound(key):
                why.append(self.free_field_bound(key))
            return [head, ""] + [f"- {w}" for w in short + why] + [""]
        if key == "damage":
            _, dmax, _ = items[0]
            s = f"### damage, {CONDITION_LABELS.get(cond, cond)}\n\n"
            tens = [self.pk.get(cond, {}).get(m, {}).get("max_tension", np.nan) for m in MONITORS]
            tmax = float(np.nanmax(tens)) if np.isfinite(tens).any() else float("nan")
            st = PAPER["lining_tensile_strength"]
            if dmax > NO_DAMAGE:
                s += (f"The paper has no damage in this condition; ours reaches D = {dmax:.3g}, with the monitors' "
                      f"largest tension {tmax / 1e6:.3g} MPa ({tmax / st:.2f} of σt). ")
            else:
                s += (f"The paper has tensile damage here; ours has none: the monitors' largest tension is "
                      f"{tmax / 1e6:.3g} MPa = {tmax / st:.2f} of the tensile strength {st / 1e6:.3g} MPa. ")
            why = self.measured([f"max_damage/{cond}"])
            if cond != "no_water":
                why.insert(0, self._hydrostatic_cause())
            return [s, ""] + [f"- {w}" for w in short + why] + [""]
        if key == "slip":
            _, opened, n = items[0]
            s = (f"### separation and slip, {CONDITION_LABELS.get(cond, cond)}\n\n"
                 f"{opened} of {n} pairs of the middle section opened, slipped or lost their bond. ")
            z = self.interface_zone(cond)
            if z and z["opened"]:
                s += (f"Of these {z['in_haunch']} lie in the haunch sectors (angles "
                      f"{', '.join(f'{a:.0f}°' for a in z['angles'][:12])}{' …' if len(z['angles']) > 12 else ''}). ")
            why = self.measured([f"opened/{cond}", f"opened_haunch/{cond}"])
            return [s, ""] + [f"- {w}" for w in short + why] + [""]
        if key == "finding":
            s = f"### finding: {cond}\n\n"
            if cond == "haunch":
                failed = [n for n, good, _ in items if not good]
                s += f"The haunch is not the most loaded point for: {', '.join(failed)} (see the table above). "
            else:
                against = "rises" if cond == "hydrostatic" else "does not rise"
                s += (f"Against the paper, the peak {against} from condition (1) for "
                      f"{', '.join(n for n, *_ in items)} (numbers in the table above). ")
            held = self.finding_in_study(cond)
            if held:
                s += f"The finding, {held}. "
            why = ([self.free_field_bound(k) for k in ("max_ux", "max_uz")] if cond != "haunch"
                   else [self.pressure_spread()] if "dynamic_water" in self.pk else [])
            return [s, ""] + [f"- {w}" for w in short + [w for w in why if w]] + [""]
        return []


def siblings(key: str) -> list[tuple[str, str]]:
    """The numbers a number can be matched against jointly, with how the two relate in a run:
    the same quantity of the same condition at the other monitors ('pressure/haunch' ->
    'pressure/top_arch', ...: their ratio), and for a lining stress the same monitor in the other
    conditions ('max_tension/static_water/haunch' -> 'max_tension/dynamic_water/haunch', ...: their
    difference, as a stress adds)."""
    head, _, m = key.rpartition("/")
    if m not in MONITORS:
        return []
    out = [(f"{head}/{o}", "ratio") for o in MONITORS if o != m]
    q, _, cond = head.partition("/")
    if q == "max_tension":
        out += [(f"{q}/{c}/{m}", "difference") for c in PAPER[q] if c != cond]
    return out


def joint_text(key: str, runs: dict[str, dict], current: dict, target: dict[str, float]) -> str:
    """For a number outside the band: a sibling (siblings()) within the band in `current` that it
    cannot join there, because their relation (ratio k/j, or difference k − j) lies outside what
    both bands allow in every run of the study: the two move together under every choice studied,
    so no level of the study (nor any level between two of its levels) brings both within the band
    at once. '' when there is none."""
    lo, hi = 1 - TOLERANCE, 1 + TOLERANCE

    def where(k: str) -> str:
        parts = k.split("/")[1:]
        return " ".join(CONDITION_LABELS.get(p, p).split(" ", 1)[0] if p in CONDITION_LABELS else p.replace("_", " ")
                        for p in parts)

    pk = target.get(key)
    for j, how in siblings(key):
        cj, pj = current.get(j), target.get(j)
        if pk is None or pj is None or cj is None or not np.isfinite(cj) or not abs(cj / pj - 1) <= TOLERANCE:
            continue
        pairs = [(float(v[key]), float(v[j])) for v in runs.values()
                 if v.get(key) is not None and v.get(j) is not None and np.isfinite(v[key]) and np.isfinite(v[j])]
        if how == "ratio":
            if pk <= 0 or pj <= 0 or any(y <= 0 for _, y in pairs):
                continue
            rel, paper_rel, op, unit, scale = [x / y for x, y in pairs], pk / pj, "/", "", 1.0
            allowed = (lo * pk / (hi * pj), hi * pk / (lo * pj))
        else:
            _, unit, scale = number_label(key)
            rel, paper_rel, op = [x - y for x, y in pairs], pk - pj, "−"
            allowed = (min(lo * pk, hi * pk) - max(lo * pj, hi * pj), max(lo * pk, hi * pk) - min(lo * pj, hi * pj))
        if len(rel) < 2 or not (max(rel) < allowed[0] or min(rel) > allowed[1]):
            continue

        def f(x: float, scale: float = scale, unit: str = unit) -> str:
            return f"{x * scale:.3g}{' ' + unit if unit else ''}"

        return (f"**unreachable** together with {where(j)}, within the band here: {where(key)} {op} {where(j)} is "
                f"{f(paper_rel)} in the paper, {f(min(rel))} … {f(max(rel))} in all {len(rel)} runs of the study "
                f"(both within ±{TOLERANCE:.0%} needs {f(allowed[0])} … {f(allowed[1])})")
    return ""


def trade_text(key: str, runs: dict[str, dict], reaching: list[str], current: dict) -> str:
    """For a number outside the band in `current` that the runs `reaching` bring within it: when
    each of those runs takes out of the band numbers that `current` holds within it, what each
    costs ("**unreachable** beside ..."): the reported set keeps more numbers within the band than
    any of those runs. '' when one of them costs nothing."""
    target = paper_numbers()

    def inside(k: str, v) -> bool:
        if v is None or not np.isfinite(v):
            return False
        if k.startswith("pressure_time"):
            return abs(v - target[k]) <= 0.5
        return abs(v / target[k] - 1) <= TOLERANCE

    kept = [k for k in target if k != key and inside(k, current.get(k))]
    costs = []
    for n in reaching:
        lost = [k for k in kept if runs[n].get(k) is not None and not inside(k, runs[n][k])]
        if not lost:
            return ""
        words = []
        for k in lost[:3]:
            label, unit, scale = number_label(k)
            words.append(f"{label} {current[k] * scale:.3g} → {runs[n][k] * scale:.3g}{' ' + unit if unit else ''}")
        more = f" and {len(lost) - 3} more" if len(lost) > 3 else ""
        _, unit, scale = number_label(key)
        costs.append(f"{n} ({runs[n][key] * scale:.3g} {unit}): {len(lost)} leave the band ({'; '.join(words)}{more})")
    return ("**unreachable** beside the numbers this set keeps within the band: the runs that bring it within take "
            "others out — " + "; ".join(costs))


def reach_text(key: str, runs: dict[str, dict], p: float, close=None, current: dict | None = None) -> str:
    """What the study's runs (name -> numbers) say of a number against the paper's p: the run that
    brings it within the band (closest first); else, when `current` (the reported run's numbers)
    holds a sibling within the band that it cannot join in any run, **unreachable** together with
    it (joint_text); else, when runs lie on both sides of p, the two that bracket it (a level
    between theirs passes through it: not reached, not unreachable); else **unreachable**, with
    the span of every run."""
    close = close or (lambda v: abs(v / p - 1) <= TOLERANCE)
    vals = [(float(v[key]), n) for n, v in runs.items() if v.get(key) is not None and np.isfinite(v[key])]
    if not vals:
        return ""
    _, unit, scale = number_label(key)
    ok = sorted((abs(v - p), v, n) for v, n in vals if close(v))
    if ok:
        traded = trade_text(key, runs, [n for _, _, n in ok], current) if current else ""
        return traded or f"within the band with {ok[0][2]}: {ok[0][1] * scale:.3g} {unit}"
    joint = joint_text(key, runs, current, paper_numbers()) if current and key in paper_numbers() else ""
    if joint:
        return joint
    below = [(v, n) for v, n in vals if v < p]
    above = [(v, n) for v, n in vals if v > p]
    if below and above:
        # the nearest on each side; among runs within SAME of it, the example's (the reference of
        # every one-at-a-time change)
        def nearest(side, pick):
            v0 = pick(v for v, _ in side)
            near = [(v, n) for v, n in side if abs(v - v0) <= SAME * abs(v0)]
            return next(((v, n) for v, n in near if n == EXAMPLE_RUN), pick(near))

        (b, nb), (a, na) = nearest(below, max), nearest(above, min)
        return (f"not reached by a level of the study, which brackets it: {b * scale:.3g} ({nb}) … {a * scale:.3g} "
                f"{unit} ({na}); a level between these two passes through it")
    lo, hi = min(vals), max(vals)
    return (f"**unreachable** in the study: its {len(vals)} runs span {lo[0] * scale:.3g} ({lo[1]}) … "
            f"{hi[0] * scale:.3g} {unit} ({hi[1]}), all {'below' if hi[0] < p else 'above'} the paper's")


def number_label(key: str) -> tuple[str, str, float]:
    """A study number's key -> (words, unit, scale to the unit)."""
    parts = key.split("/")
    where = " ".join(CONDITION_LABELS.get(p, p).split(" ", 1)[0] if p in CONDITION_LABELS else p.replace("_", " ")
                     for p in parts[1:])
    head = parts[0]
    table = {"pressure": ("hydrodynamic pressure peak", "MPa", 1e-6), "pressure_time": ("time of the pressure peak",
             "s", 1.0), "max_ux": ("max u_x", "cm", 100.0), "max_uz": ("max u_z", "cm", 100.0),
             "max_tension": ("max σ3", "MPa", 1e-6), "sigma3_start": ("σ3 at the seismic start", "MPa", 1e-6),
             "max_damage": ("largest D of the middle section", "", 1.0),
             "opened": ("interface pairs opened", "", 1.0), "opened_haunch": ("of them in the haunch sectors", "", 1.0)}
    text, unit, scale = table.get(head, (head, "", 1.0))
    return f"{text} {where}".strip(), unit, scale


def short_label(key: str, keys: list[str]) -> str:
    """The part of a key that tells it from the others in `keys` (the monitor, usually)."""
    parts = key.split("/")
    common = [i for i in range(len(parts)) if all(len(k.split("/")) > i and k.split("/")[i] == parts[i] for k in keys)]
    rest = [p for i, p in enumerate(parts) if i not in common]
    return " ".join(rest).replace("_", " ") if rest else number_label(key)[0]


def finding_holds(v: dict, name: str) -> bool | None:
    """Whether one of the paper's findings holds in a study run's numbers (None: not computed).
    hydrostatic: condition (2) below (1) for max u_x and u_z at every monitor and for σ3 at two of
    three; hydrodynamic: (3) above (1) for all three at every monitor; haunch: the haunch has the
    largest pressure and the largest σ3 in each condition (a tie with another monitor counts)."""
    def get(k):
        x = v.get(k)
        return None if x is None or not np.isfinite(x) else float(x)

    if name in ("hydrostatic", "hydrodynamic"):
        b = "static_water" if name == "hydrostatic" else "dynamic_water"
        ok = True
        for key in ("max_ux", "max_uz", "max_tension"):
            pairs = [(get(f"{key}/no_water/{m}"), get(f"{key}/{b}/{m}")) for m in MONITORS]
            if any(x is None or y is None for x, y in pairs):
                return None
            if name == "hydrostatic":
                n = sum(y < x for x, y in pairs)
                ok &= n >= (2 if key == "max_tension" else 3)
            else:
                ok &= all(y > x for x, y in pairs)
        return bool(ok)
    if name == "haunch":
        groups = [[f"pressure/{m}" for m in MONITORS]] + [[f"max_tension/{c}/{m}" for m in MONITORS]
                                                           for c in CONDITION_LABELS]
        for g in groups:
            vals = [get(k) for k in g]
            if any(x is None for x in vals):
                return None
            if vals[MONITORS.index("haunch")] < max(vals) * (1 - 1e-6):  # a tie (σ3 at σt everywhere) counts
                return False
        return True
    return None


def comparison_sections(results: list[ConditionResult], figures: dict[str, str], context: dict) -> list[str]:
    """The report's comparison part: values, damage and slip, findings, discussion. `figures`: key
    (fig05, ...) -> path relative to the report; `context`: what the discussion quotes (the record's
    source and PGA, the damping, R, the water model, the mesh mode; case_report.py `_context`)."""
    c = Comparison(results, figures, context)
    lines = ["## The paper's §3.3 numbers against ours", "",
             f"Verdicts: *reproduced* when ours is within ±{100 * TOLERANCE:.0f} % of the paper's value; *not "
             "computed* when the condition was not run or the run ended before the paper's peak time without "
             "already exceeding the band.", ""]
    lines += c.value_rows() + [
        "", "Where a number is outside the band, the verdict names the study's run that brings it within (docs/"
        "paper_reproduction.md: the example with one open choice changed, or the identified set), or marks it "
        "**unreachable** with the span of every run of the study.", "",
        "## Which displacement reference the paper's numbers match", ""]
    lines += c.reference_rows() + ["", "## The identified set", ""] + c.identified_rows()
    lines += ["", "## Where damage and slip appear", ""]
    lines += c.damage_rows() + [""] + c.slip_rows() + ["", "## The paper's findings", ""]
    lines += c.findings_rows() + [""]
    lines += ["## Discussion of the differences", ""]
    lines += c.discussion()
    return lines
