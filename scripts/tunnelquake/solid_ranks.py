"""The solid on MPI ranks (docs/architecture.md "The solid on ranks"): what a case uses that
tq-solid cannot run on ranks yet, and the mpirun command of a run on ranks.

tq-solid runs a model partitioned between ranks with ``mpirun -np N tq-solid solid_input.h5
--distributed``: elastic and Mohr-Coulomb materials, supports, loads, gravity, Rayleigh damping,
monitors and snapshots. The staged analysis every case runs (in-situ state, excavation and lining
stages, the seismic boundaries, the input motion, the rock-lining contact, the DRM layer, the
water coupling) does not run on ranks yet: ``tunnelquake check`` and ``run`` refuse ``--ranks N``
above 1 for a case, naming what is missing, before anything runs.
"""
from __future__ import annotations

import os
import shutil


class RanksError(ValueError):
    """--ranks cannot be honoured: the message says why and what to do."""


def ranks_refusal(case, ranks: int) -> list[str]:
    """What keeps this case from running its solid on `ranks` ranks (empty: it can)."""
    if ranks < 1:
        return [f"--ranks {ranks}: give 1 or more"]
    if ranks == 1:
        return []
    d = case.data
    reasons = ["the staged analysis every case runs (in-situ state, excavation and lining stages, the "
               "viscoelastic and free-field boundaries, the input motion): tq-solid on ranks runs unstaged "
               "inputs only so far"]
    if d.get("interface", {}).get("model") == "dynamic_contact":
        reasons.append("the rock-lining dynamic contact (interface.model: dynamic_contact), whose pairs may "
                       "cross a partition boundary")
    if "dynamic_water" in d.get("conditions", []):
        reasons.append("the water coupling (condition dynamic_water)")
    return reasons


def refusal_message(ranks: int, reasons: list[str]) -> str:
    if ranks < 1:
        return reasons[0]
    return (f"--ranks {ranks}: the solid cannot run this case on ranks yet; it uses " + "; ".join(reasons)
            + ". Run it without --ranks (one process, OpenMP threads: --threads is chosen for you), "
              "docs/architecture.md \"The solid on ranks\"")


def solid_command(exe, solid_input, results, threads: int, ranks: int, cores: int | None = None) -> list[str]:
    """tq-solid's command line: the plain one for one rank, else under mpirun with --distributed,
    oversubscribed when the ranks x threads exceed the cores this process may use (`cores`)."""
    base = [str(exe), str(solid_input), "-o", str(results), "--threads", str(threads)]
    if ranks <= 1:
        return base
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        raise RanksError(f"--ranks {ranks} needs mpirun (Debian package openmpi-bin, which scripts/bootstrap.sh "
                         "installs); install it or run without --ranks")
    cores = cores if cores is not None else len(os.sched_getaffinity(0))
    cmd = [mpirun, "-np", str(ranks)]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    if ranks * threads > cores:
        cmd += ["--oversubscribe", "--bind-to", "none"]
    # A waiting rank yields its core (OpenMPI spins in its waits otherwise): on a shared 2-core
    # machine 2 ranks of a 1,000-element box took 3.2-11.5 us an element-step spinning, 0.44-1.26 yielding.
    cmd += ["--mca", "mpi_yield_when_idle", "1"]
    cmd += ["-x", "OMP_NUM_THREADS=" + str(threads), "-x", "OMP_WAIT_POLICY"] if "OMP_WAIT_POLICY" in os.environ \
        else ["-x", "OMP_NUM_THREADS=" + str(threads)]
    return cmd + base + ["--distributed"]
