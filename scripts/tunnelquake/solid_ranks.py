"""The solid on MPI ranks (docs/architecture.md "The solid on ranks"): what a case uses that
tq-solid cannot run on ranks yet, and the mpirun command of a run on ranks.

tq-solid runs a model partitioned between ranks with ``mpirun -np N tq-solid solid_input.h5
--distributed``: the staged analysis (in-situ state, excavation, lining, hydrostatic pressure),
the viscoelastic base and free-field sides with the input motion, the rock-lining dynamic contact
or bonded tie, elastic and Mohr-Coulomb materials, subcycling, monitors, ring forces, snapshots, restart
checkpoints (``--resume`` on the same rank count: a checkpoint holds each rank's part of that
partition; coupled with the water, with the coupling's state at a window's end, as one process) and
the water coupling of dynamic_water (each rank exchanges the wet nodes it owns with the water over its
own connection). What does not run on ranks yet
(the DRM layer of an incident wave,
a fault offset, a motion along the tunnel's axis, the reinforced_concrete material, the
lining's joints) is refused by
``tunnelquake check`` and ``run`` for ``--ranks N`` above 1, naming it and the fix, before anything
runs; so are more ranks than the solid's mesh has elements (tq-solid's partition gives each rank one
at least).
"""
from __future__ import annotations

import os
import shutil

from .children import STOP_GRACE_S


class RanksError(ValueError):
    """--ranks cannot be honoured: the message says why and what to do."""


def ranks_refusal(case, ranks: int) -> list[str]:
    """What keeps this case from running its solid on `ranks` ranks (empty: it can), each with its fix."""
    if ranks < 1:
        return [f"--ranks {ranks}: give 1 or more"]
    if ranks == 1:
        return []
    elements = solid_elements(case.data)
    if ranks > elements:
        return [f"--ranks {ranks}: the solid's mesh has {elements:,} elements (rock and lining) and tq-solid's "
                f"partition gives every rank at least one, so it refuses more ranks than elements: give --ranks "
                f"{elements} or fewer, or a finer mesh (mesh.max_element_size, mesh.refinement_factor)"]
    from .motion import along_axis

    d = case.data
    reasons = []
    if (d.get("incident_wave") or {}).get("type", "none") != "none":
        reasons.append("the domain reduction layer of the incident wave (incident_wave.type "
                       f"{d['incident_wave']['type']}): remove incident_wave, or run without --ranks")
    if (d.get("fault_offset") or {}).get("slip") is not None or (d.get("fault_offset") or {}).get("magnitude") \
            is not None:
        reasons.append("the fault offset (fault_offset): remove it, or run without --ranks")
    if along_axis(d["ground_motion"]):
        reasons.append("a motion along the tunnel's axis (ground_motion.second_horizontal or azimuth), which the "
                       "slice takes through periodic faces: use a motion across the tunnel and vertical only, or "
                       "run without --ranks")
    from .case import lining_joints_active

    if lining_joints_active(d):
        reasons.append("the lining's joints (lining_joints: their node pairs are not yet split among ranks): remove "
                       "lining_joints, or run without --ranks")
    rc = [name for name, m in d["materials"].items() if m.get("model") == "reinforced_concrete"]
    if rc:
        reasons.append(f"the reinforced_concrete material (materials.{rc[0]}: its section share needs the whole "
                       "lining ring on one rank): use mohr_coulomb_damage or elastic there, or run without --ranks")
    if shutil.which("mpirun") is None:
        reasons.append("MPI ranks, but mpirun is not installed: install the Debian package openmpi-bin "
                       "(scripts/bootstrap.sh does), or run without --ranks")
    return reasons


#: Peak memory of tq-solid on ranks: a rank's fixed part (the program and MPI: rank 1 of the example
#: slice on 2 ranks, 1,464 elements, peaked at 28 MiB), then bytes per solid element from the
#: 2,000,376-element box on 2 ranks (docs/benchmarks.md "A 2-million-element model on ranks"): a
#: rank's part (its elements as a solver: rank 0 held 1,811 MiB more than rank 1, the whole model),
#: the whole mesh and partition every rank reads (the rest of rank 1's 1,170 MiB before the sums in
#: the one-process order), and those sums' stored corner forces and plans (rank 1 1,170 -> 1,314 MiB
#: for its 1,000,188 elements when they came).
RANK_BASE_BYTES = 28 * 2**20
PART_BYTES_PER_ELEMENT = 1811 * 2**20 / 2_000_376
WHOLE_MESH_BYTES_PER_ELEMENT = (1170 - 28 - 1811 / 2) * 2**20 / 2_000_376
ORDER_SUM_BYTES_PER_ELEMENT = (1314 - 1170) * 2**20 / 1_000_188


def memory_per_rank(solid_elements: int, ranks: int) -> tuple[float, float]:
    """Estimated peak memory (bytes) of rank 0 and of each other rank of a run of `solid_elements` on
    `ranks` ranks: every rank its share of the elements (with the one-process order's sums above one
    rank) and the whole mesh; rank 0 also the whole model it gathers the results into."""
    share = solid_elements / ranks
    other = (RANK_BASE_BYTES + share * (PART_BYTES_PER_ELEMENT + (ORDER_SUM_BYTES_PER_ELEMENT if ranks > 1 else 0))
             + solid_elements * WHOLE_MESH_BYTES_PER_ELEMENT)
    return other + solid_elements * PART_BYTES_PER_ELEMENT, other


def solid_elements(d: dict) -> int:
    """The hexahedra of the solid's mesh (rock and lining: what tq-solid partitions between its ranks) of
    a validated case's data, counted from the mesh plan's divisions (nothing is meshed): the ground and
    the lining of meshing.params.element_counts, and the water's hexahedra of the plugged ends
    (mesh.tunnel_end_plugs), which the mesher fills with rock."""
    from .case import case_geology, ground_layers
    from .meshing.params import element_counts, resolve

    plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    counts = element_counts(plan)
    plugged = plan.plugs * (1 if plan.symmetric else 2)
    return int(counts["rock"] + counts["lining"] + counts["water"] // plan.axial.count * plugged)


def refusal_message(ranks: int, reasons: list[str]) -> str:
    """The error for `reasons` (ranks_refusal's): a reason about the rank count itself ("--ranks N: ...")
    is the whole message; the features that do not run on ranks yet are joined into one."""
    if len(reasons) == 1 and reasons[0].startswith(f"--ranks {ranks}:"):
        return reasons[0]
    return (f"--ranks {ranks}: the solid cannot run this case on ranks yet; it uses " + "; ".join(reasons)
            + ". Without --ranks it runs as one process with OpenMP threads (docs/architecture.md \"The solid on "
              "ranks\")")


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
    # When a rank dies mpirun ends the others with SIGTERM, then SIGKILL after this many seconds
    # (default 1): rank 0 writes the results file's status in between. With the default, a 2-rank run
    # killed on this machine's 2 cores under a load of 24 was SIGKILLed while writing it (the status
    # stayed 'running').
    cmd += ["--mca", "odls_base_sigkill_timeout", str(int(STOP_GRACE_S))]
    cmd += ["-x", "OMP_NUM_THREADS=" + str(threads), "-x", "OMP_WAIT_POLICY"] if "OMP_WAIT_POLICY" in os.environ \
        else ["-x", "OMP_NUM_THREADS=" + str(threads)]
    return cmd + base + ["--distributed"]
