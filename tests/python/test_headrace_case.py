"""The new user's case (cases/headrace_tunnel: 6 m inner diameter, 0.5 m C30/37 lining with ø16 @
200 mm on both faces in the analysis, 80 m of cover in granite under a weathered layer, 60 m head)
runs through `tunnelquake run` (what `./Allrun cases/headrace_tunnel` runs; here its static_water
condition and the first 1 s of the shaking) and its report
1. says the bars are in the analysis (the lining is `reinforced_concrete`), not in the check only;
2. shows a lining whose hoop tension N, where the bars are in tension (N > 0), stays below the plain
   concrete's cracking force f_ctm × t (EN 1992-1-1 Table 3.1: 0.30 fck^(2/3) = 2.896 MPa × 0.5 m =
   1,448 kN/m), with the report's N the results file's: no tension cut-off shapes the forces;
3. has the summary table per condition with its governing check;
4. has the design figures (N, M, V envelopes around the ring; the M–N diagram with the demand
   points; the deformed lining at the governing time; the crack pattern: the lining's damage, the
   concrete's loss of secant stiffness in tension), as files and in the report;
5. has no contradictory verdicts: the governing check is the row with the largest utilisation and
   carries its verdict, no plain-concrete row beside the reinforced one, and the crack widths agree
   with the cracking check (zero where uncracked)."""
from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from conftest import ROOT
from tunnelquake.cli import main
from tunnelquake.ring_forces import read_ring_forces

CASE = ROOT / "cases" / "headrace_tunnel"
FCT_T = 0.30 * 30 ** (2 / 3) * 1e6 * 0.5  # N/m


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    d = tmp_path_factory.mktemp("headrace_tunnel")
    for f in CASE.iterdir():
        if f.is_file():
            shutil.copy(f, d / f.name)
    text = (d / "case.yaml").read_text()
    assert "  duration: 10 s\n" in text
    (d / "case.yaml").write_text(text.replace("  duration: 10 s\n", "  duration: 1 s\n")
                                 + "conditions: [static_water]\n")
    assert main(["run", str(d)]) == 0
    return d / "results"


def _summary(report: str, cond: str) -> str:
    start = report.index(f"### {cond}", report.index("## Design summary"))
    return report[start:report.index("\n#", start + 4)]


def test_the_report_says_the_bars_are_in_the_analysis(ran):
    report = (ran / "report.md").read_text()
    assert "The reinforcement is in the analysis too" in report
    assert "in the check only" not in report


def test_the_hoop_tension_stays_below_the_plain_concretes_cracking_force(ran):
    ring = read_ring_forces(ran / "results_static_water.h5")[0]
    tension = ring.N[ring.N > 0]
    assert tension.size > 0  # the head stretches the ring: the bars are in tension
    assert np.max(tension) < 0.99 * FCT_T, np.max(tension)
    report = (ran / "report.md").read_text()
    block = report[report.index("**static_water** (ring"):]
    row = re.search(r"\| N \(kN/m\) \| (\S+) \|", block)
    assert float(row.group(1)) == pytest.approx(np.max(ring.N) / 1e3, rel=1e-3)
    assert float(row.group(1)) < FCT_T / 1e3


def test_the_summary_table_names_the_governing_check(ran):
    s = _summary((ran / "report.md").read_text(), "static_water")
    assert "Static state at the seismic start" in s and "N₀" in s and "M₀" in s
    assert re.search(r"Governing: \*\*(.+?)\*\*, utilisation (\S+) at (\S+)°, t = (\S+) s: (passes|fails)", s)
    assert "| check | value | where | time (s) | verdict |" in s
    for check in ("reinforced M–N", "cracking", "crack width", "hydraulic jacking"):
        assert f"| {check}" in s, check


def test_the_design_figures_are_drawn_and_shown(ran):
    report = (ran / "report.md").read_text()
    for name in ("design_envelopes.png", "design_mn.png", "design_deformed.png", "design_cracks.png",
                 "fig09_damage_section.png"):
        assert (ran / "figures" / name).stat().st_size > 10_000, name
        assert f"(figures/{name})" in report, name


def test_the_verdicts_do_not_contradict_each_other(ran):
    s = _summary((ran / "report.md").read_text(), "static_water")
    assert "plain concrete" not in s
    gov = re.search(r"Governing: \*\*(.+?)\*\*, utilisation (\S+) at (\S+)°, t = (\S+) s: (passes|fails)", s)
    rows = {m.group(1): (m.group(2), m.group(3)) for m in re.finditer(r"^\| ([^|]+?) \| ([^|]*?) \|[^|]*\|[^|]*\| (\S+) \|$",
                                                                        s, re.M) if m.group(1) != "check"}
    utilisations = {k: float(v) for k, (v, _) in rows.items()  # cracking is a state, not a check with a verdict
                    if k in ("reinforced M–N (radial)", "shear") and re.fullmatch(r"[-0-9.e]+", v)}
    assert gov.group(1) == max(utilisations, key=utilisations.get)
    assert float(gov.group(2)) == pytest.approx(utilisations[gov.group(1)])
    assert gov.group(5) == rows[gov.group(1)][1]
    assert gov.group(5) == ("fails" if float(gov.group(2)) > 1 else "passes")
    cracked = rows["cracking"][1] != "uncracked"
    # an ultimate check that fails beside an uncracked section says why
    assert (gov.group(5) == "fails" and not cracked) == ("two limit states, not a contradiction" in s)
    for k, (v, _) in rows.items():
        if k.startswith("crack width"):
            assert (not v.startswith("0 ")) == cracked, (k, v)
