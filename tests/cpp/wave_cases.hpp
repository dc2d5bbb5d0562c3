// The 1D wave column of tests/verification/solid_wave_column as a function,
// shared by test_waves.cpp and the convergence ladder of `tunnelquake bench`
// (tq-verification-ladder).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <sstream>

#include "staged_helpers.hpp"

namespace tqcases {

using namespace tq;
using tqtest::GaussPulse;
using tqtest::StagedRun;

// Half-space rock of the column tests: cs = 1000 m/s, ν = 0.25 (cp = √3 cs), ρ = 2000 kg/m³.
constexpr Real kRho = 2000, kCs = 1000, kNu = 0.25;
const Real kG = kRho * kCs * kCs, kE = 2 * kG * (1 + kNu);
const Real kCp = kCs * std::sqrt(2 * (1 - kNu) / (1 - 2 * kNu));

/// One-element-wide hex column (w × w × H, n elements) with every node level tied (periodic
/// sides: a 1D field), viscoelastic base, sequence "seismic" only.
struct ColumnRun : StagedRun {
  std::shared_ptr<TiedNodeGroups> tie;
  Real width = 1.0;                    ///< the column's cross-section side (m)
  std::function<void(Mesh&)> reshape;  ///< if set: moves the nodes before the build (graded columns)
  void setUp(Real H, Index n, std::vector<std::pair<std::string, ElasticParams>> mats, Real zSplit,
             const MotionInput& motion, BottomBoundaryInput bottom) {
    const BoxSpec box{1, 1, n, 0, 0, 0, width, width, H, mats[0].first};
    mesh = mats.size() == 1 ? makeBoxMesh(box) : tqtest::twoLayerBox(box, zSplit, mats[0].first, mats[1].first);
    if (reshape) reshape(mesh);
    in.materials.clear();
    for (const auto& [region, p] : mats) in.materials.emplace_back(region, elasticValues(p));
    in.staged.present = true;
    in.staged.stages.sequence = {"seismic"};
    bottom.present = true;
    bottom.columnFace = "xmin";
    in.staged.bottom = bottom;
    in.staged.motion = motion;
    build();
    std::ostringstream log;
    stages->runStatics(log);
    stages->switchToDynamics(log);
    tie = std::make_shared<TiedNodeGroups>("periodic column", tqtest::levelGroups(mesh));
    tie->install(*solver);
    solver->addContributor(ForcePhase::Ties, tie);
  }
  Index topNode() const {
    Index best = 0;
    for (Index k = 0; k < mesh.numNodes(); ++k)
      if (mesh.coords[3 * size_t(k) + 2] > mesh.coords[3 * size_t(best) + 2]) best = k;
    return best;
  }
};

/// Errors of the uniform column (H, n cubes, rock above) under the Gaussian pulse (A 1 cm, t0 60 ms,
/// τ 15 ms) along `dir` (0 SH, 2 P), against the surface 2 u0(t − H/c): peak and L2 over the run
/// (to t0 + 4τ + 2H/c + 0.1 s), the energy left after the reflection has gone, the balance error.
struct WaveColumnResult {
  Real peakErr = 0, l2 = 0, tailEnergy = 0, balance = 0, dt = 0, tEnd = 0, wallSeconds = 0;
  Index steps = 0;
};

/// dtFactor: the step as a fraction of the critical one; 0: automatic (0.9).
inline WaveColumnResult waveColumn(int dir, Index n, Real dtFactor = 0, Real H = 100) {
  const Real c = dir == 0 ? kCs : kCp;
  GaussPulse pulse;
  MotionInput m;
  m.present = true;
  pulse.sample(1.0, 1e-4, m.time, dir == 0 ? m.ax : m.az);
  BottomBoundaryInput b;
  b.distance = 50;
  const auto t0 = std::chrono::steady_clock::now();
  ColumnRun run;
  run.width = H / Real(n);  // cubes (1 m for the test's 100 over 100 m)
  run.setUp(H, n, {{"rock", {kE, kNu, kRho}}}, 0, m, b);
  Solver& s = *run.solver;
  if (dtFactor > 0) s.setTimeStep(dtFactor * s.stableStep().dtCritical);
  const Index top = run.topNode();
  const IncidentMotion& inc = run.stages->seismic()->motion();
  const Real tEnd = pulse.t0 + 4 * pulse.tau + 2 * H / c + 0.1;
  Real peak = 0, peakRef = 0, e2 = 0, r2 = 0, eMax = 0;
  while (s.time() < tEnd) {
    s.step();
    const Real t = s.time();
    const Real u = s.relativeDisplacement(top, dir);
    const Real ref = 2 * inc.displacement(dir, t - H / c);
    peak = std::max(peak, std::abs(u));
    peakRef = std::max(peakRef, std::abs(ref));
    e2 += (u - ref) * (u - ref);
    r2 += ref * ref;
    eMax = std::max(eMax, s.energy().kinetic + s.energy().internal);
  }
  WaveColumnResult r;
  r.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.tailEnergy = (s.energy().kinetic + s.energy().internal) / eMax;
  r.peakErr = peak / peakRef - 1;
  r.l2 = std::sqrt(e2 / r2);
  r.balance = s.energy().error;
  r.dt = s.dt();
  r.tEnd = s.time();
  r.steps = s.stepCount();
  return r;
}

}  // namespace tqcases
