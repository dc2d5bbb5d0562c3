/// @file joints.hpp
/// @brief The lining's joints: circumferential planes across the tunnel axis (y) where the
///        lining's nodes are duplicated, each pair (node a on the −y side, node b on the +y side)
///        joined by a normal and a shear spring per unit area, with a tension cut-off and an
///        optional Coulomb friction (docs/theory.md "Lining joints").
///
/// Law per pair of tributary area A, relative displacement r = u_b − u_a − r0 (r0 the offset when
/// both sides became active), opening g = r_y (> 0 open), shear s = (r_x, r_z):
///   N = k_n A g (tension > 0);  T = k_s A (s − s_p)  (s_p the slip so far);
///   - tension cut-off: once N > f_t A the pair cracks: N = T = 0 while it stays open (g > 0), and
///     from then on it takes no tension; closed again (g ≤ 0) it carries compression k_n A g;
///   - friction μ (optional): |T| ≤ μ max(−N, 0); beyond it the pair slips (s_p grows); without
///     μ the shear spring is elastic without limit (dowels, gaskets' shear stiffness).
/// The springs are integrated implicitly within each pair, with the same prediction as the
/// rock–lining contact (tq/contact/pair_prediction.hpp): from the predicted relative
/// displacement r̃ without the pair's force and the pair's mobility W = w_a + w_b per direction,
/// F = K r̃ / (1 + K W) is the force that equals K times the gap it leaves at the end of the step
/// (F = K (r̃ − W F)). The stiff limit K → ∞ is the bond (F = r̃ / W, the contact's own closure), so
/// the joints add nothing to the stable step whatever their stiffness. At rest F = K r exactly:
/// the static opening of a joint pulled by F is F / (k_n A).
#pragma once

#include <string>
#include <vector>

#include "tq/contact/pair_prediction.hpp"
#include "tq/core/solver.hpp"

namespace tq {

/// The joint law's parameters (per unit area of the joint).
struct JointParams {
  Real normalStiffness = 0;  ///< k_n (Pa/m) > 0
  Real shearStiffness = 0;   ///< k_s (Pa/m) > 0
  Real tensileStrength = 0;  ///< f_t (Pa) >= 0: the tension a joint carries before it opens (0: none)
  Real friction = -1;        ///< μ >= 0 caps the shear at μ × compression; < 0: no cap
  void check() const;        ///< throws InputError on bad values
};

/// The node pairs of every joint (mesh.h5 /interfaces/lining_joints and its companions).
struct JointPairs {
  std::vector<Index> nodeA;  ///< lining node on the −y side of its joint
  std::vector<Index> nodeB;  ///< its copy on the +y side
  std::vector<Real> area;    ///< [P] tributary area on the joint plane (m²)
  std::vector<Index> joint;  ///< [P] joint index 0 … J−1 (joints ordered by y)
  std::vector<Real> y;       ///< [J] each joint's plane
  Index size() const { return Index(nodeA.size()); }
  Index numJoints() const { return Index(y.size()); }
  void check(const std::string& where, Index numNodes) const;  ///< throws InputError
};

/// Per-pair state (results.h5 /joints).
enum class JointState : int {
  Closed = 0,    ///< springs elastic (in tension below f_t, or in compression)
  Open = 1,      ///< cracked and open: no force
  Slipping = 2,  ///< sliding at |T| = μ × compression
  Inactive = 3,  ///< a side has no mass yet (the lining not installed)
};

/// One joint's resultants at a state: area-weighted mean opening and its extremes, the mean and
/// largest slip, the axial force through it (tension > 0), the opening's gradients across it.
struct JointSummary {
  Real opening = 0, openingMax = 0, openingMin = 0;  ///< m
  Real slip = 0, slipMax = 0;                        ///< m: |area-weighted mean of s|, largest |s|
  Real axialForce = 0;                               ///< N, sum of the pairs' N
  Real rotationX = 0, rotationZ = 0;                 ///< rad: d(opening)/dx, d(opening)/dz (least-squares plane)
};

class LiningJoints final : public NodalForceContributor {
 public:
  LiningJoints(const Solver& solver, JointPairs pairs, JointParams params);
  std::string name() const override { return "lining joints"; }
  void addForces(Real t, Real dt, NodalState& state) override;
  /// Minus the work of the joint forces: the springs' stored energy and what slip dissipated.
  Real dissipatedEnergy() const override { return -work_; }
  bool constrainLevels(std::vector<std::uint8_t>& level) const override {
    const bool a = lowerToFinestLevel(level, pairs_.nodeA);
    return lowerToFinestLevel(level, pairs_.nodeB) || a;
  }
  /// Each pair's force comes from its two nodes' motion.
  bool forceGroups(std::vector<std::vector<Index>>& groups) const override {
    for (size_t p = 0; p < pairs_.nodeA.size(); ++p) groups.push_back({pairs_.nodeA[p], pairs_.nodeB[p]});
    return true;
  }
  /// Its state reads its groups' motion only.
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }
  void checkpoint(StateArchive& a) override {
    a.io(state_);
    a.io(cracked_);
    a.io(r0_);
    a.io(sp_);
    a.io(force_);
    a.io(relPrev_);
    a.io(work_);
  }

  const JointPairs& pairs() const { return pairs_; }
  const JointParams& params() const { return params_; }
  Index numPairs() const { return pairs_.size(); }
  Index numJoints() const { return pairs_.numJoints(); }
  JointState state(Index p) const { return JointState(state_[size_t(p)]); }
  /// r = u_b − u_a − r0 of pair p (m).
  void relative(Index p, const NodalState& s, Real r[3]) const;
  /// The axial force of pair p in the last step (tension > 0, N).
  Real axialForce(Index p) const { return force_[3 * size_t(p) + 1]; }
  /// Every joint's resultants at state s (coordinates from the solver's mesh).
  std::vector<JointSummary> summaries(const NodalState& s) const;
  /// Compute the pairs on the solver's threads (where no node is in two pairs; the default from
  /// kThreadedPairs pairs) or in one loop: the same bits either way.
  void computeOnThreads(bool on);
  static constexpr size_t kThreadedPairs = 512;
  bool computedOnThreads() const { return !workTerm_.empty(); }

 private:
  /// One pair's step: its force, state and f_ext; its work added to *work, or kept in workTerm_.
  void stepPair(size_t p, const PairPrediction& predict, const PredictionTerms* terms, NodalState& st, Real* work);
  const Solver& solver_;
  JointPairs pairs_;
  JointParams params_;
  std::vector<std::uint8_t> state_, cracked_;
  std::vector<Real> r0_;       // [3P]
  std::vector<Real> sp_;       // [3P] slip so far (x, z used)
  std::vector<Real> force_;    // [3P] force on node a in the last step (on b: minus it)
  std::vector<Real> relPrev_;  // [3P] u_a − u_b at the last call (for the work)
  Real work_ = 0;
  std::vector<Index> predicted_;  // [2P] the pairs' node a, then their node b (terms_' order)
  PredictionTerms terms_;
  bool disjoint_ = false;       // no node in two pairs
  std::vector<Real> workTerm_;  // [3P] the pairs' work terms of the step (threaded; else empty)
};

}  // namespace tq
