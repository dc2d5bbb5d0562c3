/// @file wet_part.hpp
/// @brief A process's part of the wetted face when the solid runs on MPI ranks (docs/architecture.md
///        "The water coupling on ranks"): the wet nodes its rank owns, each node in one part only,
///        and the sums over the whole face taken in the one-process order on every part.
///
/// The water coupling (FluidCoupling) and the laws the solid carries (CarriedWater) made on a part
/// hold only its nodes; every sum they take over the wet nodes (the volume change, the projections'
/// moments, the works) runs through sumOverWetNodes(): each part computes its nodes' terms (the values
/// the sum adds), one gather brings every node's terms to every part in the face's order, and every
/// part adds them in that order, so the sums are bitwise those of one process whatever the part count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
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
  /// The wet nodes this process holds as copies of another part's (a node on a partition boundary
  /// owned by another rank): its node in this process's solver and its place in the face. `copiesAnywhere`:
  /// some part holds such a copy (the same on every part).
  std::vector<std::pair<Index, size_t>> copies;
  bool copiesAnywhere = false;
  /// Collective over the parts: `width` values a node of this part (`mine`, its nodes in order), those of
  /// every part's nodes gathered on every part into `whole`, `width` values a node of the face in the
  /// face's order.
  std::function<void(const std::vector<Real>& mine, size_t width, std::vector<Real>& whole)> gather;
  /// Work space of sumOverWetNodes(): this part's terms, and the last gather's (the whole face's).
  mutable std::vector<Real> mine, whole;
};

/// A sum over the wet nodes in the one-process order. terms(q, t) writes node q's `width` terms, the
/// values the sum adds; add(k, t) adds node k's terms t to the accumulators, in the order one process
/// adds them. One process (`part` null; n the face's nodes): node by node, terms then add. On a part (n
/// its nodes, q their index in it; k a node of the whole face): its nodes' terms, one gather
/// (WetPart::gather), then every node of the face added in the face's order on every part, so every
/// accumulator gets the same values in the same order as in one process, and the same bits. add() may
/// read only what every part holds for every node (the whole face's geometry); part->whole keeps the
/// gathered terms until the next sum.
template <class Terms, class Add>
void sumOverWetNodes(const WetPart* part, size_t n, size_t width, Terms&& terms, Add&& add) {
  if (!part) {
    Real t[64];
    std::vector<Real> big(width > 64 ? width : 0);
    Real* tk = width > 64 ? big.data() : t;
    for (size_t k = 0; k < n; ++k) {
      terms(k, tk);
      add(k, static_cast<const Real*>(tk));
    }
    return;
  }
  part->mine.resize(width * n);
  for (size_t q = 0; q < n; ++q) terms(q, part->mine.data() + width * q);
  part->gather(part->mine, width, part->whole);
  const Real* w = part->whole.data();
  for (size_t k = 0; k < part->wholeCount; ++k) add(k, w + width * k);
}

/// A part's work terms of each step (3 a wet node; 0 for a node that does not move), kept in step order
/// until flushWetWork() sums them over the whole face in the one-process order: one gather a window
/// instead of one a step.
struct PendingWetWork {
  std::vector<std::vector<Real>> terms;

  /// One step's work over the wet nodes that move (moves(k)): term(k, d, j) for each of their dofs
  /// in node order (j = 3 k + d; it may also set the dof's force). On a part (`part` not null) the
  /// terms are kept for flushWetWork(); in one process they are added up in that order and then to
  /// `total`.
  template <class Moves, class Term>
  void bookStep(const WetPart* part, size_t nodes, Moves&& moves, Term&& term, Real& total) {
    std::vector<Real> stepTerms(part ? 3 * nodes : 0, 0.0);
    Real work = 0;
    for (size_t k = 0; k < nodes; ++k) {
      if (!moves(k)) continue;
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
      terms.push_back(std::move(stepTerms));
    else
      total += work;
  }
  /// The steps kept, each with its terms. Restored, the steps kept since the save are dropped (a
  /// window stepped again books its steps again) and those kept at the save are back whole, wherever
  /// the save was taken: at a window's start (CoupledStepper) or end (a restart checkpoint, after
  /// flushWetWork: none kept, the count 0 alone), or inside a window, whose steps' work is then booked
  /// by the resumed run's flushWetWork as by the run never stopped.
  void checkpoint(StateArchive& a) {
    long long pending = (long long)terms.size();
    a.io(pending);
    if (!a.saving()) terms.resize(size_t(pending));
    for (std::vector<Real>& step : terms) a.io(step);
  }
};

/// The works a part keeps and the total each is booked to.
struct WetWorkBook {
  PendingWetWork* pending = nullptr;
  Real* total = nullptr;
};

/// Collective over the parts (every part keeps the same steps in each book): each book's kept steps,
/// each step's sum over the whole face in the one-process order, added to its total in step order, in
/// one gather for all the books together; the kept steps forgotten. A node that does not move adds
/// +0, which leaves a sum as it is (a sum that starts at +0 is never −0), as one process skips it.
inline void flushWetWork(const WetPart& part, std::initializer_list<WetWorkBook> books) {
  size_t width = 0;
  for (const WetWorkBook& b : books) width += 3 * b.pending->terms.size();
  if (width == 0) return;
  std::vector<Real> acc(width / 3, 0.0);
  sumOverWetNodes(
      &part, part.places.size(), width,
      [&](size_t q, Real* t) {
        for (const WetWorkBook& b : books)
          for (const std::vector<Real>& step : b.pending->terms)
            for (size_t j = 3 * q; j < 3 * q + 3; ++j) *t++ = step[j];
      },
      [&](size_t, const Real* t) {
        for (size_t s = 0; s < acc.size(); ++s)
          for (int d = 0; d < 3; ++d) acc[s] += *t++;
      });
  size_t s = 0;
  for (const WetWorkBook& b : books) {
    for (size_t i = 0; i < b.pending->terms.size(); ++i) *b.total += acc[s++];
    b.pending->terms.clear();
  }
}

}  // namespace tq
