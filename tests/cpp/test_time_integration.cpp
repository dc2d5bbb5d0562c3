// Time integration (eqs. 3-5, stable step, Rayleigh damping, energy, bad input).
//
// 1-dof oscillator: one hex8 element with a single free dof is u'' = -ω² u exactly. For a linear
// two-step recurrence u_n = |c| r^n cos(nθ + φ) the quantity D_n = u_n² - u_{n+1} u_{n-1}
// = |c|² sin²θ r^{2n}, so the growth factor per step is r = (D_N / D_1)^{1/(2(N-1))} exactly.
//  - Paper eqs. (3)-(4) taken literally: amplification matrix [[1-Ω²/2, 1], [-Ω², 1]] on
//    (u, Δt v), determinant 1 + Ω²/2, complex eigenvalues for Ω < 4 ⇒ r = √(1 + Ω²/2) > 1.
//  - Central difference (leapfrog): determinant 1 ⇒ r = 1 for Ω < 2.
// Tolerance: 1e-8 relative (round-off over a few thousand steps).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "test_helpers.hpp"

using namespace tq;
using tqtest::elastic;

namespace {

const Real kE = 8e9, kNu = 0.27, kRho = 2700;

// Single unit cube, only node 6's x free. Returns ω (rad/s) measured from one force evaluation.
std::unique_ptr<Solver> oneDof(const Mesh& m, SolverOptions opt) {
  auto s = std::make_unique<Solver>(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), opt);
  for (Index n = 0; n < m.numNodes(); ++n)
    for (int d = 0; d < 3; ++d)
      if (!(n == m.connectivity[6] && d == 0)) s->fix(n, d);
  return s;
}

Real measureOmega(const Mesh& m) {
  SolverOptions opt;
  auto s = oneDof(m, opt);
  const Index n6 = m.connectivity[6];
  s->state().u(n6, 0) = 1e-6;
  s->step();
  return std::sqrt(-s->state().a(n6, 0) / 1e-6);
}

// Run N steps of the 1-dof system at Ω = ω dt and return the measured growth factor per step.
Real growthFactor(const Mesh& m, Integrator integ, Real Omega, Real omega, int N, Real beta = 0) {
  SolverOptions opt;
  opt.integrator = integ;
  opt.allowUnstableStep = true;
  opt.dt = Omega / omega;
  opt.damping.beta = beta;
  opt.velocityLimit = 1e300;  // the growth is the point here
  auto s = oneDof(m, opt);
  const Index n6 = m.connectivity[6];
  s->state().v(n6, 0) = 1e-3;
  std::vector<Real> u;
  for (int i = 0; i < N; ++i) {
    s->step();
    u.push_back(s->state().u(n6, 0));
  }
  auto D = [&](int n) { return u[n] * u[n] - u[n + 1] * u[n - 1]; };
  return std::pow(D(N - 2) / D(1), 1.0 / (2.0 * (N - 3)));
}

}  // namespace

TEST(TimeIntegration, PaperEq34LiteralGrowsBySqrtOnePlusHalfOmegaSquaredPerStep) {
  const Mesh m = makeBoxMesh({1, 1, 1, 0, 0, 0, 1, 1, 1});
  const Real omega = measureOmega(m);
  for (Real Omega : {0.05, 0.3, 1.0, 1.8}) {
    const Real expected = std::sqrt(1 + 0.5 * Omega * Omega);
    const int N = std::min(1500, int(100 / std::log10(expected)));  // stay far from overflow
    const Real r = growthFactor(m, Integrator::PaperEq34, Omega, omega, N);
    EXPECT_NEAR(r / expected, 1.0, 1e-8) << "Ω = " << Omega;
    EXPECT_GT(r, 1.0);
  }
}

TEST(TimeIntegration, CentralDifferenceIsNeutrallyStableBelowOmegaTwo) {
  const Mesh m = makeBoxMesh({1, 1, 1, 0, 0, 0, 1, 1, 1});
  const Real omega = measureOmega(m);
  for (Real Omega : {0.05, 0.3, 1.0, 1.8, 1.99})
    EXPECT_NEAR(growthFactor(m, Integrator::CentralDifference, Omega, omega, 3000), 1.0, 1e-9) << "Ω = " << Omega;
}

TEST(TimeIntegration, StiffnessDampingStabilityLimitMatchesFormula) {
  // Lagged-velocity stiffness damping, ξ = βω/2: stable iff Ω ≤ 2(√(1+ξ²) - ξ)
  // (Belytschko, Liu & Moran, Nonlinear Finite Elements, §6.3). Check 1 % either side.
  const Mesh m = makeBoxMesh({1, 1, 1, 0, 0, 0, 1, 1, 1});
  const Real omega = measureOmega(m);
  const Real xi = 0.3, beta = 2 * xi / omega;
  const Real OmCrit = 2 * (std::sqrt(1 + xi * xi) - xi);
  auto amplitudeRatio = [&](Real Omega) {
    SolverOptions opt;
    opt.allowUnstableStep = true;
    opt.dt = Omega / omega;
    opt.damping.beta = beta;
    opt.velocityLimit = 1e300;
    auto s = oneDof(m, opt);
    const Index n6 = m.connectivity[6];
    s->state().v(n6, 0) = 1e-3;
    Real first = 0, last = 0;
    for (int i = 0; i < 2000; ++i) {
      s->step();
      const Real a = std::abs(s->state().u(n6, 0));
      if (i < 100) first = std::max(first, a);
      if (i >= 1900) last = std::max(last, a);
    }
    return last / first;
  };
  EXPECT_LT(amplitudeRatio(0.99 * OmCrit), 1.0);
  EXPECT_GT(amplitudeRatio(1.01 * OmCrit), 10.0);
}

TEST(TimeIntegration, RayleighCoefficientsGiveTheRatioAtBothFrequencies) {
  // ξ(ω) = α/(2ω) + βω/2 equals the requested ratio at ω1 and ω2.
  const auto d = RayleighDamping::fromRatio(0.05, 1.0, 10.0);
  for (Real f : {1.0, 10.0}) {
    const Real w = 2 * M_PI * f;
    EXPECT_NEAR(d.alpha / (2 * w) + d.beta * w / 2, 0.05, 1e-15);
  }
  EXPECT_THROW(RayleighDamping::fromRatio(0.05, 0.0, 10.0), InputError);
}

TEST(StableStep, CubeMeshCriticalStepIsEdgeOverPWaveSpeed) {
  // Lumped-mass hex8 of edge h: ω_max = 2 c_p / h ⇒ Δt_crit = h / c_p (VERIFICATION.md).
  const Mesh m = makeBoxMesh({4, 4, 4, 0, 0, 0, 2, 2, 2});
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), SolverOptions{});
  const auto mod = ElasticModuli::fromYoungPoisson(kE, kNu);
  const Real cp = std::sqrt(mod.pModulus() / kRho);
  EXPECT_NEAR(s.stableStep().dtCritical, 0.5 / cp, 1e-12 * 0.5 / cp);
  EXPECT_NEAR(s.dt(), 0.9 * 0.5 / cp, 1e-12 * 0.5 / cp);
  // With stiffness damping ξ = β ω_max / 2 the limit shrinks to (2/ω)(√(1+ξ²) - ξ).
  SolverOptions od;
  od.damping = RayleighDamping::fromRatio(0.05, 1.0, 20.0);
  Solver sd(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), od);
  const Real w = 2 * cp / 0.5, xi = od.damping.beta * w / 2;
  EXPECT_NEAR(sd.stableStep().dtCritical, (2 / w) * (std::sqrt(1 + xi * xi) - xi), 1e-15);
}

TEST(StableStep, UserStepAboveTheLimitIsRefusedWithTheLimitingElement) {
  BoxSpec spec{4, 2, 2, 0, 0, 0, 4, 2, 2};
  Mesh m = makeBoxMesh(spec);
  m.coords[3 * 1 + 0] = 0.5;  // node 1 moved: element 0 becomes the thinnest (L = 0.5 m)
  SolverOptions opt;
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), opt);
  const Real limit = s.stableStep().dtSafe;
  try {
    s.setTimeStep(1.5 * limit);
    FAIL() << "a step above the stable limit was accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("above the stable limit"), std::string::npos) << msg;
    EXPECT_NE(msg.find("element 0 of block 'rock'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("dt = 0 for automatic"), std::string::npos) << msg;
  }
  EXPECT_NO_THROW(s.setTimeStep(0.99 * limit));
}

TEST(Instability, ForcedUnstableStepStopsAtFirstExplodingValueWithLocation) {
  const Mesh m = makeBoxMesh({4, 4, 4, 0, 0, 0, 2, 2, 2});
  SolverOptions opt;
  opt.allowUnstableStep = true;
  Solver probe(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), opt);
  opt.dt = 1.2 * probe.stableStep().dtCritical;
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), opt);
  std::mt19937 rng(3);
  std::uniform_real_distribution<Real> U(-1e-3, 1e-3);
  for (Index n = 0; n < m.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) s.state().v(n, d) = U(rng);
  bool stopped = false;
  try {
    for (int i = 0; i < 5000; ++i) s.step();
  } catch (const InstabilityError& e) {
    stopped = true;
    const std::string msg = e.what();
    EXPECT_NE(msg.find("run stopped at step"), std::string::npos) << msg;
    EXPECT_NE(msg.find("at node"), std::string::npos) << msg;
    EXPECT_NE(msg.find("above the critical step"), std::string::npos) << msg;
  }
  EXPECT_TRUE(stopped) << "an unstable run was not detected";
  // Stopped before anything became non-finite: the state holds finite values only.
  for (Index n = 0; n < m.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) ASSERT_TRUE(std::isfinite(s.state().u(n, d)));
}

TEST(Energy, UndampedVibrationConservesEnergyOver10000Steps) {
  // Free distorted box, smooth + random initial displacement (excites hourglass modes too).
  // Leapfrog invariant: ½ m v^{n-½}·v^{n+½} + strain energy is exactly conserved for a linear
  // undamped system, so the drift must stay far below the 0.1 %.
  BoxSpec spec{8, 4, 4, 0, 0, 0, 8, 4, 4};
  Mesh m = makeBoxMesh(spec);
  tqtest::distortInterior(m, spec, 0.2);
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), SolverOptions{});
  std::mt19937 rng(5);
  std::uniform_real_distribution<Real> U(-1, 1);
  for (Index n = 0; n < m.numNodes(); ++n) {
    const Real x = m.coords[3 * n], z = m.coords[3 * n + 2];
    s.state().u(n, 0) = 1e-4 * std::sin(M_PI * z / 4) + 1e-6 * U(rng);
    s.state().u(n, 1) = 1e-6 * U(rng);
    s.state().u(n, 2) = 1e-4 * std::cos(M_PI * x / 8) + 1e-6 * U(rng);
  }
  Real maxErr = 0, e0 = 0;
  for (int i = 0; i < 10000; ++i) {
    s.step();
    if (i == 0) e0 = s.energy().kinetic + s.energy().internal;
    maxErr = std::max(maxErr, s.energy().error);
  }
  EXPECT_GT(e0, 0);
  EXPECT_LT(maxErr, 1e-3);
  EXPECT_LT(maxErr, 1e-9);  // what the invariant actually delivers (round-off)
  std::printf("energy drift over 10000 steps: %.3e\n", maxErr);
}

// The race-free scatter: slabs of one parity run concurrently, so they must share no node. The
// slabs are as narrow as the element order allows (docs/solid_solver.md "Data layout"); this checks
// the property they are built for on a distorted box that the block renumbers breadth first.
TEST(Determinism, SlabsOfOneParityShareNoNodeAndCoverEveryChunkOnce) {
  BoxSpec spec{24, 24, 12, 0, 0, 0, 24, 24, 12};
  Mesh m = makeBoxMesh(spec);
  tqtest::distortInterior(m, spec, 0.25);
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), SolverOptions{});
  const ElementBlock& b = *s.blocks()[0];
  const std::vector<Index>& start = b.slabStarts();
  const Index nChunks = b.numChunks(), K = ElementBlock::kChunk;
  ASSERT_GE(start.size(), 4u) << "too few slabs to test";
  EXPECT_EQ(start.front(), 0);
  EXPECT_EQ(start.back(), nChunks);
  for (size_t t = 0; t + 1 < start.size(); ++t) {
    EXPECT_LT(start[t], start[t + 1]) << "empty slab " << t;
    if (t + 2 < start.size()) EXPECT_GE(start[t + 1] - start[t], 4) << "slab " << t << " below 4 chunks";
  }
  for (int parity = 0; parity < 2; ++parity) {
    std::vector<Index> owner(size_t(m.numNodes()), -1);
    for (size_t t = size_t(parity); t + 1 < start.size(); t += 2)
      for (Index e = start[t] * K; e < std::min(b.numElems(), start[t + 1] * K); ++e)
        for (int k = 0; k < 8; ++k) {
          Index& o = owner[size_t(b.node(e, k))];
          ASSERT_TRUE(o < 0 || o == Index(t)) << "node " << b.node(e, k) << " in slabs " << o << " and " << t;
          o = Index(t);
        }
  }
}

// Subcycling: the chunks due at a step of level L get slabs of their own, in the order of their
// centres along the set's longest extent (the block's slabs are fronts of the element order, and
// the fine chunks sit in one or two of them). For every level: the list holds exactly the chunks
// of level <= L, each once, its slabs of one parity share no node, the finest level's chunks are
// spread over several slabs, and 1 and 2 threads give the same answer bit for bit. A box graded along z, the slowest
// index of its element order (layer widths (2i + 1)/24 m: the finest layer is 16 chunks, one level), gives four levels.
TEST(Determinism, LevelSlabsShareNoNodeCoverTheDueChunksAndAreBitwise) {
  BoxSpec spec{32, 32, 24, 0, 0, 0, 32, 32, 24};
  Mesh m = makeBoxMesh(spec);
  for (Index n = 0; n < m.numNodes(); ++n) {
    Real& z = m.coords[3 * size_t(n) + 2];
    z = z * z / 24;
  }
  auto make = [&] {
    auto s = std::make_unique<Solver>(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), SolverOptions{});
    s->enableSubcycling(3);
    return s;
  };
  {
    auto s = make();
    const ElementBlock& b = *s->blocks()[0];
    ASSERT_GE(b.numLevels(), 2) << "the graded box must give several levels";
    const Index K = ElementBlock::kChunk;
    for (int L = 0; L < b.numLevels(); ++L) {
      const std::vector<Index>& cs = b.levelChunks(L);
      std::vector<Index> want, got(cs);
      for (Index c = 0; c < b.numChunks(); ++c)
        if (b.chunkLevel(c) <= L) want.push_back(c);
      std::sort(got.begin(), got.end());
      EXPECT_EQ(got, want) << "level " << L;
      const std::vector<Index>& st = b.levelSlabStarts(L);
      ASSERT_GE(st.size(), 2u);
      EXPECT_EQ(st.front(), 0);
      EXPECT_EQ(st.back(), Index(cs.size()));
      for (size_t t = 0; t + 1 < st.size(); ++t) EXPECT_LT(st[t], st[t + 1]) << "level " << L << " empty slab " << t;
      if (L == 0)
        EXPECT_GE(st.size(), 5u) << "the finest chunks must be spread over several slabs: " << cs.size() << " chunks, "
                                 << st.size() - 1 << " slabs, first chunk " << cs.front();
      for (int parity = 0; parity < 2; ++parity) {
        std::vector<Index> owner(size_t(m.numNodes()), -1);
        for (size_t t = size_t(parity); t + 1 < st.size(); t += 2)
          for (Index k = st[t]; k < st[t + 1]; ++k)
            for (Index e = cs[size_t(k)] * K; e < std::min(b.numElems(), (cs[size_t(k)] + 1) * K); ++e)
              for (int j = 0; j < 8; ++j) {
                Index& o = owner[size_t(b.node(e, j))];
                ASSERT_TRUE(o < 0 || o == Index(t))
                    << "level " << L << ": node " << b.node(e, j) << " in slabs " << o << " and " << t;
                o = Index(t);
              }
      }
    }
  }
  auto run = [&](int threads) {
    omp_set_num_threads(threads);
    auto s = make();
    std::mt19937 rng(5);
    std::uniform_real_distribution<Real> U(-1e-2, 1e-2);
    for (Index n = 0; n < m.numNodes(); ++n)
      for (int d = 0; d < 3; ++d) s->state().v(n, d) = U(rng);
    for (int i = 0; i < 40; ++i) s->step();
    return std::vector<Real>(s->state().uData(), s->state().uData() + 3 * m.numNodes());
  };
  const std::vector<Real> a = run(1), b2 = run(2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_EQ(a, b2) << "1 vs 2 threads";
}

TEST(Determinism, OneAndTwoThreadsGiveBitwiseIdenticalResults) {
  BoxSpec spec{16, 16, 8, 0, 0, 0, 16, 16, 8};
  Mesh m = makeBoxMesh(spec);
  tqtest::distortInterior(m, spec, 0.25);
  auto run = [&](int threads) {
    omp_set_num_threads(threads);
    SolverOptions opt;
    opt.damping = RayleighDamping::fromRatio(0.05, 1.0, 20.0);
    Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(kE, kNu, kRho)}}), opt);
    s.fixFaceGroup("bottom", "xyz");
    std::mt19937 rng(11);
    std::uniform_real_distribution<Real> U(-1e-2, 1e-2);
    for (Index n = 0; n < m.numNodes(); ++n)
      for (int d = 0; d < 3; ++d) s.state().v(n, d) = U(rng);
    for (int i = 0; i < 60; ++i) s.step();
    std::vector<Real> out(s.state().uData(), s.state().uData() + 3 * m.numNodes());
    out.insert(out.end(), s.state().vData(), s.state().vData() + 3 * m.numNodes());
    for (Index e = 0; e < m.numElems(); ++e)
      for (int c = 0; c < 6; ++c) out.push_back(s.blocks()[0]->stress(e, c));
    out.push_back(s.energy().kinetic);
    out.push_back(s.energy().internal);
    out.push_back(s.energy().damping);
    return out;
  };
  const auto a = run(1), b = run(2);
  omp_set_num_threads(omp_get_num_procs());
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Real)), 0);
  // And the run did something: velocities changed and stresses are non-zero.
  Real smax = 0;
  for (size_t i = 6 * m.numNodes(); i < a.size() - 3; ++i) smax = std::max(smax, std::abs(a[i]));
  EXPECT_GT(smax, 1e3);
}
