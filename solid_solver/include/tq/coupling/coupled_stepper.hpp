/// @file coupled_stepper.hpp
/// @brief tq-solid's time-loop step with the water coupling: one coupling window in the protocol's
///        shape, as the water side runs it (openfoam_case tqInterface::execute): save, solve the
///        window, exchange, accept or restore (docs/coupler.md "Solid adapter", "Windows of several
///        steps"). Without a coupling, one solid step.
#pragma once

#include <functional>

#include "tq/core/state_archive.hpp"
#include "tq/coupling/fluid_coupling.hpp"

namespace tq {

class CoupledStepper {
 public:
  /// `coupling` may be null (no water): then advance() is one Solver::step(). The coupling must be
  /// one of the solver's contributors (ForcePhase::Water), and initialized (a FluidCoupling; on MPI
  /// ranks each rank's RankedCoupling).
  CoupledStepper(Solver& solver, WindowCoupling* coupling) : solver_(solver), coupling_(coupling) {
    start_.setWindowStart(true);
  }

  /// One coupling window (no coupling: one step). `onFinal` is called after each state that is final
  /// (results may be sampled): after every step, except inside an implicit window of several steps,
  /// whose steps are final only at its accepted end.
  void advance(const std::function<void()>& onFinal);

  /// At a final state: have the solver sum the kinetic energy (Solver::setKineticEnergyWanted) in
  /// the steps to the next one only where the balance will be read: a final state the histories may
  /// sample (within a gap of `nextSample`, the next requested history time; the margin of half a
  /// gap takes the clock's rounding) and the last one (`tEnd`: the summary line).
  void askKineticEnergy(Real nextSample, Real tEnd) const {
    const Real t = solver_.time(), g = finalGap();
    solver_.setKineticEnergyWanted(t + 2.5 * g >= nextSample || t + 1.5 * g >= tEnd);
  }

  /// Windows stepped again from their saved start so far.
  long long restores() const { return restores_; }
  /// Solid steps begun, repeated ones included (a one-step window's step counts once).
  long long steps() const { return steps_; }

 private:
  /// The time from one final state to the next (s): an implicit window of several steps, else one
  /// step.
  Real finalGap() const {
    return coupling_ && coupling_->repeatsWindows() ? Real(coupling_->windowSteps()) * solver_.dt() : solver_.dt();
  }
  void window(const std::function<void()>& onFinal);
  void solveWindow(bool stepsAreFinal, const std::function<void()>& onFinal);

  Solver& solver_;
  WindowCoupling* coupling_;
  StateArchive start_;  // the solver's state at the window's start (windows stepped again whole)
  long long restores_ = 0, steps_ = 0;
};

}  // namespace tq
