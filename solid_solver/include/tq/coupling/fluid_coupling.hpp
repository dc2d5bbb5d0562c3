/// @file fluid_coupling.hpp
/// @brief The solid side of the rock–lining–water coupling (paper §2.2.2–2.2.3;
///        docs/coupler.md "Solid adapter"): a NodalForceContributor that exchanges the motion of
///        the lining's wetted face (`lining_inner`) for the water's interface force R3 through the
///        coupler library (tqcoupler).
///
/// The protocol, per coupling window of k solid steps and one water step (written once, in
/// fluid_coupling.cpp, Impl::windowStep; addForces runs it once per solid step, in
/// ForcePhase::Water, after the forces of the earlier phases are known):
///  - plan, at the window's first step: the window-end force F̃ of the first pass (implicit: the
///    predictor's; paper and explicit: none) and the force at the window's start F_w. Step j < k
///    applies F_w + w_j (F̃ − F_w) (explicit: the last answer, held).
///  - exchange, at the window's last step: the interface nodes are predicted at t + Δt with F̃ by
///    the solver's own update (leapfrog with α M and the boundary dashpots, fixed dofs held:
///    v^{n+½} = [(m/Δt − c/2) v^{n−½} + f] / (m/Δt + c/2), u^{n+1} = u^n + Δt v^{n+½}); the prediction
///    (displacement relative to the seismic start, and velocity: for k > 1 the window's mean) is
///    written, the coupler advances, the water's force is read.
///  - decision: accepted → the water's work and the counters are booked, the next window starts;
///    not accepted → F̃ becomes the water's answer and the window is stepped again from its start.
///    A one-step window's step is, for the interface, the local update from the step's state, so it
///    is stepped again inside addForces by predicting again (no checkpoint of the solver); a window
///    of k steps is stepped again by the time loop (WindowedStepper), which restores the solver's
///    state saved at the window's start.
/// Every step then adds its force (with the pressure of the laws the solid carries) to f_ext.
///
/// This header and src/coupling/fluid_coupling.cpp are the only solid files that see the coupler (its
/// headers are included in the .cpp only): the physics stays free of communication.
#pragma once

#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/io/mesh.hpp"
#include "tq/io/staged_input.hpp"

namespace tq {

/// The coupling stopped the run: partner lost, timeout, handshake refused, protocol error,
/// divergence. The message names the cause and the fix.
class CouplingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What the adapter did so far.
struct FluidCouplingStats {
  long long windows = 0;             ///< completed coupling windows
  long long passes = 0;              ///< exchanges (a paper window has 2, an implicit one ≥ 2)
  long long maxPasses = 0;           ///< most passes in one window
  long long unconvergedWindows = 0;  ///< implicit: windows ended at max_iterations above the tolerance
  double secondsExchanging = 0;      ///< wall time inside the coupler (waiting for the fluid included)
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
  /// One solid step of the protocol (plan, exchange, decision; see above), then its force added to f_ext.
  void addForces(Real t, Real dt, NodalState& state) override;
  /// The adapter's own step state (the force of the window's steps, its work booking); not the
  /// iteration's data (the force being iterated and the pass count), which survive a restore.
  void checkpoint(StateArchive& archive) override;
  /// Restart checkpoints (tq/io/restart.hpp): at a window's end, the adapter's state across windows
  /// (the last windows' forces and motions, the predictor's history, the energy bookkeeping, the
  /// counters) and the coupler participant's bytes (Participant::saveState); restored before
  /// initializeResumed().
  void restartState(StateArchive& archive);
  /// initialize() for a run restored by restartState(): connects, shakes hands and carries on from
  /// the saved window (Participant::initializeResumed). Throws CouplingError.
  void initializeResumed();
  /// Completed coupling windows so far.
  long long windowsDone() const;

  /// Windows of several solid steps with the implicit scheme: the time loop saves the solver's
  /// state at each window start and restores it when takeRepeat() says the window must be
  /// repeated (docs/coupler.md "Windows of several steps"). False for one-step windows (their
  /// passes repeat only the interface nodes' update, inside addForces) and the explicit scheme.
  bool repeatsWindows() const;
  /// True between the first and the last step of a window (results are sampled at window ends).
  bool windowOpen() const;
  /// True once after the last step of a window the water did not accept: restore the state
  /// saved at the window start and step the window again (with the water's new force).
  bool takeRepeat();

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
  /// The energy guard's reference: the largest |fluidWork()| or |fluidReceivedWork()| at a window's
  /// end so far (J), and its floor (J; 0 when neither /coupling energy_floor nor the absolute
  /// tolerances give one). The run stops (InstabilityError) when couplingEnergy() exceeds
  /// energy_limit × max(peak, floor) at a window's end.
  Real interfaceWorkPeak() const;
  Real energyFloor() const;
  /// A warning to print once (the coupling energy passed a fifth of the limit); empty otherwise.
  std::string takeNote();
  FluidCouplingStats stats() const;
  /// The interface nodes (mesh indices, ascending) and the force last added to each ([3n], N).
  /// The force includes the pressure the solid carries (volume law and translation) where there is one.
  const std::vector<Index>& nodes() const;
  const std::vector<Real>& force() const;
  /// The water's volume law carried by the solid (/coupling volume_law, docs/coupler.md "Volume
  /// law in the solid"): whether there is one, its pressure this step (Pa: the uniform pressure of a
  /// closed section; with open ends the stations' volume-weighted mean), each station's pressure (one
  /// for a closed section; with open ends one per plane of wet nodes along the axis, in order of y),
  /// the work of the carried forces (volume law and translation) on the solid so far (J, part of the
  /// balance's `external` term, not of couplingEnergy()), and the enclosed volume (m³).
  bool hasVolumeLaw() const;
  Real volumePressure() const;
  std::vector<Real> stationPressures() const;
  Real volumeLawWork() const;
  Real enclosedVolume() const;
  /// Subcycling: the wet nodes step every fine step (the water force is set per step).
  bool constrainLevels(std::vector<std::uint8_t>& level) const override { return lowerToFinestLevel(level, nodes()); }
  /// One line describing the coupling (scheme, window, transport, interface size).
  std::string describe() const;
  /// True when the fluid is known to end by itself: the handshake took place (or was refused,
  /// which both sides see) and the fluid did not fall silent (no timeout). Then it was told the
  /// end (BYE or ABORT) or told it itself, and reaches MPI_Finalize (CouplingMpi::finish).
  bool partnerReleased() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The time loop's step with the water coupling (tq-solid's loop and the tests use it): the time
/// loop's part of the protocol's decision for implicit windows of several steps — it saves the
/// solver's state at each window start and restores it when the water did not accept the window
/// (docs/coupler.md "Windows of several steps"); otherwise it is Solver::step().
class WindowedStepper {
 public:
  /// `coupling` may be null (no water): then every step is final.
  WindowedStepper(Solver& solver, FluidCoupling* coupling)
      : solver_(solver), coupling_(coupling), windowed_(coupling && coupling->repeatsWindows()) {}
  /// One solid step. True when the state is final (results may be sampled): always without
  /// repeated windows, else at the end of an accepted window. False inside a window and after a
  /// window was taken back (the state is then the window's start again).
  bool step() {
    if (windowed_ && saveNext_) {
      archive_.beginSave();
      solver_.checkpoint(archive_);
      archive_.end();
      saveNext_ = false;
    }
    solver_.step();
    if (!windowed_) return true;
    if (coupling_->takeRepeat()) {
      archive_.beginRestore();
      solver_.checkpoint(archive_);
      archive_.end();
      ++restores_;
      return false;
    }
    if (coupling_->windowOpen()) return false;
    saveNext_ = true;
    return true;
  }
  /// Windows stepped again from their saved start so far.
  long long restores() const { return restores_; }

 private:
  Solver& solver_;
  FluidCoupling* coupling_;
  bool windowed_;
  bool saveNext_ = true;
  long long restores_ = 0;
  StateArchive archive_;
};

/// tq-solid as one application of an MPMD mpirun job (/coupling transport mpi; docs/coupler.md
/// "tq-solid under mpirun"): `mpirun -np 1 tq-solid ... : -np N fluid ...`. MPI is initialised
/// only here, with MPI_THREAD_FUNNELED (the solid's OpenMP threads make no MPI calls), and the
/// world is split by application before the static stages, so a missing partner is reported at
/// once. tq-solid is one MPI process (it is threaded with OpenMP): a second solid rank is refused.
class CouplingMpi {
 public:
  /// MPI_Init, SIGTERM/SIGINT handling (mpirun's way of ending the job when a process died),
  /// world split. A partner missing from the job or a second solid process is a problem().
  explicit CouplingMpi(const CouplingInput& in);
  CouplingMpi(const CouplingMpi&) = delete;
  CouplingMpi& operator=(const CouplingMpi&) = delete;
  ~CouplingMpi();  ///< finish(1) unless finish() was called

  /// Why the coupling cannot run in this job (its message and fix), or empty. The run then
  /// stops (exit 4) and finish() ends MPI: MPI_Finalize without a partner, else MPI_Abort.
  const std::string& problem() const { return problem_; }
  /// One line: the job's size and this process's cores and OpenMP threads.
  std::string describe() const;
  /// Warning (empty if none) when mpirun bound this process to fewer cores than the machine has
  /// (Open MPI binds to a core by default for up to 2 processes): OpenMP then runs on those only.
  std::string bindingWarning() const;
  /// Records how the coupling ended (read before the coupling object goes away).
  void note(const FluidCoupling& c);
  /// Ends MPI for a run that returns `exitCode`, after results.h5 is closed:
  /// - a termination signal arrived (mpirun is ending the job): nothing — MPI_Finalize would wait
  ///   for the dead process; the job ends anyway;
  /// - the fluid is known to end by itself (completed, or told the error, or it stopped on its own
  ///   error): MPI_Finalize, so mpirun reports tq-solid's exit code and message, not an abort;
  /// - otherwise (the fluid fell silent, or was never reached: an error before the handshake):
  ///   MPI_Abort with exitCode, since the fluid would never reach MPI_Finalize. Does not return then.
  /// Returns exitCode.
  int finish(int exitCode, std::ostream& err);

  /// "N processes" when this process was started by mpirun/mpiexec (Open MPI, MPICH), else "".
  static std::string launchedByMpirun();

 private:
  bool finished_ = false, partnerInJob_ = false, noted_ = false, released_ = false;
  int worldSize_ = 1;
  std::string partner_, problem_;
};

}  // namespace tq
