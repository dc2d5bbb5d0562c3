"""Absolute convergence floors of the implicit coupling, from the problem's scale (docs/coupler.md
"Convergence test").

The relative residual of the interface motion and force cannot fall below the tolerance when the
motion is round-off sized (before the seismic wave reaches the tunnel, at rest): the relative change
of noise between two passes is of order one. Each exchanged field therefore also converges when the
RMS of its residual is below an absolute floor, in the field's units, set to `tolerance` times the
field's scale in this problem:

    velocity      a_ref * window                 (m/s: the velocity the peak ground acceleration
                                                   gives the wall over one window)
    displacement  a_ref * window**2              (m)
    force         rho_w * a_ref * r_in * A       (N per node: the incompressible added-mass
                                                   pressure rho_w a r of the wall accelerated at
                                                   a_ref, on a wetted node's tributary area A)

a_ref: ground_motion.pga (1 m/s^2 when the record is not scaled), r_in: the lining's inner radius,
A = (2 pi r_in / lining_elements_around) x the axial spacing (3D: y-extent / (elements_along_axis x
refinement_factor); a slice's two node planes share its thickness: half of it each). The example:
0.535 m^2, the tributary area tq-solid computes for its monitors' wetted nodes. The floors sit far below what the relative
test accepts during the shaking (there the relative test decides), and far above round-off.
"""

from __future__ import annotations


def absolute_tolerances(case, window_size: float, tolerance: float) -> dict[str, float]:
    """{'velocity': m/s, 'displacement': m, 'force': N} absolute floors for this case and window."""
    d = case.data
    a_ref = float((d.get("ground_motion") or {}).get("pga") or 1.0)
    g = d["geometry"]
    r_in = float(g["excavated_radius"]) - float(g["lining_thickness"])
    area = wetted_node_area(case)
    rho = float(d["water"]["density"])
    v = tolerance * a_ref * window_size
    return {"velocity": v, "displacement": v * window_size, "force": tolerance * rho * a_ref * r_in * area}


def wetted_node_area(case) -> float:
    """Tributary area of one wetted lining node (m^2), from the case's mesh parameters."""
    import math

    from .meshing.params import merged_mesh_params

    d = case.data
    g = d["geometry"]
    m = merged_mesh_params(d.get("mesh"))
    r_in = float(g["excavated_radius"]) - float(g["lining_thickness"])
    k = int(m["refinement_factor"])
    arc = 2 * math.pi * r_in / (int(m["lining_elements_around"]) * k)
    y0, y1 = (float(v) for v in g["y_range"])
    along = (y1 - y0) / (int(m["elements_along_axis"]) * k)
    if m["mode"] == "slice":
        thick = float(m["slice_thickness"]) if m["slice_thickness"] is not None else along
        return arc * thick / 2
    return arc * along
