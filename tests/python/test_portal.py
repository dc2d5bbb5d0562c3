"""The shipped portal approach (cases/portal): a 35 deg slope descending along the tunnel axis towards
the block's y = 0 face, so the cover over the crown falls from 36.5 m to 11.0 m.

1. `check` passes the shipped case; a portal slope steeper than the block allows (40 deg from the
   same crest: the surface would fall 30.5 m, below a quarter of the 34 m of ground above the
   near-field box) is refused naming geology.slope.angle and the steepest angle that fits (35.0 deg).
2. Its mesh: the ground surface over the tunnel follows z_s(y) = 40 - max(36.4 - y, 0) tan 35
   to round-off, so the cover over the crown is z_s - 3.5 m at every axial grid line; every element
   keeps a positive Jacobian and every edge stays within max_element_size though the axial edges
   lean with the slope.
3. The stable step: the slope's squeezed elements do not set it; check's estimate holds.
"""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from case_edits import check_edited
from test_solid_input import _solid_with_stages

from tunnelquake.case import case_geology, ground_layers, load_case
from tunnelquake.meshing import build_tunnel_mesh, hexmesh
from tunnelquake.motion import from_case as motion_from_case
from tunnelquake.paths import ROOT
from tunnelquake.prepare import write_motion
from tunnelquake.scene import assess_slice
from tunnelquake.solid_input import write_solid_input

CASE = (ROOT / "cases" / "portal" / "case.yaml").read_text()
TAN35 = math.tan(math.radians(35.0))


def _surface(y):
    return 40.0 - np.maximum(36.4 - np.asarray(y, float), 0.0) * TAN35


def test_the_portal_case_passes_check(tmp_path, capsys):
    rc, out, err = check_edited(tmp_path, capsys, CASE)
    assert rc == 0, err


def test_check_keeps_the_portal_in_3d_because_its_cover_changes_along_the_axis(tmp_path, capsys):
    """A slope falling along the axis changes the cover along it, which no slice holds: check's advice
    says so and does not offer a slice; a slope falling across the axis (dip direction 90 deg) leaves
    the scene uniform along it."""
    rc, out, err = check_edited(tmp_path, capsys, CASE)
    assert rc == 0, err
    assert "geology.slope descends towards azimuth 180 deg, along the axis" in out + err
    assert "mesh.mode: slice gives the same answer" not in out + err
    case = load_case(tmp_path / "case.yaml")
    across = dict(case.data["geology"]["slope"], dip_direction=90.0)
    case.data["geology"] = dict(case.data["geology"], slope=across)
    assert not any("geology.slope" in a for a in assess_slice(case).advice)


def test_a_portal_slope_steeper_than_the_block_allows_is_refused(tmp_path, capsys):
    rc, _, err = check_edited(tmp_path, capsys, CASE, "slope: {angle: 35,", "slope: {angle: 40,")
    assert rc == 1
    assert ("geology.slope.angle = 40.0: is steeper than the block allows: descending from the crest through "
            "[0.0, 36.4], the surface falls 30.54 m") in err, err
    assert "use angle <= 35.0 deg with this crest, or give height <= 25.5 m" in err, err
    assert "geology.slope.angle" in err.split("Fix")[0]


@pytest.fixture(scope="module")
def portal_mesh(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("portal")
    (tmp / "case.yaml").write_text(CASE)
    d = load_case(tmp / "case.yaml").data
    summary = build_tunnel_mesh(d["geometry"], d["mesh"], tmp, ground_layers(d), case_geology(d))
    with h5py.File(tmp / "mesh.h5") as f:
        return summary, f["nodes/coordinates"][...], f["elements/connectivity"][...], f["faces/top"][...]


def test_the_cover_falls_towards_the_portal_as_the_slope_says(portal_mesh):
    summary, x, conn, top = portal_mesh
    pts = x[np.unique(top)]
    dev = np.abs(pts[:, 2] - _surface(pts[:, 1])).max()
    above = pts[np.abs(pts[:, 0]) < 1e-9]
    ys = np.unique(above[:, 1])
    cover = [float(above[above[:, 1] == y, 2][0]) - 3.5 for y in ys]
    print("cover over the crown along the axis:", ", ".join(f"y {y:.1f}: {c:.1f} m" for y, c in zip(ys, cover,
                                                                                                     strict=True)))
    print(f"largest distance of a top node from the surface {dev:.3g} m; min scaled Jacobian "
          f"{summary['min_scaled_jacobian']}, longest edge {summary['max_element_size']:.3f} m")
    assert dev < 1e-9
    assert cover[0] == pytest.approx(36.5 - 36.4 * TAN35) and cover[-1] == pytest.approx(36.5)
    assert all(b >= a - 1e-9 for a, b in zip(cover[:-1], cover[1:], strict=True))  # never rises towards the portal
    assert (hexmesh.corner_jacobians(x[conn])[0] > 0).all()
    assert summary["max_element_size"] <= 8.0


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_checks_step_estimate_holds_under_the_slope(tmp_path):
    """The slope squeezes the ground above the near-field box (to 0.25 of its height at the portal
    end here), not the lining, whose elements set the stable step: tq-solid's own step (--check) is the
    flat block's, and check's estimate (scene.runtime_estimate) is within 5 % of it."""
    from tunnelquake import paths
    from tunnelquake.scene import runtime_estimate
    from tunnelquake.solid_input import solid_step

    steps = {}
    for name, text in (("slope", CASE), ("flat", CASE.replace("  slope: {angle: 35, dip_direction: 180, crest: [0, "
                                                                "36.4]}", "  dipping_layers: []"))):
        run = tmp_path / name
        run.mkdir()
        (run / "case.yaml").write_text(text)
        case = load_case(run / "case.yaml")
        d = case.data
        build_tunnel_mesh(d["geometry"], d["mesh"], run, ground_layers(d), case_geology(d))
        motion, _ = motion_from_case(d["ground_motion"], case.dir)
        write_motion(motion, run / "motion.h5")
        inp = write_solid_input(case, run / "mesh.h5", run / "motion.h5", "no_water", run / "in.h5")
        steps[name] = (runtime_estimate(case).dt, solid_step(paths.solid_executable(), inp))
    print("step (check's estimate, tq-solid):", steps)
    assert steps["slope"][1] == pytest.approx(steps["flat"][1], rel=1e-6)
    assert steps["slope"][0] == pytest.approx(steps["slope"][1], rel=0.05)
