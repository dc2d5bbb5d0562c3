/// @file solver.hpp
/// @brief Explicit time integration of M ü + C u̇ + f_int(u) = f_ext (paper eq. 2) for rock and
///        lining: lumped mass, Rayleigh damping, stable step from the element CFL, the energy
///        balance, and a check for non-finite or exploding values every step.
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tq/core/element_block.hpp"
#include "tq/core/mesh.hpp"
#include "tq/core/nodal_state.hpp"

namespace tq {

/// Time integrator.
enum class Integrator {
  /// Default. Central difference in half-step (leapfrog) velocity form: Newmark β = 0, γ = ½.
  /// v^{n+½} = v^{n-½} + Δt M⁻¹(f_ext^n - f_int^n - C v); u^{n+1} = u^n + Δt v^{n+½}.
  /// Its displacement update coincides with the paper's eq. (3); conditionally stable.
  CentralDifference,
  /// The paper's eqs. (3)-(4) taken literally: u^{n+1} = u^n + Δt v^n + Δt²/2 a^n and
  /// v^{n+1} = 2(u^{n+1}-u^n)/Δt - v^n = v^n + Δt a^n. Its amplification matrix for ü = -ω²u
  /// has determinant 1 + (ωΔt)²/2 > 1: unstable for any step without damping. For study only.
  PaperEq34,
};
Integrator parseIntegrator(const std::string& name);  // "central_difference" | "paper_eq3_4"
std::string integratorName(Integrator i);

/// Rayleigh damping C = α M + β K.
struct RayleighDamping {
  Real alpha = 0;  ///< mass-proportional coefficient α (1/s)
  Real beta = 0;   ///< stiffness-proportional coefficient β (s)
  /// Damping ratio ξ at the two frequencies f1, f2 (Hz): α = 2ξω1ω2/(ω1+ω2), β = 2ξ/(ω1+ω2).
  static RayleighDamping fromRatio(Real xi, Real f1, Real f2);
};

/// Piecewise-linear function of time; holds the end values outside the table.
struct TimeFunction {
  std::vector<Real> t, value;
  Real operator()(Real time) const;
  static TimeFunction constant(Real v) { return {{0.0}, {v}}; }
};

/// Force on a set of nodes in one direction: F(t) = forcePerNode * f(t) on each node (N).
struct NodalLoad {
  std::vector<Index> nodes;
  int direction = 0;
  Real forcePerNode = 0;
  TimeFunction function = TimeFunction::constant(1.0);
};

/// The phases of a step's external force, in the order Solver::step sums them into state.fExt.
/// Each phase sees the complete force of the phases before it; within a phase the contributors
/// run in the order they were added (Solver::addContributor names each one's phase).
enum class ForcePhase : std::uint8_t {
  Loads,       ///< gravity, NodalLoads, constant and held forces (reactions, pressures, excavation load)
  Boundaries,  ///< seismic boundaries: viscoelastic base, free-field columns, incident motion
  Interface,   ///< the rock–lining interface (dynamic contact, or a bonded tie) and any force
               ///< predicted from every force above (e.g. a prescribed motion)
  Water,       ///< the water's force on the lining (FluidCoupling)
  Ties,        ///< ties that share every force of their members, the water's included (periodic faces)
};
/// Every phase, in the order they run.
inline constexpr ForcePhase kForcePhases[] = {ForcePhase::Loads, ForcePhase::Boundaries, ForcePhase::Interface,
                                              ForcePhase::Water, ForcePhase::Ties};

/// Something that adds nodal forces each step (absorbing boundaries, input waves, contact,
/// fluid loads): the solver calls it after the element forces are assembled, before the update,
/// in the phase it was added to (ForcePhase).
class NodalForceContributor {
 public:
  virtual ~NodalForceContributor() = default;
  virtual std::string name() const = 0;
  /// Add forces to state.fExt at time t (the state holds u^n, v, f_int^n).
  virtual void addForces(Real t, Real dt, NodalState& state) = 0;
  /// Energy this contributor has dissipated so far (J) = minus the work of its own forces, booked
  /// by the solver's trapezoid rule (e.g. friction at an interface). The solver reports it as the
  /// balance term `interface` instead of as external work. Default 0: its work is external work.
  virtual Real dissipatedEnergy() const { return 0; }
  /// Energy held or absorbed by this contributor's boundary springs (J) = minus the work of those
  /// forces, booked by the solver's trapezoid rule (the viscoelastic base). The solver reports it
  /// in the balance term `boundary` (with the dashpots) instead of as external work. Default 0.
  virtual Real boundaryEnergy() const { return 0; }
  /// Save or restore everything addForces changes (StateArchive: a coupling window of several
  /// steps is repeated from its start). A contributor with state must list it here.
  virtual void checkpoint(StateArchive& /*archive*/) {}
  /// Subcycling: lower the levels (Solver::enableSubcycling) of the nodes this contributor needs
  /// at a finer step: 0 for nodes whose force it computes from their motion within each step
  /// (contact pairs, the coupled wall), one common level for nodes it moves together (ties).
  /// Nodes it only loads (boundaries, surface pressures) need nothing. Return true if it lowered one.
  virtual bool constrainLevels(std::vector<std::uint8_t>& /*level*/) const { return false; }
  /// A coupling window's re-pass steps again only what a change of the water's force can reach
  /// (Solver::planRepasses): which nodes' forces this contributor computes from the motion or the
  /// forces of other nodes, as groups (a change of one member's motion, or of its other forces at a
  /// step, may change every member's force at that step). Return true
  /// and add them to `groups` (none: each node's force depends on its own motion and the time only);
  /// the default, false, says it does not know, and every re-pass is then stepped whole.
  virtual bool forceGroups(std::vector<std::vector<Index>>& /*groups*/) const { return false; }
  /// A re-pass also leaves alone the node chunks that nothing it steps reads (Solver::planRepasses):
  /// which nodes, besides its groups' members, this contributor reads the motion of into its own
  /// state or energy at every step (a spring's work), so that a re-pass keeps stepping them. Return
  /// true and add them (none: its state reads no other node's motion); the default, false, says it
  /// does not know, and a re-pass then steps every node chunk.
  virtual bool motionReadNodes(std::vector<Index>& /*nodes*/) const { return false; }
  /// A contributor whose [3N] force never changes may return it here: added to the Loads phase,
  /// the solver then adds it in gravity's parallel pass instead of calling addForces (one serial
  /// pass fewer; Solver::addContributor decides).
  virtual const std::vector<Real>* constantForces() const { return nullptr; }
};

/// A contributor as the solver holds it: its phase, and whether its constant force is added in
/// gravity's pass (foldedIntoGravity: then addForces is never called).
struct AddedContributor {
  ForcePhase phase;
  bool foldedIntoGravity;
  std::shared_ptr<NodalForceContributor> contributor;
};

/// Subcycling: set the listed nodes to level 0 (the finest step); true if one was coarser.
inline bool lowerToFinestLevel(std::vector<std::uint8_t>& level, const std::vector<Index>& nodes) {
  bool lowered = false;
  for (Index n : nodes)
    if (level[size_t(n)] != 0) level[size_t(n)] = 0, lowered = true;
  return lowered;
}

/// The solid on MPI ranks (tq/parallel/): what the solver of one rank asks of the others. A solver
/// without one (the default) is the whole model in one process and runs as it always did.
class RankExchange {
 public:
  virtual ~RankExchange() = default;
  /// Blocks [0, frontierBlocks()) hold this rank's elements with a frontier node, the later ones
  /// none: the frontier's internal forces are complete once those blocks are done.
  virtual size_t frontierBlocks() const = 0;
  /// Sum `comps` values per node over the ranks that hold each frontier node (lumped masses).
  virtual void sumFrontier(Real* data, int comps) = 0;
  /// The internal forces f [3N]: start the frontier sum (after the frontier blocks), and finish it
  /// (after the others): every rank then holds the same total on its copy of a frontier node.
  /// `activeLevel`: the step's subcycling level (Solver::beginStep; 255 without subcycling).
  virtual void beginForceSum(const Real* f) = 0;
  virtual void finishForceSum(Real* f, int activeLevel) = 0;
  /// The smallest of each frontier node's copies (`comps` values per node), on every copy.
  virtual void minFrontier(Real* data, int comps) = 0;
  /// Subcycling: the levels of this rank's chunks, [block][chunk]: each the level one process gives
  /// the chunk its elements belong to (min over its active elements' nodes of nodeLevel, over every
  /// rank; a rank's chunk lies in one such chunk, the blocks are made so). From then on each
  /// node's force at a step of level L is summed from the elements due at L in the one-process
  /// order of that level (ElementBlock::levelSumOrders). nodeLevel [local node], the same on
  /// every copy; collective.
  virtual std::vector<std::vector<std::uint8_t>> subcycle(const std::vector<std::uint8_t>& nodeLevel, int maxLevel,
                                                          const std::vector<std::unique_ptr<ElementBlock>>& blocks) = 0;
  /// Each node's sum of its elements' values (perBlock[b][e]: element e of block b, the same at each
  /// of its corners) over every rank, in the order one process adds them (lumpMassInto), into
  /// nodal [N]: the lumped masses the same bits as one process's.
  virtual void sumElementShares(const std::vector<std::vector<Real>>& perBlock, Real* nodal) = 0;
  /// Sums over the whole model's nodes in the order one process adds them: node by node in the
  /// global numbering, each node's `per` terms in turn, each node on its owner. terms[(nSums i + s)
  /// per + j]: this rank's node i, sum s, term j; sums[s] receives the same bits on every rank and
  /// as one process's sequential loop (a term one process skips is given as 0).
  virtual void sumInNodeOrder(const Real* terms, int nSums, int per, Real* sums) = 0;
  /// Sum n values over every rank, in place; the largest and the smallest of one value.
  virtual void sumAll(Real* v, int n) = 0;
  virtual Real maxAll(Real v) = 0;
  virtual Real minAll(Real v) = 0;
  /// [node] 1 where this rank owns the node: node sums count each node on its owner only.
  virtual const std::uint8_t* owned() const = 0;
  /// Frontier nodes this rank holds but does not own.
  virtual const std::vector<Index>& ghosts() const = 0;
  /// The largest difference, over every rank, between this rank's copy of a frontier node's values
  /// (`comps` per node) and another rank's copy of the same node: 0 when the copies agree bitwise.
  virtual Real frontierMismatch(const Real* data, int comps) = 0;
  /// Wall time this rank has spent waiting for the others so far (the frontier sums' and the
  /// reductions' completion), s.
  virtual double waitSeconds() const = 0;
};

/// The stable time step and what limits it.
struct StableStep {
  Real dtCritical = 0;  ///< (2/ω)(√(1+ξ²) - ξ) at ω = omegaLimit (s)
  Real dtSafe = 0;      ///< safety * dtCritical (s)
  Real omegaMax = 0;    ///< max element frequency 2 c_p / L_e (rad/s)
  Real omegaLimit = 0;  ///< the limiting element's frequency: ω_max, or a viscous block's own ω_b (rad/s)
  Real xiMax = 0;       ///< damping ratio at omegaLimit from β, a viscous material's τ (and α for paper_eq3_4)
  std::string block;    ///< block of the limiting element
  Index element = -1;   ///< mesh index of the limiting element
  Real charLength = 0;  ///< its V / A_max (m)
  Real waveSpeed = 0;   ///< its c_p (m/s)
};

/// Energy balance (J). balance = kinetic + internal + damping + boundary - external stays
/// constant; `error` is its drift relative to the largest of the terms.
struct EnergyBalance {
  Real kinetic = 0;    ///< ½ m v^{n-½}·v^{n+½} (central difference; exact invariant when undamped)
  Real internal = 0;   ///< strain energy incl. hourglass (= work of the stresses); subcycled: the work
                       ///< of the internal forces booked at each node's updates, like `external`
  Real damping = 0;    ///< dissipated by Rayleigh damping
  Real boundary = 0;   ///< absorbed by boundary dashpots
  Real external = 0;   ///< work of the external forces
  Real interface = 0;  ///< dissipated by contributors (interface friction); not part of `external`
  Real plastic = 0;    ///< dissipated by plasticity and damage (already part of `internal`)
  Real error = 0;      ///< |balance - balance_0| / max(terms)
};

struct SolverOptions {
  Integrator integrator = Integrator::CentralDifference;
  RayleighDamping damping;
  Real safety = 0.9;               ///< stable-step safety factor
  Real dt = 0;                     ///< user step (s); 0 = safety * critical
  bool allowUnstableStep = false;  ///< testing only: accept dt above the stable limit
  Real velocityLimit = 1.0e3;      ///< |v| above this (m/s) counts as exploding
  Real gravity[3] = {0, 0, 0};     ///< body acceleration (m/s^2), e.g. {0, 0, -9.81}
  /// Subcycling during the time loop (Solver::enableSubcycling): an element may step up to
  /// 2^subcyclingLevels times the finest step where its own stable step allows; 0 = off.
  int subcyclingLevels = 0;
};

/// What enableSubcycling set up.
struct SubcyclingInfo {
  int levels = 0;               ///< the coarsest level in use (steps of 2^levels fine steps)
  std::vector<Index> nodes;     ///< nodes per level
  std::vector<Index> elements;  ///< active elements per level (their chunk's level)
  Real costFraction = 1;        ///< element evaluations per fine step / active elements
};

/// Dynamic relaxation to static equilibrium (explicit steps with adaptive critical mass damping,
/// Underwood's Rayleigh-quotient estimate of the lowest active frequency).
struct RelaxResult;
struct RelaxParams {
  Real tolerance = 1e-6;  ///< stop when |f_ext - f_int| / |f_ext| on free dofs is below this
  Index maxSteps = 200000;
  Index checkEvery = 10;  ///< steps between residual checks
  /// Scale each element's mass so that all share the largest element's critical step (statics
  /// only: the equilibrium does not depend on the mass; gravity keeps the true mass). Turns the
  /// step count from (largest/smallest element) × (elements across) into (elements across).
  bool massScaling = false;
  /// If > 0: the ratio is |f_ext − f_int|₂ (free dofs) / referenceForce instead, e.g. the
  /// out-of-balance force a stage starts from (its load), so the tolerance means "this stage's
  /// load equilibrated to that fraction" whatever else the model carries.
  Real referenceForce = 0;
  /// Called at every check with the result so far (progress lines).
  std::function<void(const RelaxResult&)> onCheck;
};
struct RelaxResult {
  Index steps = 0;
  Real ratio = 0;  ///< final unbalanced-force ratio
  bool converged = false;
};

class Solver {
 public:
  Solver(const Mesh& mesh, std::vector<std::unique_ptr<ElementBlock>> blocks, SolverOptions opt);

  // ---- set-up -------------------------------------------------------------------------------
  /// Fix direction d (0 x, 1 y, 2 z) of a node (zero displacement increment).
  void fix(Index node, int d);
  /// Free a fixed direction again (a static support replaced by a dynamic boundary).
  void release(Index node, int d) { free_[dofIndex(node, d)] = 1; }
  /// Fix the given directions ("x", "xz", "xyz", ...) of every node of a face group.
  void fixFaceGroup(const std::string& group, const std::string& dirs);
  void addLoad(NodalLoad load) { loads_.push_back(std::move(load)); }
  /// Add a contributor to a phase of the external force (after those added to it before). A
  /// constant force (constantForces()) added to the Loads phase is folded into gravity's parallel
  /// pass, up to kMaxFoldedLoads of them; any more run as the other Loads contributors do.
  void addContributor(ForcePhase phase, std::shared_ptr<NodalForceContributor> c);
  static constexpr int kMaxFoldedLoads = 4;
  /// Recompute lumped masses and the node->corner map (after (de)activating elements).
  void rebuild();
  /// The stable step for the current mesh, materials and damping.
  StableStep stableStep() const;
  /// Set the step; throws InputError (with the limiting element) when above the stable one
  /// unless options.allowUnstableStep. dt = 0 picks safety * critical.
  void setTimeStep(Real dt);

  // ---- time stepping ------------------------------------------------------------------------
  /// One explicit step: element forces -> assembly -> external forces (gravity and the
  /// contributors, phase by phase in ForcePhase order) -> update -> check. beginStep(), finishStep().
  void step();
  /// The step in two halves, for the water coupling's exchange (CoupledStepper), which needs the
  /// step's other forces before the water's: beginStep() assembles f_int and the external force of
  /// the phases before ForcePhase::Water; finishStep() adds the Water and Ties phases and updates.
  /// Between the two the step is open (stepOpen()); restoring a checkpoint abandons an open step.
  void beginStep();
  void finishStep();
  bool stepOpen() const { return stepOpen_; }
  /// Steps until time >= tEnd (calls `each` after every step if given).
  void runUntil(Real tEnd, const std::function<void()>& each = {});
  /// Dynamic relaxation to static equilibrium (Rayleigh damping is suspended meanwhile).
  RelaxResult relax(const RelaxParams& p);
  /// Start the seismic record: velocities zeroed, displacements from here on reported relative
  /// to the current (equilibrium) state by relativeDisplacement(), energies restart at 0.
  void resetMotion();
  /// Displacement relative to the state at the last resetMotion() (m).
  Real relativeDisplacement(Index node, int d) const;
  /// Evaluate f_int and f_ext (gravity, loads and, if asked, the contributors) at the current
  /// displacement without stepping and without damping forces (support reactions at rest).
  void computeForces(bool withContributors);
  /// Save (archive.beginSave()) or restore (beginRestore()) the whole mutable state: nodes,
  /// element stresses and history, energies, clock and every contributor's state. A restored
  /// solver continues bitwise as the saved one did.
  void checkpoint(StateArchive& archive);
  /// Subcycling (multi-time-step explicit integration, nodal partition with linear interpolation,
  /// Belytschko, Yen & Mullen 1979; docs/solid_solver.md "Subcycling"). Each node gets the level
  /// ℓ = min over its active elements of floor(log2(Δt_e / Δt)) (at most maxLevel; Δt_e = safety ×
  /// the element's own critical step), lowered where the contributors ask (constrainLevels) and so
  /// that the nodes of one element differ by at most one level.
  /// A node of level ℓ updates its velocity every 2^ℓ fine steps with the step 2^ℓ Δt and moves
  /// with it linearly in between; an element chunk is evaluated every 2^ℓ fine steps, ℓ the
  /// finest level of its nodes. Needs the central difference and no stiffness damping (β = 0).
  /// Throws InputError otherwise. maxLevel = 0 turns it off.
  SubcyclingInfo enableSubcycling(int maxLevel);
  /// What enableSubcycling refuses (levels, integrator, stiffness damping, a viscous material),
  /// without setting anything up: the starter asks it before the static stages. Throws InputError.
  void checkSubcycling(int maxLevel) const;
  /// What planRepasses set up.
  struct RepassPlan {
    Index chunks = 0, skippedChunks = 0;      ///< element chunks, and those a re-pass leaves alone
    Index elements = 0, skippedElements = 0;  ///< their active elements
    Index replayNodes = 0;  ///< nodes whose internal force a re-pass takes from the window's first pass
    Index nodeChunks = 0, frozenNodeChunks = 0;  ///< node chunks, and those a re-pass leaves alone
    Index frozenNodes = 0;                       ///< their nodes
    std::string why;       ///< empty when set up, else why not (every re-pass is then stepped whole)
    std::string whyNodes;  ///< set up, but every node chunk stepped: why (empty otherwise)
  };
  /// A coupling window of `windowSteps` steps whose water loads the nodes `wet` (CoupledStepper):
  /// between its passes only that force differs, and an explicit step carries a change one element
  /// ring further at most (a node of level L takes it up at its updates only), so a re-pass need
  /// evaluate only the element chunks with an element on a node the change can reach within the
  /// window. The others it neither evaluates nor restores (their stresses, strains and history stay
  /// as the first pass left them, its last), and the nodes they act on take their internal force
  /// and the chunks their energy terms, step by step, from the first pass: the same bits as a
  /// re-pass stepped whole. Needs one process, the blocks' slabs in one loop, no material with a
  /// block pass, every contributor's forceGroups, and with subcycling windows of a multiple of the
  /// coarsest level's steps; `why` says which is missing otherwise. Subcycled, a re-pass also
  /// leaves alone the node chunks (kNodeChunk nodes in a row) of nodes that no element it evaluates
  /// acts on, that the change does not reach, and that no contributor reads (its force groups and
  /// motionReadNodes): it neither restores nor updates them (they end as the first pass ended
  /// them), and each such chunk's energy terms come from the first pass step by step; `whyNodes`
  /// says why none are left alone where the elements are. Plan after enableSubcycling.
  RepassPlan planRepasses(const std::vector<Index>& wet, Index windowSteps);
  /// A window's passes (CoupledStepper): beginPass(false) before the window's save and its first
  /// pass (which records what a re-pass takes from it; the save then holds what a re-pass restores
  /// only), beginPass(true) before each restore for a further pass, endPasses() once the water
  /// accepts the window. Nothing without a plan.
  void beginPass(bool repass);
  void endPasses();
  /// Set the clock (the seismic stage restarts it at 0 after the static stages).
  void setTime(Real t) { t_ = t; }
  /// The solid on ranks (tq/parallel/): the exchange with the other ranks (not owned; null: one
  /// process). Call rebuild() and setTimeStep() after setting it (summed masses, reduced step).
  void setRankExchange(RankExchange* x) { rx_ = x; }
  /// Whether the internal forces run the slabs of every element block in one parallel loop a
  /// parity (the default where no node is in two blocks and the solver is not on ranks) or block
  /// after block: the same bits either way.
  void setBlockSlabsInOneLoop(bool on) { blocksOneLoop_ = on; }
  bool blockSlabsInOneLoop() const { return blocksDisjoint_ && blocksOneLoop_ && !rx_; }
  /// Subcycling on one process: a step sets f_int to zero and f_ext to the constant loads only in
  /// the node chunks that hold a node due at it (true, the default), or in every chunk (false; the
  /// same bits: no update reads a node's forces at a step it is not due).
  void setDueChunksOnly(bool on) { dueChunksOnly_ = on; }
  /// The node chunks a step of level `activeLevel` sets, and all of them.
  Index nodeChunksSet(int activeLevel) const;
  Index numNodeChunks() const;
  RankExchange* rankExchange() const { return rx_; }
  /// A solver that only holds a state gathered from the ranks for the results (tq/parallel/): the
  /// energy balance the ranks reduced (its plastic part is summed from this solver's blocks).
  void setReportedEnergy(const EnergyBalance& e) {
    energy_ = e;
    plasticStale_ = true;
  }

  // ---- access -------------------------------------------------------------------------------
  NodalState& state() { return state_; }
  const NodalState& state() const { return state_; }
  const Mesh& mesh() const { return mesh_; }
  std::vector<std::unique_ptr<ElementBlock>>& blocks() { return blocks_; }
  const std::vector<std::unique_ptr<ElementBlock>>& blocks() const { return blocks_; }
  const SolverOptions& options() const { return opt_; }
  Real time() const { return t_; }
  Real dt() const { return dt_; }
  Index stepCount() const { return step_; }
  /// The energy balance after the last step (the plastic dissipation, a sum over every element,
  /// is summed here on demand rather than every step). After a step that did not sum the kinetic
  /// energy (setKineticEnergyWanted) its `kinetic` and `error` are NaN; the works are whole.
  const EnergyBalance& energy() const;
  /// Whether the steps from now on sum the kinetic energy (default: every step). It is a state, not
  /// an accumulated work, and the balance needs it only where it is read: a time loop that reads
  /// energy() after some steps only (the results' samples) turns it off for the others, which skip
  /// its sum in the node update. The first step after resetMotion() sums it in any case (the
  /// balance's reference). On ranks every rank must be given the same setting.
  void setKineticEnergyWanted(bool wanted) { kineticWanted_ = wanted; }
  /// The energy error of the last step that summed the kinetic energy (NaN before the first one),
  /// and the time that step ended at (s): for progress lines.
  Real checkedEnergyError() const { return checkedError_; }
  Real checkedEnergyTime() const { return checkedTime_; }
  bool isFixed(Index node, int d) const { return free_[dofIndex(node, d)] == 0; }
  /// Mass-proportional damping coefficient of the current step (1/s): α, or the relaxation's.
  Real massDampingCoefficient() const { return alphaRelax_ >= 0 ? alphaRelax_ : opt_.damping.alpha; }
  /// The nodal force contributors with their phases, in the order they were added.
  const std::vector<AddedContributor>& contributors() const { return contributors_; }
  /// Latest velocity: v^{n+½} after a central-difference step to t_{n+1} (half a step behind the
  /// displacement), v^{n+1} for paper_eq3_4.
  Real velocityAt(Index node, int d) const;
  /// Residual |f_ext - f_int| / max(|f_ext|, |f_int|) over free dofs (2-norms).
  Real unbalancedRatio() const;
  /// Same, with the reference norms over all dofs (supports included) when allDofsReference.
  Real unbalancedRatio(bool allDofsReference) const;
  /// |f_ext − f_int|₂ over the free dofs (N).
  Real residualNorm() const;

 private:
  void computeInternalForces(int activeLevel = 255);
  void computeExternalForces();
  void addPhaseForces(ForcePhase first, ForcePhase last);  // the contributors of the phases first … last
  void addGravityAndFoldedLoads(int activeLevel = 255);    // the Loads phase's parallel pass
  void addGravityAndLoads(int activeLevel = 255);          // gravity, the folded loads, the NodalLoads
  /// Subcycling: whether node chunk c holds a node due at a step of level activeLevel (a chunk
  /// that does not needs neither its f_int zeroed nor its f_ext set: no update reads them).
  bool chunkDue(Index c, int activeLevel) const { return activeLevel >= int(nodeChunkLevel_[size_t(c)]); }
  bool everyChunkDue(int activeLevel) const {
    return !dueChunksOnly_ || nodeChunkLevel_.empty() || activeLevel >= maxChunkLevel_;
  }
  void updateNodes();
  void updateNodesSubcycled(int activeLevel);
  void bookNodeChunks(Index nChunks);  // after a node update: sum its chunks, check, book
  void finishEnergy(Index bad = -1);   // the balance terms from the accumulated works (after a node update)
  // On ranks: the ghost nodes' share of a node update's sums, taken out again (they count on their owner).
  void subtractGhostSums(Real& ke, Real& ext, Real& damp, Real& bdry, Real& wint) const;
  [[noreturn]] void reportInstability(Index dof, Real value);

  const Mesh& mesh_;
  std::vector<std::unique_ptr<ElementBlock>> blocks_;
  SolverOptions opt_;
  NodalState state_;
  std::vector<std::uint8_t> free_;     // [3N] 1 free, 0 fixed (one byte per dof: streamed every step)
  std::vector<Real> fExtPrev_, uRef_;  // f_ext of the previous step (swapped with the state's each step, for
                                       // the trapezoidal work); the seismic reference
  std::vector<NodalLoad> loads_;
  std::vector<AddedContributor> contributors_;  // in the order added
  Real t_ = 0, dt_ = 0, dtLast_ = 0;
  Index step_ = 0;
  // planRepasses: the plan, and what the window's first pass records for its re-passes
  struct Repasses {
    bool planned = false;
    int mode = 0;      // 0 off, 1 the first pass (records), 2 a re-pass (replays)
    Index period = 1;  // a window's first step is at a multiple of it (every level due there)
    std::vector<std::vector<Index>> nodesByLevel;                  // [level] the nodes whose f_int is replayed
    std::vector<std::array<Index, 3>> chunks;                      // the skipped chunks: block, chunk, level
    std::vector<Real> fInt;                                        // recorded f_int, step by step
    std::vector<BlockEnergy> energy;                               // recorded chunk energies, step by step
    size_t fAt = 0, eAt = 0;                                       // a re-pass's read positions
    std::vector<std::uint8_t> frozen;                              // [node chunk] 1: left alone by a re-pass
    Index nFrozen = 0;                                             // chunks with frozen = 1
    std::vector<Index> frozenAt;                                   // [node chunk] its place among the frozen ones
    std::vector<std::pair<size_t, size_t>> dofRanges, nodeRanges;  // the other chunks' [dof) and [node)
    std::vector<Real> sums;                                        // the frozen chunks' node-update sums, step by step
    size_t sAt = 0;                                                // a re-pass's read position in sums
  };
  // a pass of this mode (1 a window's first, 2 a re-pass) with node chunks a re-pass leaves alone
  bool leavesNodeChunks(int mode) const { return rp_.mode == mode && rp_.nFrozen > 0; }
  bool frozenChunk(Index c) const { return leavesNodeChunks(2) && rp_.frozen[size_t(c)]; }
  Repasses rp_;
  void repassEnergies(int activeLevel);  // computeInternalForces: the skipped chunks' energy terms
  void repassForces(int activeLevel);    // computeInternalForces: the replayed nodes' f_int
  int activeLevel_ = 255;                // subcycling: the level of the open step (beginStep to finishStep)
  bool stepOpen_ = false;
  Real alphaRelax_ = -1;          // >= 0 while relaxing: replaces α
  mutable EnergyBalance energy_;  // energy_.plastic: summed by energy() when plasticStale_
  mutable bool plasticStale_ = true;
  bool kineticWanted_ = true;  // setKineticEnergyWanted
  bool kineticStep_ = true;    // the last node update summed the kinetic energy
  Real checkedError_ = std::numeric_limits<Real>::quiet_NaN(), checkedTime_ = std::numeric_limits<Real>::quiet_NaN();
  Real stressWork_ = 0, storedEnergy_ = 0, dampWork_ = 0, bdryWork_ = 0, extWork_ = 0;
  Real balance0_ = 0;
  Real interface0_ = 0, plastic0_ = 0;  // dissipation totals at the last resetMotion()
  Real boundary0_ = 0;                  // contributors' boundary energy at the last resetMotion()
  std::vector<Real> gravityMass_;       // true masses for gravity while relax() scales them
  // Gravity and the folded constant loads summed (addGravityAndFoldedLoads), and what they were
  // summed from: the masses' version, gravityMass_'s, the folded loads (the gravity vector is the
  // options', fixed for the solver's life).
  struct ConstantLoads {
    std::vector<Real> f;  // [3N]
    std::uint64_t massVersion = ~std::uint64_t(0), gravityMassVersion = 0;
    const Real* folded[kMaxFoldedLoads] = {};
    int nFolded = -1;
  };
  ConstantLoads constantLoads_;
  std::uint64_t gravityMassVersion_ = 0;  // changes with gravityMass_
  bool balanceSet_ = false;
  bool avx2_ = false;                // node update path (ElementBlock::defaultUseAvx2)
  std::vector<Real> nodeChunkSums_;  // per node chunk: ke, ext, damp, bdry, bad dof
  // Subcycling: node levels, f_ext and f_int at each node's last velocity update and the step that
  // update took (the trapezoidal works over its next step), fine steps since enableSubcycling; the
  // internal energy is then the elements' at enableSubcycling (intBase_) plus the internal forces'
  // work booked at the node updates (nodalIntWork_), as the external work is.
  std::vector<std::uint8_t> nodeLevel_;
  // The finest level of each node chunk's nodes (one process only; empty on ranks and single-rate),
  // and the coarsest of those: a step of that level or coarser has every chunk due.
  std::vector<std::uint8_t> nodeChunkLevel_;
  int maxChunkLevel_ = 0;
  bool dueChunksOnly_ = true;  // setDueChunksOnly
  std::vector<Real> fSync_, fIntSync_, dtPrevNode_;
  Real intBase_ = 0, nodalIntWork_ = 0;
  Index cycle_ = 0;
  // On ranks (tq/parallel/): the exchange, and the ghost nodes' velocities before a node update.
  RankExchange* rx_ = nullptr;
  bool blocksDisjoint_ = false;  // two blocks or more and no node in two: their slabs in one loop
  bool blocksOneLoop_ = true;    // setBlockSlabsInOneLoop
  struct SlabTask {
    size_t block;
    Index slab, width;
  };
  /// computeInternalForces: [step level, the last for every level from it on][parity] the slabs of
  /// every block, widest first
  static constexpr int kSlabTaskLevels = 16;
  std::vector<std::array<std::vector<SlabTask>, 2>> slabTasks_;
  std::vector<Real> rankTerms_;  // on ranks: the relaxation's per-node terms (RankExchange::sumInNodeOrder)
  std::vector<Real> ghostV_;
  // subcycling on ranks: the ghosts' fSync_, fIntSync_, accelerations and dtPrevNode_ before the update
  std::vector<Real> ghostFs_, ghostFis_, ghostA_, ghostDtp_;
};

/// The mesh region of each material's region name, in the order given; InputError naming the fix for
/// a name the mesh has no region of, or for a region with elements and no material.
std::vector<Index> materialRegions(const Mesh& mesh, const std::vector<std::string>& names);

/// One block per mesh region, each with the material given for that region name.
std::vector<std::unique_ptr<ElementBlock>> makeBlocksByRegion(
    const Mesh& mesh, const std::vector<std::pair<std::string, std::shared_ptr<const Material>>>& materials,
    Hex8Formulation formulation = Hex8Formulation::OnePointAssumedStrain);

}  // namespace tq
