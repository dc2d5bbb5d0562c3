/// @file pair_prediction.hpp
/// @brief A node's displacement at the end of the step without a pair force, and its mobility:
///        the prediction both node-pair interfaces (the rock–lining contact, the lining joints)
///        build their forces on (docs/theory.md §4).
#pragma once

#include "tq/core/nodal_state.hpp"
#include "tq/core/solver.hpp"

namespace tq {

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

  void operator()(Index n, int d, Real& ut, Real& w) const {
    const size_t i = 3 * size_t(n) + size_t(d);
    const Real fr = solver_.isFixed(n, d) ? 0.0 : 1.0, mn = m_[n];
    const Real f = fe_[i] - fi_[i], cm = alpha_ * mn;
    if (leapfrog_) {
      const Real mdt = mn / dt_, ch = 0.5 * (cm + cb_[i]);
      ut = u_[i] + dt_ * (fr * ((mdt - ch) * v_[i] + f) / (mdt + ch));
      w = fr * dt_ * dt_ / (mn + ch * dt_);
    } else {
      const Real acc = fr * (f - (cm + cb_[i]) * v_[i]) / mn;
      ut = u_[i] + dt_ * v_[i] + 0.5 * dt_ * dt_ * acc;
      w = fr * 0.5 * dt_ * dt_ / mn;
    }
  }

 private:
  const Solver& solver_;
  Real dt_;
  bool leapfrog_;
  Real alpha_;
  const Real *u_, *v_, *fi_, *fe_, *m_, *cb_;
};

}  // namespace tq
