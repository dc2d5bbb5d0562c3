"""What a scene needs: which solvers each condition runs, and whether a plane-strain slice is
equivalent to the 3D model (ARCHITECTURE.md §6).

A slice (one element thick along the tunnel axis y, u_y = 0, a one-cell-thick water mesh) gives
the 3D answer when nothing varies along y: one straight tunnel along y, materials and interface
uniform along y, and a vertically incident motion with no y component — which every TunnelQuake
case satisfies by construction (the geometry is an extruded section, the motion has x and z
components only). What can break the equivalence is the water: in a slice the water cannot flow
along the axis, so a motion that changes the lining's cross-sectional area (the vertical P wave
squeezes the ring) meets water that cannot leave. Incompressible water then makes the problem
ill-posed (and the fluid side refuses it); compressible water (bulk modulus K) resists the area
change with p = -K dA/A, which is the long-tunnel limit of the 3D model and the right slice model.
"""
from __future__ import annotations

from dataclasses import dataclass, field

PARTICIPANTS = {
    "no_water": ("solid",),  # rock + lining only: no fluid process, no coupling
    "static_water": ("solid",),  # hydrostatic pressure as a static load: still no fluid process
    "dynamic_water": ("solid", "fluid"),  # OpenFOAM water coupled every window
}


@dataclass
class SliceAssessment:
    valid: bool
    reasons: list[str] = field(default_factory=list)  # why not (empty when valid)
    advice: list[str] = field(default_factory=list)  # what the user may want to change


def plan(case) -> list[tuple[str, tuple[str, ...]]]:
    """The participants each requested condition runs, in the case's order."""
    return [(c, PARTICIPANTS[c]) for c in case.data["conditions"]]


def assess_slice(case) -> SliceAssessment:
    d = case.data
    reasons: list[str] = []
    advice: list[str] = []
    dynamic = "dynamic_water" in d["conditions"]
    water = d["water"]
    if dynamic and water["model"] == "incompressible":
        reasons.append(
            "dynamic_water with incompressible water: in a slice the water cannot flow along the axis, so "
            "the vertical P wave's change of the lining's cross-section meets water that cannot leave "
            "(ill-posed); use water.model: compressible (the long-tunnel limit), or mesh.mode: 3d with open ends")
    if d["mesh"]["mode"] == "3d" and not reasons:
        advice.append("the scene is uniform along the tunnel axis: mesh.mode: slice gives the same answer for "
                      f"about 1/{d['mesh'].get('elements_along_axis', 44)} of the solid's cost")
    return SliceAssessment(valid=not reasons, reasons=reasons, advice=advice)
