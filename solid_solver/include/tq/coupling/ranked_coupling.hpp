/// @file ranked_coupling.hpp
/// @brief The water coupling of the solid on MPI ranks (docs/architecture.md "The solid on ranks",
///        "The water coupling on ranks"). Each rank exchanges its own part of the wetted face: the
///        wet nodes it owns (a node on a partition boundary on its owner only, so each once), with
///        its own connection to the water (a part of the coupler's solid participant,
///        Participant::setPart), through its own FluidCoupling and CarriedWater made on its own
///        solver. The water checks that the parts cover the face once each and decides on the whole
///        face (convergence, acceleration, window by window), as with one process. The sums over the
///        wet nodes (the volume law's, its projections', the works that the energy guard reads) are
///        taken in the one-process order on every rank, from every node's terms gathered in one
///        collective (tq/water/wet_part.hpp), so every decision and every value is bitwise that of
///        one process. No rank holds the whole face's state.
///
/// Each rank's RankedCoupling is a contributor of its solver (ForcePhase::Water, in place of the
/// adapter and the carried laws of the one-process run) and the WindowCoupling CoupledStepper runs:
/// every call is collective; an error one rank meets is thrown on every rank (the lowest such rank's
/// message). After the step's water force the other ranks that hold a wet node on a partition
/// boundary take its owner's f_ext (their copies stay bitwise equal): with the carried laws it comes
/// with the step's gather of their sums, else in a message from the owner. On one rank it is the
/// one-process run: the adapter on the rank's own solver, no messages.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/coupling/fluid_coupling.hpp"
#include "tq/parallel/rank_layout.hpp"
#include "tq/water/carried_water.hpp"

namespace tq {

class RankedCoupling final : public NodalForceContributor, public WindowCoupling {
 public:
  /// Collective; MPI initialised. `global`: the whole mesh; `layout`: this rank's part (empty on one
  /// rank); `local`: this rank's solver, switched to the seismic stage with its step set. Makes this
  /// rank's carried laws and adapter on its part (not connected). Throws InputError alike on every rank.
  RankedCoupling(const CouplingInput& in, const Mesh& global, const RankLayout& layout, Solver& local);
  ~RankedCoupling() override;

  /// Collective: every rank's part listens for the fluid and shakes hands (CouplingError on every rank).
  void initialize();
  /// Collective: the clean end after the last window.
  void finalize();
  /// This rank's part tells the fluid this side stops (never throws).
  void abort(const std::string& reason) noexcept;

  /// This rank's adapter and carried laws on its part (the laws null when none). Their works,
  /// pressures and counters are the whole face's, alike on every rank; nodes() and force() the part's.
  FluidCoupling* adapter();
  const CarriedWater* water() const;
  /// Collective, before a results sample: the works booked (flushWetWork); the wet nodes'
  /// force last added (the exchanged one and the carried pressure's) gathered on rank 0 in the order
  /// of wetNodeList(), and their mass as the ranks sum it set on rank 0's `view` (the whole-model
  /// mirror the results are written from; null elsewhere). Results only: gathered as the rest of the
  /// results on ranks.
  void observe(Solver* view);
  /// Rank 0, after observe(): the whole face's nodes (global indices, ascending) and their force.
  const std::vector<Index>& wetNodeList() const { return wet_; }
  const std::vector<Real>& wetForce() const;
  /// This rank's part: its wet nodes (owned, each node in one part only).
  Index partNodes() const;
  /// Rank 0: every rank's part node count, in rank order (they add up to wetNodes()).
  std::vector<Index> partCounts() const;

  /// The same on every rank.
  Real endTime() const { return endTime_; }
  long long windowCount() const { return windows_; }
  bool ongoing() const { return done_ < windows_; }
  Index wetNodes() const { return Index(wet_.size()); }
  /// Seconds this rank spent in the coupling's messages between the ranks (the sums' gathers, the
  /// frontier's force, the errors agreed; waiting for the other ranks included).
  double secondsCommunicating() const { return secondsComm_; }
  /// Of them, the sums' gathers (WetPart::gather), and how many.
  double secondsSumming() const { return secondsSums_; }
  long long sumsGathered() const { return sums_; }

  // ---- as a contributor (ForcePhase::Water) of this rank's solver -------------------------------
  std::string name() const override;
  /// Collective: this rank's part adds the exchanged force and the carried pressure to its nodes;
  /// the frontier's f_ext from each owner to the other ranks that hold the node.
  void addForces(Real t, Real dt, NodalState& state) override;
  /// The adapter's and the carried laws' step state of this rank's part (a window stepped again restores it).
  void checkpoint(StateArchive& archive) override;
  /// Subcycling: this rank's wet nodes at the finest level (as the adapter's on one process).
  bool constrainLevels(std::vector<std::uint8_t>& level) const override;

  // ---- the protocol (CoupledStepper), collective ------------------------------------------------
  void planWindow(const NodalState& state) override;
  void planStep(Index j, Real dt) override;
  bool exchange(Real dt, const NodalState& state) override;
  void acceptWindow() override;
  bool repeatsWindows() const override { return repeats_; }
  Index windowSteps() const override { return steps_; }

  // ---- restart checkpoints (at a window's end) ----------------------------------------------------
  /// Completed windows, and whether a window is open (between its first step and its exchange): the
  /// same on every rank, without a message.
  long long windowsDone() const { return done_; }
  bool windowOpen() const { return open_; }
  /// The coupling's state across windows: the windows done, and this rank's adapter's
  /// (FluidCoupling::restartState: the bytes of this rank's part of the coupler participant among
  /// it), on every rank. Saved at a window's end; restored before initializeResumed().
  void restartState(StateArchive& archive);
  /// Collective, initialize() for a run restored by restartState(): every rank's part connects to the
  /// water and carries on from the saved window (CouplingError on every rank).
  void initializeResumed();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Index> wet_;  // the wetted face's nodes (global indices, ascending)
  bool repeats_ = false, open_ = false;
  Index steps_ = 1;
  Real endTime_ = 0;
  long long windows_ = 0, done_ = 0;
  double secondsComm_ = 0, secondsSums_ = 0;
  long long sums_ = 0;
};

}  // namespace tq
