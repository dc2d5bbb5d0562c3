/// @file ranked_coupling.hpp
/// @brief The water coupling of the solid on MPI ranks (docs/architecture.md "The solid on ranks",
///        "The water coupling on ranks"). A gather, not an m:n exchange: rank 0 holds the one coupler
///        participant (FluidCoupling) and the water's laws the solid carries (CarriedWater), both on
///        its whole-model mirror solver; each rank sends it the state of the wet nodes it owns (u, v,
///        f_int, f_ext so far, mass, dashpot: each node once, from its owner), rank 0 runs the
///        protocol's part on the whole wetted face in the one-process order, and sends every rank the
///        wet nodes' external force, which each rank sets on every copy it holds (a frontier node's
///        copies stay bitwise equal). The carried laws' sums over the wet nodes run on rank 0 in the
///        order of the one-process run, whatever the rank count.
///
/// Each rank's RankedCoupling is a contributor of its solver (ForcePhase::Water, in place of the
/// adapter and the carried laws of the one-process run) and the WindowCoupling CoupledStepper runs:
/// every call is collective, and an error rank 0 meets (the fluid lost, the energy guard) is thrown
/// on every rank alike. On one rank it is the one-process run: the adapter on the rank's own solver,
/// no messages.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/coupling/fluid_coupling.hpp"
#include "tq/water/carried_water.hpp"

namespace tq {

class RankedCoupling final : public NodalForceContributor, public WindowCoupling {
 public:
  /// Collective; MPI initialised. `global`: the whole mesh; `localNode` [global node]: this rank's
  /// index of it or −1 (empty on one rank); `owned` [local node]: 1 on the node's owner; `local`: this
  /// rank's solver, switched to the seismic stage with its step set; `mirror`: rank 0's solver of the
  /// whole model (null elsewhere; on one rank `local` itself), its state gathered at the seismic start.
  /// Makes the carried laws and the adapter on rank 0 (not connected). Throws InputError alike on
  /// every rank.
  RankedCoupling(const CouplingInput& in, const Mesh& global, const std::vector<Index>& localNode,
                 const std::vector<std::uint8_t>& owned, Solver& local, Solver* mirror);
  ~RankedCoupling() override;

  /// Collective: rank 0 connects to the fluid and shakes hands (CouplingError on every rank).
  void initialize();
  /// Collective: the clean end after the last window.
  void finalize();
  /// Rank 0 tells the fluid this side stops (never throws; nothing on the other ranks).
  void abort(const std::string& reason) noexcept;

  /// Rank 0's adapter and carried laws (null on the other ranks; the laws null when none).
  FluidCoupling* adapter();
  const CarriedWater* water() const;

  /// The same on every rank.
  Real endTime() const { return endTime_; }
  long long windowCount() const { return windows_; }
  bool ongoing() const { return done_ < windows_; }
  Index wetNodes() const { return Index(wet_.size()); }
  /// Seconds this rank spent in the coupling's gathers and broadcasts (waiting for rank 0 included).
  double secondsCommunicating() const { return secondsComm_; }

  // ---- as a contributor (ForcePhase::Water) of this rank's solver -------------------------------
  std::string name() const override;
  /// Collective: the wet nodes' state to rank 0, which adds the exchanged force and the carried
  /// pressure there; their f_ext back to every copy.
  void addForces(Real t, Real dt, NodalState& state) override;
  /// Rank 0: the adapter's and the carried laws' step state (a window stepped again restores it).
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
  /// The coupling's state across windows: the windows done (every rank), and on rank 0 the adapter's
  /// (FluidCoupling::restartState: the coupler participant's bytes among it). Saved at a window's
  /// end; restored before initializeResumed().
  void restartState(StateArchive& archive);
  /// Collective, initialize() for a run restored by restartState(): rank 0 connects and carries on
  /// from the saved window (CouplingError on every rank).
  void initializeResumed();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Index> wet_;  // the wetted face's nodes (global indices, ascending)
  bool repeats_ = false, open_ = false;
  Index steps_ = 1;
  Real endTime_ = 0;
  long long windows_ = 0, done_ = 0;
  double secondsComm_ = 0;
};

}  // namespace tq
