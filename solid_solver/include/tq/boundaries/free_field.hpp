/// @file free_field.hpp
/// @brief The incident motion (exact integration of a piecewise-linear acceleration) and the 1D
///        free-field column: the horizontally layered model's response to a vertically incident
///        wave, computed alongside the main model with the same time step, the same element
///        (linear displacement per layer, lumped mass ρh/2 per level and per unit area), the same
///        Rayleigh damping and the same viscoelastic base. A 3D model made of the same layers
///        reproduces the column to round-off (test FreeField.BlockFollowsColumn...).
#pragma once

#include <array>
#include <vector>

#include "tq/core/solver.hpp"

namespace tq {

/// Incident (up-going) acceleration a_d(t) at the base for d = x, y, z, linear between samples
/// and zero before the first; velocity and displacement are its exact integrals (piecewise
/// quadratic and cubic), starting from rest. After the last sample a = 0 and v is held.
class IncidentMotion {
 public:
  IncidentMotion() = default;  ///< no motion
  /// @param t strictly increasing sample times (s); ax, ay, az accelerations (m/s²), same length
  ///          (an empty component is zero).
  IncidentMotion(std::vector<Real> t, std::vector<Real> ax, std::vector<Real> ay, std::vector<Real> az);
  Real acceleration(int d, Real t) const;
  Real velocity(int d, Real t) const;
  Real displacement(int d, Real t) const;
  bool empty() const { return t_.empty(); }
  Real endTime() const { return t_.empty() ? 0 : t_.back(); }

 private:
  size_t interval(Real t) const;  // k with t_k <= t < t_{k+1}
  std::vector<Real> t_;
  std::array<std::vector<Real>, 3> a_, v_, u_;
};

/// One horizontal layer of a free-field column.
struct ColumnLayer {
  Real rho = 0;     ///< kg/m³
  Real lambda = 0;  ///< Lamé λ (Pa)
  Real mu = 0;      ///< shear modulus (Pa)
};

/// The half-space under the base: impedances per unit area for the base dashpots and the
/// incident-wave force 2ρc v_in (Lysmer & Kuhlemeyer 1969; Joyner & Chen 1975).
struct BaseHalfSpace {
  Real rho = 0, cp = 0, cs = 0;
};

/// 1D column of linear elements between the levels z_0 < … < z_n (z_0 at the base), per unit
/// area, three displacement components per level. The base has dashpots ρc (c = cs for x, y;
/// cp for z) and the incident force 2ρc v_in(t): exactly absorbing for vertical incidence in 1D.
/// Stresses are the dynamic part only (the static state is carried elsewhere).
class FreeFieldColumn {
 public:
  FreeFieldColumn(std::vector<Real> levels, std::vector<ColumnLayer> layers, BaseHalfSpace base,
                  RayleighDamping damping);

  /// One step from t_n to t_{n+1} = t + dt, the same central-difference update as the solver
  /// (Rayleigh α M and the base dashpot with the mean of the half-step velocities, β K as a
  /// damping stress with the lagged strain rate). Afterwards u(), vMean() and the stresses
  /// describe time t_n: u^n, ½(v^{n−½} + v^{n+½}) and σ^n + σ_d^n.
  void advance(Real t, Real dt, const IncidentMotion& motion);

  Index numLevels() const { return Index(z_.size()); }
  Index numLayers() const { return Index(layers_.size()); }
  Real level(Index k) const { return z_[size_t(k)]; }
  const ColumnLayer& layer(Index l) const { return layers_[size_t(l)]; }
  const BaseHalfSpace& base() const { return base_; }
  /// Displacement u^n of level k, direction d (m).
  Real u(Index k, int d) const { return un_[dofIndex(k, d)]; }
  /// Mean velocity ½(v^{n−½} + v^{n+½}) of level k (m/s).
  Real vMean(Index k, int d) const { return vbar_[dofIndex(k, d)]; }
  /// Stress σ^n + σ_d^n of layer l, Voigt order xx, yy, zz, xy, yz, zx (Pa; σ_xy = 0).
  const Real* stress(Index l) const { return &sTot_[6 * size_t(l)]; }
  /// Layer index containing z (clamped to the column), and level interpolation z -> (k, w):
  /// value = (1 − w) f_k + w f_{k+1}.
  Index layerAt(Real z) const;
  void interpolation(Real z, Index* k, Real* w) const;
  /// Kinetic + strain energy per unit area (J/m²) at the last state (for tests).
  Real energyPerArea() const;
  /// Save or restore the column's motion and stresses (StateArchive).
  void checkpoint(StateArchive& a) {
    a.io(u_);
    a.io(v_);
    a.io(un_);
    a.io(vbar_);
    a.io(eps_);
    a.io(sig_);
    a.io(sTot_);
    a.io(dtLast_);
  }

 private:
  std::vector<Real> z_;
  std::vector<ColumnLayer> layers_;
  BaseHalfSpace base_;
  RayleighDamping damping_;
  std::vector<Real> m_;                  // mass per area per level
  std::vector<Real> u_, v_, un_, vbar_;  // [3 levels]
  std::vector<Real> eps_, sig_, sTot_;   // eps [3 layers]: ezz, gyz, gzx; sig, sTot [6 layers]
  Real dtLast_ = 0;
};

}  // namespace tq
