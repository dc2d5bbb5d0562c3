// Helpers for the staged-analysis and seismic-boundary tests: in-memory inputs, pulses, meshes.
#pragma once

#include <cmath>
#include <complex>
#include <memory>
#include <vector>

#include "tq/app/stages.hpp"
#include "tq/io/input.hpp"

namespace tqtest {

using tq::Index;
using tq::Real;

/// Incident displacement pulse u0(t) = A exp(−((t − t0)/τ)²) given to the solver as its second
/// derivative sampled every dts (the solver integrates the piecewise-linear samples exactly).
struct GaussPulse {
  Real amplitude = 0.01, t0 = 0.06, tau = 0.015;
  Real acc(Real t) const {
    const Real s = (t - t0) / tau;
    return amplitude * std::exp(-s * s) * (4 * s * s - 2) / (tau * tau);
  }
  void sample(Real tEnd, Real dts, std::vector<Real>& t, std::vector<Real>& a, Real scale = 1) const {
    for (Real x = 0; x <= tEnd + 0.5 * dts; x += dts) {
      t.push_back(x);
      a.push_back(scale * acc(x));
    }
  }
};

/// A solver and the staged analysis built from an in-memory input (the same path as tq-solid
/// after reading the files).
struct StagedRun {
  tq::SolidInput in;
  tq::Mesh mesh;
  std::unique_ptr<tq::Solver> solver;
  std::unique_ptr<tq::StagedAnalysis> stages;
  void build() {
    solver = tq::buildSolver(in, mesh);
    stages = std::make_unique<tq::StagedAnalysis>(in, mesh, *solver);
  }
};

/// Box mesh whose elements below z = zSplit form region `lower` and above it region `upper`.
inline tq::Mesh twoLayerBox(const tq::BoxSpec& b, Real zSplit, const std::string& lower, const std::string& upper) {
  tq::Mesh m = tq::makeBoxMesh(b);
  m.regionNames = {lower, upper};
  for (Index e = 0; e < m.numElems(); ++e) {
    Real zc = 0;
    for (int k = 0; k < 8; ++k) zc += 0.125 * m.coords[3 * size_t(m.connectivity[8 * size_t(e) + k]) + 2];
    m.region[size_t(e)] = zc < zSplit ? 0 : 1;
  }
  return m;
}

/// Nodes grouped by height (one group per node level of a structured box), for periodic ties.
inline std::vector<std::vector<Index>> levelGroups(const tq::Mesh& m) {
  std::vector<std::pair<Real, Index>> z;
  for (Index n = 0; n < m.numNodes(); ++n) z.push_back({m.coords[3 * size_t(n) + 2], n});
  std::sort(z.begin(), z.end());
  std::vector<std::vector<Index>> g;
  for (size_t i = 0; i < z.size(); ++i) {
    if (i == 0 || z[i].first - z[i - 1].first > 1e-9) g.emplace_back();
    g.back().push_back(z[i].second);
  }
  return g;
}

/// Discrete Fourier transform of a uniformly sampled record at frequency f (Hz).
inline std::complex<Real> dft(const std::vector<Real>& t, const std::vector<Real>& x, Real f) {
  std::complex<Real> s = 0;
  const Real w = 2 * M_PI * f;
  for (size_t i = 0; i < t.size(); ++i) s += x[i] * std::exp(std::complex<Real>(0, -w * t[i]));
  return s;
}

}  // namespace tqtest
