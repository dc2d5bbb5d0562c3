"""scripts/include_layers.py: tq-solid's include direction (docs/architecture.md "The include direction").

The tree passes (every inversion left is in the script's ALLOWED, each entry still matched); a tree
with core including io, with contact including io through the private root, or with an ALLOWED
entry that no longer matches is refused, each named."""
from __future__ import annotations

import subprocess
import sys

from conftest import ROOT

SCRIPT = ROOT / "scripts" / "include_layers.py"


def _check(root) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), "--root", str(root)], capture_output=True, text=True,
                          timeout=60)


def _tree(tmp_path, files: dict[str, str]):
    for rel, text in files.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp_path


def test_the_tree_keeps_the_direction():
    run = _check(ROOT / "solid_solver")
    assert run.returncode == 0, run.stdout + run.stderr


def test_an_include_up_the_layers_is_named(tmp_path):
    good = _tree(tmp_path / "good", {
        "include/tq/core/solver.hpp": '#include "tq/core/mesh.hpp"\n#include "tq/materials/material.hpp"\n',
        "include/tq/io/mesh.hpp": '#include "tq/core/mesh.hpp"\n',
        "src/io/input.cpp": '#include "h5util.hpp"\n#include "tq/contact/contact.hpp"\n',
        "include/tq/materials/material.hpp": '#include "tq/core/types.hpp"\n',  # the foundation
        "src/coupling/fluid_coupling.cpp": '#include "tq/coupler/participant.hpp"\n',  # another library
    })
    run = _check(good)
    assert run.returncode == 0, run.stdout

    bad = _tree(tmp_path / "bad", {
        "src/core/constraints.cpp": '#include "tq/boundaries/boundaries.hpp"\n',
        "include/tq/core/solver.hpp": '#include "tq/io/mesh.hpp"\n',
        "src/contact/contact.cpp": '#include "io/input_schema.hpp"\n',
        "src/materials/material_kv.cpp": '#include "io/input_schema.hpp"\n',
        "src/boundaries/drm.cpp": '#include "tq/contact/contact.hpp"\n',
    })
    run = _check(bad)
    assert run.returncode == 1
    assert "include/tq/core/solver.hpp: includes tq/io/mesh.hpp (io/ is a layer above core/)" in run.stdout
    assert "src/contact/contact.cpp: includes io/input_schema.hpp (io/ is a layer above contact/)" in run.stdout
    assert "src/materials/material_kv.cpp: includes io/input_schema.hpp (io/ is a layer above materials/)" \
        in run.stdout
    assert "src/boundaries/drm.cpp: includes tq/contact/contact.hpp (contact/ is a layer of the same height" \
        in run.stdout
    assert "src/core/constraints.cpp: includes tq/boundaries/boundaries.hpp (boundaries/ is a layer above core/)" \
        in run.stdout


def test_an_allowed_inversion_is_kept_and_one_gone_must_leave_the_list(tmp_path, monkeypatch, capsys):
    """An inversion listed in ALLOWED passes while it is included; once the include is gone the entry
    is refused (the real list is empty: one is listed here)."""
    import include_layers

    monkeypatch.setattr(include_layers, "ALLOWED", {
        ("src/core/constraints.cpp", "boundaries/boundaries.hpp"): "the periodic tie finds its faces there"})
    kept = _tree(tmp_path / "kept", {"src/core/constraints.cpp": '#include "tq/boundaries/boundaries.hpp"\n'})
    assert include_layers.main(["--root", str(kept)]) == 0
    gone = _tree(tmp_path / "gone", {"src/core/constraints.cpp": '#include "tq/core/constraints.hpp"\n'})
    assert include_layers.main(["--root", str(gone)]) == 1
    assert "src/core/constraints.cpp -> boundaries/boundaries.hpp is no longer included; remove the entry" \
        in capsys.readouterr().out


def test_a_folder_in_no_layer_is_refused(tmp_path):
    """A new folder of tq-solid must be given its height; until then nothing it includes is checked."""
    tree = _tree(tmp_path, {"src/newpart/thing.cpp": '#include "tq/app/app.hpp"\n'})
    r = _check(tree)
    assert r.returncode == 1
    assert "newpart/ is in no layer" in r.stdout
