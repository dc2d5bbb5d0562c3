"""`output.displacement_reference`: the monitors' displacements absolute, relative to the base, or
relative to the free field at the tunnel's depth, against a known case: shaking so slow that the
ground moves as a rigid body.

The case: an elastic block 55 m high (rock 20 GPa, ν 0.25, 2650 kg/m³: c_s = 1737 m/s, c_p = 3009
m/s) with a lined 6 m bore 30 m above the base, under a 0.5 Hz pulse (a Gaussian-enveloped sine,
outcrop convention), run through `tunnelquake run` (no_water only, about 20 s).

Reference (1D vertically incident waves in a uniform layer of height H on its base): a point at
height h above the base moves u(h) = u_base cos k(H − h) / cos kH, k = 2πf/c. For kH ≪ 1 the
whole layer follows the base: the displacement relative to the base is
T(f) = cos k(H − h)/cos kH − 1 of the base's, and the absolute displacement is the outcrop
motion's (twice the incident wave, the record itself). The pulse's spectrum is below 1 % of its
peak above 1.2 Hz, where T = 0.024 for the crown (h = 32.6 m, S wave); the bound asserted is
2 × T(1.2 Hz) = 4.9 % of the absolute peak, against the 100 % an absolute reading would give.
"""
from __future__ import annotations

import numpy as np
import pytest
from case_texts import record_motion, tunnel

from tunnelquake import post as P
from tunnelquake.cli import main
from tunnelquake.motion import integrate

H, H_CROWN = 55.0, 32.6  # block height; the crown's height above the base, m
CS, CP = float(np.sqrt(8e9 / 2650)), float(np.sqrt(24e9 / 2650))  # G = 8 GPa, λ + 2G = 24 GPa
F_MAX = 1.2  # Hz: above it the pulse's spectrum is below 1 % of its peak (asserted below)

CASE = tunnel("slow_shaking", [-40.0, 40.0], [0.0, 8.0], [-20.0, 35.0], centre_x=0.0, centre_z=10.0, radius="3.0 m",
              lining="0.4 m", mode="slice", max_element_size="5.5 m", lining_elements_around=24,
              lining_elements_through=2, near_field_half_width=7.0, near_field_radial_divisions=5) + """materials:
  rock: {model: elastic, youngs_modulus: 20 GPa, poisson_ratio: 0.25, density: 2650 kg/m^3}
  lining: {model: elastic, youngs_modulus: 20 GPa, poisson_ratio: 0.25, density: 2650 kg/m^3,
           compressive_strength: 40 MPa}
interface: {model: bonded}
in_situ: {kx: 1.1, ky: 0.8}
""" + record_motion("record.txt", units="m/s^2", duration="5.0 s", vertical_ratio=0.5,
                    baseline_correction="false") + """damping: {model: mass_proportional, ratio: 0.02, frequencies: [0.5 Hz, 10 Hz]}
conditions: [no_water]
output:
  displacement_reference: base
  monitors:
    crown: [0.0, 4.0, 12.6]
    springline: [2.6, 4.0, 10.0]
"""


def _pulse(t):
    """A 0.5 Hz sine under a Gaussian envelope centred at 2.5 s (1 m/s² peak)."""
    return np.sin(2 * np.pi * 0.5 * (t - 2.5)) * np.exp(-(((t - 2.5) / 1.0) ** 2))


def _transfer(f, h, c):
    k = 2 * np.pi * f / c
    return np.cos(k * (H - h)) / np.cos(k * H) - 1.0


def test_the_pulse_is_slow():
    """Above F_MAX the pulse's amplitude spectrum is below 1 % of its peak (the premise of the bound)."""
    t = np.arange(0.0, 40.96, 0.01)
    spec = np.abs(np.fft.rfft(_pulse(t)))
    f = np.fft.rfftfreq(t.size, 0.01)
    assert spec[f > F_MAX].max() < 0.01 * spec.max()


@pytest.fixture(scope="module")
def slow_case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("slow_shaking")
    t = np.arange(0.0, 5.0 + 1e-9, 0.01)
    (folder / "record.txt").write_text("".join(f"{x:.3f} {y:.8e}\n" for x, y in zip(t, _pulse(t), strict=True)))
    (folder / "case.yaml").write_text(CASE)
    assert main(["run", str(folder / "case.yaml")]) == 0
    return folder / "results"


def test_slow_shaking_moves_the_ground_as_a_rigid_body(slow_case):
    f = slow_case / "results_no_water.h5"
    absolute = P.read_condition(f, "no_water")
    base = P.read_condition(f, "no_water", "base")
    free = P.read_condition(f, "no_water", "free_field")
    assert set(absolute.monitors) == {"crown", "springline"}  # the references are not monitors
    assert set(absolute.references) == {"base", "free_field"}
    # the absolute displacement is the outcrop motion's (the record's, twice the incident wave's)
    import h5py

    with h5py.File(slow_case / "motion.h5", "r") as m:
        dt = float(m.attrs["dt"])
        outcrop = {0: 2 * integrate(m["incident_ax"][...], dt)[1], 2: 2 * integrate(m["incident_az"][...], dt)[1]}
    for c, wave in ((0, CS), (2, CP)):
        bound = 2 * _transfer(F_MAX, H_CROWN, wave)
        peak = np.abs(outcrop[c]).max()
        for m in ("crown", "springline"):
            a = np.abs(absolute.monitors[m].u[:, c]).max()
            assert a == pytest.approx(peak, rel=bound), (m, c)
            # relative to the base and to the free field: the rigid body's motion is gone
            assert np.abs(base.monitors[m].u[:, c]).max() <= bound * a, (m, c)
            assert np.abs(free.monitors[m].u[:, c]).max() <= bound * a, (m, c)
            # and the relative history is the absolute one less the reference's, sample by sample
            np.testing.assert_allclose(base.monitors[m].u, absolute.monitors[m].u - absolute.references["base"].u,
                                       rtol=0, atol=1e-15)
    assert 2 * _transfer(F_MAX, H_CROWN, CS) < 0.05


def test_the_report_names_the_reference(slow_case):
    report = (slow_case / "report.md").read_text()
    assert "Displacements are relative to the base under the tunnel axis (output.displacement_reference: base)" \
        in report


def test_check_refuses_an_unknown_reference(tmp_path, capsys):
    (tmp_path / "record.txt").write_text("0 0\n1 0\n")
    (tmp_path / "case.yaml").write_text(CASE.replace("displacement_reference: base",
                                                     "displacement_reference: surface"))
    assert main(["check", str(tmp_path / "case.yaml")]) != 0
    err = capsys.readouterr().err
    assert "output.displacement_reference" in err and "free_field" in err, err
