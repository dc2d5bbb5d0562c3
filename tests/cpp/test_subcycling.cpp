// Subcycling (multi-time-step explicit integration, Solver::enableSubcycling; docs/solid_solver.md
// "Subcycling"): elements whose own stable step is 2^l times the finest step at least are
// stepped every 2^l fine steps, their nodes move linearly in between (nodal partition with linear
// interpolation, Belytschko, Yen & Mullen 1979).
//
// Reference (VERIFICATION.md "Solid: waves and boundaries"): a soil layer on elastic rock, surface
// over outcrop F2(ω) = 1/[cos(kH) + i α sin(kH)], α = ρs cs/(ρr cr) (Kramer 1996 §7.2), on a
// column meshed fine (h = 0.25 m) in its lower half and coarse (h = 1 m) in its upper half, so the
// coarse elements may step 4 times the step the fine ones set.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstring>
#include <map>
#include <sstream>

#include "mc_helpers.hpp"
#include "test_helpers.hpp"
#include "tq/contact/contact.hpp"
#include "tq/core/state_archive.hpp"
#include "wave_cases.hpp"

using namespace tq;
using tqtest::GaussPulse;
using tqtest::pairRockWithLiningAt;
using tqtest::StagedRun;

namespace {

constexpr Real kH = 50, kHFine = 0.25, kHCoarse = 1.0, kCsS = 500, kRhoS = 1900, kNuS = 0.3;
constexpr Real kCsR = 1500, kRhoR = 2500, kNuR = 0.25;

/// The layer of H = 50 m (cs 500 m/s) on the rock's viscoelastic base, meshed with 100 elements of
/// 0.25 m below z = 25 m and 25 of 1 m above (cross-section 1 m), every node level tied (a 1D
/// column), undamped: tests/cpp/wave_cases.hpp's column with its nodes moved.
struct GradedColumn : tqcases::ColumnRun {
  void setUp(Real tEndMotion) {
    const Index nFine = Index(0.5 * kH / kHFine), nCoarse = Index(0.5 * kH / kHCoarse);
    width = kHCoarse;
    reshape = [nFine](Mesh& m) {  // layer j (at z = j m) to j h_fine, then h_coarse steps
      for (Index n = 0; n < m.numNodes(); ++n) {
        Real& z = m.coords[3 * size_t(n) + 2];
        const Real j = std::round(z);
        z = j <= Real(nFine) ? j * kHFine : 0.5 * kH + (j - Real(nFine)) * kHCoarse;
      }
    };
    const Real GS = kRhoS * kCsS * kCsS;
    BottomBoundaryInput b;
    b.distance = 25;
    b.rho = kRhoR;
    b.cs = kCsR;
    b.cp = kCsR * std::sqrt(2 * (1 - kNuR) / (1 - 2 * kNuR));
    GaussPulse pulse;
    pulse.t0 = 0.02;
    pulse.tau = 0.003;
    MotionInput m;
    m.present = true;
    pulse.sample(tEndMotion, 1e-4, m.time, m.ax);
    ColumnRun::setUp(Real(nFine + nCoarse), nFine + nCoarse, {{"soil", {2 * GS * (1 + kNuS), kNuS, kRhoS}}}, 0, m, b);
  }
};

/// Surface over outcrop of the graded column at frequency f, from 8 s of the pulse's response.
struct TransferRun {
  std::vector<Real> t, us, uo;
  SubcyclingInfo info;
  std::complex<Real> at(Real f) const { return tqtest::dft(t, us, f) / tqtest::dft(t, uo, f); }
};

TransferRun runColumn(int levels) {
  GradedColumn run;
  run.setUp(0.2);
  Solver& s = *run.solver;
  TransferRun r;
  r.info = s.enableSubcycling(levels);
  const Index top = run.topNode();
  const IncidentMotion& inc = run.stages->seismic()->motion();
  while (s.time() < 8.0) {
    s.step();
    r.t.push_back(s.time());
    r.us.push_back(s.relativeDisplacement(top, 0));
    r.uo.push_back(2 * inc.displacement(0, s.time()));  // outcrop = 2 × incident
  }
  return r;
}

/// A lined circular tunnel in a ring of rock (plane strain, 1 m thick): C25 lining (r 5.25–6 m,
/// 3 × 48 elements, Mohr–Coulomb damage) bonded to Mohr–Coulomb damage rock (r 6–40 m, 12 × 48,
/// the paper's non-associated flow, dilation 0) by the dynamic contact, loaded by a sudden
/// pressure on the rock's outer face, ramped in 2 ms: the wave focuses on the opening, the rock
/// round it yields in shear (its uniaxial strength 2c cos φ/(1 − sin φ) = 2.2 MPa, the hoop stress
/// about twice the pressure there) and presses the lining onto it, so the interface stays
/// bonded. The rock's elements grow from 0.8 to 5.2 m, so its outer nodes may step 8 times the
/// lining's step.
struct LinedTunnelPeaks {
  SubcyclingInfo info;
  std::vector<Real> hoopMin, hoopMax;  // each lining element's extreme hoop stress (Pa)
  Real uPeak = 0;                      // the lining's largest inward radial displacement (m)
  Real plastic = 0;                    // the plastic dissipation at the end (J)
  Real rockDamage = 0;                 // the rock's largest damage at the end
  Index bonded = 0, pairs = 0;
  std::vector<Real> u;  // the displacements at the end
};

/// A sudden pressure on the quads `q` as nodal loads p × (quad area)/4 along each quad's inward
/// normal (toward the axis), ramped as (1 − cos)/2 over 40 ms in 17 linear pieces, then held: the
/// load's content below cs/(8 h) of the coarse rock elements, which their step resolves.
void addOuterPressure(Solver& s, const Mesh& m, const std::vector<Index>& q, Real pressure) {
  std::map<Index, std::array<Real, 3>> f;
  for (size_t k = 0; k < q.size() / 4; ++k) {
    Real c[3], x[3] = {0, 0, 0};
    tqtest::quadDiagonalCross(m, q, k, c);  // twice the area vector, either orientation
    for (int i = 0; i < 4; ++i)
      for (int d = 0; d < 3; ++d) x[d] += m.coords[3 * size_t(q[4 * k + size_t(i)]) + size_t(d)];
    const Real sgn = c[0] * x[0] + c[2] * x[2] > 0 ? -1.0 : 1.0;  // inward
    for (int i = 0; i < 4; ++i)
      for (int d = 0; d < 3; ++d) f[q[4 * k + size_t(i)]][size_t(d)] += sgn * pressure * 0.5 * c[d] / 4;
  }
  const Real tRamp = 0.04;
  TimeFunction ramp;
  for (int i = 0; i <= 16; ++i) {
    ramp.t.push_back(tRamp * i / 16);
    ramp.value.push_back(0.5 * (1 - std::cos(M_PI * i / 16)));
  }
  ramp.t.push_back(10.0);
  ramp.value.push_back(1.0);
  for (const auto& [n, fv] : f)
    for (int d : {0, 2}) s.addLoad({{n}, d, fv[size_t(d)], ramp});
}

LinedTunnelPeaks runLinedTunnel(int levels, Real dtFactor, Real pressure, Real tEnd, bool blocksInOneLoop = true) {
  const Index nAround = 48;
  const Mesh l = makeRingSliceMesh({5.25, 6.0, 3, nAround, 1.0, "lining"});
  const Mesh r = makeRingSliceMesh({6.0, 40.0, 12, nAround, 1.0, "rock"});
  Mesh m = tqtest::withLining(r, l);
  const Index off = r.numNodes();
  for (const char* f : {"ymin", "ymax"}) {
    for (Index q : r.faces.at(f)) m.faces["sides"].push_back(q);
    for (Index q : l.faces.at(f)) m.faces["sides"].push_back(q + off);
  }
  m.faces["rock_outer"] = r.faces.at("outer");
  for (Index q : l.faces.at("outer")) m.faces["lining_outer"].push_back(q + off);
  pairRockWithLiningAt(m, off, 6.0);  // the rock's nodes at r = 6 m with the lining's outer nodes
  checkMesh(m);
  SolverOptions opt;
  opt.damping.alpha = 2;  // light mass damping
  auto rock = std::make_shared<MohrCoulombDamageMaterial>(tqtest::paperRock(100));
  auto lining = std::make_shared<MohrCoulombDamageMaterial>(tqtest::paperLining(100));
  Solver s(m, makeBlocksByRegion(m, {{"rock", rock}, {"lining", lining}}), opt);
  s.fixFaceGroup("sides", "y");  // plane strain
  s.setBlockSlabsInOneLoop(blocksInOneLoop);
  auto contact = std::make_shared<DynamicContact>(s, rockLiningPairs(m), ContactParams{});
  s.addContributor(ForcePhase::Interface, contact);
  addOuterPressure(s, m, m.faces.at("rock_outer"), pressure);
  s.setTimeStep(dtFactor * s.stableStep().dtSafe);
  LinedTunnelPeaks p;
  p.info = s.enableSubcycling(levels);
  const ElementBlock& b = *s.blocks()[1];
  const Index nl = b.numElems();
  std::vector<Real> ct(static_cast<size_t>(nl)), sn0(static_cast<size_t>(nl));
  for (Index e = 0; e < nl; ++e) {
    Real c[3] = {0, 0, 0};
    for (int k = 0; k < 8; ++k)
      for (int d = 0; d < 3; ++d) c[d] += m.coords[3 * size_t(b.node(e, k)) + size_t(d)] / 8;
    const Real th = std::atan2(c[2], c[0]);
    ct[size_t(e)] = std::cos(th), sn0[size_t(e)] = std::sin(th);
  }
  const std::vector<Index>& inner = l.faces.at("inner");
  p.hoopMin.assign(size_t(nl), 0);
  p.hoopMax.assign(size_t(nl), 0);
  while (s.time() < tEnd) {
    s.step();
    for (Index e = 0; e < nl; ++e) {
      const Real c = ct[size_t(e)], sn = sn0[size_t(e)];
      const Real h = b.stress(e, XX) * sn * sn + b.stress(e, ZZ) * c * c - 2 * b.stress(e, ZX) * sn * c;
      p.hoopMin[size_t(e)] = std::min(p.hoopMin[size_t(e)], h);
      p.hoopMax[size_t(e)] = std::max(p.hoopMax[size_t(e)], h);
    }
    for (Index qn : inner) {
      const Index n = qn + off;
      const Real x = m.coords[3 * size_t(n)], z = m.coords[3 * size_t(n) + 2], rr = std::hypot(x, z);
      const Real ur = (s.state().u(n, 0) * x + s.state().u(n, 2) * z) / rr;
      p.uPeak = std::max(p.uPeak, -ur);
    }
  }
  p.plastic = s.energy().plastic;
  const ElementBlock& rb = *s.blocks()[0];
  for (Index e = 0; e < rb.numElems(); ++e) p.rockDamage = std::max(p.rockDamage, rb.history(mc_history::kDamage, e));
  p.bonded = contact->count(PairState::Bonded);
  p.pairs = contact->numPairs();
  p.u.assign(s.state().uData(), s.state().uData() + 3 * size_t(s.state().numNodes()));
  return p;
}

/// The largest relative difference of the peaks of `b` from those of `a`: each element's extreme
/// hoop stresses (relative to the largest |hoop stress| of `a`, so that a near-zero extreme does not
/// count as a large error), the lining's peak inward displacement and the plastic dissipation.
Real worstPeakDifference(const LinedTunnelPeaks& a, const LinedTunnelPeaks& b, Real& hoopScale) {
  hoopScale = 0;
  for (size_t e = 0; e < a.hoopMin.size(); ++e) hoopScale = std::max({hoopScale, -a.hoopMin[e], a.hoopMax[e]});
  Real w = 0;
  for (size_t e = 0; e < a.hoopMin.size(); ++e)
    w = std::max(
        {w, std::abs(b.hoopMin[e] - a.hoopMin[e]) / hoopScale, std::abs(b.hoopMax[e] - a.hoopMax[e]) / hoopScale});
  w = std::max(w, std::abs(b.uPeak / a.uPeak - 1));
  return std::max(w, std::abs(b.plastic / a.plastic - 1));
}

/// The energy record of a preloaded box stepped single-rate (levels 0) or subcycled: an elastic
/// block 4 × 4 m, 1 m of elements 0.25 m high at the bottom and 12 m of cubes of 1 m above (the
/// upper part may step 4 times the lower part's step: levels 0 | 1 | 2, the top 128 elements
/// evaluated every 4th step), its base fixed, brought to rest under its own weight (dynamic
/// relaxation), then a vertical and a lateral load on its top, 0.5 and 0.2 % of the weight, applied
/// suddenly (light mass damping, α = 0.5 /s): it bounces and sways about its loaded state, the weight's and
/// the preload's first-order work hundreds of times the energy of the motion, as under a
/// preloaded tunnel's shaking. At every fine step: the balance's drift (EnergyBalance::error); at
/// the steps where every node updates (all the elements evaluated): the reported internal energy
/// against the change of the block's strain energy ½ u·f_int(u) (linear elastic, no initial stress).
struct PreloadedBoxEnergy {
  SubcyclingInfo info;
  Real maxDrift = 0;       // the largest |balance − balance₀| over every fine step / scale
  Real maxStrainDiff = 0;  // the largest |internal − Δ(½ u·f_int)| / scale at the synchronous steps
  Real motionEnergy = 0;   // the largest kinetic energy (J)
  Real scale = 0;          // the largest |external work| (J)
};

PreloadedBoxEnergy runPreloadedBox(int levels, Real dtFactor, Real tEnd) {
  BoxSpec box{4, 4, 16, 0, 0, 0, 4, 4, 16, "rock"};
  Mesh m = makeBoxMesh(box);
  for (Index n = 0; n < m.numNodes(); ++n) {  // layer j at z = j m: 0.25 m steps to z = 1 m, then 1 m
    Real& z = m.coords[3 * size_t(n) + 2];
    const Real j = std::round(z);
    z = j <= 4 ? 0.25 * j : j - 3;
  }
  const Real rho = 2200, g = 9.81;
  SolverOptions opt;
  opt.gravity[2] = -g;
  opt.damping.alpha = 0.5;
  Solver s(m, makeBlocksByRegion(m, {{"rock", tqtest::elastic(2e9, 0.25, rho)}}), opt);
  s.fixFaceGroup("bottom", "xyz");
  RelaxParams rp;
  rp.tolerance = 1e-9;
  EXPECT_TRUE(s.relax(rp).converged);
  s.resetMotion();
  s.setTime(0);
  const std::vector<Index> top = m.faceNodes("top");
  const Real perNode = rho * g * 4 * 4 * 13 / Real(top.size());
  s.addLoad({top, 2, -0.005 * perNode, TimeFunction::constant(1.0)});
  s.addLoad({top, 0, 0.002 * perNode, TimeFunction::constant(1.0)});
  s.setTimeStep(dtFactor * s.stableStep().dtSafe);
  PreloadedBoxEnergy r;
  r.info = s.enableSubcycling(levels);
  const Index cycle = Index(1) << r.info.levels, N = s.state().numNodes();
  Real ref = 0, balance0 = 0;
  for (Index k = 0; s.time() < tEnd; ++k) {
    s.step();
    const EnergyBalance& e = s.energy();
    const Real balance = e.interface + e.kinetic + e.internal + e.damping + e.boundary - e.external;
    if (k == 0) balance0 = balance;
    r.maxDrift = std::max(r.maxDrift, std::abs(balance - balance0));
    r.motionEnergy = std::max(r.motionEnergy, e.kinetic);
    r.scale = std::max(r.scale, std::abs(e.external));
    if (k % cycle != 0) continue;
    // This step evaluated every element at the positions it started from, u − Δt v.
    Real strain = 0;
    for (size_t i = 0; i < 3 * size_t(N); ++i)
      strain += 0.5 * (s.state().uData()[i] - s.dt() * s.state().vData()[i]) * s.state().fIntData()[i];
    if (k == 0) ref = strain;
    r.maxStrainDiff = std::max(r.maxStrainDiff, std::abs(e.internal - (strain - ref)));
  }
  r.maxStrainDiff /= r.scale;
  r.maxDrift /= r.scale;
  return r;
}

}  // namespace

// The energy balance of subcycled stepping closes at every fine step (runPreloadedBox): the works
// of the internal and the external forces and of the dashpots are booked at each node's own
// updates, consistently with its kinetic energy ½ m v^{k-½}·v^{k+½} of its own step, kept also
// between them (updateNodesSubcycled), so kinetic + internal + damping − external is the sum of
// the nodes' own update identities: round-off, measured 1.0e-15 of the external work (bound
// 1e-12). Single-rate books the damping as c v̄² Δt, 2.0e-6 here (bound 1e-5; 1.7e-14 undamped).
// Booked as the single-rate scheme books them, the internal work as the elements are evaluated and
// the kinetic energy from v alone between updates, a coarse node's motion was counted on the fine
// elements next to it before its external work, and the balance swung by 2.7e-2 of the external
// work here (7.4 % of the example's static_water energies at 0.005 s). What multi-rate stepping
// does not conserve exactly is the strain energy: the internal work booked at the coarse nodes'
// updates differs from the change of ½ u·f_int(u) by the sampling of the fine elements' forces
// at those updates, 6.2e-5 of the external work at the steps where every node updates (bound
// 1e-4; single-rate 1.6e-9), 1.5e-6 at half the step (levels then 1 | 2; bound a quarter of it).
TEST(Subcycling, EnergyBalanceClosesAtEveryFineStep) {
  const Real tEnd = 0.1;
  const PreloadedBoxEnergy one = runPreloadedBox(0, 1.0, tEnd), sub = runPreloadedBox(2, 1.0, tEnd);
  const PreloadedBoxEnergy half = runPreloadedBox(2, 0.5, tEnd), oneHalf = runPreloadedBox(0, 0.5, tEnd);
  std::printf(
      "preloaded box, %.3g s: external work up to %.4g J, kinetic up to %.4g J; balance drift over every fine step: "
      "single-rate %.3g, subcycled (levels %d, %.2f of the evaluations) %.3g, at half the step %.3g; "
      "internal vs ½ u·f_int at the synchronous steps: single-rate %.3g (half the step %.3g), subcycled %.3g, at half "
      "the step (levels %d) %.3g (ratio %.3g)\n",
      tEnd, one.scale, one.motionEnergy, one.maxDrift, sub.info.levels, sub.info.costFraction, sub.maxDrift,
      half.maxDrift, one.maxStrainDiff, oneHalf.maxStrainDiff, sub.maxStrainDiff, half.info.levels, half.maxStrainDiff,
      half.maxStrainDiff / sub.maxStrainDiff);
  ASSERT_EQ(sub.info.levels, 2) << "the 1 m cubes step 4 times the 0.25 m cubes' step";
  ASSERT_GT(one.scale, 50 * one.motionEnergy) << "the loads' first-order work must dominate";
  EXPECT_LT(one.maxDrift, 1e-5);
  EXPECT_LT(sub.maxDrift, 1e-12);
  EXPECT_LT(half.maxDrift, 1e-12);
  EXPECT_LT(sub.maxStrainDiff, 1e-4);
  EXPECT_LT(half.maxStrainDiff, 0.25 * sub.maxStrainDiff);
}

// The coarse half steps 4 times the fine step (levels 0 | 1 at the size change | 2), and the
// surface/outcrop transfer function stays within 3 % of Kramer's F2 up to the coarse elements'
// limit cs/(40 h) = 12.5 Hz (the criterion of the uniform column, tests/cpp/test_waves.cpp), and
// within 1 % of the same column stepped at one step (measured 0.71 % at 12.5 Hz: the coarse
// elements' time-step dispersion, (ωΔt)²/24 of the phase, is 16 times the single step's there).
TEST(Subcycling, GradedLayerOnRockMatchesKramerAndTheSingleStepRun) {
  const TransferRun one = runColumn(0), sub = runColumn(3);
  ASSERT_EQ(sub.info.levels, 2) << "coarse elements of 4 × the fine size step 4 × the fine step";
  ASSERT_EQ(sub.info.nodes.size(), 3u);
  EXPECT_GT(sub.info.nodes[2], 0);
  const Real alpha = kRhoS * kCsS / (kRhoR * kCsR);
  Real worstOne = 0, worstSub = 0, worstDiff = 0, fSub = 0, fDiff = 0;
  for (Real f = 0.5; f <= kCsS / (40 * kHCoarse) + 1e-9; f += 0.25) {
    const Real k = 2 * M_PI * f / kCsS;
    const Real F2 = 1 / std::abs(std::complex<Real>(std::cos(k * kH), alpha * std::sin(k * kH)));
    const Real a1 = std::abs(one.at(f)), as = std::abs(sub.at(f));
    worstOne = std::max(worstOne, std::abs(a1 / F2 - 1));
    if (std::abs(as / F2 - 1) > worstSub) worstSub = std::abs(as / F2 - 1), fSub = f;
    if (std::abs(as / a1 - 1) > worstDiff) worstDiff = std::abs(as / a1 - 1), fDiff = f;
  }
  std::printf(
      "graded layer on rock, 0.5 .. 12.5 Hz: one step vs F2 worst %.2f %%; subcycled (levels %d, %.2f of "
      "the evaluations) vs F2 worst %.2f %% at %.2f Hz, vs one step worst %.3f %% at %.2f Hz\n",
      100 * worstOne, sub.info.levels, sub.info.costFraction, 100 * worstSub, fSub, 100 * worstDiff, fDiff);
  EXPECT_LT(worstOne, 0.03);
  EXPECT_LT(worstSub, 0.03);
  EXPECT_LT(worstDiff, 0.01);
}

// A case with contact and Mohr–Coulomb plasticity (runLinedTunnel, 5 MPa): the rock yields
// (damage up to 0.05), the lining too, the interface stays bonded. Stepped at levels 0 | 1 | 2,
// the lining's extreme hoop stresses, its peak displacement and the plastic dissipation stay
// within 0.1 % of the single-rate run, the accuracy asked of a stepping setting (measured
// 0.028 %). Beside it, the single-rate run's own sensitivity to its step: at 0.99 of it the same
// peaks move by 0.040 %, at half of it by 0.13 %; the subcycled run must be no further from the
// half-step run than the single-rate run is (10 % margin): multi-rate stepping adds no error of
// its own beyond the time discretisation's. (With 0.8 MPa ramped linearly in 2 ms instead, content
// far above what the coarse elements resolve, the subcycled run differed by 0.23 % with the rock
// elastic, 0.99 of the step by 0.079 %: the coarse elements step near their own limit, where
// their dispersion of that content differs.)
TEST(Subcycling, LinedTunnelWithContactAndMohrCoulombMatchesTheSingleRateRun) {
  const Real p = 5e6, tEnd = 0.12;
  const LinedTunnelPeaks one = runLinedTunnel(0, 1.0, p, tEnd), sub = runLinedTunnel(3, 1.0, p, tEnd);
  const LinedTunnelPeaks step99 = runLinedTunnel(0, 0.99, p, tEnd), half = runLinedTunnel(0, 0.5, p, tEnd);
  Real scale = 0, unused = 0;
  const Real dSub = worstPeakDifference(one, sub, scale), d99 = worstPeakDifference(one, step99, unused);
  const Real dOneHalf = worstPeakDifference(half, one, unused), dSubHalf = worstPeakDifference(half, sub, unused);
  std::printf(
      "lined tunnel, contact + Mohr–Coulomb, %.1f MPa outer pressure: hoop stress scale %.3f MPa, peak inward "
      "displacement %.4g mm, plastic dissipation %.4g J, rock damage %.3g, %d of %d pairs bonded; subcycled "
      "(levels %d, %.2f of the evaluations) worst peak difference %.4f %%; single-rate at 0.99 dt %.4f %%; "
      "from the half-step run: single-rate %.4f %%, subcycled %.4f %%\n",
      p / 1e6, scale / 1e6, 1e3 * one.uPeak, one.plastic, one.rockDamage, int(one.bonded), int(one.pairs),
      sub.info.levels, sub.info.costFraction, 100 * dSub, 100 * d99, 100 * dOneHalf, 100 * dSubHalf);
  ASSERT_GE(sub.info.levels, 2) << "the outer rock steps 4 times the lining's step";
  ASSERT_GT(one.rockDamage, 0.01) << "the rock must yield (the case tests plasticity)";
  ASSERT_EQ(one.bonded, one.pairs) << "the interface stays bonded (no brittle failure)";
  EXPECT_EQ(sub.bonded, sub.pairs);
  EXPECT_LT(dSub, 1e-3);
  EXPECT_LT(dSubHalf, 1.1 * dOneHalf);
}

// Subcycled steps are deterministic: 1 and 2 threads give the same displacements bit for bit, and
// a state saved in the middle of a coarse step and restored repeats the following steps bitwise.
TEST(Subcycling, ThreadsAndRestoreMidCycleAreBitwise) {
  auto run = [](int threads, bool restore) {
    omp_set_num_threads(threads);
    GradedColumn c;
    c.setUp(0.05);
    Solver& s = *c.solver;
    s.enableSubcycling(3);
    for (int i = 0; i < 3; ++i) s.step();  // fine step 3 of a 4-step coarse cycle
    StateArchive ar;
    if (restore) {
      ar.beginSave();
      s.checkpoint(ar);
      ar.end();
      for (int i = 0; i < 37; ++i) s.step();
      ar.beginRestore();
      s.checkpoint(ar);
      ar.end();
    }
    for (int i = 0; i < 400; ++i) s.step();
    const Real* u = s.state().uData();
    return std::vector<Real>(u, u + 3 * size_t(s.state().numNodes()));
  };
  const std::vector<Real> a = run(1, false), b = run(2, false), c = run(1, true);
  omp_set_num_threads(omp_get_num_procs());
  Real peak = 0;
  for (Real x : a) peak = std::max(peak, std::abs(x));
  ASSERT_GT(peak, 1e-6) << "the pulse must have reached the column";
  EXPECT_EQ(a, b) << "1 vs 2 threads";
  EXPECT_EQ(a, c) << "restored in mid-cycle";
}

// The rock and the lining share no node (contact pairs join them), so the internal forces run both
// blocks' slabs in one parallel loop a parity, the widest first: the same bits as block after
// block, on 1 and 2 threads (runLinedTunnel subcycled, the rock and the lining yielding).
TEST(Subcycling, BlocksSlabsInOneLoopGiveTheBlockByBlockBits) {
  const Real p = 5e6, tEnd = 0.03;
  omp_set_num_threads(1);
  const LinedTunnelPeaks apart = runLinedTunnel(3, 1.0, p, tEnd, false), one = runLinedTunnel(3, 1.0, p, tEnd);
  omp_set_num_threads(2);
  const LinedTunnelPeaks two = runLinedTunnel(3, 1.0, p, tEnd);
  omp_set_num_threads(omp_get_num_procs());
  ASSERT_GE(apart.info.levels, 2);
  ASSERT_GT(apart.plastic, 0.0) << "the rock must yield";
  for (const LinedTunnelPeaks* r : {&one, &two}) {
    EXPECT_EQ(apart.u, r->u);
    EXPECT_EQ(apart.hoopMin, r->hoopMin);
    EXPECT_EQ(apart.hoopMax, r->hoopMax);
    EXPECT_EQ(std::memcmp(&apart.plastic, &r->plastic, sizeof(Real)), 0);
  }
}

// A rock ring of 6–150 m (30 × 96 elements, 10 m thick, 5,952 nodes: 6 node chunks) under a sudden
// pressure on its outer face, subcycled: the outer chunks hold coarse nodes only, so the fine
// steps set f_int and f_ext in fewer chunks than all (asserted). The displacements, velocities,
// stresses, works and plastic dissipation after 1,500 fine steps are those of the run that sets every
// chunk, bitwise, on 1 and 2 threads, and after a coupling window's start copy (no forces in it:
// StateArchive::setWindowStart) restored in mid-cycle, single-rate too.
TEST(Subcycling, ForcesSetInTheDueChunksOnlyGiveEveryChunksBits) {
  struct Out {
    std::vector<Real> u, v, stress;
    Real plastic = 0, external = 0, internal = 0;  // the works booked (f_ext: trapezoidal)
    Index fine = 0, chunks = 0;
    int levels = 0;
  };
  const auto run = [](int levels, bool dueOnly, int threads, bool restore) {
    omp_set_num_threads(threads);
    const Mesh m = makeRingSliceMesh({6.0, 150.0, 30, 96, 10.0, "rock"});
    SolverOptions opt;
    opt.damping.alpha = 2;
    auto rock = std::make_shared<MohrCoulombDamageMaterial>(tqtest::paperRock(100));
    Solver s(m, makeBlocksByRegion(m, {{"rock", rock}}), opt);
    for (const char* side : {"ymin", "ymax"}) s.fixFaceGroup(side, "y");  // plane strain
    s.setDueChunksOnly(dueOnly);
    addOuterPressure(s, m, m.faces.at("outer"), 2e7);
    s.setTimeStep(s.stableStep().dtSafe);
    Out o;
    o.levels = s.enableSubcycling(levels).levels;
    o.fine = s.nodeChunksSet(0);
    o.chunks = s.numNodeChunks();
    StateArchive window;
    window.setWindowStart(true);
    for (int k = 0; k < 1500; ++k) {
      if (restore && k == 99) {  // fine step 3 of a coarse cycle, in the load's ramp: save, 37 steps, back
        window.beginSave();
        s.checkpoint(window);
        window.end();
        for (int j = 0; j < 37; ++j) s.step();
        window.beginRestore();
        s.checkpoint(window);
        window.end();
      }
      s.step();
    }
    const NodalState& st = s.state();
    o.u.assign(st.uData(), st.uData() + 3 * size_t(st.numNodes()));
    o.v.assign(st.vData(), st.vData() + 3 * size_t(st.numNodes()));
    const ElementBlock& b = *s.blocks()[0];
    for (Index e = 0; e < b.numElems(); ++e)
      for (int c = 0; c < 6; ++c) o.stress.push_back(b.stress(e, c));
    o.plastic = s.energy().plastic;
    o.external = s.energy().external;
    o.internal = s.energy().internal;
    return o;
  };
  const auto sameBits = [](Real a, Real b) { return std::memcmp(&a, &b, sizeof(Real)) == 0; };
  const Out every = run(3, false, 1, false), due = run(3, true, 1, false), two = run(3, true, 2, false),
            restored = run(3, true, 1, true), single = run(0, true, 1, false), singleRestored = run(0, true, 1, true);
  omp_set_num_threads(omp_get_num_procs());
  Real peak = 0;
  for (Real x : every.u) peak = std::max(peak, std::abs(x));
  std::printf("rock ring, %d levels: the fine steps set %ld of %ld node chunks; |u| up to %.3g m, plastic %.4g J\n",
              due.levels, long(due.fine), long(due.chunks), peak, every.plastic);
  ASSERT_EQ(every.levels, 3);
  ASSERT_LT(due.fine, due.chunks) << "a chunk of coarse nodes only must be left out at the fine steps";
  ASSERT_EQ(every.fine, every.chunks);
  ASSERT_GT(peak, 1e-4) << "the load must move the ring";
  ASSERT_GT(every.plastic, 0.0) << "the rock must yield";
  for (const Out* r : {&due, &two, &restored}) {
    EXPECT_EQ(every.u, r->u);
    EXPECT_EQ(every.v, r->v);
    EXPECT_EQ(every.stress, r->stress);
    EXPECT_TRUE(sameBits(every.plastic, r->plastic));
    EXPECT_TRUE(sameBits(every.external, r->external));
    EXPECT_TRUE(sameBits(every.internal, r->internal));
  }
  EXPECT_EQ(single.u, singleRestored.u);
  EXPECT_EQ(single.v, singleRestored.v);
  EXPECT_EQ(single.stress, singleRestored.stress);
  EXPECT_TRUE(sameBits(single.external, singleRestored.external));
  EXPECT_TRUE(sameBits(single.plastic, singleRestored.plastic));
}

// The kinetic energy summed only at the steps whose balance is read (Solver::setKineticEnergyWanted):
// on the graded column (dashpots at its base: every instance of the node update) subcycled and
// single-rate, the run that sums it at every 7th step only and the one that sums it at every step
// hold the same displacements, velocities and accelerations and the same works after every step,
// bitwise, and the same kinetic energy and balance error at the summed steps; at the others kinetic
// and error are NaN and the last summed error stays reported with its time.
TEST(Subcycling, KineticEnergyOnlyWhereReadLeavesEverythingBitwise) {
  for (const int levels : {3, 0}) {
    GradedColumn every, some;
    every.setUp(0.05);
    some.setUp(0.05);
    Solver &a = *every.solver, &b = *some.solver;
    const SubcyclingInfo info = a.enableSubcycling(levels);
    b.enableSubcycling(levels);
    ASSERT_TRUE(a.state().hasDashpots());
    if (levels > 0) ASSERT_EQ(info.levels, 2) << "the coarse half steps 4 times the fine step";
    const size_t D = 3 * size_t(a.state().numNodes());
    const auto same = [D](const Real* x, const Real* y) { return std::equal(x, x + D, y); };
    Index summed = 0, skipped = 0;
    Real lastTime = 0;
    for (int k = 0; k < 400; ++k) {
      const bool wanted = k % 7 == 0;
      b.setKineticEnergyWanted(wanted);
      a.step();
      b.step();
      ASSERT_TRUE(same(a.state().uData(), b.state().uData())) << "u, step " << k << ", levels " << levels;
      ASSERT_TRUE(same(a.state().vData(), b.state().vData())) << "v, step " << k;
      ASSERT_TRUE(same(a.state().aData(), b.state().aData())) << "a, step " << k;
      const EnergyBalance &ea = a.energy(), &eb = b.energy();
      ASSERT_EQ(ea.internal, eb.internal) << "step " << k;
      ASSERT_EQ(ea.damping, eb.damping) << "step " << k;
      ASSERT_EQ(ea.boundary, eb.boundary) << "step " << k;
      ASSERT_EQ(ea.external, eb.external) << "step " << k;
      // step 0 (the first after resetMotion) sets the balance's reference: summed whatever is asked
      if (wanted || k == 0) {
        ASSERT_EQ(ea.kinetic, eb.kinetic) << "step " << k;
        ASSERT_EQ(ea.error, eb.error) << "step " << k;
        lastTime = b.time();
        ++summed;
      } else {
        ASSERT_TRUE(std::isnan(eb.kinetic) && std::isnan(eb.error)) << "step " << k;
        ++skipped;
      }
      ASSERT_EQ(b.checkedEnergyTime(), lastTime);
    }
    const Real* v = a.state().vData();
    Real vmax = 0;
    for (size_t i = 0; i < D; ++i) vmax = std::max(vmax, std::abs(v[i]));
    std::printf(
        "graded column, levels %d: %lld steps summed the kinetic energy, %lld skipped it; |v| up to %.3g m/s, "
        "kinetic energy %.4g J, balance error %.3g at the last summed step\n",
        levels, (long long)summed, (long long)skipped, vmax, a.energy().kinetic, b.checkedEnergyError());
    EXPECT_GT(vmax, 1e-6) << "the pulse must have reached the column";
    EXPECT_GT(a.energy().kinetic, 0);
  }
}

// What subcycling cannot do is refused with the reason and the fix.
TEST(Subcycling, RefusesStiffnessDampingAndTooManyLevels) {
  GradedColumn c;
  c.in.options.damping = RayleighDamping{0.1, 1e-4};
  c.setUp(0.05);
  try {
    c.solver->enableSubcycling(3);
    FAIL() << "stiffness-proportional damping accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mass-proportional"), std::string::npos) << e.what();
  }
  EXPECT_THROW(c.solver->enableSubcycling(9), InputError);
}
