// Mohr–Coulomb damage material inside the explicit solver: cyclic shear of one element and of a
// small mesh, energy bookkeeping of the dissipation, and thread-count independence.
//  - One element in simple shear (bottom fixed, top driven u_x = γ(t) h, top y and z held): the
//    stress is pure shear τ_zx, elastic–perfectly plastic with τ_y = c cos φ (Mohr–Coulomb with
//    σ1 = −τ, σ3 = τ: Nφ τ + τ = 2c√Nφ). A strain cycle ±γa dissipates the parallelogram's area
//    4 τ_y (γa − τ_y/G) V (e.g. Lubliner, Plasticity Theory, §3.3). Tolerance 1 % (the issue);
//    the loop is sampled once per step (≈ 500 steps per cycle, error O(Δγ²) at the four kinks).
//  - The hysteresis loop's area (work of the driving forces over a cycle between two equal peaks)
//    must equal what the energy balance books as dissipated (plastic term) plus the change of
//    stored and kinetic energy, within 1 %; the balance itself closes within 1 %.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <random>

#include "mc_helpers.hpp"
#include "test_helpers.hpp"

using namespace tq;
using namespace tqtest;

namespace {

std::vector<Index> faceNodes(const Mesh& m, const std::string& g) { return m.faceNodes(g); }

struct CycleResult {
  Real loopArea = 0;      // work of the actuator over one cycle (J)
  Real plastic = 0;       // plastic dissipation over the same cycle (J)
  Real storedChange = 0;  // change of internal − plastic (elastic incl. hourglass) (J)
  Real kineticChange = 0;
  Real maxError = 0;  // largest energy-balance error over the run
  Real gammaPeak = 0;
};

// Drive the top face of `mesh` with u_x = γa h sin(2π t / T) for 2.25 cycles and measure the
// second cycle, between the peaks at t = 1.25 T and 2.25 T.
CycleResult cyclicShear(const Mesh& mesh, std::shared_ptr<const Material> mat, Real h, Real gammaA, Real period,
                        const std::string& topFixed) {
  Solver s(mesh, makeBlocksByRegion(mesh, {{"rock", mat}}), {});
  s.fixFaceGroup("bottom", "xyz");
  if (!topFixed.empty()) s.fixFaceGroup("top", topFixed);
  auto act = std::make_shared<DisplacementActuator>(
      faceNodes(mesh, "top"), 0, [=](Real t) { return gammaA * h * std::sin(2 * M_PI * t / period); });
  s.addContributor(ForcePhase::Interface, act);  // a prescribed motion: after the loads
  CycleResult r;
  Real w1 = 0, p1 = 0, e1 = 0, k1 = 0;
  bool marked = false;
  while (s.time() < 2.25 * period) {
    s.step();
    r.maxError = std::max(r.maxError, s.energy().error);
    if (!marked && s.time() >= 1.25 * period) {
      marked = true;
      w1 = act->work();
      p1 = s.energy().plastic;
      e1 = s.energy().internal - s.energy().plastic;
      k1 = s.energy().kinetic;
    }
  }
  r.loopArea = act->work() - w1;
  r.plastic = s.energy().plastic - p1;
  r.storedChange = s.energy().internal - s.energy().plastic - e1;
  r.kineticChange = s.energy().kinetic - k1;
  return r;
}

// The cycle's energy balance: the loop's area equals the plastic dissipation plus the stored and
// kinetic energy's changes within 1 % of the area, and the step-wise balance error stays below 1 %.
void expectEnergyBalance(const CycleResult& r) {
  EXPECT_NEAR(r.loopArea, r.plastic + r.storedChange + r.kineticChange, 0.01 * r.loopArea);
  EXPECT_LT(r.maxError, 0.01);
}

// cyclicShear (period 0.5 s) of `mesh` in the Mohr–Coulomb damage material `p` to k times the
// shear strain at which it yields in simple shear, c cos φ / G.
CycleResult shearBeyondYield(const Mesh& mesh, const MohrCoulombDamageParams& p, Real h, Real k,
                             const std::string& topFixed) {
  auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
  const Real G = mat->elasticModuli().mu, tauY = p.cohesion * std::cos(p.frictionAngle * M_PI / 180);
  return cyclicShear(mesh, mat, h, k * tauY / G, 0.5, topFixed);
}

}  // namespace

TEST(SolidMcCyclicShear, OneElementLoopMatchesAnalyticAndEnergyBalance) {
  const Mesh m = makeBoxMesh({1, 1, 1, 0, 0, 0, 1, 1, 1});
  auto p = paperRock(0);  // perfect plasticity for the analytic loop
  auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
  const Real G = mat->elasticModuli().mu, tauY = p.cohesion * std::cos(p.frictionAngle * M_PI / 180);
  const Real gammaY = tauY / G, gammaA = 4 * gammaY;
  // Step: the top actuator snaps the top exactly to the target, so the 2.25 cycles take a few
  // thousand steps; the loading period is 300 times the element's period (quasi-static).
  const CycleResult r = cyclicShear(m, mat, 1.0, gammaA, 0.5, "yz");
  const Real analytic = 4 * tauY * (gammaA - gammaY) * 1.0;
  std::printf(
      "one element: loop %.6e J, plastic %.6e J, analytic %.6e J, stored change %.3e, kinetic change %.3e, "
      "max balance error %.2e\n",
      r.loopArea, r.plastic, analytic, r.storedChange, r.kineticChange, r.maxError);
  EXPECT_NEAR(r.plastic / analytic, 1.0, 0.01);
  EXPECT_NEAR(r.loopArea / analytic, 1.0, 0.01);
  expectEnergyBalance(r);
}

TEST(SolidMcCyclicShear, OneElementWithDamageLoopEqualsBookedDissipation) {
  const Mesh m = makeBoxMesh({1, 1, 1, 0, 0, 0, 1, 1, 1});
  for (auto effect : {DamageEffect::Cohesion, DamageEffect::CohesionAndStiffness}) {
    auto p = paperRock(100);
    p.damageEffect = effect;
    const CycleResult r = shearBeyondYield(m, p, 1.0, 20, "yz");
    std::printf("one element, damage %s: loop %.6e J, plastic %.6e J, stored change %.3e, max balance error %.2e\n",
                damageEffectName(effect).c_str(), r.loopArea, r.plastic, r.storedChange, r.maxError);
    EXPECT_GT(r.plastic, 0.0);
    expectEnergyBalance(r);
  }
}

TEST(SolidMcCyclicShear, SmallMeshLoopEqualsBookedDissipation) {
  BoxSpec spec{3, 3, 3, 0, 0, 0, 3, 3, 3};
  Mesh m = makeBoxMesh(spec);
  distortInterior(m, spec, 0.2);
  for (Real R : {0.0, 100.0}) {
    auto p = paperRock(R);
    const CycleResult r = shearBeyondYield(m, p, 3.0, 6, "z");
    std::printf(
        "3x3x3 mesh, R %.0f: loop %.6e J, plastic %.6e J, stored change %.3e, kinetic change %.3e, "
        "max balance error %.2e\n",
        R, r.loopArea, r.plastic, r.storedChange, r.kineticChange, r.maxError);
    EXPECT_GT(r.plastic, 0.5 * r.loopArea);  // the loop is mostly plastic dissipation
    expectEnergyBalance(r);
  }
}

TEST(SolidMcDeterminism, OneAndTwoThreadsGiveBitwiseIdenticalResults) {
  BoxSpec spec{16, 16, 8, 0, 0, 0, 16, 16, 8};
  Mesh m = makeBoxMesh(spec);
  distortInterior(m, spec, 0.25);
  auto mat = std::make_shared<MohrCoulombDamageMaterial>(paperRock(100));
  auto run = [&](int threads) {
    omp_set_num_threads(threads);
    Solver s(m, makeBlocksByRegion(m, {{"rock", mat}}), {});
    s.fixFaceGroup("bottom", "xyz");
    std::mt19937 rng(11);
    std::uniform_real_distribution<Real> U(-0.5, 0.5);  // strong enough to yield
    for (Index n = 0; n < m.numNodes(); ++n)
      for (int d = 0; d < 3; ++d) s.state().v(n, d) = U(rng);
    for (int i = 0; i < 40; ++i) s.step();
    std::vector<Real> out(s.state().uData(), s.state().uData() + 3 * m.numNodes());
    const auto& b = *s.blocks()[0];
    for (Index e = 0; e < m.numElems(); ++e) {
      for (int c = 0; c < 6; ++c) out.push_back(b.stress(e, c));
      out.push_back(b.history(mc_history::kDamage, e));
    }
    out.push_back(s.energy().plastic);
    out.push_back(s.energy().internal);
    return out;
  };
  const auto a = run(1), b = run(2);
  omp_set_num_threads(omp_get_num_procs());
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Real)), 0);
  EXPECT_GT(a[a.size() - 2], 0.0);  // plasticity happened
}

namespace {

// A block of `mat` on a distorted 15 x 13 x 7 box (1,365 elements: the last chunk 21 full) with
// stiffness damping, every 97th element inactive, random velocities strong enough to yield, 40 steps
// on the kernel path `simd`: u, v, every element's stress and history, and the energy terms.
std::vector<Real> kernelPathRun(const std::shared_ptr<const Material>& mat, ElementBlock::Simd simd) {
  BoxSpec spec{15, 13, 7, 0, 0, 0, 15, 13, 7};
  Mesh m = makeBoxMesh(spec);
  distortInterior(m, spec, 0.25);
  SolverOptions opt;
  opt.damping = RayleighDamping::fromRatio(0.05, 1.0, 20.0);
  Solver s(m, makeBlocksByRegion(m, {{"rock", mat}}), opt);
  ElementBlock& b = *s.blocks()[0];
  b.setSimd(simd);
  EXPECT_EQ(b.simd(), simd);
  for (Index e = 5; e < m.numElems(); e += 97) b.setActive(e, false, s.state());
  s.rebuild();
  s.fixFaceGroup("bottom", "xyz");
  s.setTimeStep(0);
  std::mt19937 rng(23);
  std::uniform_real_distribution<Real> U(-0.5, 0.5);
  for (Index n = 0; n < m.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) s.state().v(n, d) = U(rng);
  for (int i = 0; i < 40; ++i) s.step();
  std::vector<Real> out(s.state().uData(), s.state().uData() + 3 * m.numNodes());
  out.insert(out.end(), s.state().vData(), s.state().vData() + 3 * m.numNodes());
  for (Index e = 0; e < m.numElems(); ++e) {
    for (int c = 0; c < 6; ++c) out.push_back(b.stress(e, c));
    for (int h = 0; h < b.numHistory(); ++h) out.push_back(b.history(h, e));
  }
  const EnergyBalance& en = s.energy();
  out.insert(out.end(), {en.kinetic, en.internal, en.damping, en.plastic, en.external});
  return out;
}

}  // namespace

// The kernel's AVX-512 path runs the AVX2 path's operations on 8 elements a vector instead of 4
// (ElementBlock::Simd) and the Mohr–Coulomb trial and screen on 8 lanes instead of 4 (without FMA
// contraction: with it this test fails on the yielding block): the same bits, on a yielding
// Mohr–Coulomb block (the stored form, the material called a chunk at a time) and on an elastic one
// (the total form), both with stiffness damping (the damped kernel), a chunk filled in part and some
// elements inactive (the lanes' masks). Skipped on a CPU without AVX-512.
TEST(SolidSimdPaths, Avx512KernelGivesTheAvx2KernelsBits) {
  if (ElementBlock::simdAvailable() < ElementBlock::Simd::Avx512) GTEST_SKIP() << "this CPU has no AVX-512";
  const std::shared_ptr<const Material> yielding = std::make_shared<MohrCoulombDamageMaterial>(paperRock(100));
  const std::shared_ptr<const Material> elastic = std::make_shared<ElasticMaterial>(ElasticParams{8e9, 0.27, 2700});
  for (const bool yields : {true, false}) {
    const auto& mat = yields ? yielding : elastic;
    const auto a = kernelPathRun(mat, ElementBlock::Simd::Avx2), b = kernelPathRun(mat, ElementBlock::Simd::Avx512);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Real)), 0) << (yields ? "yielding" : "elastic");
    EXPECT_GT(a[a.size() - 3], 0.0);           // the stiffness damping dissipated
    EXPECT_EQ(a[a.size() - 2] > 0.0, yields);  // plasticity happened in the yielding block only
  }
}

// The vector paths gather the corners' displacements and velocities four elements at a time,
// transposed in registers; the generic path copies them one value at a time. On the elastic block of
// the test above (the total form: no return map to amplify a last bit) the AVX2 path's state after 40
// steps equals the generic path's to round-off (1e-12 of each quantity's largest magnitude; the
// paths differ only in fused multiply-adds), so every corner of every element, the chunk's tail and
// the inactive lanes are gathered as the scalar loop gathers them. Skipped on a CPU without AVX2.
TEST(SolidSimdPaths, VectorGatherGivesTheGenericPathsState) {
  if (ElementBlock::simdAvailable() < ElementBlock::Simd::Avx2) GTEST_SKIP() << "this CPU has no AVX2";
  const std::shared_ptr<const Material> elastic = std::make_shared<ElasticMaterial>(ElasticParams{8e9, 0.27, 2700});
  const auto a = kernelPathRun(elastic, ElementBlock::Simd::Generic);
  const auto b = kernelPathRun(elastic, ElementBlock::Simd::Avx2);
  ASSERT_EQ(a.size(), b.size());
  const size_t nu = size_t(3 * 16 * 14 * 8);  // u, then v, of the box's nodes
  auto worst = [&](size_t from, size_t to) {
    Real scale = 0, diff = 0;
    for (size_t i = from; i < to; ++i) {
      scale = std::max(scale, std::abs(a[i]));
      diff = std::max(diff, std::abs(a[i] - b[i]));
    }
    return diff / scale;
  };
  EXPECT_LT(worst(0, nu), 1e-12) << "displacements";
  EXPECT_LT(worst(nu, 2 * nu), 1e-12) << "velocities";
  EXPECT_LT(worst(2 * nu, a.size() - 5), 1e-12) << "stresses";
  EXPECT_GT(worst(0, nu), 0.0);  // the two paths are different code (fused multiply-adds)
}
