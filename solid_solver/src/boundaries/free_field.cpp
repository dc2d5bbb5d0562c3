// Incident motion and the 1D free-field column (tq/boundaries/free_field.hpp; docs/solid_solver.md
// "Seismic boundaries").
#include "tq/boundaries/free_field.hpp"

#include <algorithm>
#include <cmath>

namespace tq {

IncidentMotion::IncidentMotion(std::vector<Real> t, std::vector<Real> ax, std::vector<Real> ay, std::vector<Real> az)
    : t_(std::move(t)) {
  const size_t n = t_.size();
  std::array<std::vector<Real>*, 3> in = {&ax, &ay, &az};
  for (int d = 0; d < 3; ++d) {
    a_[d] = in[d]->empty() ? std::vector<Real>(n, 0.0) : *in[d];
    if (a_[d].size() != n)
      throw InputError("incident motion: acceleration component " + std::string(1, "xyz"[d]) + " has " +
                       std::to_string(a_[d].size()) + " samples for " + std::to_string(n) + " times");
    v_[d].assign(n, 0.0);
    u_[d].assign(n, 0.0);
    // Exact integrals of the piecewise-linear acceleration (the trapezoid for v, the cubic for u:
    // the same as tunnelquake.motion.integrate).
    for (size_t k = 0; k + 1 < n; ++k) {
      const Real h = t_[k + 1] - t_[k];
      if (!(h > 0))
        throw InputError("incident motion: time must be strictly increasing (sample " + std::to_string(k + 1) + ")");
      v_[d][k + 1] = v_[d][k] + 0.5 * h * (a_[d][k] + a_[d][k + 1]);
      u_[d][k + 1] = u_[d][k] + h * v_[d][k] + h * h * (a_[d][k] / 3 + a_[d][k + 1] / 6);
    }
  }
}

size_t IncidentMotion::interval(Real t) const {
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  return size_t(it - t_.begin()) - 1;
}

Real IncidentMotion::acceleration(int d, Real t) const {
  if (t_.empty() || t < t_.front() || t >= t_.back()) return 0;
  const size_t k = interval(t);
  const Real h = t_[k + 1] - t_[k], s = t - t_[k];
  return a_[d][k] + (a_[d][k + 1] - a_[d][k]) * s / h;
}

Real IncidentMotion::velocity(int d, Real t) const {
  if (t_.empty() || t < t_.front()) return 0;
  if (t >= t_.back()) return v_[d].back();
  const size_t k = interval(t);
  const Real h = t_[k + 1] - t_[k], s = t - t_[k], j = (a_[d][k + 1] - a_[d][k]) / h;
  return v_[d][k] + a_[d][k] * s + 0.5 * j * s * s;
}

Real IncidentMotion::displacement(int d, Real t) const {
  if (t_.empty() || t < t_.front()) return 0;
  if (t >= t_.back()) return u_[d].back() + v_[d].back() * (t - t_.back());
  const size_t k = interval(t);
  const Real h = t_[k + 1] - t_[k], s = t - t_[k], j = (a_[d][k + 1] - a_[d][k]) / h;
  return u_[d][k] + v_[d][k] * s + 0.5 * a_[d][k] * s * s + j * s * s * s / 6;
}

FreeFieldColumn::FreeFieldColumn(std::vector<Real> levels, std::vector<ColumnLayer> layers, BaseHalfSpace base,
                                 RayleighDamping damping)
    : z_(std::move(levels)), layers_(std::move(layers)), base_(base), damping_(damping) {
  if (z_.size() < 2 || layers_.size() + 1 != z_.size())
    throw InputError("free-field column: needs n + 1 levels for n >= 1 layers (got " + std::to_string(z_.size()) +
                     " levels, " + std::to_string(layers_.size()) + " layers)");
  for (size_t k = 0; k + 1 < z_.size(); ++k)
    if (!(z_[k + 1] > z_[k])) throw InputError("free-field column: levels must increase upwards");
  if (!(base_.rho > 0 && base_.cp > 0 && base_.cs > 0))
    throw InputError("free-field column: the base half-space needs rho, cp, cs > 0");
  const size_t K = z_.size(), L = layers_.size();
  m_.assign(K, 0.0);
  for (size_t l = 0; l < L; ++l) {
    const Real h = z_[l + 1] - z_[l];
    m_[l] += 0.5 * layers_[l].rho * h;
    m_[l + 1] += 0.5 * layers_[l].rho * h;
  }
  u_.assign(3 * K, 0.0);
  v_.assign(3 * K, 0.0);
  un_.assign(3 * K, 0.0);
  vbar_.assign(3 * K, 0.0);
  eps_.assign(3 * L, 0.0);
  sig_.assign(6 * L, 0.0);
  sTot_.assign(6 * L, 0.0);
}

void FreeFieldColumn::advance(Real t, Real dt, const IncidentMotion& motion) {
  const size_t K = z_.size(), L = layers_.size();
  const Real rate = dtLast_ > 0 ? damping_.beta / dtLast_ : 0.0;
  // 1. Layer strains at u^n, their increments, stresses (elastic, rate form as the 3D kernel),
  //    and the lagged stiffness-damping stress σ_d = (β/Δt_last) C:Δε.
  for (size_t l = 0; l < L; ++l) {
    const Real h = z_[l + 1] - z_[l];
    const Real* ua = &u_[3 * l];
    const Real* ub = &u_[3 * (l + 1)];
    const Real e[3] = {(ub[2] - ua[2]) / h, (ub[1] - ua[1]) / h, (ub[0] - ua[0]) / h};  // εzz, γyz, γzx
    Real de[3];
    for (int i = 0; i < 3; ++i) {
      de[i] = e[i] - eps_[3 * l + i];
      eps_[3 * l + i] = e[i];
    }
    const ColumnLayer& m = layers_[l];
    Real* s = &sig_[6 * l];
    s[XX] += m.lambda * de[0];
    s[YY] += m.lambda * de[0];
    s[ZZ] += (m.lambda + 2 * m.mu) * de[0];
    s[YZ] += m.mu * de[1];
    s[ZX] += m.mu * de[2];
    Real* st = &sTot_[6 * l];
    st[XX] = s[XX] + rate * m.lambda * de[0];
    st[YY] = s[YY] + rate * m.lambda * de[0];
    st[ZZ] = s[ZZ] + rate * (m.lambda + 2 * m.mu) * de[0];
    st[XY] = 0;
    st[YZ] = s[YZ] + rate * m.mu * de[1];
    st[ZX] = s[ZX] + rate * m.mu * de[2];
  }
  // 2. Net force per area on each level: traction of the layer above minus the layer below
  //    (components on a horizontal plane: σzx, σyz, σzz), plus the base input 2ρc v_in(t_n).
  const Real cBase[3] = {base_.rho * base_.cs, base_.rho * base_.cs, base_.rho * base_.cp};
  const Real alpha = damping_.alpha;
  for (size_t k = 0; k < K; ++k) {
    Real f[3] = {0, 0, 0};
    if (k < L) {
      const Real* st = &sTot_[6 * k];
      f[0] += st[ZX];
      f[1] += st[YZ];
      f[2] += st[ZZ];
    }
    if (k > 0) {
      const Real* st = &sTot_[6 * (k - 1)];
      f[0] -= st[ZX];
      f[1] -= st[YZ];
      f[2] -= st[ZZ];
    }
    for (int d = 0; d < 3; ++d) {
      const size_t i = 3 * k + d;
      Real c = alpha * m_[k];
      if (k == 0) {
        f[d] += 2 * cBase[d] * motion.velocity(d, t);
        c += cBase[d];
      }
      // 3. v^{n+½} = [(m/Δt − c/2) v^{n−½} + f] / (m/Δt + c/2); u^{n+1} = u^n + Δt v^{n+½}.
      const Real mdt = m_[k] / dt, vo = v_[i];
      const Real vn = ((mdt - 0.5 * c) * vo + f[d]) / (mdt + 0.5 * c);
      un_[i] = u_[i];
      vbar_[i] = 0.5 * (vo + vn);
      v_[i] = vn;
      u_[i] += dt * vn;
    }
  }
  dtLast_ = dt;
}

Index FreeFieldColumn::layerAt(Real z) const {
  const auto it = std::upper_bound(z_.begin(), z_.end(), z);
  const Index k = Index(it - z_.begin()) - 1;
  return std::clamp<Index>(k, 0, Index(layers_.size()) - 1);
}

void FreeFieldColumn::interpolation(Real z, Index* k, Real* w) const {
  const Index l = layerAt(z);
  *k = l;
  *w = std::clamp((z - z_[size_t(l)]) / (z_[size_t(l) + 1] - z_[size_t(l)]), 0.0, 1.0);
}

Real FreeFieldColumn::energyPerArea() const {
  Real e = 0;
  for (size_t k = 0; k < z_.size(); ++k)
    for (int d = 0; d < 3; ++d) e += 0.5 * m_[k] * v_[3 * k + d] * v_[3 * k + d];
  for (size_t l = 0; l < layers_.size(); ++l) {
    const Real h = z_[l + 1] - z_[l];
    const ColumnLayer& m = layers_[l];
    const Real* ep = &eps_[3 * l];
    e += 0.5 * h * ((m.lambda + 2 * m.mu) * ep[0] * ep[0] + m.mu * (ep[1] * ep[1] + ep[2] * ep[2]));
  }
  return e;
}

}  // namespace tq
