/// @file rank_exchange.hpp
/// @brief The halo exchange of the solid on MPI ranks: the frontier nodes' partial sums (internal
///        forces each step, lumped masses when they change) sent to and received from the ranks
///        that share them with non-blocking MPI, and the sums over every rank (step size, energies,
///        norms). The only file of tq-solid, with app/ranked_run.cpp, that calls MPI.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/parallel/rank_layout.hpp"

namespace tq {

/// True when this build of tq-solid can run on MPI ranks (MPI found at compile time).
bool rankRunsAvailable();

/// The exchange of one rank. Each frontier node's total is summed in ascending rank order from
/// every holder's partial value, the same expression on every rank: the copies of a frontier node
/// stay bitwise equal on all the ranks that hold it. MPI must be initialised (MPI_COMM_WORLD).
/// Throws InputError when this build has no MPI.
std::unique_ptr<RankExchange> makeRankExchange(const RankLayout& layout, size_t frontierBlocks);

}  // namespace tq
