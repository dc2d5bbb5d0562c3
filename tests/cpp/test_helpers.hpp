// Shared helpers for the solid-solver tests: small meshes and solvers built in memory.
#pragma once

#include <cmath>
#include <memory>
#include <random>

#include "tq/core/solver.hpp"

namespace tqtest {

using tq::Index;
using tq::Real;

inline std::shared_ptr<const tq::Material> elastic(Real E, Real nu, Real rho) {
  return std::make_shared<tq::ElasticMaterial>(tq::ElasticParams{E, nu, rho});
}

/// Move every interior node of a box mesh by up to `amount` times the local spacing (random,
/// reproducible), keeping boundary nodes on their planes, so elements are general hexahedra.
inline void distortInterior(tq::Mesh& m, const tq::BoxSpec& s, Real amount, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> U(-1, 1);
  const Real h[3] = {s.lx / s.nx, s.ly / s.ny, s.lz / s.nz};
  const Real lo[3] = {s.x0, s.y0, s.z0}, hi[3] = {s.x0 + s.lx, s.y0 + s.ly, s.z0 + s.lz};
  for (Index n = 0; n < m.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) {
      Real& x = m.coords[3 * n + d];
      const Real r = U(rng);
      if (std::abs(x - lo[d]) > 1e-9 && std::abs(x - hi[d]) > 1e-9) x += amount * h[d] * r;
    }
}

}  // namespace tqtest
