"""The study of the paper's open choices (benchmarks/paper_study.py), on hand-made numbers whose
answer is known: the count of the paper's numbers, the findings read from a run's numbers, the
choices each run and which runs are matched with the paper (the verdicts and the calibration:
test_paper_verdicts.py)."""
from __future__ import annotations

import math

import pytest

from benchmarks import paper_study as S
from tunnelquake import paper


def _scaled(factor_of) -> dict:
    """The paper's numbers, each times factor_of(key)."""
    return {k: v * factor_of(k) for k, v in paper.paper_numbers().items()}


def test_misfit_and_within_count_the_33_numbers():
    p = paper.paper_numbers()
    assert len(p) == 33
    assert paper.misfit(p) == 0.0 and paper.within(p) == 33
    # every number 1.25x: ln²(1.25) each, none within ±20 %
    assert paper.misfit(_scaled(lambda k: 1.25)) == pytest.approx(33 * math.log(1.25) ** 2, rel=1e-12)
    assert paper.within(_scaled(lambda k: 1.25)) == 0
    # a missing number counts as a factor e² (4), the others exact
    missing = dict(p)
    del missing["pressure/haunch"]
    assert paper.misfit(missing) == pytest.approx(4.0, rel=1e-12)


def test_the_findings_read_from_numbers():
    """hydrostatic: (2) below (1) in every displacement and in σ3 at 2 of 3; hydrodynamic: (3)
    above (1) everywhere; haunch: the largest pressure and σ3 in each condition."""
    p = paper.paper_numbers()
    # the paper's own numbers: (2) = (1) - x and (3) = (1) + x; its σ3 (2) is below (1) at the haunch
    # and the bottom arch (0.88 < 1.09, 0.79 < 0.92), above at the top arch (0.80 > 0.65): 2 of 3
    assert paper.finding_holds(p, "hydrodynamic") is True
    assert paper.finding_holds(p, "hydrostatic") is True
    q = dict(p)
    q["max_tension/static_water/haunch"] = 1.2e6  # now 1 of 3
    assert paper.finding_holds(q, "hydrostatic") is False
    q = dict(p)
    q["max_uz/static_water/haunch"] = 0.04  # above (1)'s 0.0374: a displacement must fall everywhere
    assert paper.finding_holds(q, "hydrostatic") is False
    assert paper.finding_holds(p, "haunch") is True
    q = dict(p)
    q["pressure/top_arch"] = 0.5e6  # above the haunch's 0.466
    assert paper.finding_holds(q, "haunch") is False
    del q["pressure/top_arch"]
    assert paper.finding_holds(q, "haunch") is None


def test_the_choices_run_the_conditions_they_can_change():
    cs = S.choices(S.CASE.parent)
    assert cs[0].name == paper.EXAMPLE_RUN and not cs[0].overrides
    assert len({c.slug for c in cs}) == len(cs)
    for c in cs:
        # the water changes condition (3) only; a choice cut short (too slow over the whole record)
        # runs the solid-only conditions, beside the example cut alike
        cut = "time.end_time" in c.overrides
        assert c.conditions == (S.DYN if c.dimension == "water" else S.SOLID if cut else S.ALL)
        assert c.dimension == "example" or c.dimension in S.EXAMPLE_LEVELS


def test_a_run_cut_short_is_never_calibrated_nor_matched_with_the_paper():
    """A choice run over the record's first seconds only (Rayleigh damping) has peaks that are not the
    whole record's: it is left out of the runs a paper number is matched against and calibrated on
    (whole_record), and kept for its own comparison with the example cut alike."""
    cut = [c for c in S.choices(S.CASE.parent) if "time.end_time" in c.overrides]
    assert cut and all(c.overrides["time.end_time"] == S.SHORT_END for c in cut)
    nums = {c.name: {"max_ux/no_water/top_arch": 0.03} for c in S.choices(S.CASE.parent)}
    assert not set(S.whole_record(nums)) & {c.name for c in cut}
    assert len(S.whole_record(nums)) + len(cut) == len(nums)
