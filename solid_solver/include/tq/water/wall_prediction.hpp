/// @file wall_prediction.hpp
/// @brief The motion the solver's own update gives a set of nodes this step (the wetted wall), with
///        an extra force, before the update is made: u^{n+1} − u0 and v^{n+½} (leapfrog with α M and
///        the boundary dashpots, fixed dofs held: v^{n+½} = [(m/Δt − c/2) v^{n−½} + f] / (m/Δt + c/2),
///        u^{n+1} = u^n + Δt v^{n+½}; Solver::updateNodes), and its response ∂u^{n+1}/∂f, ∂v^{n+½}/∂f
///        (the update is linear in the force).
///
/// The water coupling predicts the wall it sends with it, and the water's laws the solid carries
/// (tq/water/carried_water.hpp) set their pressure implicitly in the step with it.
#pragma once

#include <vector>

#include "tq/core/solver.hpp"
#include "tq/io/mesh.hpp"

namespace tq {

/// The nodes of a face group, ascending, without repeats. Throws InputError (/coupling) on a
/// missing or empty group.
std::vector<Index> wallNodes(const Mesh& mesh, const std::string& face);

/// f(k, i, j) for each dof of the wall's nodes that moves (a node of an active element): k the
/// node's place in `nodes`, i its dof in the solver's [3N] arrays, j in the wall's [3n] ones.
template <class F>
void forEachMovingDof(const std::vector<Index>& nodes, const NodalState& st, F&& f) {
  for (size_t k = 0; k < nodes.size(); ++k) {
    if (!(st.mass(nodes[k]) > 0)) continue;
    for (int d = 0; d < 3; ++d) f(k, dofIndex(nodes[k], d), 3 * k + size_t(d));
  }
}

/// A predicted motion of the wall's nodes ([3n] each, n the nodes in order).
struct WallMotion {
  std::vector<Real> disp;          ///< u^{n+1} − u0 (m)
  std::vector<Real> vel;           ///< v^{n+½} (m/s)
  std::vector<Real> respU, respV;  ///< ∂u^{n+1}/∂f and ∂v^{n+½}/∂f (filled when asked)
  void resize(size_t n3) { disp.assign(n3, 0.0), vel.assign(n3, 0.0), respU.assign(n3, 0.0), respV.assign(n3, 0.0); }
};

class WallPrediction {
 public:
  /// The nodes (mesh indices) and the reference u0: their displacement now (the seismic start).
  WallPrediction(const Solver& solver, std::vector<Index> nodes);

  /// The step's motion with the forces the state holds (f_ext so far, f_int^n) plus F ([3n]; null:
  /// none). withResponse: respU and respV too. A node of no active element stays at rest.
  void predict(Real dt, const NodalState& st, const Real* F, WallMotion& m, bool withResponse) const;

  const std::vector<Index>& nodes() const { return nodes_; }
  /// u0 ([3n]); mutable for a restart checkpoint.
  std::vector<Real>& reference() { return u0_; }
  const std::vector<Real>& reference() const { return u0_; }

 private:
  const Solver& solver_;
  std::vector<Index> nodes_;
  std::vector<Real> u0_;
};

}  // namespace tq
