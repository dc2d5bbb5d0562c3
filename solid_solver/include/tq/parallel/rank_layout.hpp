/// @file rank_layout.hpp
/// @brief What one MPI rank holds of the solid: its elements and their nodes as a mesh of their own
///        (numbered in the global order), the frontier nodes it shares with other ranks, and who owns
///        each of them. Built from the global mesh and the partition alone, so every rank derives
///        every other rank's layout without a message.
#pragma once

#include <cstdint>
#include <vector>

#include "tq/core/types.hpp"
#include "tq/io/mesh.hpp"

namespace tq {

/// The nodes this rank shares with one other rank.
struct RankNeighbour {
  int rank = -1;
  std::vector<Index> nodes;  ///< local node indices, ascending (= the global order, the same on both sides)
};

/// One rank's part of the solid.
struct RankLayout {
  int rank = 0, ranks = 1;
  /// Its elements and their nodes: coordinates, connectivity (local node indices), regions (the
  /// global region list), the slice flag. No face groups or node sets: supports and loads are
  /// resolved on the global mesh and mapped (globalNode / localNode).
  Mesh mesh;
  std::vector<Index> globalNode;  ///< [local node] its global index (ascending)
  std::vector<Index> globalElem;  ///< [local element] its global index (ascending)
  std::vector<Index> localNode;   ///< [global node] its local index, or -1 when this rank does not hold it
  /// Frontier: local nodes also held by another rank, ascending; for each, the ranks that hold it
  /// (ascending, this one included) in frontierRanks[frontierStart[k] .. frontierStart[k + 1]).
  std::vector<Index> frontier, frontierStart;
  std::vector<int> frontierRanks;
  std::vector<RankNeighbour> neighbours;  ///< ascending rank
  /// [local node] 1 when this rank owns it (the lowest rank that holds it): the node sums
  /// (energies, norms) count each node on its owner only.
  std::vector<std::uint8_t> owned;
  /// Frontier nodes this rank holds but does not own (ascending local indices).
  std::vector<Index> ghosts;
  /// [local element] 1 when one of its nodes is a frontier node.
  std::vector<std::uint8_t> frontierElem;
};

/// The layout of rank `rank` of `ranks` for a partition (partitionRcb) of the global mesh.
/// `together`: groups of nodes whose force needs the state of every member (a contact pair, a tie):
/// a rank that holds one member of a group holds them all (as frontier nodes, summed like any
/// other), so each rank computes the group's force from its own copies, which are bitwise equal on
/// every rank.
RankLayout makeRankLayout(const Mesh& global, const std::vector<int>& part, int rank, int ranks,
                          const std::vector<std::vector<Index>>& together = {});

}  // namespace tq
