"""`tunnelquake bench`: the observed order and the docs section it rewrites.

The benchmark's figures are not tests; what is tested here is the arithmetic the table reports
(observed order of a known power law, exact) and that --update-docs touches only its section.
"""
from __future__ import annotations

import math

from benchmarks.common import observed_orders
from benchmarks.solid import BEGIN, END, update_docs


def test_observed_order_of_a_power_law_is_its_exponent():
    # e = C s^p with s halving: log(e_i/e_{i+1}) / log(s_i/s_{i+1}) = p exactly (round-off).
    for p in (1.0, 2.0, 1.7):
        s = [0.4, 0.2, 0.1, 0.05]
        e = [3.0 * x**p for x in s]
        orders = observed_orders(s, e)
        assert orders[0] is None
        for o in orders[1:]:
            assert math.isclose(o, p, rel_tol=1e-12)
    # Negative errors: the order of their magnitude; a sign change has no asymptotic order.
    assert math.isclose(observed_orders([2.0, 1.0], [-0.04, -0.01])[1], 2.0, rel_tol=1e-12)
    assert observed_orders([2.0, 1.0], [0.04, -0.01])[1] is None
    assert observed_orders([2.0, 1.0], [0.04, 0.0])[1] is None


def test_update_docs_replaces_only_the_marked_section_or_appends_it():
    new = f"{BEGIN}\nnew table\n{END}"
    doc = f"# Benchmarks\n\nbefore\n\n{BEGIN}\nold table\n{END}\n\nafter\n"
    out = update_docs(doc, new)
    assert out == f"# Benchmarks\n\nbefore\n\n{new}\n\nafter\n"
    assert "old table" not in out
    # Idempotent: a second update with the same section changes nothing.
    assert update_docs(out, new) == out
    # Absent markers: appended once at the end, the rest untouched.
    plain = "# Benchmarks\n\ntext\n"
    appended = update_docs(plain, new)
    assert appended == f"# Benchmarks\n\ntext\n\n{new}\n"
    assert update_docs(appended, new) == appended


def test_peer_part_of_the_section_gives_the_ratio_or_the_reason_it_was_skipped():
    from benchmarks.calculix import PeerResult
    from benchmarks.solid import section

    reason = "ccx (CalculiX) not found on PATH: install Debian's calculix-ccx"
    text = section("T", "P", "tunnelquake bench x --peer", "today", "here", "f.png", reason)
    assert f"skipped: {reason}" in text
    assert "not run: add `--peer`" in section("T", "P", "tunnelquake bench x", "today", "here", "f.png")
    # Ratio of medians and answer difference, exact arithmetic on made-up figures.
    r = PeerResult(n=10, steps=20, dt=1e-4, pressure=1e6, ccx_version="2.20", tq_us=[0.2, 0.1, 0.3],
                   tq_generic_us=[0.4], ccx_us=[3.0, 2.0, 4.0], ccx_whole_s=[1.0], tq_uz=-1.01e-3,
                   tq_generic_uz=-1.01e-3, ccx_uz=-1.0e-3)
    assert math.isclose(r.ratio(), 15.0) and math.isclose(r.ratio(generic=True), 7.5)
    assert math.isclose(r.answer_difference, 0.01)
    peer_text = section("T", "P", "c", "w", "m", "f.png", r)
    assert "Ratio CalculiX / tq-solid: 15.0×" in peer_text and "= 1.00 %" in peer_text


def test_tunnelquake_bench_reaches_the_benchmarks_outside_the_package(tmp_path):
    """`tunnelquake bench` runs benchmarks/ (not in the installed package) from any folder, with the
    arguments it was given: a build without the stress-test executable gets the benchmark's own
    message naming the missing file, and its exit status 1."""
    import os
    import subprocess
    import sys

    from tunnelquake.paths import ROOT

    env = dict(os.environ, TQ_BUILD_DIR=str(tmp_path / "no-build"), PYTHONPATH=str(ROOT / "scripts"))
    out = subprocess.run([sys.executable, "-m", "tunnelquake", "bench", "out", "--stress"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 1, out.stdout + out.stderr
    assert f"{tmp_path / 'no-build'}/tests/cpp/tq_solid_stress_tests not found" in out.stderr
    assert (tmp_path / "out").is_dir()  # the folder argument is read relative to the caller's folder
