/// @file fluid_coupling.hpp
/// @brief The solid side of the rock–lining–water coupling (paper §2.2.2–2.2.3;
///        docs/coupler.md "Solid adapter"): the exchange of the lining's wetted face (`lining_inner`)
///        motion for the water's interface force R3 through the coupler library (tqcoupler).
///
/// The protocol's parts, per coupling window of k solid steps and one water step, in the order
/// CoupledStepper::window (tq/coupling/coupled_stepper.hpp) runs them:
///  - planWindow, at the window's start: the window-end force F̃ of the first pass (implicit: the
///    predictor's; paper and explicit: none) and the force at the window's start F_w.
///  - planStep j < k: the force step j applies, F_w + w_j (F̃ − F_w) (explicit: the last answer, held).
///  - exchange, at the window's last step with its other forces known (Solver::beginStep): the
///    interface nodes are predicted at t + Δt with F̃ by the solver's own update
///    (tq/water/wall_prediction.hpp) and the laws the solid carries (tq/water/carried_water.hpp); the
///    prediction (displacement relative to the seismic start, and velocity: for k > 1 the window's
///    mean) is written, the coupler advances, the water's force is read. Not accepted: F̃ becomes the
///    water's answer, and the window is stepped again.
///  - acceptWindow, after the window's last step: the water's work and the counters booked, the
///    energy guard.
/// As a contributor (ForcePhase::Water) it adds the force planStep or exchange decided to f_ext.
///
/// This header and src/coupling/ are the only solid files that see the coupler (its headers are
/// included in the .cpp files only): the physics stays free of communication.
#pragma once

#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/io/mesh.hpp"
#include "tq/io/staged_input.hpp"
#include "tq/water/carried_water.hpp"

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
  double secondsCoupled = 0;    ///< wall from the end of initialize() to the end of the last protocol part
  double secondsInCoupler = 0;  ///< wall inside the protocol's parts (predict, write, advance, read)
  double secondsWaiting = 0;    ///< of which receives were blocked until the fluid's message began
  double secondsMapping = 0;    ///< of which the interface maps were applied
  double cpuCoupled = 0;        ///< CPU seconds of the calling thread over the same span as secondsCoupled
  double cpuInCoupler = 0;      ///< of which inside the coupler part (a blocked receive costs no CPU)
  // The solid's wall outside the coupler split by the pass it steps (an implicit window of several
  // steps; the rest of it is the windows' ends: last steps, results, the next window's save):
  double secondsFirstPasses = 0;  ///< from a window's plan to its first exchange
  double secondsRepasses = 0;     ///< from a refused exchange to the next (the restore included)
};

/// The protocol's parts CoupledStepper runs, per window (see FluidCoupling's for what each does):
/// FluidCoupling, and on MPI ranks RankedCoupling (tq/coupling/ranked_coupling.hpp), which runs
/// rank 0's FluidCoupling for every rank.
class WindowCoupling {
 public:
  virtual ~WindowCoupling() = default;
  virtual void planWindow(const NodalState& state) = 0;
  virtual void planStep(Index j, Real dt) = 0;
  virtual bool exchange(Real dt, const NodalState& state) = 0;
  virtual void acceptWindow() = 0;
  virtual bool repeatsWindows() const = 0;
  virtual Index windowSteps() const = 0;
};

class FluidCoupling final : public NodalForceContributor, public WindowCoupling {
 public:
  /// Builds the coupling configuration from /coupling and the interface nodes of `in.face`: a
  /// window of `in.windowSize` s (0: windowSteps × the solver's step), `in.windows` of them (at least 1;
  /// the case decides the count, fluid_case.coupling_windows). The adapter reads the solver's step and
  /// never sets it: the run sets it from /coupling first (SolidRun::connectWater, windowSize /
  /// windowSteps), as it sets every other step. The rules between settings (the paper scheme's one-step
  /// windows, ...) are the reader's (io/input_staged.cpp). Does not connect yet. Throws InputError on a
  /// bad configuration.
  /// The solver must outlive the adapter; its displacement now is the reference of the
  /// displacement written (construct it right after the switch to the seismic stage). `water`: the
  /// laws the solid carries on the same face (CarriedWater::fromCoupling; null: none), added to
  /// the solver after this adapter; it must outlive the adapter.
  FluidCoupling(Solver& solver, const CouplingInput& in, const CarriedWater* water = nullptr);
  /// On MPI ranks: the exchange of this rank's part of the wetted face (tq/water/wet_part.hpp), a
  /// part of the coupler's participant (Participant::setPart) with its own connection to the water:
  /// `nodes` its nodes in `solver` (in the order of part.places), `ids` their global indices (the
  /// interface's ids); `water` the carried laws on the same part. Every sum over the wet nodes is
  /// taken in the one-process order on every part (sumOverWetNodes), so each protocol part that sums
  /// is collective. The coincident map only (InputError otherwise). `part` outlives it.
  FluidCoupling(Solver& solver, const CouplingInput& in, const CarriedWater* water, const WetPart& part,
                std::vector<Index> nodes, std::vector<std::int64_t> ids);
  ~FluidCoupling() override;  ///< without finalize(): tells the fluid this side stopped (ABORT)

  /// Connects to the fluid and runs the handshake. Throws CouplingError.
  void initialize();
  /// Clean end after the last window (BYE). Throws CouplingError.
  void finalize();
  /// Tells the fluid this side stops on an error (never throws).
  void abort(const std::string& reason) noexcept;
  /// The solver whose time and step count the messages name (default: the one it couples; on MPI
  /// ranks rank 0's own, whose clock the mirror it couples does not follow step by step).
  void tellTimeBy(const Solver& clock);

  // ---- the protocol's parts, in the order CoupledStepper::window runs them -----------------------
  /// The window's start (pass 0): its plan. Throws CouplingError before initialize() or past the last window.
  void planWindow(const NodalState& state) override;
  /// Step j (1 ≤ j < k) of the window: the force it applies; the coupler's clock moves on.
  void planStep(Index j, Real dt) override;
  /// One pass of the window's end, the last step's other forces known (Solver::beginStep): predict,
  /// write, advance, read. True when the water accepted the window; else the next pass uses its answer.
  bool exchange(Real dt, const NodalState& state) override;
  /// The accepted window, its last step taken: the water's work booked, the counters, the energy
  /// guard (InstabilityError when the coupling created more than energy_limit).
  void acceptWindow() override;

  // ---- the step -------------------------------------------------------------------------------------
  std::string name() const override;
  /// The force the protocol decided for this step added to f_ext (its work booked); a step the
  /// protocol did not decide (a solid stepped outside CoupledStepper) is a CouplingError.
  void addForces(Real t, Real dt, NodalState& state) override;
  /// The adapter's own step state (the force of the window's steps, its work booking); not the
  /// iteration's data (the force being iterated and the pass count), which survive a restore.
  void checkpoint(StateArchive& archive) override;
  /// On a part (MPI ranks): the work terms of the steps not booked yet and the work they go to
  /// (flushWetWork(), before fluidWork() is read: the steps' terms are kept until then, so a step costs
  /// no message for them); in one process none are kept (each step books its own).
  WetWorkBook workBook();
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

  /// Implicit windows of k > 1 steps are stepped again whole from their saved start when the water
  /// does not accept them (docs/coupler.md "Windows of several steps"); one-step windows are not
  /// (their step is predicted again before it is taken), nor are explicit ones (always accepted).
  bool repeatsWindows() const override;
  /// k: solid steps a window.
  Index windowSteps() const override;
  /// True between the first and the last step of a window (results are sampled at window ends).
  bool windowOpen() const;

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
  /// The interface nodes (mesh indices, ascending; on a part: the part's, in its solver's indices)
  /// and the force last added to each ([3n], N):
  /// the exchanged force plus the pressure the solid carries (CarriedWater::force()) where there is one.
  const std::vector<Index>& nodes() const;
  const std::vector<Real>& force() const;
  /// Subcycling: the wet nodes step every fine step (the water force is set per step).
  bool constrainLevels(std::vector<std::uint8_t>& level) const override { return lowerToFinestLevel(level, nodes()); }
  /// The water's force on the wet nodes: one group (a window's passes differ there first).
  bool forceGroups(std::vector<std::vector<Index>>& groups) const override {
    groups.push_back(nodes());
    return true;
  }
  /// Its state reads its groups' motion only.
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }
  /// One line describing the coupling (scheme, window, transport, interface size).
  std::string describe() const;
  /// True when the fluid is known to end by itself: the handshake took place (or was refused,
  /// which both sides see) and the fluid did not fall silent (no timeout). Then it was told the
  /// end (BYE or ABORT) or told it itself, and reaches MPI_Finalize (CouplingMpi::finish).
  bool partnerReleased() const;

 private:
  void setUp(std::vector<std::int64_t> ids, std::vector<std::int32_t> triangles);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tq
