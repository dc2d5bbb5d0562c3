"""Post-processing of condition results: monitors as CSV, the paper's figures, the comparison table.

Works on whatever a run left: a results file cut off by a crash is read up to its last written
row (rows are appended and flushed as the solver goes), and its status attribute is reported.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

CONDITION_LABELS = {"no_water": "(1) no water", "static_water": "(2) static water",
                    "dynamic_water": "(3) dynamic water"}
MONITORS = ("top_arch", "haunch", "bottom_arch")

#: The paper's §3.3 numbers (Liu, Zhang & Xiao 2021). Displacements in m, stresses/pressures in Pa.
PAPER = {
    "hydrodynamic_pressure_peak": {"top_arch": 0.256e6, "haunch": 0.466e6, "bottom_arch": 0.326e6},
    "hydrodynamic_pressure_peak_time": 5.2,
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


@dataclass
class Monitor:
    time: np.ndarray
    u: np.ndarray  # [T, 3] m
    principal: np.ndarray  # [T, 3] Pa, sigma1 <= sigma2 <= sigma3
    extra: dict = field(default_factory=dict)  # damage, pressure, ... when present


@dataclass
class ConditionResult:
    condition: str
    path: Path
    status: str
    monitors: dict[str, Monitor]

    @property
    def complete(self) -> bool:
        return self.status == "completed"


def _rows(ds) -> np.ndarray:
    a = np.asarray(ds[...])
    return a.reshape(a.shape[0], -1) if a.ndim > 1 else a.reshape(-1, 1)


def read_condition(path: Path, condition: str) -> ConditionResult:
    """Read a condition's results.h5; monitor arrays are cut to the rows all of them share."""
    import h5py

    with h5py.File(path, "r") as f:
        status = str(f.attrs.get("status", "unknown"))
        mons: dict[str, Monitor] = {}
        for name, g in f.get("monitors", {}).items():
            t = _rows(g["time"])[:, 0]
            u = _rows(g["u"])
            pr = _rows(g["principal"]) if "principal" in g else np.zeros((t.size, 3))
            n = min(t.size, u.shape[0], pr.shape[0])
            extra = {k: _rows(g[k])[:n] for k in ("damage", "pressure") if k in g}
            mons[name] = Monitor(time=t[:n], u=u[:n], principal=pr[:n], extra=extra)
    return ConditionResult(condition, path, status, mons)


def monitors_csv(res: ConditionResult, out: Path) -> Path:
    """One CSV per condition: time and, per monitor, ux, uy, uz (m) and sigma1..3 (Pa)."""
    names = sorted(res.monitors)
    n = min((res.monitors[m].time.size for m in names), default=0)
    header = ["time_s"]
    for m in names:
        header += [f"{m}_ux_m", f"{m}_uy_m", f"{m}_uz_m", f"{m}_s1_Pa", f"{m}_s2_Pa", f"{m}_s3_Pa"]
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for i in range(n):
            row = [f"{res.monitors[names[0]].time[i]:.6g}"]
            for m in names:
                mo = res.monitors[m]
                row += [f"{v:.6e}" for v in (*mo.u[i], *mo.principal[i])]
            w.writerow(row)
    return out


def peaks(res: ConditionResult) -> dict[str, dict[str, float]]:
    """Per monitor: max |ux|, max |uz| (m) and max tension = max sigma3 (Pa)."""
    out = {}
    for m, mo in res.monitors.items():
        out[m] = {
            "max_ux": float(np.max(np.abs(mo.u[:, 0]))) if mo.u.size else float("nan"),
            "max_uz": float(np.max(np.abs(mo.u[:, 2]))) if mo.u.size else float("nan"),
            "max_tension": float(np.max(mo.principal[:, 2])) if mo.principal.size else float("nan"),
        }
    return out


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fig_max_displacements(results: list[ConditionResult], out: Path) -> Path:
    """Paper Fig. 6: maximum x and z displacements of the monitors per condition, ours beside the paper's."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    width = 0.8 / max(1, 2 * len(results))
    for ax, key, title in ((axes[0], "max_ux", "x-direction"), (axes[1], "max_uz", "z-direction")):
        xs = np.arange(len(MONITORS))
        for k, res in enumerate(results):
            pk = peaks(res)
            ours = [100 * pk.get(m, {}).get(key, np.nan) for m in MONITORS]
            paper = [100 * PAPER[key][res.condition][m] for m in MONITORS]
            ax.bar(xs + (2 * k) * width, ours, width, label=f"{CONDITION_LABELS[res.condition]} ours")
            ax.bar(xs + (2 * k + 1) * width, paper, width, alpha=0.45, label=f"{CONDITION_LABELS[res.condition]} paper")
        ax.set_xticks(xs + width * (len(results) - 0.5), [m.replace("_", " ") for m in MONITORS])
        ax.set_ylabel("max displacement (cm)")
        ax.set_title(title)
        ax.grid(alpha=0.3, axis="y")
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def fig_principal_stress(results: list[ConditionResult], out: Path) -> Path:
    """Paper Fig. 7: maximum principal (most tensile) stress histories per condition."""
    plt = _plt()
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.4), squeeze=False)
    for ax, res in zip(axes[0], results, strict=True):
        for m in MONITORS:
            if m in res.monitors:
                mo = res.monitors[m]
                ax.plot(mo.time, mo.principal[:, 2] / 1e6, lw=0.8, label=m.replace("_", " "))
        ax.set_title(CONDITION_LABELS[res.condition])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("max principal stress (MPa)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def comparison_table(results: list[ConditionResult]) -> list[str]:
    """Markdown rows: the paper's §3.3 value beside ours, value by value."""
    lines = ["| quantity | condition | monitor | paper | ours | ours / paper |", "|---|---|---|---|---|---|"]
    units = {"max_ux": ("cm", 100), "max_uz": ("cm", 100), "max_tension": ("MPa", 1e-6)}
    for res in results:
        pk = peaks(res)
        for key, (unit, scale) in units.items():
            for m in MONITORS:
                p = PAPER[key][res.condition][m] * scale
                o = pk.get(m, {}).get(key, float("nan")) * scale
                ratio = o / p if p else float("nan")
                lines.append(f"| {key} ({unit}) | {res.condition} | {m} | {p:.3g} | {o:.3g} | {ratio:.2f} |")
    return lines
