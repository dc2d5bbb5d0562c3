// The rock–lining dynamic contact force (paper eqs. 9–13). References (VERIFICATION.md "Coulomb
// interface with cohesion"):
//  - a bonded pair moves as one node would: a mesh whose interface nodes are duplicated and
//    bonded must reproduce the mesh with merged nodes (masses added) to round-off (issue: 1e-6
//    relative; the pair force is exactly the one that makes both end the step together);
//  - a block of mass m on a fixed base, normal force N, slowly rising tangential force T: sticks
//    until T = μs N + c A, then slides with acceleration (T − μd N)/m (1 %); friction dissipation
//    μd N × slip in the energy balance;
//  - a pair pulled apart separates when the tension exceeds c A; pushed back it closes without
//    interpenetration (the normal force closes the predicted gap exactly: opening ≥ −1e-12 m).
#include <gtest/gtest.h>

#include <omp.h>

#include <array>
#include <cmath>
#include <cstring>
#include <map>

#include "mc_helpers.hpp"
#include "test_helpers.hpp"
#include "tq/contact/contact.hpp"

using namespace tq;
using namespace tqtest;

namespace {

const Real kRhoL = 2500;

// A rock box (z in [−hr, 0]) under a lining box (z in [0, hl]), nx × ny columns of side `w`; with
// `duplicate` the nodes at z = 0 are doubled (rock side, lining side) and listed as pairs, and
// the lining's bottom face is `lining_outer` (outward normal −z, towards the rock).
Mesh stackMesh(Index nx, Index ny, Index nzr, Index nzl, Real hr, Real hl, Real w, bool duplicate) {
  if (!duplicate) {
    Mesh m = makeBoxMesh({nx, ny, nzr + nzl, 0, 0, -hr, nx * w, ny * w, hr + hl});
    // Grade the z coordinates so the interface sits at z = 0 with the split's element heights.
    for (Index n = 0; n < m.numNodes(); ++n) {
      Real& z = m.coords[3 * size_t(n) + 2];
      const Real k = std::round((z + hr) / (hr + hl) * (nzr + nzl));
      z = k <= nzr ? -hr + hr * k / nzr : hl * (k - nzr) / nzl;
    }
    m.regionNames = {"rock", "lining"};
    for (Index e = 0; e < m.numElems(); ++e) m.region[e] = e / (nx * ny) < nzr ? 0 : 1;
    return m;
  }
  return pairedStack(nx, ny, nzr, nzl, hr, hl, w, true);
}

std::shared_ptr<const Material> rockMat() { return elastic(8e9, 0.27, 2700); }
std::shared_ptr<const Material> liningMat() { return elastic(28e9, 0.17, kRhoL); }

Index nodeAt(const Mesh& m, const Real x[3], Index skip = -1) {
  for (Index n = 0; n < m.numNodes(); ++n) {
    if (n == skip) continue;
    Real d = 0;
    for (int i = 0; i < 3; ++i) d += std::abs(m.coords[3 * size_t(n) + i] - x[i]);
    if (d < 1e-9) return n;
  }
  return -1;
}

}  // namespace

// Duplicated and bonded vs merged: same loads (top pressure pulse and lateral push, equal per
// position), same initial velocity field, Rayleigh damping on (exercises the effective masses of
// the prediction); every node's displacement after 400 steps agrees to round-off.
TEST(SolidContact, BondedPairMovesAsOneNodeOfAMergedMesh) {
  for (auto model : {InterfaceModel::Bonded, InterfaceModel::DynamicContact}) {
    const Mesh split = stackMesh(3, 2, 3, 2, 3.0, 1.0, 1.0, true);
    const Mesh merged = stackMesh(3, 2, 3, 2, 3.0, 1.0, 1.0, false);
    SolverOptions opt;
    opt.damping = RayleighDamping::fromRatio(0.05, 50.0, 500.0);
    auto build = [&](const Mesh& m) {
      auto s = std::make_unique<Solver>(m, makeBlocksByRegion(m, {{"rock", rockMat()}, {"lining", liningMat()}}), opt);
      s->fixFaceGroup("bottom", "xyz");
      const auto top = m.faceNodes("top");
      TimeFunction pulse{{0.0, 0.002, 0.004, 1.0}, {0.0, 1.0, 0.0, 0.0}};
      s->addLoad({top, 2, -2e5, pulse});
      s->addLoad({top, 0, 1e5, pulse});
      for (Index n = 0; n < m.numNodes(); ++n) {
        const Real x = m.coords[3 * size_t(n)], z = m.coords[3 * size_t(n) + 2];
        s->state().v(n, 0) = 0.05 * std::sin(0.7 * z + 0.3 * x);
        s->state().v(n, 2) = 0.03 * std::cos(0.5 * x - 0.2 * z);
      }
      return s;
    };
    auto a = build(split), b = build(merged);
    ContactParams cp;
    cp.model = model;
    cp.cohesion = 1e12;  // never fails here: this is the bonded state
    auto contact = std::make_shared<DynamicContact>(*a, rockLiningPairs(split), cp);
    a->addContributor(ForcePhase::Interface, contact);
    ASSERT_EQ(a->dt(), b->dt());
    for (int i = 0; i < 400; ++i) {
      a->step();
      b->step();
    }
    Real umax = 0, diff = 0;
    for (Index n = 0; n < merged.numNodes(); ++n) {
      const Real* x = &merged.coords[3 * size_t(n)];
      const Index p = nodeAt(split, x), q = nodeAt(split, x, p);
      ASSERT_GE(p, 0);
      for (int d = 0; d < 3; ++d) {
        umax = std::max(umax, std::abs(b->state().u(n, d)));
        diff = std::max(diff, std::abs(a->state().u(p, d) - b->state().u(n, d)));
        if (q >= 0) diff = std::max(diff, std::abs(a->state().u(q, d) - b->state().u(n, d)));
      }
    }
    std::printf("bonded (%s) vs merged: max |u| %.3e m, max difference %.3e m (%.2e relative), energy error %.2e\n",
                interfaceModelName(model).c_str(), umax, diff, diff / umax, a->energy().error);
    EXPECT_GT(umax, 1e-5);
    EXPECT_LT(diff / umax, 1e-10);
    EXPECT_EQ(contact->count(PairState::Bonded), contact->numPairs());
    EXPECT_LT(std::abs(a->energy().interface), 1e-9 * a->energy().external + 1e-12);
  }
}

namespace {

// One lining element (the block, 2 m × 2 m × 0.5 m: wide, so that it slides without rocking) on
// one rock element (the base, fixed), four pairs with A = 1 m² each. Forces on the block's bottom
// nodes (the pair nodes), equal shares: normal −N ẑ (pressing) and tangential T(t) x̂ or a
// vertical fz(t). Time step: safety 0.75, because a single hex8 that has lifted off is a free
// element whose volumetric mode, ω = 2√((3λ+2μ)/ρ)/h, lies 19 % above the element estimate
// 2 c_p / h used for the stable step (ν = 0.17) — a property of an isolated element, not of the
// contact (docs/solid_solver.md, "Rock–lining interface").
constexpr Real kBlockArea = 4.0;
struct BlockOnBase {
  Mesh mesh = stackMesh(1, 1, 1, 1, 0.5, 0.5, 2.0, true);
  std::unique_ptr<Solver> solver;
  std::shared_ptr<DynamicContact> contact;
  std::vector<Index> blockNodes, bottom;
  Real mass = 0;
  BlockOnBase(const ContactParams& cp, Real N, TimeFunction T, TimeFunction fz, Real fzScale, Real alpha = 0) {
    SolverOptions opt;
    opt.damping.alpha = alpha;  // mass damping: lets a block that hit the base come to rest
    opt.safety = 0.75;
    solver =
        std::make_unique<Solver>(mesh, makeBlocksByRegion(mesh, {{"rock", rockMat()}, {"lining", liningMat()}}), opt);
    for (Index n = 0; n < 8; ++n)
      for (int d = 0; d < 3; ++d) solver->fix(n, d);  // the base: rock nodes 0-7
    for (Index n = 8; n < 16; ++n) blockNodes.push_back(n);
    bottom = {8, 9, 10, 11};
    for (Index n : blockNodes) mass += solver->state().mass(n);
    solver->addLoad({bottom, 2, -N / 4, TimeFunction::constant(1.0)});
    solver->addLoad({bottom, 0, 0.25, std::move(T)});
    solver->addLoad({bottom, 2, fzScale / 4, std::move(fz)});
    contact = std::make_shared<DynamicContact>(*solver, rockLiningPairs(mesh), cp);
    solver->addContributor(ForcePhase::Interface, contact);
  }
  Real momentum(int d) const {
    Real p = 0;
    for (Index n : blockNodes) p += solver->state().mass(n) * solver->state().v(n, d);
    return p;
  }
};

constexpr Real kPullCohesion = 0.5e6;  // Pa, the pulled blocks' cohesion

// A block bonded by cohesion kPullCohesion (`after` its failure), under no normal or tangential
// force, pulled up by fz × c A; mass damping (200 /s) lets it come to rest on the base.
BlockOnBase pulledBlock(AfterFailure after, TimeFunction fz) {
  ContactParams cp;
  cp.cohesion = kPullCohesion;
  cp.afterFailure = after;
  return BlockOnBase(cp, 0.0, TimeFunction::constant(0.0), std::move(fz), cp.cohesion * kBlockArea, 200.0);
}

}  // namespace

TEST(SolidContact, BlockSticksUntilStaticStrengthThenSlidesWithDynamicFriction) {
  ContactParams cp;
  cp.staticFriction = 0.6;
  cp.dynamicFriction = 0.5;
  cp.cohesion = 0.5e6;
  const Real N = 4e6, cA = cp.cohesion * kBlockArea, rate = 4.4e6 / 0.25;  // T reaches μs N + cA at 0.25 s
  BlockOnBase b(cp, N, TimeFunction{{0.0, 10.0}, {0.0, 10.0 * rate}}, TimeFunction::constant(0.0), 0.0);
  Solver& s = *b.solver;
  ASSERT_NEAR(b.contact->pairs().area[0], 1.0, 1e-12);
  ASSERT_NEAR(b.contact->pairs().normal[2], -1.0, 1e-12);
  Real tSlip = -1;
  while (s.time() < 0.4) {
    s.step();
    const Index slipping = b.contact->count(PairState::Slipping);
    if (tSlip < 0 && slipping > 0) {
      tSlip = s.time() - s.dt();  // the force of the step just taken was computed at t − Δt
      EXPECT_EQ(slipping, 4);
    }
    if (tSlip < 0) EXPECT_EQ(b.contact->count(PairState::Bonded), 4);
  }
  ASSERT_GT(tSlip, 0);
  const Real Tslip = rate * tSlip, expected = cp.staticFriction * N + cA;
  std::printf("block: slip starts at T = %.6e N, expected μs N + c A = %.6e N (%.3f %%)\n", Tslip, expected,
              100 * (Tslip / expected - 1));
  EXPECT_NEAR(Tslip / expected, 1.0, 0.01);
  // Sliding phase: from t1 to t2 the block's momentum grows by ∫(T − μd N)dt.
  const Real t1 = s.time(), p1 = b.momentum(0), w1 = s.energy().interface;
  Real slip1 = 0;
  for (Index p = 0; p < 4; ++p) slip1 += b.contact->slip(p, s.state()) / 4;
  Real impulse = 0;
  while (s.time() < t1 + 0.05) {
    impulse += s.dt() * (rate * s.time() - cp.dynamicFriction * N);
    s.step();
    ASSERT_EQ(b.contact->count(PairState::Slipping), 4);
  }
  const Real t2 = s.time(), p2 = b.momentum(0);
  const Real accel = (p2 - p1) / (b.mass * (t2 - t1));
  const Real expectedAccel = impulse / (b.mass * (t2 - t1));
  std::printf("block: sliding acceleration %.6e m/s^2, (T - μd N)/m = %.6e m/s^2 (%.4f %%)\n", accel, expectedAccel,
              100 * (accel / expectedAccel - 1));
  EXPECT_NEAR(accel / expectedAccel, 1.0, 0.01);
  // Friction dissipation μd N × slip booked in the balance; the balance closes.
  Real slip2 = 0;
  for (Index p = 0; p < 4; ++p) slip2 += b.contact->slip(p, s.state()) / 4;
  const Real dissipated = s.energy().interface - w1, expectedDiss = cp.dynamicFriction * N * (slip2 - slip1);
  std::printf("block: friction dissipation %.6e J, μd N slip = %.6e J; energy error %.2e\n", dissipated, expectedDiss,
              s.energy().error);
  EXPECT_NEAR(dissipated / expectedDiss, 1.0, 0.01);
  EXPECT_LT(s.energy().error, 0.01);
}

TEST(SolidContact, PulledApartPairSeparatesAtCohesionAndRecontactsWithoutPenetration) {
  for (auto after : {AfterFailure::CohesionLost, AfterFailure::CohesionKept}) {
    const Real cA = kPullCohesion * kBlockArea;
    // Upward pull rising to 1.2 c A at 0.1 s, then a downward push of 0.2 c A from 0.1 s on.
    TimeFunction fz{{0.0, 0.1, 0.1 + 1e-9, 10.0}, {0.0, 1.2, -0.2, -0.2}};
    BlockOnBase b = pulledBlock(after, fz);
    Solver& s = *b.solver;
    Real tSep = -1, tClose = -1, minOpening = 0;
    while (s.time() < 0.4) {
      s.step();
      const Index sep = b.contact->count(PairState::Separated);
      if (tSep < 0 && sep > 0) {
        tSep = s.time() - s.dt();
        EXPECT_EQ(sep, 4);
      }
      if (tSep > 0 && tClose < 0 && sep == 0) tClose = s.time();
      for (Index p = 0; p < 4; ++p) minOpening = std::min(minOpening, b.contact->opening(p, s.state()));
    }
    ASSERT_GT(tSep, 0);
    ASSERT_GT(tClose, 0) << "the pushed-back block never closed the gap";
    const Real Fsep = fz(tSep) * cA;
    std::printf(
        "pull (%s): separation at tension %.6e N (c A = %.6e N, %.3f %%), re-contact at t = %.4f s, "
        "min opening %.2e m\n",
        afterFailureName(after).c_str(), Fsep, cA, 100 * (Fsep / cA - 1), tClose, minOpening);
    EXPECT_NEAR(Fsep / cA, 1.0, 0.01);
    EXPECT_GE(minOpening, -1e-12);  // no interpenetration
    // After re-contact the block rests on the base: all pairs closed, sticking.
    for (Index p = 0; p < 4; ++p) {
      EXPECT_NEAR(b.contact->opening(p, s.state()), 0.0, 1e-12);
      EXPECT_EQ(int(b.contact->state(p)),
                int(after == AfterFailure::CohesionLost ? PairState::Stuck : PairState::Bonded));
      EXPECT_TRUE(b.contact->failed(p));
    }
    EXPECT_LT(s.energy().error, 0.01);
  }
}

// After failure: a re-closed pair carries tension again only with cohesion_kept.
TEST(SolidContact, AfterFailureOptionDecidesWhetherAClosedPairCarriesTensionAgain) {
  for (auto after : {AfterFailure::CohesionLost, AfterFailure::CohesionKept}) {
    // Break (pull to 1.2 c A), push back for a while, then pull again with 0.5 c A.
    BlockOnBase b =
        pulledBlock(after, {{0.0, 0.1, 0.1 + 1e-9, 0.4, 0.4 + 1e-9, 10.0}, {0.0, 1.2, -0.2, -0.2, 0.5, 0.5}});
    Solver& s = *b.solver;
    while (s.time() < 0.4) s.step();
    ASSERT_EQ(b.contact->count(PairState::Separated), 0) << "not closed again before the second pull";
    while (s.time() < 0.5) s.step();
    const Index sep = b.contact->count(PairState::Separated);
    if (after == AfterFailure::CohesionLost)
      EXPECT_EQ(sep, 4);
    else
      EXPECT_EQ(sep, 0);
  }
}

TEST(SolidContact, PairsFromTheMeshHaveRadialNormalsAndTributaryAreasOnARing) {
  // Lining ring (r 5.25-6.0) and rock ring (6.0-9.0) with duplicated nodes at r = 6.
  RingSpec rl{5.25, 6.0, 3, 48, 0.25, "lining"}, rr{6.0, 9.0, 4, 48, 0.25, "rock"};
  Mesh l = makeRingSliceMesh(rl), r = makeRingSliceMesh(rr);
  Mesh m = withLining(r, l);
  const Index off = r.numNodes();
  for (Index q : l.faces.at("outer")) m.faces["lining_outer"].push_back(q + off);
  pairRockWithLiningAt(m, off, 6.0);
  const ContactPairs p = rockLiningPairs(m);
  ASSERT_EQ(p.size(), 96);  // every rock node at r = 6 m (48 around, 2 across) with its lining node
  Real total = 0;
  for (Index k = 0; k < p.size(); ++k) {
    const Real* x = &m.coords[3 * size_t(p.node1[k])];
    const Real rr2 = std::hypot(x[0], x[2]);
    EXPECT_NEAR(p.normal[3 * k] * x[0] / rr2 + p.normal[3 * k + 2] * x[2] / rr2, 1.0, 1e-12);  // radial, outwards
    EXPECT_NEAR(p.normal[3 * k + 1], 0.0, 1e-12);
    total += p.area[k];
  }
  // Σ A = the polygon's lateral area 48 · 2 R sin(π/48) · width.
  EXPECT_NEAR(total, 48 * 2 * 6.0 * std::sin(M_PI / 48) * 0.25, 1e-10);
}

// Node-disjoint pairs are computed on the solver's threads (from DynamicContact::kThreadedPairs
// pairs), their work summed after in pair order: the same bits as the one loop, at any thread
// count. 625 pairs under a shaken stack whose pairs bond, slip and separate.
TEST(SolidContact, PairsOnThreadsGiveTheOneLoopsBits) {
  const Mesh m = stackMesh(24, 24, 2, 1, 2.0, 0.5, 1.0, true);
  auto run = [&](int threads, bool onThreads, bool& threaded) {
    omp_set_num_threads(threads);
    Solver s(m, makeBlocksByRegion(m, {{"rock", rockMat()}, {"lining", liningMat()}}), {});
    s.fixFaceGroup("bottom", "xyz");
    for (Index n = 0; n < m.numNodes(); ++n) {  // a shaking that differs from pair to pair
      const Real x = m.coords[3 * size_t(n)], y = m.coords[3 * size_t(n) + 1], z = m.coords[3 * size_t(n) + 2];
      const Real up = z > 0 ? 0.1 : 0.0;  // m/s: the lining moves, the rock is at rest
      s.state().v(n, 0) = up * 0.4 * std::sin(0.9 * x + 0.4 * y);
      s.state().v(n, 1) = up * 0.3 * std::cos(0.6 * y - 0.5 * x);
      s.state().v(n, 2) = up * 0.5 * std::sin(0.35 * x * y);
    }
    ContactParams cp;
    cp.cohesion = 2e5;
    auto contact = std::make_shared<DynamicContact>(s, rockLiningPairs(m), cp);
    contact->computeOnThreads(onThreads);
    threaded = contact->computedOnThreads();
    s.addContributor(ForcePhase::Interface, contact);
    for (int i = 0; i < 300; ++i) s.step();
    std::vector<Real> out(s.state().uData(), s.state().uData() + 3 * m.numNodes());
    for (Index p = 0; p < contact->numPairs(); ++p) {
      out.push_back(Real(contact->state(p)));
      out.push_back(contact->normalForce(p));
      out.push_back(contact->tangentialForce(p));
    }
    out.push_back(contact->dissipatedEnergy());
    out.push_back(s.energy().error);
    std::printf("%d thread(s), %s: bonded %d, slipping %d, separated %d of %d; dissipated %.6e J\n", threads,
                threaded ? "pairs on the threads" : "one loop", int(contact->count(PairState::Bonded)),
                int(contact->count(PairState::Slipping)), int(contact->count(PairState::Separated)),
                int(contact->numPairs()), contact->dissipatedEnergy());
    return std::make_pair(out,
                          std::array<Index, 3>{contact->count(PairState::Bonded), contact->count(PairState::Slipping),
                                               contact->count(PairState::Separated)});
  };
  bool t0 = true, t1 = false, t2 = false;
  const auto serial = run(1, false, t0), one = run(1, true, t1), two = run(2, true, t2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_FALSE(t0);
  EXPECT_TRUE(t1 && t2);
  const Index P = (24 + 1) * (24 + 1);
  ASSERT_GE(size_t(P), DynamicContact::kThreadedPairs);
  // every branch taken: pairs still bonded, slipping and separated
  for (Index c : serial.second) EXPECT_GT(c, 0);
  EXPECT_GT(serial.first[serial.first.size() - 2], 0.0);  // friction and separation dissipated work
  ASSERT_EQ(serial.first.size(), one.first.size());
  ASSERT_EQ(serial.first.size(), two.first.size());
  EXPECT_EQ(std::memcmp(serial.first.data(), one.first.data(), serial.first.size() * sizeof(Real)), 0);
  EXPECT_EQ(std::memcmp(serial.first.data(), two.first.data(), serial.first.size() * sizeof(Real)), 0);
}

// The pairs' prediction from kept terms (PredictionTerms: the central difference's m/Δt ± h and
// Δt²/(m + hΔt) formed once for the masses, dashpots, α and Δt) is the same arithmetic as the
// direct one: the same bits at every dof, fixed ones included, and again after each of a mass, a
// dashpot and Δt changed (the terms formed again).
TEST(SolidContact, PredictionFromKeptTermsGivesTheDirectPredictionsBits) {
  const Mesh m = stackMesh(4, 3, 2, 1, 2.0, 0.5, 1.0, true);
  SolverOptions opt;
  opt.damping.alpha = 0.7;
  Solver s(m, makeBlocksByRegion(m, {{"rock", rockMat()}, {"lining", liningMat()}}), opt);
  s.fixFaceGroup("bottom", "xyz");
  for (Index n = 0; n < m.numNodes(); n += 3) s.state().addDashpot(n, n % 3, 1e6 * (1 + n % 5));
  for (Index n = 0; n < m.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) s.state().v(n, d) = 0.01 * std::sin(1.3 * Real(n) + 0.7 * d);
  s.setTimeStep(s.stableStep().dtSafe);
  s.step();  // f_int from the motion
  std::vector<Index> nodes;
  for (Index n = m.numNodes() - 1; n >= 0; --n) nodes.push_back(n);  // any order
  PredictionTerms terms;
  Index fixed = 0;
  auto compare = [&](const char* after) {
    SCOPED_TRACE(after);
    for (Index n = 0; n < m.numNodes(); ++n)
      for (int d = 0; d < 3; ++d) s.state().fExt(n, d) = 1e3 * std::cos(0.9 * Real(n) - 0.4 * d);
    ASSERT_TRUE(terms.update(s, s.dt(), s.state(), nodes));
    const PairPrediction predict(s, s.dt(), s.state());
    fixed = 0;
    for (size_t k = 0; k < nodes.size(); ++k)
      for (int d = 0; d < 3; ++d) {
        Real u0, w0, u1, w1;
        predict(nodes[k], d, u0, w0);
        predict(nodes[k], d, terms.node(k), u1, w1);
        fixed += s.isFixed(nodes[k], d);
        ASSERT_EQ(std::memcmp(&u0, &u1, sizeof(Real)), 0) << "node " << nodes[k] << " dof " << d;
        ASSERT_EQ(std::memcmp(&w0, &w1, sizeof(Real)), 0) << "node " << nodes[k] << " dof " << d;
      }
  };
  compare("the first step");
  EXPECT_GT(fixed, 0);
  const Index top = m.numNodes() - 1;  // a free node of the lining
  ASSERT_FALSE(s.isFixed(top, 0));
  s.state().addMass(top, 123.0);
  compare("a mass changed");
  s.state().addDashpot(top, 0, 3e5);
  compare("a dashpot changed");
  s.setTimeStep(0.8 * s.dt());
  compare("the step changed");
}
