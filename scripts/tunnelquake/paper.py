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
#: leaves beside the case file: every choice's numbers, the calibration and the paper variant's run.
STUDY_FILE = "paper_study.json"
#: The example's variant with the paper's own model: incompressible water, the calibrated choices.
PAPER_VARIANT = "paper"
#: The study's name of the paper variant's run.
PAPER_RUN = "the paper variant"
#: A σ3 peak within this fraction of the tensile strength above its value at the seismic start is
#: that static state, not a response to the shaking.
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
                for key in ("max_ux", "max_uz", "max_tension"):
                    out[f"t_{key}/{cond}/{m}"] = pk[m].get(f"t_{key}", math.nan)
                rel = self._relative(r, m)
                if rel is not None:
                    out[f"rel_ux/{cond}/{m}"], out[f"rel_uz/{cond}/{m}"] = rel
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

    @staticmethod
    def _relative(r, m: str) -> tuple[float, float] | None:
        """A monitor's peak |u_x|, |u_z| relative to the free field at its depth, or None."""
        from .post import displacement_against

        u = displacement_against(r, m, "free_field") if m in r.monitors else None
        if u is None or not len(u):
            return None
        return float(np.abs(u[:, 0]).max()), float(np.abs(u[:, 2]).max())

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
                    if o is not None and res is not None and key in ("max_ux", "max_uz"):
                        t = self.pk[cond][m].get(f"t_{key}")
                        if t is not None and not v.startswith(NOT_COMPUTED):
                            v += f" (ours at t = {t:.2f} s, the paper's at {t_paper:g} s)"
                    if o is not None and res is not None and key == "max_tension" and v == REPRODUCED \
                            and res.samples and o <= float(res.monitors[m].principal[0, 2]) + SAME * abs(p):
                        v = "reached at the static state (t = 0, before the shaking): not a response to it"
                    os_ = "—" if o is None else f"{o * scale:.3g}"
                    ratio = "—" if o is None else f"{o / p:.2f}"
                    if o is not None and v.startswith(NOT_REPRODUCED):
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
            d2 = self.max_damage("static_water")[0] if wet and "static_water" in self.by else None
            if has and wet and d2 is not None and d2 >= dmax:
                v = f"{NOT_REPRODUCED} (static water's D = {d2:.3g} is at least as large: not the moving water's damage)"
            d0 = [float(mo.extra["damage"][0]) for mo in res.monitors.values()
                  if mo.extra.get("damage") is not None and mo.extra["damage"].size]
            start = f"; at the seismic start the monitors have D ≤ {max(d0):.3g} (static stages)" if d0 else ""
            lines.append(f"| damage, {cond} | {paper} | max D = {dmax:.3g} ({where}){start} | {v} | "
                         f"{self.figs('fig08', 'fig09')} |")
            if v.startswith(NOT_REPRODUCED):
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
        """Every whole-record run of the study by name (the example, each choice, the paper variant)."""
        st = self.study
        if not st:
            return {}
        runs = dict(st.get("choices") or {})
        if st.get("paper_variant"):
            runs[PAPER_RUN] = st["paper_variant"]
        return runs

    def reach(self, key: str, tol=None, paper: float | None = None) -> str:
        """For a number outside the band: what the study's runs say of it (reach_text)."""
        p = paper if paper is not None else paper_numbers()[key]
        if self._numbers is None:
            self._numbers = self.numbers()
        text = reach_text(key, self.study_runs(), p, tol, self._numbers, (self.study or {}).get("example_levels"))
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

    def roles(self) -> dict[str, str]:
        """Quantity key -> the open choice calibrated on it (the study's declared calibration)."""
        out = {}
        for dim, c in ((self.study or {}).get("calibration") or {}).items():
            for k in c.get("targets", []):
                out[k] = dim
        return out

    def quantity_rows(self) -> list[str]:
        """The independent quantities (quantities()): the paper's, ours, whether ours is a calibrated
        target or a prediction, this run's verdict (with how it is reached: the static state, the
        timing) and what the study's runs say."""
        mine = self.numbers()
        qv = quantity_values(mine)
        roles = self.roles()
        runs = {n: quantity_values(v) for n, v in self.study_runs().items()}
        targets = {q.key: (q.paper, q.close) for q in scored()}
        texts = {q.key: q.text for q in quantities()}
        lines = ["| quantity | paper | ours | calibrated or predicted | verdict | the study's runs |",
                 "|---|---:|---:|---|---|---|"]
        for q in quantities():
            o = qv.get(q.key)
            ours = "—" if o is None else ("yes" if o is True else "no" if o is False else f"{o * q.scale:.3g}")
            unit = f" ({q.unit})" if q.unit else ""
            role = f"calibrated ({roles[q.key]})" if q.key in roles else "predicted" if roles else "—"
            if q.paper is None:
                paper_txt = "—"
                v = "— (the paper gives none: it bounds what the water can move)"
                lines.append(f"| {q.text}{unit} | {paper_txt} | {ours} | — | {v} | — |")
                continue
            paper_txt = ("yes" if q.paper else "no") if isinstance(q.paper, bool) else f"{q.paper * q.scale:.3g}"
            note = q.note(mine) if o is not None else ""
            if o is None:
                v = NOT_COMPUTED
            elif _inside(o, q.paper, q.close):
                v = f"reached at the {note}" if note.startswith("static") else "reached"
            else:
                v = NOT_REPRODUCED
            if note and not note.startswith("static"):
                v += f" ({note})"
            mech = free_field_mechanism(q, qv)
            study = ""
            if runs:
                static = {n for n, v in self.study_runs().items() if q.note(v).startswith("static")}
                _, study = study_verdict(q.key, runs, q.paper, q.close, qv, targets, mech,
                                         example_levels=(self.study or {}).get("example_levels"),
                                         unit=q.unit, scale=q.scale, static=static, label=texts.get)
            elif mech:
                study = f"out of reach: {mech}"
            lines.append(f"| {q.text}{unit} | {paper_txt} | {ours} | {role} | {v} | {study or '—'} |")
        return lines

    def paper_variant_rows(self) -> list[str]:
        """The study's calibration: each open choice's declared target and the level it gave, what
        the paper variant is, and the counts of this run, calibrated and predicted apart."""
        st = self.study
        if not st:
            return ["No study of the paper's open choices beside the case file: run `tunnelquake bench FOLDER "
                    "--identify --update-docs` (docs/paper_reproduction.md)."]
        lines = ["| open choice | calibrated on (declared before the fit) | the example | the paper variant |",
                 "|---|---|---|---|"]
        for dim, c in (st.get("calibration") or {}).items():
            lines.append(f"| {dim} | {c.get('on', '—')} | {(st.get('example_levels') or {}).get(dim, '—')} | "
                         f"{c.get('level', '—')} |")
        keys_txt = ", ".join(f"`{k}: {v}`" for k, v in (st.get("overrides") or {}).items()) or "none"
        here = self.ctx.get("variant") == PAPER_VARIANT
        lines += ["", (f"This run is the paper variant (`--variant {PAPER_VARIANT}`)" if here else
                       f"The paper variant (`--variant {PAPER_VARIANT}`) is this case with")
                  + f" {keys_txt if not here else 'with the keys ' + keys_txt}. "]
        roles = self.roles()
        qv = quantity_values(self.numbers())
        cal = [q for q in scored() if q.key in roles and qv.get(q.key) is not None]
        pred = [q for q in scored() if q.key not in roles and qv.get(q.key) is not None]

        def count(qs):
            n = sum(1 for q in qs if _inside(qv[q.key], q.paper, q.close) and not q.note(self.numbers())
                    .startswith("static"))
            s_ = sum(1 for q in qs if _inside(qv[q.key], q.paper, q.close) and q.note(self.numbers())
                     .startswith("static"))
            return f"{n} of {len(qs)}" + (f" (and {s_} more reached by the static state)" if s_ else "")

        lines[-1] += (f"In this run: calibrated quantities within the band {count(cal)}; predicted {count(pred)} "
                      "(the table above).")
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
            if dmax > NO_DAMAGE and cond == "dynamic_water":
                d2 = self.max_damage("static_water")[0]
                s += (f"The paper's damage here comes with the moving water (none with static water); ours reaches "
                      f"D = {dmax:.3g} here and {d2:.3g} with static water, with the monitors' largest tension "
                      f"{tmax / 1e6:.3g} MPa ({tmax / st:.2f} of σt). ")
            elif dmax > NO_DAMAGE:
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


# -- the study's verdict words ---------------------------------------------------------------------
#: What the study's verdicts say (docs/paper_reproduction.md): a run brings the number within the
#: band at no cost; runs bring it within only by taking others out (trade-off); two levels of one
#: choice lie on both sides (bracketed: a level between passes through it, for a number that moves
#: continuously with the choice); a measured mechanism bounds it away from the paper's (out of
#: reach); else not reached, with the span of the runs.
REACHED, TRADE_OFF, BRACKETED, OUT_OF_REACH, NOT_REACHED = ("reached", "trade-off", "bracketed",
                                                             "out of reach", "not reached")
#: A value within the band only because the static state at the seismic start already is.
STATIC = "static state"
#: The study's verdict words in the order the documents count them.
WORDS = (REACHED, TRADE_OFF, STATIC, BRACKETED, OUT_OF_REACH, NOT_REACHED)


def _finite(v) -> bool:
    return v is not None and not isinstance(v, str) and np.isfinite(float(v))


def _inside(v, p, close=None) -> bool:
    if not _finite(v) or p is None:
        return False
    if isinstance(p, bool) or isinstance(v, bool):
        return bool(v) == bool(p)
    if close is not None:
        return bool(close(float(v)))
    return abs(float(v) - p) <= TOLERANCE * abs(p)


def _level_words(name: str, example_levels: dict | None) -> tuple[str, str] | None:
    """A run's name 'dimension: level' -> (dimension, level); None for a run of no dimension."""
    dim, sep, level = name.partition(": ")
    return (dim, level) if sep and dim != "example" else None


def study_verdict(key: str, runs: dict[str, dict], p, close=None, current: dict | None = None,
                  targets: dict | None = None, mechanism: str = "", example: str = EXAMPLE_RUN,
                  example_levels: dict | None = None, unit: str = "", scale: float = 1.0,
                  static: set | None = None, label=None) -> tuple[str, str]:
    """What the study's runs (name -> values) say of one value against the paper's p: (word, text).

    - REACHED: a run brings it within the band (`close`, default ±TOLERANCE) and, when `current`
      (the reported set's values) is given, keeps every other value of `targets` (key -> (paper,
      close)) that `current` holds within its band;
    - TRADE_OFF: every run that brings it within takes other values out (with how many);
    - BRACKETED: not reached, and two levels of one choice (runs named 'dimension: level'; the
      example counts as each dimension's own level) lie on both sides of p: a level between
      passes through it;
    - OUT_OF_REACH: not reached, not bracketed, and `mechanism` (a measured reason, from the
      caller) says why no choice can reach it;
    - NOT_REACHED: otherwise, with the number of runs and their span.
    - STATIC: the runs that bring it within are all in `static` (theirs is the static state at the
      seismic start, reached at t = 0: not a response to the shaking).
    A reached or bracketed value is never OUT_OF_REACH, whatever the mechanism says. `label`: key ->
    words, for the values a trade-off loses."""
    label = label or (lambda k: number_label(k)[0])
    static = static or set()
    vals = [(v[key], n) for n, v in runs.items() if _finite(v.get(key)) or isinstance(v.get(key), bool)]
    if not vals:
        return "", ""

    def f(x) -> str:
        if isinstance(x, bool):
            return "yes" if x else "no"
        y = float(x) * scale
        return "0" if abs(y) < 1e-9 else f"{y:.3g}"

    u = f" {unit}" if unit else ""
    ok = [(n, v) for v, n in vals if _inside(v, p, close)]
    if ok:
        if isinstance(p, bool):
            ok.sort(key=lambda t: t[0] != example)
        else:
            ok.sort(key=lambda t: abs(float(t[1]) - p))
        kept = []
        if current is not None:
            kept = [k for k, (pk, ck) in (targets or {}).items() if k != key and _inside(current.get(k), pk, ck)]
        if all(n in static for n, _ in ok):
            return STATIC, (f"reached only at the static state (t = 0, before the shaking) by {ok[0][0]} ({f(ok[0][1])}{u})"
                            + (f" and {len(ok) - 1} more run(s)" if len(ok) > 1 else ""))
        ok = [(n, v) for n, v in ok if n not in static]
        costs = []
        for n, v in ok:
            lost = [k for k in kept if k in runs[n] and not _inside(runs[n][k], *targets[k])]
            if not lost:
                return REACHED, f"reached by {n} ({f(v)}{u})" + (f" and {len(ok) - 1} more run(s)" if len(ok) > 1 else "")
            costs.append(f"{n} ({f(v)}{u}) takes {len(lost)} other(s) out of the band "
                         f"({', '.join(label(k) for k in lost[:3])}"
                         f"{' …' if len(lost) > 3 else ''})")
        return TRADE_OFF, f"trade-off: reached only by losing others — {'; '.join(costs)}"
    if not isinstance(p, bool):
        best = None
        for dim in sorted({d for d in (_level_words(n, example_levels) for _, n in vals) if d}):
            side = [(float(v), n) for v, n in vals
                    if n == example or (_level_words(n, example_levels) or ("",))[0] == dim[0]]
            lo = [t for t in side if t[0] < p]
            hi = [t for t in side if t[0] > p]
            if lo and hi:
                a, b = max(lo), min(hi)
                gap = b[0] - a[0]
                if best is None or gap < best[0]:
                    best = (gap, dim[0], a, b)
        if best:
            _, dim, (va, na), (vb, nb) = best

            def lv(n: str) -> str:
                if n == example:
                    return (example_levels or {}).get(dim, "the example's").split(" (")[0]
                return n.partition(": ")[2]

            return BRACKETED, (f"bracketed by {dim} {lv(na)}–{lv(nb)} ({f(va)} … {f(vb)}{u}): a level between passes "
                               "through it")
    if mechanism:
        return OUT_OF_REACH, f"out of reach: {mechanism}"
    if isinstance(p, bool):
        return NOT_REACHED, f"not reached in {len(vals)} runs (none has it)"
    lo, hi = min((float(v), n) for v, n in vals), max((float(v), n) for v, n in vals)
    if len(vals) == 1:
        return NOT_REACHED, (f"not reached in 1 run ({f(lo[0])}{u}, {lo[1]}; "
                             f"{'below' if lo[0] < p else 'above'} the paper's)")
    where = "all below the paper's" if hi[0] < p else "all above the paper's" if lo[0] > p else \
        "on both sides, by different choices"
    return NOT_REACHED, (f"not reached in {len(vals)} runs (span {f(lo[0])} … {f(hi[0])}{u}, {lo[1]} … {hi[1]}; "
                         f"{where})")


def reach_text(key: str, runs: dict[str, dict], p: float, close=None, current: dict | None = None,
               example_levels: dict | None = None) -> str:
    """study_verdict()'s text for one of the §3.3 numbers (paper_numbers()), the others of the 33
    the values a trade-off may lose."""
    target = paper_numbers()
    tp = PAPER["hydrodynamic_pressure_peak_time"]
    targets = {k: (v, (lambda x, tp=tp: abs(x - tp) <= 0.5) if k.startswith("pressure_time") else None)
               for k, v in target.items()}
    _, unit, scale = number_label(key)
    return study_verdict(key, runs, p, close, current, targets, unit=unit, scale=scale,
                         example_levels=example_levels)[1]


# -- the independent quantities --------------------------------------------------------------------
CONDS = ("no_water", "static_water", "dynamic_water")
_C = {"no_water": "(1)", "static_water": "(2)", "dynamic_water": "(3)"}


def _get(v: dict, k: str):
    x = v.get(k)
    return None if x is None or isinstance(x, str) or not np.isfinite(x) else float(x)


def _mean(xs):
    return None if not xs or any(x is None for x in xs) else float(np.mean(xs))


def _paper_u(key: str, cond: str, m: str) -> float:
    return PAPER[key][cond][m]


def _q_rigid(key):
    return lambda v: _mean([_get(v, f"{key}/{c}/{m}") for c in CONDS for m in MONITORS])


def _q_du(key, a, b):
    return lambda v: _mean([(_get(v, f"{key}/{b}/{m}") - _get(v, f"{key}/{a}/{m}"))
                            if _get(v, f"{key}/{b}/{m}") is not None and _get(v, f"{key}/{a}/{m}") is not None
                            else None for m in MONITORS])


def _q_ds(a, b, m):
    def q(v):
        x, y = _get(v, f"max_tension/{a}/{m}"), _get(v, f"max_tension/{b}/{m}")
        return None if x is None or y is None else y - x
    return q


def _q_start(v):
    return _mean([_get(v, f"sigma3_start/static_water/{m}") for m in MONITORS])


def _q_plevel(v):
    return _mean([_get(v, f"pressure/{m}") for m in MONITORS])


def _q_pspread(v):
    t, h, b = (_get(v, f"pressure/{m}") for m in MONITORS)
    return None if None in (t, h, b) or t + b <= 0 else h / (0.5 * (t + b))


def _q_ptime(v):
    ps = [(_get(v, f"pressure/{m}"), _get(v, f"pressure_time/{m}")) for m in MONITORS]
    return None if any(a is None or b is None for a, b in ps) else max(ps)[1]


def _q_utime(v):
    ts = [_get(v, f"t_{k}/{c}/{m}") for k in ("max_ux", "max_uz") for c in CONDS for m in MONITORS]
    ts = [t for t in ts if t is not None]
    return float(np.median(ts)) if ts else None


def _q_rel(v):
    xs = [_get(v, f"rel_{k}/{c}/{m}") for k in ("ux", "uz") for c in CONDS for m in MONITORS]
    xs = [x for x in xs if x is not None]
    return max(xs) if xs else None


def _q_cut3(v):
    st = PAPER["lining_tensile_strength"]
    xs = [_get(v, f"max_tension/dynamic_water/{m}") for m in MONITORS]
    return None if None in xs else all(x >= 0.98 * st for x in xs)


def _q_damage(cond, present):
    def q(v):
        d = _get(v, f"max_damage/{cond}")
        if d is None:
            return None
        if not present:
            return d <= NO_DAMAGE
        d2 = _get(v, "max_damage/static_water")
        return d > NO_DAMAGE and (d2 is None or d > d2)
    return q


def _q_slip(v):
    n, h = _get(v, "opened/dynamic_water"), _get(v, "opened_haunch/dynamic_water")
    return None if n is None or h is None else (n > 0 and h >= 0.75 * n)


def _static_sigma(cond, monitors=MONITORS):
    """The note for a σ3 peak that is the static state at the seismic start (ours within 0.5 %)."""
    def note(v):
        hits = [m for m in monitors if _get(v, f"max_tension/{cond}/{m}") is not None
                and _get(v, f"sigma3_start/{cond}/{m}") is not None
                and _get(v, f"max_tension/{cond}/{m}") <= _get(v, f"sigma3_start/{cond}/{m}") + SAME * 1.27e6]
        return "static state (at t = 0, before the shaking)" if len(hits) == len(monitors) else ""
    return note


def _static_diff(a, b, m):
    """The note for a change whose later condition's σ3 peak is its static state."""
    sb = _static_sigma(b, (m,))
    return lambda v: "static state (at t = 0)" if sb(v) else ""


def _disp_timing(v):
    t = _q_utime(v)
    return "" if t is None else f"ours peak at {t:.2f} s, the paper's at {PAPER['displacement_peak_time']:g} s"


class Quantity:
    """One independent quantity the study and the report score: its key, words, unit, scale to the
    unit, the paper's value (a number, or True/False for a fact), how to compute it from a run's
    numbers (Comparison.numbers' keys), its band (`close`, default ±TOLERANCE), and a note on how
    ours is reached (the static state, the timing)."""

    def __init__(self, key, text, unit, scale, paper, of, close=None, note=None, kind="level"):
        self.key, self.text, self.unit, self.scale, self.paper, self.of = key, text, unit, scale, paper, of
        self.close, self.note, self.kind = close, note or (lambda v: ""), kind


def _mean_paper(key, cond):
    return float(np.mean([PAPER[key][cond][m] for m in MONITORS]))


def quantities() -> list[Quantity]:
    """The paper's §3.3 numbers merged into the quantities they measure, with what separates the
    conditions: the rigid displacement (the mean of the 9 peaks; ours move with the ground), the
    changes (2) − (1) and (3) − (2), σ3 per monitor without water and its changes, the uniform
    pressure level, its spread round the ring, the peak times, the static state at the seismic start,
    and the paper's facts (damage, slip, σ3 at σt)."""
    tp = PAPER["hydrodynamic_pressure_peak_time"]
    q = []
    for key, comp in (("max_ux", "u_x"), ("max_uz", "u_z")):
        allp = float(np.mean([PAPER[key][c][m] for c in CONDS for m in MONITORS]))
        q.append(Quantity(f"rigid_{comp}", f"peak {comp}, the mean of 9 (the rigid displacement)", "cm", 100.0, allp,
                          _q_rigid(key), note=_disp_timing))
        for a, b in (("no_water", "static_water"), ("static_water", "dynamic_water")):
            pv = _mean_paper(key, b) - _mean_paper(key, a)
            q.append(Quantity(f"d{comp}/{b}-{a}", f"peak {comp} {_C[b]} − {_C[a]}, the mean of 3", "cm", 100.0, pv,
                              _q_du(key, a, b), note=_disp_timing, kind="difference"))
    q.append(Quantity("relative", "largest displacement of the lining relative to the free field", "cm", 100.0, None,
                      _q_rel, kind="bound"))
    for m in MONITORS:
        w = m.replace("_", " ")
        q.append(Quantity(f"sigma3/no_water/{m}", f"peak σ3 (1) {w}", "MPa", 1e-6, PAPER["max_tension"]["no_water"][m],
                          lambda v, m=m: _get(v, f"max_tension/no_water/{m}"), note=_static_sigma("no_water", (m,))))
    for a, b in (("no_water", "static_water"), ("static_water", "dynamic_water")):
        for m in MONITORS:
            pv = PAPER["max_tension"][b][m] - PAPER["max_tension"][a][m]
            q.append(Quantity(f"dsigma3/{b}-{a}/{m}", f"peak σ3 {_C[b]} − {_C[a]} {m.replace('_', ' ')}", "MPa", 1e-6,
                              pv, _q_ds(a, b, m), note=_static_diff(a, b, m), kind="difference"))
    q.append(Quantity("sigma3_at_cutoff/dynamic_water", "peak σ3 (3) at the tensile strength at all 3 monitors", "",
                      1.0, True, _q_cut3, note=_static_sigma("dynamic_water"), kind="fact"))
    q.append(Quantity("sigma3_start", "σ3 at the seismic start with water, the mean of 3", "MPa", 1e-6,
                      PAPER["initial_tension_with_water"], _q_start))
    q.append(Quantity("pressure_level", "hydrodynamic pressure peak, the mean of 3 (its uniform level)", "MPa", 1e-6,
                      float(np.mean(list(PAPER["hydrodynamic_pressure_peak"].values()))), _q_plevel))
    pp = PAPER["hydrodynamic_pressure_peak"]
    q.append(Quantity("pressure_spread", "pressure peak: haunch / mean of the arches", "", 1.0,
                      pp["haunch"] / (0.5 * (pp["top_arch"] + pp["bottom_arch"])), _q_pspread))
    q.append(Quantity("pressure_time", "time of the largest pressure peak (±0.5 s)", "s", 1.0, tp, _q_ptime,
                      close=lambda x: abs(x - tp) <= 0.5, kind="time"))
    q.append(Quantity("displacement_time", "time of the displacement peaks, the median (±0.5 s)", "s", 1.0,
                      PAPER["displacement_peak_time"], _q_utime,
                      close=lambda x: abs(x - PAPER["displacement_peak_time"]) <= 0.5, kind="time"))
    q.append(Quantity("no_damage/no_water", "no damage in (1)", "", 1.0, True, _q_damage("no_water", False),
                      kind="fact"))
    q.append(Quantity("no_damage/static_water", "no damage in (2)", "", 1.0, True, _q_damage("static_water", False),
                      kind="fact"))
    q.append(Quantity("damage/dynamic_water", "damage in (3), above (2)'s", "", 1.0, True,
                      _q_damage("dynamic_water", True), kind="fact"))
    q.append(Quantity("slip/dynamic_water", "separation/slip in (3), mainly at the haunches", "", 1.0, True, _q_slip,
                      kind="fact"))
    return q


def quantity_values(v: dict) -> dict:
    """A run's numbers -> its value of every quantity (None where it lacks what one needs)."""
    return {q.key: q.of(v) for q in quantities()}


def scored(qs: list[Quantity] | None = None) -> list[Quantity]:
    """The quantities scored against the paper (the bound has no paper value)."""
    return [q for q in (qs or quantities()) if q.paper is not None]


def free_field_mechanism(q: Quantity, values: dict) -> str:
    """For a displacement change between conditions: out of reach when the band's nearest edge
    exceeds what the water can move, twice the lining's largest displacement relative to the free
    field (the change of an absolute peak is at most the sum of the two conditions' relative
    peaks: the free field is the same record). '' when the bound is not measured or does not
    exclude the band."""
    rel = values.get("relative")
    if q.kind != "difference" or not q.key.startswith("du_") or \
            not _finite(rel):
        return ""
    need = abs(q.paper) * (1 - TOLERANCE)
    if need <= 2 * rel:
        return ""
    return (f"the water can change an absolute peak by at most twice the lining's displacement relative to the free "
            f"field, 2 × {rel * q.scale:.3g} = {2 * rel * q.scale:.3g} cm; the band needs at least {need * q.scale:.3g} cm")


def finding_sentence(name: str, runs: dict[str, dict]) -> str:
    """One measured sentence on a paper finding over the runs: in how many it holds, and what
    stands against it (the numbers of the first run, the reported one)."""
    held = [n for n, v in runs.items() if finding_holds(v, name)]
    total = [n for n, v in runs.items() if finding_holds(v, name) is not None]
    if not total:
        return ""
    first = next(iter(runs.values()))
    qv = quantity_values(first)
    if name == "hydrostatic":
        why = (f"static water changes the peak u_x by {_fmt(qv.get('du_x/static_water-no_water'), 100)} cm (the paper "
               f"{_fmt(_mean_paper('max_ux', 'static_water') - _mean_paper('max_ux', 'no_water'), 100)}) and raises "
               f"σ3 where the paper lowers it, "
               f"{_fmt(qv.get('dsigma3/static_water-no_water/haunch'), 1e-6)} MPa at the haunch (the paper −0.21): "
               "the water's static pressure puts the lining in tension before the shaking")
    elif name == "hydrodynamic":
        why = (f"moving water changes the peak u_x by {_fmt(qv.get('du_x/dynamic_water-static_water'), 100)} cm from "
               f"(2) (the paper +{_fmt(_mean_paper('max_ux', 'dynamic_water') - _mean_paper('max_ux', 'static_water'), 100)}"
               f"), the lining moving at most {_fmt(qv.get('relative'), 100)} cm against the free field")
    else:
        why = (f"the pressure peak is uniform round the ring, haunch / arches {_fmt(qv.get('pressure_spread'), 1)} "
               f"(the paper {PAPER['hydrodynamic_pressure_peak']['haunch'] / (0.5 * (PAPER['hydrodynamic_pressure_peak']['top_arch'] + PAPER['hydrodynamic_pressure_peak']['bottom_arch'])):.2f})")
    return f"holds in {len(held)} of {len(total)} runs: {why}"


def _fmt(x, scale) -> str:
    return "–" if not _finite(x) else f"{float(x) * scale:+.3g}" if scale != 1 else f"{float(x):.3g}"


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
    """The report's comparison part: the paper's findings first, then the independent quantities
    (calibrated and predicted apart), the §3.3 numbers value by value, damage and slip, the
    discussion. `figures`: key (fig05, ...) -> path relative to the report; `context`: what the
    discussion quotes (the record's source and PGA, the damping, R, the water model, the mesh mode;
    case_report.py `_context`)."""
    c = Comparison(results, figures, context)
    lines = ["## The paper's findings", ""]
    lines += c.findings_rows() + [""]
    lines += ["## The paper's numbers as the quantities they measure", "",
              "The §3.3 numbers merged where they measure one thing (the 18 displacement peaks: the rigid "
              "displacement and the changes between conditions; the 3 pressure peaks: their level and their spread; "
              "the peak times), with the paper's facts. *calibrated*: the target an open choice was set on, declared "
              "before the fit (the study's calibration); *predicted*: every other. A value reached by the static "
              "state at the seismic start says so; a displacement's verdict gives its timing. The study's verdicts: "
              "*reached*, *trade-off* (reached only by losing others), *bracketed* (two levels of one choice on both "
              "sides), *out of reach* (with the measured mechanism), *not reached in N runs* (with their span).", ""]
    lines += c.quantity_rows() + ["", "## The paper variant and its calibration", ""] + c.paper_variant_rows()
    lines += ["", "## The paper's §3.3 numbers against ours", "",
              f"Verdicts: *reproduced* when ours is within ±{100 * TOLERANCE:.0f} % of the paper's value; *not "
              "computed* when the condition was not run or the run ended before the paper's peak time without "
              "already exceeding the band.", ""]
    lines += c.value_rows() + [
        "", "Where a number is outside the band, the verdict says what the study's runs give for it (docs/"
        "paper_reproduction.md): reached, trade-off, bracketed, or not reached in N runs with their span.", "",
        "## Which displacement reference the paper's numbers match", ""]
    lines += c.reference_rows()
    lines += ["", "## Where damage and slip appear", ""]
    lines += c.damage_rows() + [""] + c.slip_rows() + [""]
    lines += ["## Discussion of the differences", ""]
    lines += c.discussion()
    return lines
