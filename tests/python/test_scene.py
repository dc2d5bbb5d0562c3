"""What each condition runs, and when a slice is equivalent to the 3D model (ARCHITECTURE.md §6)."""
from __future__ import annotations

from conftest import EXAMPLE
from tunnelquake.case import load_case
from tunnelquake.scene import assess_slice, plan


def _case(write_case, **edits):
    text = EXAMPLE.read_text()
    for old, new in edits.values():
        assert old in text
        text = text.replace(old, new, 1)
    return load_case(write_case(text))


def test_conditions_run_only_what_they_need(write_case):
    case = _case(write_case)
    assert dict(plan(case)) == {"no_water": ("solid",), "static_water": ("solid",),
                                "dynamic_water": ("solid", "fluid")}


def test_example_slice_is_valid(write_case):
    assert assess_slice(_case(write_case)).valid


def test_slice_with_incompressible_dynamic_water_is_not_equivalent(write_case):
    case = _case(write_case, m=("  model: compressible\n", "  model: incompressible\n"))
    a = assess_slice(case)
    assert not a.valid and "cannot flow along the axis" in a.reasons[0]
    # without the dynamic condition there is no water flow to model: the slice is fine again
    case = _case(write_case, m=("  model: compressible\n", "  model: incompressible\n"),
                 c=("conditions: [no_water, static_water, dynamic_water]", "conditions: [no_water, static_water]"))
    assert assess_slice(case).valid


def test_3d_case_is_offered_the_slice(write_case):
    case = _case(write_case, m=("  mode: slice ", "  mode: 3d "))
    a = assess_slice(case)
    assert a.valid and "mesh.mode: slice" in a.advice[0]
