/// @file contact.hpp
/// @brief The rock–lining interface: the dynamic contact force method (paper eqs. 9–13;
///        ARCHITECTURE.md §3; docs/theory.md §4) between coincident, duplicated node pairs
///        (rock node 1, lining node 2).
///
/// Each step, after every force of the earlier phases is known (ForcePhase::Interface), both nodes of a pair are
/// predicted without the contact force by the solver's own update formula; the contact force R1 = −R2 (eq. 9) that
/// makes the pair end the step together is
///     R1 = K ∘ Δ,  K_d = 1 / (w1_d + w2_d),  w_d = Δu per unit force of the node in direction d
/// — for the central difference w = Δt² / (m + ½(α m + c)Δt), i.e. K = M1 M2 / ((M1 + M2) Δt²)
/// without damping; for the literal eqs. (3)–(4) w = Δt²/(2m), i.e. the paper's
/// K = 2 M1 M2 / ((M1 + M2) Δt²). Δ is the predicted gap (10): normal part n·(Ũ2 − Ũ1), tangential
/// part the increment of the tangential relative displacement (the total one while bonded).
/// R1 is split into N (along n, from node 2 to node 1: compression > 0) and T, then corrected:
///  - opening (Δn < 0): separation when the tension exceeds f_c A (12) → N = T = 0; a bonded
///    pair in tension below f_c A also fails when |T| > f_c A − μs|N| (Coulomb in tension);
///  - closing (Δn ≥ 0): slip when |T| > μs N + f_c A → |T| = μd N along the trial T (13);
///  - a separated pair feels nothing until its predicted gap closes; it then gets exactly the
///    normal force that closes the gap (no penetration) and sticks or slides by friction.
/// After a failure (slip or separation) the pair's cohesion is lost (default) or kept.
#pragma once

#include <string>
#include <vector>

#include "tq/contact/pair_prediction.hpp"
#include "tq/core/mesh.hpp"
#include "tq/core/solver.hpp"

namespace tq {

/// How the pairs interact.
enum class InterfaceModel {
  DynamicContact,  ///< the paper's method: bond, separation, slip, re-contact (default)
  Bonded,          ///< always bonded: the pair moves as one node (no failure)
};
/// What a pair keeps once its bond has failed (docs/theory.md §4).
enum class AfterFailure {
  CohesionLost,  ///< default: from then on only friction (and no tension)
  CohesionKept,  ///< f_c A stays in the checks: a closed pair that sticks carries tension again
};
InterfaceModel parseInterfaceModel(const std::string& name);  // "dynamic_contact" | "bonded"
AfterFailure parseAfterFailure(const std::string& name);      // "cohesion_lost" | "cohesion_kept"
std::string interfaceModelName(InterfaceModel m);
std::string afterFailureName(AfterFailure a);

/// Interface parameters (paper: μs = μd = 0.6, f_c = 0.5 MPa).
struct ContactParams {
  InterfaceModel model = InterfaceModel::DynamicContact;
  Real staticFriction = 0.6;   ///< μs (-)
  Real dynamicFriction = 0.6;  ///< μd (-), ≤ μs
  Real cohesion = 0.5e6;       ///< f_c (Pa): bond strength in tension and shear per unit area
  AfterFailure afterFailure = AfterFailure::CohesionLost;
  void check() const;  ///< throws InputError on bad values
};

/// Geometry of the node pairs.
struct ContactPairs {
  std::vector<Index> node1;  ///< rock node of each pair
  std::vector<Index> node2;  ///< lining node of each pair
  std::vector<Real> normal;  ///< [3P] unit normal n1, from node 2 towards node 1 (lining → rock)
  std::vector<Real> area;    ///< [P] tributary (control) area A1 (m²)
  Index size() const { return Index(node1.size()); }
};

/// The pairs of mesh.h5's /interfaces/rock_lining with normals and tributary areas from the
/// face group `lining_outer` (area-weighted average of the adjacent quads' outward normals at the
/// lining node, a quarter of each quad's area), or else from `rock_hole` (its normals reversed).
/// Throws InputError if the mesh has no pairs, no such face, a pair whose nodes do not coincide,
/// or a pair node on no face.
ContactPairs rockLiningPairs(const Mesh& mesh);

/// Per-pair state, as written to results.h5 (/interface/state).
enum class PairState : int {
  Bonded = 0,     ///< intact bond (or re-bonded with cohesion_kept): no relative motion
  Separated = 1,  ///< open: no force
  Slipping = 2,   ///< in contact, sliding with |T| = μd N
  Stuck = 3,      ///< in contact and sticking by friction after its bond failed (cohesion lost)
  Inactive = 4,   ///< a node of the pair has no mass yet (e.g. lining not yet installed)
};

/// The dynamic contact force between the pairs; add it to the solver in ForcePhase::Interface.
class DynamicContact final : public NodalForceContributor {
 public:
  /// The solver supplies the masses, supports and damping of the prediction; it must outlive this.
  DynamicContact(const Solver& solver, ContactPairs pairs, ContactParams params);
  std::string name() const override { return "rock-lining dynamic contact"; }
  void addForces(Real t, Real dt, NodalState& state) override;
  Real dissipatedEnergy() const override { return -work_; }
  /// Subcycling: the pairs step every fine step (their force is predicted from each step's motion).
  bool constrainLevels(std::vector<std::uint8_t>& level) const override {
    const bool rock = lowerToFinestLevel(level, pairs_.node1);
    return lowerToFinestLevel(level, pairs_.node2) || rock;
  }
  /// Each pair's force comes from its two nodes' motion.
  bool forceGroups(std::vector<std::vector<Index>>& groups) const override {
    for (Index p = 0; p < pairs_.size(); ++p) groups.push_back({pairs_.node1[size_t(p)], pairs_.node2[size_t(p)]});
    return true;
  }
  /// Its state reads its groups' motion only.
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }
  void checkpoint(StateArchive& a) override {
    a.io(state_);
    a.io(failed_);
    a.io(cohesive_);
    a.io(r0_);
    a.io(force_);
    a.io(relPrev_);
    a.io(fn_);
    a.io(ft_);
    a.io(work_);
  }

  const ContactPairs& pairs() const { return pairs_; }
  const ContactParams& params() const { return params_; }
  Index numPairs() const { return pairs_.size(); }
  PairState state(Index p) const { return PairState(state_[size_t(p)]); }
  /// True once the pair's bond has failed (slip or separation) at least once.
  bool failed(Index p) const { return failed_[size_t(p)] != 0; }
  /// Opening −n·(u2 − u1 − r0) (m, > 0 open), r0 the offset when the pair became active.
  Real opening(Index p, const NodalState& s) const;
  /// Tangential relative displacement |(I − n nᵀ)(u2 − u1 − r0)| (m): the slip so far.
  Real slip(Index p, const NodalState& s) const;
  /// Normal (compression > 0) and tangential force magnitudes on the pair in the last step (N).
  Real normalForce(Index p) const { return fn_[size_t(p)]; }
  Real tangentialForce(Index p) const { return ft_[size_t(p)]; }
  /// Number of pairs in a state.
  Index count(PairState s) const;

  /// On MPI ranks (tq/parallel/): every rank computes each pair it holds, but only the pairs marked
  /// here (those it owns) count in its dissipated energy, so that the ranks' sum counts each once.
  void countOnly(std::vector<std::uint8_t> counted) { counted_ = std::move(counted); }
  /// Compute the pairs on the solver's threads (where no node is in two pairs; the default from
  /// kThreadedPairs pairs) or in one loop: the same bits either way.
  void computeOnThreads(bool on);
  /// From this many node-disjoint pairs the step computes them on the solver's threads.
  static constexpr size_t kThreadedPairs = 512;
  bool computedOnThreads() const { return !workTerm_.empty(); }
  /// The results of a run on ranks: pair p's state in kGatheredSize values (state, failed, r0,
  /// normal and tangential force), and a contact that only holds gathered states for the results
  /// (the mirror of rank 0) set from them and from the ranks' summed dissipated energy.
  static constexpr int kGatheredSize = 7;
  void gatheredPair(Index p, Real* out) const;
  void setGatheredPair(Index p, const Real* in);
  void setDissipatedEnergy(Real e) { work_ = -e; }

 private:
  const Solver& solver_;
  ContactPairs pairs_;
  ContactParams params_;
  std::vector<std::uint8_t> state_, failed_, cohesive_;
  std::vector<Real> r0_;       // [3P] relative offset u2 − u1 when the pair became active
  std::vector<Real> force_;    // [3P] force on node 1 of the last step (N)
  std::vector<Real> relPrev_;  // [3P] u1 − u2 at the last call (for the work)
  std::vector<Real> fn_, ft_;
  std::vector<std::uint8_t> counted_;  // empty: every pair counts in work_
  bool disjoint_ = false;              // no node in two pairs
  std::vector<Real> workTerm_;         // [3P] the pairs' work terms of the step (threaded; else empty)
  std::vector<Index> predicted_;       // [2P] the pairs' node 1, then their node 2 (terms_' order)
  PredictionTerms terms_;
  /// One pair's step: its force, state and f_ext; its work added to *work, or kept in workTerm_.
  /// `terms`: the prediction's kept terms (the central difference), else null.
  void stepPair(size_t p, const PairPrediction& predict, const PredictionTerms* terms, NodalState& st, Real* work);
  Real work_ = 0;  // work of the contact forces so far (J, ≤ 0 up to round-off)
};

}  // namespace tq
