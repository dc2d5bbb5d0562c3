/// @file pair_prediction.hpp
/// @brief A node's displacement at the end of the step without a pair force, and its mobility:
///        the prediction both node-pair interfaces (the rock–lining contact, the lining joints)
///        build their forces on (docs/theory.md §4).
#pragma once

#include <vector>

#include "tq/core/nodal_state.hpp"
#include "tq/core/solver.hpp"

namespace tq {

class PredictionTerms;

/// Predicts dof (n, d) by the solver's own update formula (Solver::updateNodes) from the forces
/// known so far: ut = u^{n+1} without a further force on the node, w = ∂u^{n+1}/∂f (m/N; 0 for a
/// fixed dof). Central difference: w = Δt² / (m + ½(α m + c)Δt); the literal eqs. (3)–(4):
/// w = Δt²/(2m).
class PairPrediction {
 public:
  PairPrediction(const Solver& solver, Real dt, const NodalState& st)
      : solver_(solver),
        dt_(dt),
        leapfrog_(solver.options().integrator == Integrator::CentralDifference),
        alpha_(solver.massDampingCoefficient()),
        u_(st.uData()),
        v_(st.vData()),
        fi_(st.fIntData()),
        fe_(st.fExtData()),
        m_(st.massData()),
        cb_(st.dashpotData()) {}

  bool leapfrog() const { return leapfrog_; }

  /// The same from the node's PredictionTerms (the central difference): the same arithmetic on the
  /// kept terms, the same bits.
  void operator()(Index n, int d, const Real* terms, Real& ut, Real& w) const {
    const size_t i = dofIndex(n, d);
    const Real fr = solver_.isFixed(n, d) ? 0.0 : 1.0;
    const Real f = fe_[i] - fi_[i];
    const Real* t = terms + 3 * d;  // m/Δt − h, m/Δt + h, Δt²/(m + hΔt)
    ut = u_[i] + dt_ * (fr * (t[0] * v_[i] + f) / t[1]);
    w = fr != 0 ? t[2] : 0.0;  // fr Δt Δt / (m + hΔt) with fr 0 or 1
  }

  void operator()(Index n, int d, Real& ut, Real& w) const {
    const size_t i = dofIndex(n, d);
    if (leapfrog_) {
      Real t[9];
      centralTerms(m_[n], alpha_, cb_[i], dt_, t + 3 * d);
      return (*this)(n, d, t, ut, w);
    }
    const Real fr = solver_.isFixed(n, d) ? 0.0 : 1.0, mn = m_[n];
    const Real f = fe_[i] - fi_[i], cm = alpha_ * mn;
    const Real acc = fr * (f - (cm + cb_[i]) * v_[i]) / mn;
    ut = u_[i] + dt_ * v_[i] + 0.5 * dt_ * dt_ * acc;
    w = fr * 0.5 * dt_ * dt_ / mn;
  }

  /// Pair p of P, nodes a and b, direction d: the predicted u_b − u_a and the pair's mobility w_a + w_b,
  /// from the kept terms where given (a's at p, b's at P + p, PredictionTerms' order), else directly.
  inline void pair(size_t p, size_t P, Index a, Index b, int d, const PredictionTerms* terms, Real& rel, Real& w) const;

  /// The central difference's terms of one dof from its mass, α, its dashpot and Δt: m/Δt − h,
  /// m/Δt + h and Δt²/(m + hΔt), h = ½(αm + c).
  static void centralTerms(Real mn, Real alpha, Real c, Real dt, Real* t) {
    const Real cm = alpha * mn, mdt = mn / dt, ch = 0.5 * (cm + c);
    t[0] = mdt - ch;
    t[1] = mdt + ch;
    t[2] = dt * dt / (mn + ch * dt);
  }

 private:
  const Solver& solver_;
  Real dt_;
  bool leapfrog_;
  Real alpha_;
  const Real *u_, *v_, *fi_, *fe_, *m_, *cb_;
};

/// The central difference's terms of PairPrediction that depend on the masses, the dashpots, α and
/// Δt only, kept from step to step for a list of nodes (a contributor's pairs): per dof m/Δt − h,
/// m/Δt + h and Δt²/(m + hΔt), h = ½(αm + c), formed again when one of those changes. A prediction
/// from them is the same arithmetic as without: the same bits, two divisions a dof fewer.
class PredictionTerms {
 public:
  /// Up to date for `nodes` (9 terms a node, in its order); false where the integrator is not the
  /// central difference (predict without them).
  bool update(const Solver& solver, Real dt, const NodalState& st, const std::vector<Index>& nodes) {
    if (solver.options().integrator != Integrator::CentralDifference) return false;
    const Real alpha = solver.massDampingCoefficient();
    if (t_.size() == 9 * nodes.size() && massVersion_ == st.massVersion() && dashpotVersion_ == st.dashpotVersion() &&
        dt_ == dt && alpha_ == alpha)
      return true;
    t_.resize(9 * nodes.size());
    const Real* m = st.massData();
    const Real* cb = st.dashpotData();
    for (size_t k = 0; k < nodes.size(); ++k)
      for (int d = 0; d < 3; ++d)
        PairPrediction::centralTerms(m[nodes[k]], alpha, cb[dofIndex(nodes[k], d)], dt,
                                     t_.data() + 9 * k + 3 * size_t(d));
    massVersion_ = st.massVersion();
    dashpotVersion_ = st.dashpotVersion();
    dt_ = dt;
    alpha_ = alpha;
    return true;
  }
  /// The terms of nodes[k].
  const Real* node(size_t k) const { return t_.data() + 9 * k; }

 private:
  std::vector<Real> t_;
  std::uint64_t massVersion_ = 0, dashpotVersion_ = 0;
  Real dt_ = 0, alpha_ = 0;
};

void PairPrediction::pair(size_t p, size_t P, Index a, Index b, int d, const PredictionTerms* terms, Real& rel,
                          Real& w) const {
  Real ua, wa, ub, wb;
  if (terms) {
    (*this)(a, d, terms->node(p), ua, wa);
    (*this)(b, d, terms->node(P + p), ub, wb);
  } else {
    (*this)(a, d, ua, wa);
    (*this)(b, d, ub, wb);
  }
  rel = ub - ua;
  w = wa + wb;
}

/// Steps the P pairs of a node-pair interface: `step(p, work)` computes pair p's force and adds its
/// work to *work, or, given nullptr, keeps its three work terms in terms[3p .. 3p + 3). With `terms`
/// empty, one loop adding each pair's work as it goes; else (the pairs sharing no node, each reading
/// and writing only its own two nodes) the pairs on the solver's threads, their terms summed after in
/// pair order for those `counted(p)` says (a pair that returned before its work has none): the very
/// additions of the one loop, the same bits at any thread count.
template <class Step, class Counted>
void stepPairs(size_t P, const std::vector<Real>& terms, Real& work, Step&& step, Counted&& counted) {
  if (terms.empty()) {
    for (size_t p = 0; p < P; ++p) step(p, &work);
    return;
  }
#pragma omp parallel for schedule(static)
  for (size_t p = 0; p < P; ++p) step(p, nullptr);
  for (size_t p = 0; p < P; ++p)
    if (counted(p))
      for (size_t d = 0; d < 3; ++d) work += terms[3 * p + d];
}

}  // namespace tq
