"""tq-solid's static stress at monitors against a plane-strain reference of the same section (the
slope and portal tests' CalculiX comparisons)."""
from __future__ import annotations

import subprocess
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np


def monitors_against_section(results, names, reference: Callable, axis: int, components: tuple[int, int, int],
                             labels: tuple[str, str, str], sigma0: Callable, place: Callable = lambda h, z: "") -> float:
    """The largest difference, as a share of the reference's vertical stress at each monitor, between
    the first stress sample of the monitors `names` (each at its element's centre; `axis` 0 or 1 is
    the section's horizontal axis) and `reference` ([[h, z]] -> [horizontal, vertical, shear]).
    `components` pick the horizontal, vertical and shear stresses from tq-solid's six, `labels` name
    them in the printed lines; each monitor must have moved more than 5 % from the start `sigma0(z)`
    ([horizontal, vertical]), so that the relaxation's release is compared, not the start."""
    worst = 0.0
    with h5py.File(results) as r:
        assert r.attrs["status"] == "completed"
        coords, conn = r["mesh/coordinates"][...], r["mesh/connectivity"][...]
        for name in names:
            g = r[f"monitors/{name}"]
            centre = coords[conn[int(g.attrs["element"])]].mean(axis=0)
            h, z = centre[axis], centre[2]
            tq = np.asarray(g["stress"][0])[list(components)]
            ref = reference([[h, z]])[0]
            err = np.abs(tq - ref) / abs(ref[1])
            worst = max(worst, float(err.max()))
            start = sigma0(z)
            moved = max(abs(tq[0] - start[0]), abs(tq[1] - start[1])) / abs(ref[1])
            a, b, c = labels
            print(f"{name} ({'xy'[axis]} = {h:.1f}, z = {z:.1f} m{place(h, z)}): tq-solid {a} {tq[0] / 1e6:.4f} "
                  f"{b} {tq[1] / 1e6:.4f} {c} {tq[2] / 1e6:.4f} MPa; CalculiX {ref[0] / 1e6:.4f} {ref[1] / 1e6:.4f} "
                  f"{ref[2] / 1e6:.4f} MPa; differences / |{b}| {100 * err[0]:.2f} {100 * err[1]:.2f} "
                  f"{100 * err[2]:.2f} %; the relaxation moved the start by {100 * moved:.0f} %")
            assert moved > 0.05, name
    print(f"largest difference {100 * worst:.2f} % of the vertical stress")
    return worst


def ccx_section_stress(work: Path, name: str, deck: list[str], elements: int, start) -> np.ndarray:
    """CalculiX on the plane-strain deck `deck` (lines; written to work/name.inp, one thread): each
    CPE8R element's stress [horizontal, vertical, shear], the mean of its 8 printed points, with
    the start `start` ([horizontal, vertical] at each element) added (the deck loads only the change
    from it)."""
    (work / f"{name}.inp").write_text("\n".join(deck) + "\n")
    env = {"OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1", "CCX_NPROC_STIFFNESS": "1",
           "NUMBER_OF_CPUS": "1", "PATH": "/usr/bin:/bin"}
    run = subprocess.run(["ccx", "-i", name], cwd=work, capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0 and "Job finished" in run.stdout, run.stdout[-2000:] + run.stderr
    stress, count = np.zeros((elements, 3)), np.zeros(elements)
    for line in (work / f"{name}.dat").read_text().splitlines():
        parts = line.split()
        if len(parts) == 8 and parts[0].isdigit():
            e = int(parts[0]) - 1
            horizontal, vertical, _, shear = (float(v) for v in parts[2:6])
            stress[e] += (horizontal, vertical, shear)
            count[e] += 1
    assert (count == 8).all()  # CalculiX expands a CPE8R into a C3D20R of 8 points
    stress /= count[:, None]
    stress[:, 0] += start[0]
    stress[:, 1] += start[1]
    return stress
