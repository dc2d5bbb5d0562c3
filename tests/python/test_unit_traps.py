"""Inputs that were silently taken in a unit or with a default the user did not mean: `check`
refuses each, naming the key and the fix, before anything runs. A PGA and a reinforcement area
need their unit (0.3 meant as g was taken as 0.3 m/s^2, 1005 meant as mm^2/m as 1005 m^2/m); the
vertical component, the in-situ stress ratios (K0) and a 3D model's water ends have no neutral
default and must be given."""
from __future__ import annotations

import pytest
from test_input_checks import _case, _check

DESIGN = "\ndesign:\n  concrete: {fck: 30 MPa}\n  reinforcement: {As_inner: AREA, As_outer: 1005 mm2/m}\n\nstages:"

TRAPS = [
    ("pga without a unit", ("  pga: 1.575 m/s^2\n", "  pga: 0.3\n"), "ground_motion.pga",
     "needs its unit", "'0.3 g' or '2.94 m/s^2'"),
    ("a vertical record's pga without a unit",
     ("  vertical_ratio: 0.6666667     # z = 2/3 x\n",
      "  vertical: {file: ../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2, pga: 0.2}\n"),
     "ground_motion.vertical.pga", "needs its unit", "1.96 m/s^2"),
    ("reinforcement area without a unit", ("\nstages:", DESIGN.replace("AREA", "1005")),
     "design.reinforcement.As_inner", "needs its unit", "'1005 mm2/m'"),
    ("no vertical_ratio", ("  vertical_ratio: 0.6666667     # z = 2/3 x\n", ""), "ground_motion.vertical_ratio",
     "is missing", "0: no vertical motion"),
    ("no kx", ("  kx: 1.1\n", ""), "in_situ.kx", "is missing", "in_situ: {kx:"),
    ("no ky", ("  ky: 0.8\n", ""), "in_situ.ky", "is missing", "in_situ: {ky:"),
    ("no water ends in 3D", ("  ends: open\n", "", "  mode: slice ", "  mode: 3d "), "water.ends", "is missing",
     "water: {ends: open}"),
]


@pytest.mark.parametrize("desc, edits, key, problem, fix", TRAPS, ids=[t[0] for t in TRAPS])
def test_check_refuses_the_trap_naming_the_key(tmp_path, capsys, desc, edits, key, problem, fix):
    rc, err = _check(capsys, _case(tmp_path, *edits))
    assert rc != 0, err
    line = next((x for x in err.splitlines() if f"{key}" in x and problem in x), None)
    assert line is not None, err
    assert "Fix:" in line and fix in line, line


def test_the_units_given_are_taken(tmp_path):
    """With its unit each is what was meant: 0.3 g, 1005 mm^2/m."""
    from tunnelquake.case import load_case

    case = load_case(_case(tmp_path, "  pga: 1.575 m/s^2\n", "  pga: 0.3 g\n", "\nstages:",
                           DESIGN.replace("AREA", "1005 mm2/m")))
    assert case.data["ground_motion"]["pga"] == pytest.approx(0.3 * 9.80665, rel=1e-12)
    assert case.data["design"]["reinforcement"]["As_inner"] == pytest.approx(1.005e-3, rel=1e-12)


def test_without_water_or_in_a_slice_the_ends_are_not_asked_for(tmp_path, capsys):
    """A slice has no axial flow, so its water ends need not be given."""
    rc, err = _check(capsys, _case(tmp_path, "  ends: open\n", ""))
    assert rc == 0 and "water.ends" not in err, err
