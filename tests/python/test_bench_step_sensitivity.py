"""benchmarks.step_sensitivity on hand-made files: the changed copy of a solid input (each change
where tq-solid reads it, the mesh path made absolute) and the history divergence (hand-computed
running maxima)."""
import math

import h5py
import numpy as np
import pytest

from benchmarks.step_sensitivity import divergence, perturb


def _input(path):
    with h5py.File(path, "w") as f:
        f.attrs["mesh"] = "../mesh/mesh.h5"
        f.create_group("solver").attrs.update({"safety": 0.9, "dt": 0.0})
        f.create_group("stages").attrs["relaxation_tolerance"] = 1e-4
        f.create_group("materials/rock").attrs["dilation_angle"] = 0.0
        f.create_group("materials/lining").attrs.update({"dilation_angle": 0.0, "friction_angle": 40.0})
        f.create_group("materials/elastic").attrs["E"] = 1e9
        f["motion/ax"] = np.array([0.0, 1.0, -2.0])
        f["motion/az"] = np.array([0.0, 0.5, 1.0])


def test_perturb_changes_what_it_names(tmp_path):
    src = tmp_path / "results" / "no_water" / "solid_input.h5"
    src.parent.mkdir(parents=True)
    _input(src)
    dst = tmp_path / "elsewhere" / "p" / "solid_input.h5"
    perturb(src, dst, {"safety": 0.5, "levels": 3, "relaxation_tolerance": 1e-9, "motion": 2.0, "associated": True,
                       "rock.dilation_angle": 37.0})
    with h5py.File(dst, "r") as f:
        assert f.attrs["mesh"] == str((tmp_path / "results" / "mesh" / "mesh.h5").resolve())
        assert math.isclose(f["solver"].attrs["safety"], 0.45, rel_tol=1e-15)
        assert f["solver"].attrs["subcycling_levels"] == 3
        assert f["stages"].attrs["relaxation_tolerance"] == 1e-9
        assert list(f["motion/ax"][:]) == [0.0, 2.0, -4.0] and list(f["motion/az"][:]) == [0.0, 1.0, 2.0]
        assert f["materials/rock"].attrs["dilation_angle"] == 37.0  # named, after `associated`
        assert f["materials/lining"].attrs["dilation_angle"] == 40.0  # associated: its friction angle
        assert "dilation_angle" not in f["materials/elastic"].attrs
    with h5py.File(src, "r") as f:  # the original is left as it was
        assert f["solver"].attrs["safety"] == 0.9 and "subcycling_levels" not in f["solver"].attrs
    with pytest.raises(ValueError, match="unknown change 'dt'"):
        perturb(src, tmp_path / "q" / "solid_input.h5", {"dt": 1e-5})


def _results(path, stress, ring, base=1.0):
    t = np.arange(len(stress), dtype=float)[:, None] * 0.5
    with h5py.File(path, "w") as f:
        for m, scale in (("a", 1.0), ("@base", base)):
            f[f"monitors/{m}/time"] = t
            f[f"monitors/{m}/stress"] = np.repeat(np.asarray(stress, float)[:, None], 6, axis=1) * scale
        f["ring_forces/0/N"] = np.asarray(ring, np.float32)[:, None]


def test_divergence_is_the_running_maximum_over_the_scales(tmp_path):
    # stress scale 4 (the reference's largest), ring scale 10; samples at 0, 0.5, 1.0, 1.5 s
    _results(tmp_path / "r.h5", [1.0, 2.0, 4.0, 3.0], [10.0, 5.0, 5.0, 5.0])
    _results(tmp_path / "n.h5", [1.0, 2.4, 4.0, 3.0], [10.0, 5.0, 5.0, 8.0], base=100.0)
    d = divergence(tmp_path / "r.h5", tmp_path / "n.h5", times=(0.0, 0.5, 1.0, 1.5))
    # stress differs by 0.4 at 0.5 s (0.1 of 4), held by the running maximum; ring N by 3 at 1.5 s (0.3 of 10);
    # the @base monitor (the model's base, not the lining; 100 times larger here) is left out
    assert d == pytest.approx({0.0: 0.0, 0.5: 0.1, 1.0: 0.1, 1.5: 0.3}, abs=1e-12)
    assert divergence(tmp_path / "r.h5", tmp_path / "r.h5", times=(1.5,)) == {1.5: 0.0}
