/// @file wet_part.hpp
/// @brief A process's part of the wetted face when the solid runs on MPI ranks (docs/architecture.md
///        "The water coupling on ranks"): the wet nodes its rank owns, each node in one part only,
///        and the sums over the whole face taken in the one-process order across the parts.
///
/// The water coupling (FluidCoupling) and the laws the solid carries (CarriedWater) made on a part
/// hold only its nodes; every sum they take over the wet nodes (the volume change, the projections'
/// moments, the works) runs through fold(), which adds the nodes' terms in the order of the whole
/// face's node list whatever the part count, so the sums are bitwise those of one process.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "tq/core/types.hpp"

namespace tq {

struct WetPart {
  /// The places k of this part's nodes in the whole wetted face's node list (ascending global
  /// node index), ascending: node q of the part is node places[q] of the face.
  std::vector<size_t> places;
  /// The nodes of the whole face.
  size_t wholeCount = 0;
  /// This part and the part count (the coupler's parts: Participant::setPart).
  int part = 0, parts = 1;
  /// Collective over the parts: node(q) for each node q of this part, in order, `acc` carried from
  /// the part that holds the face's nodes before them to the one after, so that every term node()
  /// adds to acc is added in the order of the whole face; the final acc on every part. The initial
  /// acc of the part that holds the face's first node is the one used.
  std::function<void(std::vector<Real>& acc, const std::function<void(size_t)>& node)> fold;
};

/// node(q) for q < n in order (one process: `part` null), or part->fold(acc, node).
template <class F>
void foldOverWetNodes(const WetPart* part, size_t n, std::vector<Real>& acc, F&& node) {
  if (!part) {
    for (size_t q = 0; q < n; ++q) node(q);
    return;
  }
  part->fold(acc, std::function<void(size_t)>(node));
}

}  // namespace tq
