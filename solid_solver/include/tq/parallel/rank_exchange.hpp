/// @file rank_exchange.hpp
/// @brief The halo exchange of the solid on MPI ranks: every node's internal force (each step) and
///        lumped mass (when it changes) summed from its elements' values in the one-process order,
///        the frontier elements' values sent to and received from the ranks that share their nodes
///        with non-blocking MPI, and the sums over every rank (step size, energies, the
///        relaxation's norms in the one-process order). The only file of tq-solid, with
///        app/ranked_run.cpp, that calls MPI.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/parallel/rank_layout.hpp"

namespace tq {

/// True when this build of tq-solid can run on MPI ranks (MPI found at compile time).
bool rankRunsAvailable();

/// The exchange of one rank. Every node's internal force and mass (every node this rank holds,
/// frontier or not) is summed from its elements' values in the order one process adds them: the
/// one-process blocks (one per region, in `blockRegions`' order, as makeBlocksByRegion) with their
/// element and scatter orders (ElementBlock::nodeSumOrder), the other ranks' elements' values sent
/// to the ranks that share the node. So every copy of a node and the one process add the same
/// values in the same order: the same bits. `blocks`: this rank's solver's blocks (they store their
/// corner forces for it from now on); `part`: the partition. sumFrontier adds the holders' partial
/// values in ascending rank order. MPI must be initialised (MPI_COMM_WORLD). Throws InputError when
/// this build has no MPI.
std::unique_ptr<RankExchange> makeRankExchange(const RankLayout& layout, size_t frontierBlocks, const Mesh& global,
                                               const std::vector<int>& part, const std::vector<Index>& blockRegions,
                                               const std::vector<std::unique_ptr<ElementBlock>>& blocks);

}  // namespace tq
