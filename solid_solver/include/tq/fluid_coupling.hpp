/// @file fluid_coupling.hpp
/// @brief The solid side of the rock–lining–water coupling (paper §2.2.2–2.2.3; issue 6;
///        docs/coupler.md "Solid adapter"): a NodalForceContributor that exchanges the motion of
///        the lining's wetted face (`lining_inner`) for the water's interface force R3 through the
///        coupler library (tqcoupler).
///
/// Each solid step, after every other force of the step is known (runsLast), the interface nodes
/// are predicted at t + Δt by the solver's own update (leapfrog with α M and the boundary dashpots,
/// fixed dofs held): v^{n+½} = [(m/Δt − c/2) v^{n−½} + f] / (m/Δt + c/2), u^{n+1} = u^n + Δt v^{n+½}.
/// The prediction (displacement relative to the seismic start, and velocity) is written to the
/// fluid, the coupler advances, and the force it returns is added to f_ext. Because the solid's
/// response to an interface force is this local update, the solid needs no checkpoint of its whole
/// state: for every new force the prediction is recomputed (paper and implicit schemes iterate
/// inside addForces until the coupler says the window is complete).
///
/// This header and src/fluid_coupling.cpp are the only solid files that see the coupler (its
/// headers are included in the .cpp only): the physics stays free of communication.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "tq/mesh.hpp"
#include "tq/solver.hpp"
#include "tq/staged_input.hpp"

namespace tq {

/// The coupling stopped the run: partner lost, timeout, handshake refused, protocol error,
/// divergence. The message names the cause and the fix.
class CouplingError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// What the adapter did so far.
struct FluidCouplingStats {
  long long windows = 0;        ///< completed coupling windows
  long long passes = 0;         ///< exchanges (a paper window has 2, an implicit one ≥ 2)
  long long maxPasses = 0;      ///< most passes in one window
  double secondsExchanging = 0; ///< wall time inside the coupler (waiting for the fluid included)
  // Cost split (docs/coupler.md "Exchange cost"), all over the stepping only (start-up excluded):
  double secondsCoupled = 0;    ///< wall from the end of initialize() to the end of the last addForces()
  double secondsInCoupler = 0;  ///< wall inside addForces' coupler part (predict, write, advance, read)
  double secondsWaiting = 0;    ///< of which receives were blocked until the fluid's message began
  double secondsMapping = 0;    ///< of which the interface maps were applied
  double cpuCoupled = 0;        ///< CPU seconds of the calling thread over the same span as secondsCoupled
  double cpuInCoupler = 0;      ///< of which inside the coupler part (a blocked receive costs no CPU)
};

class FluidCoupling final : public NodalForceContributor {
public:
  /// Builds the coupling configuration from /coupling and the interface nodes of `in.face`.
  /// With `in.windowSize` > 0 the solver's step is set to windowSize / windowSteps (refused when
  /// above the stable step). Does not connect yet. Throws InputError on a bad configuration.
  /// The solver must outlive the adapter; its displacement now is the reference of the
  /// displacement written (construct it right after the switch to the seismic stage).
  FluidCoupling(Solver& solver, const CouplingInput& in, Real tEnd);
  ~FluidCoupling() override;  ///< without finalize(): tells the fluid this side stopped (ABORT)

  /// Connects to the fluid and runs the handshake. Throws CouplingError.
  void initialize();
  /// Clean end after the last window (BYE). Throws CouplingError.
  void finalize();
  /// Tells the fluid this side stops on an error (never throws).
  void abort(const std::string& reason) noexcept;

  std::string name() const override;
  /// One solid step: predict, write, advance (exchange at the end of a window), read R3, add it.
  void addForces(Real t, Real dt, NodalState& state) override;
  bool runsLast() const override { return true; }

  /// False once the last window has been exchanged (the time loop stops there).
  bool ongoing() const;
  /// windows × window size (s): the end of the coupled run.
  Real endTime() const;
  Real windowSize() const;
  long long windowCount() const;
  /// Work of the interface force R3 on the solid so far (J), booked by the solver's own
  /// trapezoid rule (it is part of the balance's `external` term).
  Real fluidWork() const;
  /// Work the fluid received from the wall so far (J), from the exchanged data: each window's
  /// final force on the motion the fluid was sent, same trapezoid rule (docs/coupler.md "Energy").
  Real fluidReceivedWork() const;
  /// fluidWork() + fluidReceivedWork(): the energy the coupling scheme created (> 0) or
  /// destroyed (< 0) at the interface (J); zero for an exchange converged to round-off.
  Real couplingEnergy() const;
  FluidCouplingStats stats() const;
  /// The interface nodes (mesh indices, ascending) and the force last added to each ([3n], N).
  const std::vector<Index>& nodes() const;
  const std::vector<Real>& force() const;
  /// One line describing the coupling (scheme, window, transport, interface size).
  std::string describe() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tq
