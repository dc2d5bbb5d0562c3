/// @file nodal_state.hpp
/// @brief The one owner of the nodal data layout. Every nodal vector (x0, u, v, a, f_int, f_ext)
///        is one array of 3N values, node-major (x, y, z of node n at dofIndex(n, d) = 3n + d), like
///        OpenRadioss' X(3, NUMNOD): one cache line per node in the element gathers. Kernels use
///        the raw pointers; everything else goes through the accessors, so a change of layout
///        touches this file only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "tq/core/state_archive.hpp"
#include "tq/core/types.hpp"

namespace tq {

class NodalState {
 public:
  NodalState() = default;
  explicit NodalState(Index numNodes) { resize(numNodes); }
  void resize(Index numNodes);
  Index numNodes() const { return n_; }

  /// Reference position (m).
  Real x0(Index n, int d) const { return x0_[dofIndex(n, d)]; }
  /// Displacement u^n (m).
  Real& u(Index n, int d) { return u_[dofIndex(n, d)]; }
  Real u(Index n, int d) const { return u_[dofIndex(n, d)]; }
  /// Velocity (m/s): v^{n-1/2} for the central difference (leapfrog), v^n for paper_eq3_4.
  Real& v(Index n, int d) { return v_[dofIndex(n, d)]; }
  Real v(Index n, int d) const { return v_[dofIndex(n, d)]; }
  /// Acceleration a^n of the last step (m/s^2).
  Real& a(Index n, int d) { return a_[dofIndex(n, d)]; }
  Real a(Index n, int d) const { return a_[dofIndex(n, d)]; }
  /// Internal (element) force including the stiffness-proportional damping force (N).
  Real fInt(Index n, int d) const { return fInt_[dofIndex(n, d)]; }
  /// External force of the current step (N).
  Real& fExt(Index n, int d) { return fExt_[dofIndex(n, d)]; }
  Real fExt(Index n, int d) const { return fExt_[dofIndex(n, d)]; }
  /// Lumped mass (kg).
  Real mass(Index n) const { return m_[n]; }
  /// Nodal dashpot coefficient per direction from absorbing boundaries (N s/m).
  Real dashpot(Index n, int d) const { return c_[dofIndex(n, d)]; }

  void setX0(Index n, int d, Real value) { x0_[dofIndex(n, d)] = value; }
  void addMass(Index n, Real value) {
    m_[n] += value;
    ++massVersion_;
  }
  /// Changes with every change of the masses (addMass, resize): what a cache of mass-derived values
  /// compares.
  std::uint64_t massVersion() const { return massVersion_; }
  void addDashpot(Index n, int d, Real value) {
    c_[dofIndex(n, d)] += value;
    if (value != 0) hasDashpots_ = true;
    ++dashpotVersion_;
  }
  /// Changes with every change of the dashpots (addDashpot, resize).
  std::uint64_t dashpotVersion() const { return dashpotVersion_; }
  /// False while no dashpot was ever added (the node update then skips the dashpot stream).
  bool hasDashpots() const { return hasDashpots_; }
  /// Exchange the external-force array with `other` (same size): the solver keeps the previous
  /// step's f_ext by swapping buffers instead of copying it.
  void swapFExt(std::vector<Real>& other) { fExt_.swap(other); }
  /// Save or restore what a step changes (u, v, a, f_int, f_ext); masses and dashpots change only
  /// between stages, never inside a coupling window.
  void checkpoint(StateArchive& ar) {
    checkpointMotion(ar, false);
    ar.io(fInt_);
    ar.io(fExt_);
  }
  /// u, v, a and, with `withFExt`, f_ext: a coupling window's start (Solver::checkpoint); with
  /// `dofs`, their values in those index ranges only (StateArchive::io).
  void checkpointMotion(StateArchive& ar, bool withFExt,
                        const std::vector<std::pair<std::size_t, std::size_t>>* dofs = nullptr) {
    ar.io(u_, dofs);
    ar.io(v_, dofs);
    ar.io(a_, dofs);
    if (withFExt) ar.io(fExt_, dofs);
  }

  // Raw arrays for the kernels ([3N] unless noted).
  const Real* x0Data() const { return x0_.data(); }
  Real* uData() { return u_.data(); }
  const Real* uData() const { return u_.data(); }
  Real* vData() { return v_.data(); }
  const Real* vData() const { return v_.data(); }
  Real* aData() { return a_.data(); }
  Real* fIntData() { return fInt_.data(); }
  const Real* fIntData() const { return fInt_.data(); }
  Real* fExtData() { return fExt_.data(); }
  const Real* fExtData() const { return fExt_.data(); }
  const Real* massData() const { return m_.data(); }  ///< [N]
  const Real* dashpotData() const { return c_.data(); }

 private:
  Index n_ = 0;
  std::vector<Real> x0_, u_, v_, a_, fInt_, fExt_, m_, c_;
  bool hasDashpots_ = false;
  std::uint64_t massVersion_ = 0, dashpotVersion_ = 0;
};

}  // namespace tq
