"""The designer's figures: the design forces' envelopes around the ring, the section's M–N
diagram with the demand points, the deformed lining and the crack pattern at the governing time. Angles as everywhere in the report: from the crown towards +x; the
ring is drawn as seen along the tunnel axis, the crown up and +x to the right."""
from __future__ import annotations

from pathlib import Path

import numpy as np

# _plt: the Agg back end; _save: the PNG put in place only once complete
from ..post import _plt, _save, damage_section, read_snapshot


def ring_scale(values: list[np.ndarray], radius: float) -> float:
    """Metres of drawing per unit of the quantity: the largest |value| drawn at 0.45 × the radius."""
    big = max((float(np.max(np.abs(v))) for v in values if v.size), default=0.0)
    return 0.45 * radius / big if big > 0 else 0.0


def fig_envelopes(conditions, out: Path) -> Path | None:
    """N, M, V of the seismic design situation around the ring, one panel each: per condition the
    largest and smallest value of each section over the run (solid, dashed) and the static state
    (dotted), drawn off the lining's mid-line, outwards positive (N tension, M tension at the inner
    face), at the scale given in each panel."""
    items = [c for c in conditions if c.angles is not None and c.envelope]
    if not items:
        return None
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(14, 5.2))
    R = items[0].radius
    for ax, (q, unit) in zip(axes, (("N", "kN/m"), ("M", "kN·m/m"), ("V", "kN/m")), strict=True):
        vals = [a / 1e3 for c in items for a in (*c.envelope[q], c.static_forces[q])]
        k = ring_scale(vals, R)
        t = np.radians(np.linspace(-180, 180, 361))
        ax.plot(R * np.sin(t), R * np.cos(t), color="0.6", lw=1)
        for i, c in enumerate(items):
            order = np.argsort(c.angles)
            th = np.radians(np.append(c.angles[order], c.angles[order][0] + 360))
            for arr, ls, lab in ((c.envelope[q][0], "-", "max"), (c.envelope[q][1], "--", "min"),
                                 (c.static_forces[q], ":", "static")):
                v = np.append(arr[order], arr[order][0]) / 1e3
                r = R + k * v
                ax.plot(r * np.sin(th), r * np.cos(th), ls, color=f"C{i}", lw=1.2, label=f"{c.condition} {lab}")
        ax.set_aspect("equal")
        ax.set_title(f"{q} ({unit}); 1 m of drawing = {1 / k:.3g} {unit}" if k else f"{q}: zero", fontsize=9)
        ax.set_xlabel("x from the axis (m)")
        ax.set_ylabel("z from the axis (m)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6, loc="lower left")
    fig.suptitle("Design forces around the ring (outwards: N tension, M tension at the inner face, V +); "
                 "crown up, +x right", fontsize=10)
    fig.tight_layout()
    _save(fig, out)
    plt.close(fig)
    return out


def fig_mn(conditions, section, out: Path) -> Path | None:
    """The reinforced section's M–N resistance (design values) with each condition's demand points
    (the vertices of the pairs' convex hull and the largest |M| per band of N)."""
    items = [c for c in conditions if c.demand is not None and c.demand[0].size]
    if not items or section is None:
        return None
    plt = _plt()
    NR, MR = section.diagram()
    fig, ax = plt.subplots(figsize=(7, 5.5))
    ax.plot(MR / 1e3, NR / 1e3, color="k", lw=1.5, label="resistance (design)")
    for i, c in enumerate(items):
        ax.plot(c.demand[1] / 1e3, c.demand[0] / 1e3, "o", ms=3, color=f"C{i}", label=f"{c.condition} demand")
    ax.axhline(0, color="0.7", lw=0.8)
    ax.axvline(0, color="0.7", lw=0.8)
    ax.set_xlabel("M (kN·m/m, tension at the inner face +)")
    ax.set_ylabel("N (kN/m, compression +)")
    ax.set_title("M–N interaction of the lining section with the seismic design situation's demand", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, out)
    plt.close(fig)
    return out


def fig_deformed(conditions, out: Path) -> Path | None:
    """The lining's ovaling at each condition's governing time (the summary's governing check):
    each diameter's change relative to the seismic start, half of it at each of its ends, drawn
    radially off the mid-line at one scale stated in the title (the symmetric part of the
    deformation; a rigid-body motion of the ring moves no diameter)."""
    items = []
    for c in conditions:
        t = c.governing_time() if c.diameter is not None else None
        if t is not None:
            i = int(np.argmin(np.abs(c.diameter[1] - t)))
            items.append((c, float(c.diameter[1][i]), c.diameter[2][i] / 2))
    if not items:
        return None
    R = items[0][0].radius
    big = max(float(np.max(np.abs(u))) for _, _, u in items)
    k = 0.15 * R / big if big > 0 else 0.0
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    t = np.radians(np.linspace(-180, 180, 361))
    ax.plot(R * np.sin(t), R * np.cos(t), color="0.6", lw=1, label="undeformed mid-line")
    for i, (c, time, u) in enumerate(items):
        phi = np.concatenate([c.diameter[0], c.diameter[0] + 180.0])
        ur = np.concatenate([u, u])
        order = np.argsort(phi)
        th = np.radians(np.append(phi[order], phi[order][0] + 360))
        r = R + k * np.append(ur[order], ur[order][0])
        ax.plot(r * np.sin(th), r * np.cos(th), "-", color=f"C{i}", lw=1.5,
                label=f"{c.condition} at t = {time:.3f} s (largest |Δd/2| {1e3 * float(np.max(np.abs(u))):.3g} mm)")
    ax.set_aspect("equal")
    ax.set_xlabel("x from the axis (m)")
    ax.set_ylabel("z from the axis (m)")
    ax.set_title(f"Deformed lining at the governing time (ovaling from the seismic start), displacements × {k:.3g}"
                 if k else "Deformed lining: no diameter change", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    _save(fig, out)
    plt.close(fig)
    return out


def nearest_snapshot(res, time: float) -> tuple[str, float] | None:
    """The complete field snapshot of a condition's results nearest `time` (of two at the same
    distance, the earlier): (key, its time); None without snapshots."""
    if not res.snapshots:
        return None
    return min(res.snapshots, key=lambda s: (abs(s[1] - time), s[1]))


def crack_pattern(res, time: float):
    """The lining's middle section at the snapshot nearest `time`: (the snapshot's time, the
    elements' outlines, their damage D); None without a snapshot or without damage."""
    near = nearest_snapshot(res, time)
    if near is None or res.mesh is None:
        return None
    snap = read_snapshot(res, near[0])
    polys, d, _ = damage_section(res, snap)
    return (snap["time"], polys, d) if polys else None


def fig_cracks(conditions, results, out: Path) -> Path | None:
    """The crack pattern (the lining's damage D over its middle section: a reinforced_concrete
    lining's loss of secant stiffness in tension) at each condition's governing time (the summary's
    governing check), from the field snapshot nearest it; both times in each panel's title, the
    colour scale fitted to the largest D drawn."""
    from matplotlib.collections import PolyCollection

    by_condition = {r.condition: r for r in results}
    items = []
    for c in conditions:
        res, t = by_condition.get(c.condition), c.governing_time()
        if res is None or t is None:
            continue
        got = crack_pattern(res, t)
        if got is not None:
            items.append((c.condition, t, *got))
    if not items:
        return None
    plt = _plt()
    dmax = max(float(d.max()) for *_, d in items)
    vmax = dmax if dmax > 0 else 1.0  # 0 to 1 when nothing has cracked
    fig, axes = plt.subplots(1, len(items), figsize=(4.2 * len(items) + 0.8, 4.4), squeeze=False)
    for ax, (cond, t, ts, polys, d) in zip(axes[0], items, strict=True):
        pc = PolyCollection(polys, array=d, cmap="inferno_r", edgecolors="0.6", linewidths=0.2)
        pc.set_clim(0.0, vmax)
        ax.add_collection(pc)
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_title(f"{cond}: governing t = {t:.3f} s,\nnearest snapshot t = {ts:.3f} s; max D = {d.max():.3g}",
                     fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("z (m)")
    fig.colorbar(pc, ax=axes[0].tolist(), label="damage D (cracked: loss of secant stiffness in tension)", shrink=0.8)
    fig.suptitle("Crack pattern at the governing time (the field snapshot nearest it)", fontsize=10)
    _save(fig, out)
    plt.close(fig)
    return out
