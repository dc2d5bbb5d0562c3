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
    force         rho_w * a_ref * r_in * h**2    (N per node: the incompressible added-mass
                                                   pressure rho_w a r of the wall accelerated at
                                                   a_ref, on a node's area h**2)

a_ref: ground_motion.pga (1 m/s^2 when the record is not scaled), r_in: the lining's inner radius,
h: mesh.max_element_size (r_in / 4 when not given). The floors sit far below what the relative
test accepts during the shaking (there the relative test decides), and far above round-off.
"""

from __future__ import annotations


def absolute_tolerances(case, window_size: float, tolerance: float) -> dict[str, float]:
    """{'velocity': m/s, 'displacement': m, 'force': N} absolute floors for this case and window."""
    d = case.data
    a_ref = float((d.get("ground_motion") or {}).get("pga") or 1.0)
    g = d["geometry"]
    r_in = float(g["excavated_radius"]) - float(g["lining_thickness"])
    h = float((d.get("mesh") or {}).get("max_element_size") or r_in / 4.0)
    rho = float(d["water"]["density"])
    v = tolerance * a_ref * window_size
    return {"velocity": v, "displacement": v * window_size, "force": tolerance * rho * a_ref * r_in * h * h}
