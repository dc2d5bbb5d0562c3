"""solid_input.h5 has one table (tunnelquake.solver_input_schema) that the writer, tq-solid's reader and
docs/formats.md are made from.

1. The generated files (solid_solver/src/io/input_schema.inc, solid_solver/src/materials/parameter_names.hpp,
   docs/formats.md "## solid_input.h5") are what the table gives now, byte for byte.
2. A material parameter added to the table alone (a test fixture: `test_parameter` for every model,
   default 2.5, >= 0) is written by the one writer and reaches tq-solid's per-region parameter map
   (`tq-solid --print-input`) without rebuilding tq-solid; its bound is enforced by tq-solid; the same
   attribute without its row in the file is refused naming it; a change to a row tq-solid was built
   with (not a material one) is refused by the hash.
3. No second hand-written list of solid_input.h5 keys: in solid_solver/ and scripts/, no run of
   three or more string literals that are keys of one group of the table, and no attribute read in
   tq-solid by a literal key name, outside the table and its generated header.
4. Which /coupling attributes are written is the table's rows' rule (group_attrs): every setting but
   the constant predictor, reuse 0, and without a volume law none of the law's attributes (tq-solid
   refuses a water density without one); with a law, water_density 0 and closed ends (with the axial
   density) are left out. Checked for settings and for the case words that make them.
"""
from __future__ import annotations

import json
import re
import subprocess
from dataclasses import replace

import h5py
import pytest
from test_solid_input import _case, prepared  # noqa: F401  (module fixture: the slice mesh and a motion)

from conftest import EXAMPLE
from tunnelquake import fluid_case as fc
from tunnelquake import paths
from tunnelquake import solver_input_schema as sis
from tunnelquake.case import load_case
from tunnelquake.solid_input import write_solid_input

ROOT = sis.ROOT


def test_generated_header_and_docs_are_up_to_date():
    assert sis.INC.read_text() == sis.cpp_table(), "run: python -m tunnelquake.solver_input_schema --write"
    assert sis.NAMES.read_text() == sis.cpp_material_names(), "run: python -m tunnelquake.solver_input_schema --write"
    doc = sis.DOC.read_text()
    current = doc[doc.index(sis.BEGIN) + len(sis.BEGIN):doc.index(sis.END)]
    assert current == "\n" + sis.doc_section() + "\n", "run: python -m tunnelquake.solver_input_schema --write"


def test_case_links_take_the_case_schemas_bounds_and_defaults():
    from tunnelquake.case import schema

    rt = sis.lookup("/stages", "relaxation_tolerance")
    spec = schema().fields["stages"].fields["relaxation_tolerance"]
    assert (rt.lo, rt.hi, rt.default) == (spec.min, spec.max, spec.default)
    fa = sis.lookup(sis.MATERIALS, "friction_angle")
    assert (fa.lo, fa.hi, fa.hi_open) == (0.0, 90.0, True)


def test_the_writer_refuses_a_key_or_a_value_outside_the_table(tmp_path):
    with h5py.File(tmp_path / "x.h5", "w") as f:
        with pytest.raises(KeyError, match="relaxation_tol"):
            sis.put(f, "/stages", "relaxation_tol", 1e-4)
        with pytest.raises(sis.SchemaError, match=r"lies outside \(0, 1\)"):
            sis.put(f, "/stages", "relaxation_tolerance", 1.0)
        with pytest.raises(sis.SchemaError, match="not one of"):
            sis.put(f, "/coupling", "scheme", "weak")


def _solid():
    exe = paths.solid_executable()
    if exe is None:
        return None
    out = subprocess.run([str(exe), "--print-input", "/nonexistent.h5"], capture_output=True, text=True, timeout=10)
    return exe if "usage" not in out.stderr else None


needs_solid = pytest.mark.skipif(_solid() is None, reason="tq-solid with --print-input is not built")

EXTRA = sis.Entry(sis.MATERIALS, "test_parameter", "float", doc="a parameter of the test fixture", default=2.5,
                  lo=0.0)


def _print_input(path):
    return subprocess.run([str(_solid()), "--print-input", str(path)], capture_output=True, text=True, timeout=30)


@needs_solid
def test_a_new_material_parameter_reaches_tq_solid_without_a_rebuild(prepared, tmp_path, monkeypatch):  # noqa: F811
    monkeypatch.setattr(sis, "ENTRIES", sis.ENTRIES + (EXTRA,))
    case = _case(tmp_path, model="mohr_coulomb_damage")
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "no_water", tmp_path / "in.h5")
    with h5py.File(inp) as f:
        assert f["materials/rock"].attrs["test_parameter"] == 2.5
    out = _print_input(inp)
    assert out.returncode == 0, out.stderr
    read = json.loads(out.stdout)["materials"]
    # the added parameter is in every region's map, beside the model's own (lining: eq. 16's c = 1.8 MPa)
    assert read["rock"]["test_parameter"] == 2.5 and read["lining"]["test_parameter"] == 2.5
    assert read["lining"]["model"] == "mohr_coulomb_damage" and read["lining"]["cohesion"] == 1.8e6
    # its bound is the file's row: tq-solid refuses a value below it, naming the group and the bound
    with h5py.File(inp, "a") as f:
        f["materials/rock"].attrs["test_parameter"] = -1.0
    out = _print_input(inp)
    assert out.returncode == 2 and "/materials/rock: test_parameter = -1 must be >= 0" in out.stderr, out.stderr


@needs_solid
def test_a_parameter_without_its_row_and_a_foreign_table_are_refused(prepared, tmp_path, monkeypatch):  # noqa: F811
    case = _case(tmp_path)
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "no_water", tmp_path / "in.h5")
    out = _print_input(inp)
    assert out.returncode == 0 and "test_parameter" not in out.stdout, out.stderr
    with h5py.File(inp, "a") as f:
        f["materials/rock"].attrs["test_parameter"] = 2.5
    out = _print_input(inp)
    assert out.returncode == 2 and "/materials/rock: unknown attribute 'test_parameter' (allowed: model E nu" \
        in out.stderr, out.stderr
    # a row tq-solid was built with, changed in the writer's table: another table, refused by its hash
    changed = tuple(replace(e, default=0.5) if (e.group, e.name) == ("/solver", "safety") else e
                    for e in sis.ENTRIES)
    monkeypatch.setattr(sis, "ENTRIES", changed)
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "no_water", tmp_path / "in2.h5")
    out = _print_input(inp)
    assert out.returncode == 2 and "/schema: hash" in out.stderr and "another version of the table" in out.stderr


# --------------------------------------------------------------------------------------------------
# No second list
# --------------------------------------------------------------------------------------------------
_LITERAL = r'"([A-Za-z_][A-Za-z0-9_]*)"'
#: a run of string literals separated by commas (and blanks, newlines): a hand-written list
_RUN = re.compile(_LITERAL + r"(?:\s*,\s*" + _LITERAL.replace("(", "(?:") + r")+")
#: tq-solid reading an attribute of an HDF5 object by a literal name
_READ = re.compile(r"h5::(?:hasAttr|read\w*Attr)\([^,()]+,\s*" + _LITERAL)
GENERATED = {sis.INC, sis.NAMES, ROOT / "scripts" / "tunnelquake" / "solver_input_schema.py",
             ROOT / "scripts" / "tunnelquake" / "solver_input_table.py"}
#: lists of the same words that are not solid_input.h5's, or not yet made from the table: (file, the
#: list's first words) -> why. Any other list fails.
KNOWN = {
    ("scripts/tunnelquake/verification/stiffness_map.py", '"window", "reuse", "predictor"'):
        "case keys of the coupling section the study drops for the explicit scheme",
    ("scripts/tunnelquake/freefield.py", '"u", "v", "a"'):
        "the free field's own arrays, which solid_input.h5's /drm takes under the same names",
}


def _keys_by_group() -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for e in sis.entries():
        out.setdefault(e.group, set()).add(e.name)
    return out


def second_lists(text: str, keys: dict[str, set[str]]) -> list[str]:
    """Runs of >= 3 literals that are keys of one group of the table (a list of keys written again)."""
    found = []
    for m in _RUN.finditer(text):
        words = re.findall(_LITERAL, m.group(0))
        for group, names in keys.items():
            if len({w for w in words if w in names}) >= 3:
                found.append(f"{group}: {m.group(0)[:80]}")
                break
    return found


def _known(path, run: str) -> bool:
    rel = str(path.relative_to(ROOT))
    return any(rel == f and run.startswith(start) for f, start in KNOWN)


def literal_reads(text: str, keys: dict[str, set[str]]) -> list[str]:
    names = set().union(*keys.values())
    return [m.group(0) for m in _READ.finditer(text) if m.group(1) in names]


def _sources():
    for base, exts in ((ROOT / "solid_solver", ("*.cpp", "*.hpp", "*.h", "*.inc")),
                       (ROOT / "scripts" / "tunnelquake", ("*.py",))):
        for ext in exts:
            for p in sorted(base.rglob(ext)):
                if p not in GENERATED:
                    yield p


def test_the_detector_finds_a_second_list():
    keys = _keys_by_group()
    assert second_lists('checkKeys(g, {"t_end", "dt",\n "safety"});', keys)
    assert second_lists('KEYS = ("cohesion", "friction_angle", "tensile_strength")', keys)
    assert not second_lists('{"in_situ", "excavation", "lining"}', keys)  # stage names: values, not keys
    assert literal_reads('if (h5::hasAttr(g, "write_fields")) x();', keys)
    assert not literal_reads("h5::hasAttr(g, K::coupling::write_fields.name)", keys)


def test_no_second_hand_written_list_of_solver_input_keys():
    keys = _keys_by_group()
    problems = []
    for p in _sources():
        text = p.read_text(errors="replace")
        problems += [f"{p.relative_to(ROOT)}: list {x}" for x in second_lists(text, keys)
                     if not _known(p, x.split(": ", 1)[1])]
        if p.name.startswith("input"):  # tq-solid's reader of solid_input.h5
            problems += [f"{p.relative_to(ROOT)}: read {x}" for x in literal_reads(text, keys)]
    assert not problems, "keys of solid_input.h5 belong in scripts/tunnelquake/solver_input_schema.py:\n" + \
        "\n".join(problems)


# --------------------------------------------------------------------------------------------------
# Which /coupling attributes are written
# --------------------------------------------------------------------------------------------------
#: the settings no rule leaves out (fluid_case.coupling_settings' keys), and the attributes they give
_ALWAYS = {"scheme": "implicit", "window": 4, "window_size": 2.5e-4, "windows": 80, "tolerance": 1e-4,
           "max_iterations": 20, "acceleration": "iqn-ils", "initial_relaxation": 0.5, "transport": "tcp",
           "address_file": "/run/wall.addr", "token": "ab" * 16, "timeout": 120.0, "connect_timeout": 60.0,
           "face": "lining_inner", "mesh": "wall", "map": "coincident", "map_tolerance": 1e-6,
           "participant": "solid", "partner": "fluid"}
_ALWAYS_ATTRS = {**_ALWAYS, "write_fields": "velocity,displacement", "absolute_tolerance_velocity": 1e-6,
                 "absolute_tolerance_displacement": 2e-9, "absolute_tolerance_force": 3.0}


def _settings(law, bulk, density, ends, predictor="constant", reuse=0) -> dict:
    return {**_ALWAYS, "write_fields": ["velocity", "displacement"],
            "absolute_tolerance": {"velocity": 1e-6, "displacement": 2e-9, "force": 3.0},
            "predictor": predictor, "reuse": reuse, "volume_law": law, "bulk_modulus": bulk,
            "water_density": density, "water_ends": ends, "axial_density": 998.0}


@pytest.mark.parametrize("settings, conditional", [
    (_settings("none", 0.0, 0.0, "closed"), {}),
    (_settings("none", 0.0, 998.0, "open", "linear", 16), {"predictor": "linear", "reuse": 16}),
    (_settings("compressible", 2e9, 998.0, "closed"),
     {"volume_law": "compressible", "bulk_modulus": 2e9, "water_density": 998.0}),
    (_settings("compressible", 2e9, 0.0, "open", "linear"),
     {"predictor": "linear", "volume_law": "compressible", "bulk_modulus": 2e9, "water_ends": "open",
      "axial_density": 998.0}),
    (_settings("incompressible", 0.0, 998.0, "open", reuse=16),
     {"reuse": 16, "volume_law": "incompressible", "bulk_modulus": 0.0, "water_density": 998.0,
      "water_ends": "open", "axial_density": 998.0}),
    (_settings("incompressible", 0.0, 0.0, "closed"), {"volume_law": "incompressible", "bulk_modulus": 0.0}),
])
def test_coupling_attributes_leave_out_what_the_rows_say(settings, conditional, tmp_path):
    attrs = fc.solid_coupling_attrs(settings)
    assert attrs == {**_ALWAYS_ATTRS, **conditional}
    assert all(type(attrs[k]) is type(v) for k, v in {**_ALWAYS_ATTRS, **conditional}.items())
    # what reaches the file: these attributes, stored by the table's kinds
    with h5py.File(tmp_path / "c.h5", "w") as f:
        g = f.create_group("coupling")
        for key, value in attrs.items():
            sis.put(g, "/coupling", key, value)
        assert set(g.attrs) == set(attrs)
        assert g.attrs["window"].dtype == "int64" and g.attrs["write_fields"] == "velocity,displacement"
    # a setting missing is an attribute missing (tq-solid reads its default); a key outside the table is refused
    assert "predictor" not in fc.solid_coupling_attrs({k: v for k, v in settings.items() if k != "predictor"})
    with pytest.raises(KeyError, match="relaxation"):
        fc.solid_coupling_attrs({**settings, "relaxation": 0.5})


def test_the_largest_residual_scale_reaches_both_participants(tmp_path):
    """coupling.residual_scale largest is written to tq-solid's /coupling and to the water's exchange
    dictionary alike (the coupler refuses a pair whose configurations differ); current, the default,
    is left out of /coupling (tq-solid's default) and written to the dictionary."""
    case = load_case(EXAMPLE)
    for scale, attr in (("largest", "largest"), ("current", None)):
        case.data["coupling"]["residual_scale"] = scale
        s = fc.coupling_settings(case, 2.5e-4, tmp_path / "wall.addr", "ab" * 16, t_end=0.02)
        assert fc.solid_coupling_attrs(s).get("residual_scale") == attr
        assert fc.exchange_dict(s)["residualScale"] == scale


@pytest.mark.parametrize("mode, ends, law, model, translation, predictor, reuse, conditional", [
    ("slice", "open", "solid", "compressible", "solid", "constant", 0,
     {"volume_law": "compressible", "bulk_modulus": 2e9, "water_density": 998.0, "subtract_mean_pressure": 1.0}),
    ("3d", "open", "solid", "compressible", "water", "linear", 16,
     {"predictor": "linear", "reuse": 16, "volume_law": "compressible", "bulk_modulus": 2e9,
      "water_ends": "open", "axial_density": 998.0}),
    ("3d", "closed", "solid", "incompressible", "solid", "linear", 0,
     {"predictor": "linear", "volume_law": "incompressible", "bulk_modulus": 0.0, "water_density": 998.0,
      "subtract_mean_pressure": 1.0}),
    ("3d", "open", "solid", "incompressible", "solid", "constant", 16,
     {"reuse": 16, "volume_law": "incompressible", "bulk_modulus": 0.0, "water_density": 998.0,
      "water_ends": "open", "axial_density": 998.0}),
    ("3d", "open", "water", "compressible", "solid", "constant", 0, {}),
    ("slice", "closed", "water", "compressible", "water", "linear", 16, {"predictor": "linear", "reuse": 16}),
])
def test_the_cases_coupling_words_give_the_attributes(mode, ends, law, model, translation, predictor, reuse,
                                                      conditional, tmp_path):
    """The case's coupling.volume_law (solid: the water model's law; water: none), water_translation
    (water: no water density), the section (a slice or closed ends: closed), predictor and reuse."""
    case = load_case(EXAMPLE)
    d = case.data
    d["mesh"]["mode"] = mode
    d["water"].update(ends=ends, model=model, density=998.0, bulk_modulus=2e9)
    d["coupling"].update(volume_law=law, water_translation=translation, predictor=predictor, reuse=reuse)
    attrs = fc.solid_coupling_attrs(fc.coupling_settings(case, 2.5e-4, tmp_path / "wall.addr", "ab" * 16,
                                                         t_end=0.02))
    # the example's implicit windows of 16 steps: the window force weight 0.75, the energy guard at 0.05,
    # a checkpoint every 1 s = 4000 windows of 2.5e-4 s
    conditional = {**conditional, "window_force_weight": 0.75, "energy_limit": 0.05, "checkpoint_windows": 4000}
    assert set(attrs) == set(_ALWAYS_ATTRS) | set(conditional)
    assert {k: attrs[k] for k in conditional} == conditional
