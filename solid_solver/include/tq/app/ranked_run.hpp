/// @file ranked_run.hpp
/// @brief tq-solid on MPI ranks: `mpirun -np N tq-solid solid_input.h5 --distributed` (what
///        `tunnelquake run CASE --ranks N` starts). Each rank steps its part of the model
///        (partition.hpp, rank_layout.hpp, rank_exchange.hpp); rank 0 gathers the state at the
///        sample and snapshot times and writes the one results file.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace tq {

/// True when the command line asks for a run on ranks (--distributed).
bool wantsRankedRun(const std::vector<std::string>& args);

/// The run on ranks; exit codes as runSolid (tq/app/app.hpp). Restart checkpoints as the
/// one-process run's (--checkpoint-dir DIR, --resume, --resume-sequence N; tq/io/restart.hpp), each
/// rank's part gathered into the one state file by rank 0, and resumable on the same rank count.
/// What it does not support yet (the water coupling, the DRM layer, a fault offset, periodic faces,
/// subcycling, the reinforced_concrete material on more than one rank, the paper_eq3_4 integrator)
/// is refused with exit 2 and a message naming it, before anything runs.
int runSolidOnRanks(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace tq
