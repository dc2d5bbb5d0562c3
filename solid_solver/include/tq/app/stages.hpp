/// @file stages.hpp
/// @brief The staged analysis (paper §3.2; ARCHITECTURE.md §2; docs/theory.md §2): in-situ
///        stress, excavation, lining activation with the rock–lining interface, hydrostatic
///        internal pressure, static equilibrium by dynamic relaxation after each change, and the
///        switch to the seismic stage (displacements zeroed, supports replaced by their reactions
///        plus the viscoelastic base and free-field sides, so nothing jumps).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tq/boundaries/boundaries.hpp"
#include "tq/boundaries/drm.hpp"
#include "tq/core/constraints.hpp"
#include "tq/io/input.hpp"

namespace tq {

class HeldExcavationLoad;
class PrescribedSlip;

/// One MPI rank's part of the model for the staged analysis (tq/parallel/): the face groups, the
/// interface pairs, the supports and the seismic boundaries are resolved on the whole model's mesh,
/// as in one process, and mapped onto the rank's nodes; every sum over the model (norms, energies)
/// counts each node on its owner and is summed over the ranks.
struct RankPart {
  int rank = 0;
  const Mesh* global = nullptr;                      ///< the whole model's mesh
  const std::vector<Index>* localNode = nullptr;     ///< [global node] local index, or −1
  const std::vector<std::uint8_t>* owned = nullptr;  ///< [local node] 1 where this rank owns it
  std::vector<const Material*> elementMaterial;      ///< [global element] its region's material
};

/// What one stage did.
struct StageReport {
  std::string name;
  Index steps = 0;  ///< dynamic relaxation steps (0: no relaxation in this stage)
  Real ratio = 0;   ///< final |unbalanced| / max(the stage's initial out-of-balance force, 1e-6 × force scale)
  bool converged = true;
  double wallSeconds = 0;
  std::string note;  ///< e.g. the interface model used, the reactions held at the switch
};

/// Drives the stages of a version 2 input on a built solver. The solver must outlive it.
class StagedAnalysis {
 public:
  /// Checks the stage prerequisites against the mesh (lining region, interface pairs, faces).
  /// Throws InputError.
  /// On MPI ranks `mesh` and `solver` are the rank's part, and `part` says how it maps onto the
  /// whole model (copied; null: one process).
  StagedAnalysis(const SolidInput& in, const Mesh& mesh, Solver& solver, const RankPart* part = nullptr);

  /// Run the static stages (in_situ … hydrostatic) in order; a `lining` stage first deactivates
  /// the lining (installed stress-free in its stage). Progress lines go to `log` every
  /// `progressSeconds` of wall time. Throws InstabilityError if a stage does not reach the
  /// relaxation tolerance within relaxation_max_steps.
  void runStatics(std::ostream& log, double progressSeconds = 5);
  /// Start the seismic stage: zero the motion record (resetMotion), hold the support reactions of
  /// the released supports (and, with equilibrium_correction, the residual out-of-balance force)
  /// as constant forces, install the seismic boundaries, restart the clock at t = 0.
  void switchToDynamics(std::ostream& log);

  bool hasSeismic() const { return in_.staged.stages.has("seismic"); }
  const std::vector<StageReport>& reports() const { return reports_; }
  /// Residual out-of-balance force held at the switch, relative to the force norms (0 if none).
  Real correctionRatio() const { return correctionRatio_; }
  const std::shared_ptr<SeismicBoundaries>& seismic() const { return seismic_; }
  const std::shared_ptr<DomainReduction>& domainReduction() const { return drm_; }
  const std::shared_ptr<NodalForceContributor>& rockLiningInterface() const { return interface_; }
  const std::shared_ptr<ConstantNodalForces>& heldForces() const { return held_; }
  /// The part (1 − λ) of the excavation load held from the excavation stage to the lining stage
  /// (/stages release_fraction λ < 1; null otherwise). Released, it adds no force.
  const std::shared_ptr<HeldExcavationLoad>& heldExcavationLoad() const { return unreleased_; }
  /// On ranks: the index in the whole model's pair list (rockLiningPairs) of each pair of the
  /// dynamic contact (its pairs are those this rank holds), and whether this rank owns it.
  const std::vector<Index>& contactPairIndex() const { return contactPairIndex_; }
  const std::vector<std::uint8_t>& contactPairOwned() const { return contactPairOwned_; }

 private:
  void setInSituStress();
  StageReport relaxStage(const std::string& name, std::ostream& log, double progressSeconds);
  /// Why a static stage did not converge: which region holds the unbalanced force and where its
  /// largest nodal value is, and whether the ratio was still falling (`history`: steps, ratio).
  std::string notInEquilibrium(const std::string& name, const RelaxResult& r,
                               const std::vector<std::pair<Index, Real>>& history);
  /// The fault_offset stage: the /fault_offset nodes fixed and moved, in its increments, each
  /// relaxed (the report sums their steps and times).
  StageReport faultOffsetStage(std::ostream& log, double progressSeconds);
  void activateLining(std::ostream& log, StageReport& rep);
  void installInterface(std::ostream& log, StageReport& rep);
  void holdUnreleasedLoad(std::ostream& log, StageReport& rep);

  // On ranks: the local index of a global node (−1: not held), whether a local node counts in the
  // model's sums, the sum of n values over the ranks (nothing in one process), a [3N] global force
  // on the local nodes.
  Index local(Index globalNode) const { return part_ ? (*part_->localNode)[size_t(globalNode)] : globalNode; }
  bool counts(Index node) const { return !part_ || (*part_->owned)[size_t(node)] != 0; }
  void sumRanks(Real* v, int n) const;
  std::vector<Real> toLocal(const std::vector<Real>& global) const;
  bool isLining(const ElementBlock* b) const;

  const SolidInput& in_;
  const Mesh& mesh_;   // the solver's mesh (on ranks: the rank's part)
  const Mesh& model_;  // the whole model's mesh (face groups, pairs, extents)
  Solver& solver_;
  std::unique_ptr<RankPart> part_;      // on ranks
  std::vector<ElementBlock*> linings_;  // the blocks of the lining region (on ranks: a frontier and an interior one)
  bool hasLining_ = false;              // the whole model has lining elements
  std::vector<Index> contactPairIndex_;
  std::vector<std::uint8_t> contactPairOwned_;
  std::vector<StageReport> reports_;
  std::shared_ptr<NodalForceContributor> interface_;
  std::shared_ptr<ConstantNodalForces> pressure_, held_;
  std::shared_ptr<SeismicBoundaries> seismic_;
  std::shared_ptr<DomainReduction> drm_;  // /drm: built (and checked) with the stages, added at the switch
  std::shared_ptr<HeldExcavationLoad> unreleased_;
  std::shared_ptr<PrescribedSlip> slip_;  // /fault_offset with rise_time > 0, from the switch on
  Real correctionRatio_ = 0;
};

/// Constant nodal forces that hold back the unreleased part of the excavation load until the
/// lining is active; release() removes them (the solver then relaxes their release on the
/// composite rock and lining).
class HeldExcavationLoad final : public NodalForceContributor {
 public:
  explicit HeldExcavationLoad(std::vector<Real> forces) : f_(std::move(forces)) {}
  std::string name() const override { return "held excavation load"; }
  void addForces(Real t, Real dt, NodalState& state) override;
  bool forceGroups(std::vector<std::vector<Index>>& /*groups*/) const override { return true; }  // held values
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }
  void release() { released_ = true; }
  bool released() const { return released_; }
  const std::vector<Real>& forces() const { return f_; }

 private:
  std::vector<Real> f_;  // [3N]
  bool released_ = false;
};

/// A fault's slip during the seismic stage (/fault_offset with rise_time > 0): each node, held in
/// x, y, z by the solver, is put at u0 + d ramp(t) before each step's update, u0 its displacement at
/// the switch, d its displacement, ramp(t) = ½(1 − cos(π (t − t0)/T)) on [t0, t0 + T] (0 before, 1
/// after), so the next step's element forces see the slip at its end. The held nodes' velocity
/// stays 0 in the state (a stiffness-proportional damping does not see the slip's rate).
class PrescribedSlip final : public NodalForceContributor {
 public:
  PrescribedSlip(const FaultOffsetInput& in, const NodalState& state);
  std::string name() const override { return "prescribed fault slip"; }
  void addForces(Real t, Real dt, NodalState& state) override;
  void checkpoint(StateArchive& a) override { a.io(u0_); }
  /// The ramp at time t (0 … 1).
  Real ramp(Real t) const;

 private:
  std::vector<Index> nodes_;
  std::vector<Real> d_, u0_;  // [3N]
  Real t0_, rise_;
};

/// λ_min/8 check (Kuhlemeyer & Lysmer 1973): elements whose longest edge exceeds c_s/(8 f) for
/// the cut-off frequency f (Hz). Returns a warning line, or "" when every element is small enough.
std::string elementSizeWarning(const Solver& solver, Real cutoffFrequency);

}  // namespace tq
