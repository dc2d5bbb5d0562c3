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
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "tq/core/state_archive.hpp"
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

/// A part's work terms of each step (3 a wet node) and which of its nodes moved, kept in step order
/// until flush() sums them over the whole face in the one-process order: one fold a window instead
/// of one a step.
struct PendingWetWork {
  std::vector<std::vector<Real>> terms;
  std::vector<std::vector<std::uint8_t>> moving;

  void add(std::vector<Real> stepTerms, std::vector<std::uint8_t> stepMoving) {
    terms.push_back(std::move(stepTerms));
    moving.push_back(std::move(stepMoving));
  }
  /// One step's work over the wet nodes that move (moves(k)): term(k, d, j) for each of their dofs
  /// in node order (j = 3 k + d; it may also set the dof's force). On a part (`part` not null) the
  /// terms are kept for flush(); in one process they are added up in that order and then to `total`.
  template <class Moves, class Term>
  void bookStep(const WetPart* part, size_t nodes, Moves&& moves, Term&& term, Real& total) {
    std::vector<Real> stepTerms(part ? 3 * nodes : 0, 0.0);
    std::vector<std::uint8_t> stepMoving(part ? nodes : 0, 0);
    Real work = 0;
    for (size_t k = 0; k < nodes; ++k) {
      if (!moves(k)) continue;
      if (part) stepMoving[k] = 1;
      for (int d = 0; d < 3; ++d) {
        const size_t j = 3 * k + size_t(d);
        const Real w = term(k, d, j);
        if (part)
          stepTerms[j] = w;
        else
          work += w;
      }
    }
    if (part)
      add(std::move(stepTerms), std::move(stepMoving));
    else
      total += work;
  }
  /// Collective over the parts (every part keeps the same steps): adds each kept step's sum over the
  /// whole face to `total`, in step order (acc: work space), and forgets them.
  void flush(const WetPart& part, std::vector<Real>& acc, Real& total) {
    if (terms.empty()) return;
    const size_t m = terms.size();
    acc.assign(m, 0.0);
    part.fold(acc, [&](size_t k) {
      for (size_t s = 0; s < m; ++s)
        if (moving[s][k])
          for (size_t j = 3 * k; j < 3 * k + 3; ++j) acc[s] += terms[s][j];
    });
    for (size_t s = 0; s < m; ++s) total += acc[s];
    terms.clear();
    moving.clear();
  }
  /// The count of steps kept (those of a window stepped again are dropped).
  void checkpoint(StateArchive& a) {
    long long pending = (long long)terms.size();
    a.io(pending);
    if (!a.saving()) terms.resize(size_t(pending)), moving.resize(size_t(pending));
  }
};

}  // namespace tq
