"""tunnelquake.foam_dict: OpenFOAM dictionaries written from Python data.

References: the OpenFOAM v1912 dictionary syntax (a quoted key is a regular expression matched
against the names looked up; a word may hold balanced parentheses), read back by the module's own
parser (exact: every value, floats to the bit) and, where OpenFOAM is installed, by OpenFOAM's
foamDictionary (the keys it lists and the pattern it matches).
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess

import pytest

from tunnelquake.foam_dict import Dimensions, FoamDictError, Quoted, Uniform, foam_file, inline, parse, value_text

FIELD = {
    "dimensions": Dimensions([0, 1, -1, 0, 0, 0, 0]),
    "internalField": Uniform([0, 0, 0]),
    "boundaryField": {
        "interface": {"type": "tqInterfaceVelocity", "value": Uniform([0, 0, 0])},
        Quoted("end_y(min|max)"): {"type": "fixedValue", "value": Uniform(-2.5)},
    },
}
SOLUTION = {
    "solvers": {
        "p": {"solver": "tqProjected", "vectors": 32, "tolerance": 1e-6, "relTol": 0,
              "inner": {"solver": "GAMG", "smoother": "GaussSeidel"}},
        Quoted("U(Final)?"): {"solver": "smoothSolver", "tolerance": 1e-9},
    },
    "divSchemes": {"default": "none", "div((nuEff*dev2(T(grad(U)))))": "Gauss linear"},
    "libs": [Quoted("libtqFoam.so")],
    "nested": [[1, 2], ["a", Quoted("b c")], []],
    "g": [0, 0, -9.81],
    "momentumPredictor": False,
    "startTime": 0,
    "writeInterval": 1 / 3,
}


def test_text_of_sub_dictionaries_lists_fields_and_pattern_keys():
    text = foam_file(FIELD, "U", cls="volVectorField", location="0", note="two\nlines")
    lines = text.splitlines()
    assert lines[:8] == ["FoamFile", "{", "    version         2.0;", "    format          ascii;",
                         "    class           volVectorField;", '    location        "0";', "    object          U;",
                         "}"]
    assert lines[8:10] == ["// two", "// lines"]
    assert "dimensions      [0 1 -1 0 0 0 0];" in lines
    assert "internalField   uniform (0 0 0);" in lines
    # a sub-dictionary is a block; a pattern key is quoted, a word key is not
    i = lines.index('    "end_y(min|max)"')
    assert lines[i:i + 5] == ['    "end_y(min|max)"', "    {", "        type            fixedValue;",
                              "        value           uniform -2.5;", "    }"]
    text = foam_file(SOLUTION, "fvSolution")
    assert "    div((nuEff*dev2(T(grad(U))))) Gauss linear;" in text
    assert '    "U(Final)?"\n    {' in text
    assert 'libs            ("libtqFoam.so");' in text
    assert 'nested          ((1 2) (a "b c") ());' in text
    assert "g               (0 0 -9.81);" in text
    assert "momentumPredictor no;" in text  # a key past the column: one space
    assert "tolerance       1e-06;" in text and "relTol          0;" in text
    assert inline({"a": 1, "b": {"c": True}}) == "a 1; b { c yes; }"
    assert value_text({"x": [1, Uniform(0)]}) == "{ x (1 uniform 0); }"


def test_read_back_exactly():
    for data in (FIELD, SOLUTION):
        back = parse(foam_file(data, "x"))
        assert back.pop("FoamFile") == {"version": 2.0, "format": "ascii", "class": "dictionary", "object": "x"}
        expected = dict(data)
        if "momentumPredictor" in expected:
            expected["momentumPredictor"] = "no"  # a switch reads back as its word
        assert back == expected
        # pattern keys stay patterns (Quoted), words stay words
        assert [type(k) for k in back.get("boundaryField", back.get("solvers"))] in (
            [str, Quoted], [str, Quoted])
    # floats to the bit (repr), whatever their size
    for x in (1 / 3, 6.3006e-05 * 16, 1e-300, -2.2e9 / (1000 * 293.15), 123.0):
        assert parse(foam_file({"v": x}, "x"))["v"] == x
    # comments and OpenFOAM's compact one-line form are read too
    assert parse('FoamFile { version 2.0; } /* a */ a 1; // b\nb { c "d;e"; }') == {
        "FoamFile": {"version": 2.0}, "a": 1, "b": {"c": "d;e"}}


def test_refusals_say_what_is_wrong():
    with pytest.raises(FoamDictError, match="Quoted"):
        foam_file({"end y": 1}, "x")  # not a word: a pattern must be given as Quoted
    with pytest.raises(FoamDictError, match="Quoted"):
        foam_file({"div(phi": 1}, "x")  # unbalanced parenthesis
    with pytest.raises(FoamDictError, match="cannot be written"):
        foam_file({"a": math.nan}, "x")
    with pytest.raises(FoamDictError, match="verbatim"):
        foam_file({"a": "b; c d"}, "x")
    with pytest.raises(FoamDictError, match="NoneType"):
        foam_file({"a": None}, "x")
    with pytest.raises(FoamDictError, match="not closed"):
        parse("a { b 1;")


@pytest.mark.skipif(shutil.which("foamDictionary") is None, reason="OpenFOAM's foamDictionary not installed")
def test_openfoam_reads_the_keys_and_matches_the_patterns(tmp_path):
    path = tmp_path / "U"
    path.write_text(foam_file({**FIELD, **SOLUTION}, "U", cls="volVectorField"))
    env = {**os.environ, "WM_PROJECT_DIR": os.environ.get("WM_PROJECT_DIR", "/usr/share/openfoam")}

    def foam(*args):
        out = subprocess.run(["foamDictionary", str(path), *args], capture_output=True, text=True, env=env,
                             timeout=60)
        assert out.returncode == 0, out.stdout + out.stderr
        return out.stdout.strip()

    # the word with parentheses is one key; the quoted keys are OpenFOAM's patterns
    assert foam("-entry", "divSchemes", "-keywords").split() == ["default", "div((nuEff*dev2(T(grad(U)))))"]
    assert foam("-entry", "boundaryField/end_ymax/type", "-value") == "fixedValue"
    assert foam("-entry", "solvers/UFinal/solver", "-value") == "smoothSolver"
    assert foam("-entry", "solvers/p/inner/smoother", "-value") == "GaussSeidel"
    # values as OpenFOAM writes them back, read by parse
    for entry in ("boundaryField/end_ymin/value", "nested", "dimensions", "g", "libs"):
        back = parse(f"v {foam('-entry', entry, '-value')};")["v"]
        node = {**FIELD, **SOLUTION}
        for part in entry.split("/"):
            node = node["end_y(min|max)" if part == "end_ymin" else part]
        assert back == node, entry
