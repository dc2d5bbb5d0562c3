// The lining's joints (tq/contact/joints.hpp; docs/verification.md "Lining joints"). Two lining
// rings (tubes of r 1.80–2.05 m, 1.2 m long, concrete E 35 GPa) joined at one joint plane, the
// first ring's far end held, the second's pulled or pushed along the axis by a total force F:
//  - static pull: the joint's area-weighted mean opening equals F / (k_n A) (A the joint's area,
//    the sum of the pairs' tributary areas) and the axial force through it equals F, both to 1e-6
//    relative (closed form: equilibrium of the second ring, N = Σ k_n A_p g_p = F; the springs are
//    exact at rest, F_p = k_n A_p g_p);
//  - static push: the opening is −F / (k_n A) to the same tolerance (the spring carries compression);
//  - tension cut-off: a pull above f_t A opens every pair (no force, state Open) and the joint keeps
//    opening;
//  - the pairs computed on the threads (and their prediction from kept terms) give the one loop's
//    bits at any thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "test_helpers.hpp"
#include "tq/contact/joints.hpp"

using namespace tq;
using namespace tqtest;

namespace {

constexpr Real kRi = 1.80, kRo = 2.05, kRing = 1.2;

struct TwoRings {
  Mesh mesh;
  JointPairs pairs;
  std::unique_ptr<Solver> solver;
  std::shared_ptr<LiningJoints> joints;
  Real area = 0;  // the joint's area (sum of the pairs' tributary areas)

  TwoRings(const JointParams& jp, Real force, Real alpha = 0) {
    RingSpec rs;
    rs.rInner = kRi;
    rs.rOuter = kRo;
    rs.nRadial = 2;
    rs.nAround = 24;
    rs.width = kRing;
    rs.nAxial = 2;
    const Mesh a = makeRingSliceMesh(rs);
    Mesh b = makeRingSliceMesh(rs);
    for (Index n = 0; n < b.numNodes(); ++n) b.coords[3 * size_t(n) + 1] += kRing;
    const Index off = a.numNodes();
    mesh = a;
    mesh.coords.insert(mesh.coords.end(), b.coords.begin(), b.coords.end());
    for (Index c : b.connectivity) mesh.connectivity.push_back(c + off);
    mesh.region.insert(mesh.region.end(), b.region.begin(), b.region.end());
    mesh.faces.clear();
    mesh.faces["held"] = a.faces.at("ymin");
    for (Index q : b.faces.at("ymax")) mesh.faces["pulled"].push_back(q + off);
    // the pairs: ring a's end-face nodes with ring b's coincident start-face nodes; tributary
    // areas a quarter of each of ring a's end quads
    std::vector<Real> trib(size_t(a.numNodes()), 0.0);
    const auto& q = a.faces.at("ymax");
    for (size_t f = 0; f < q.size() / 4; ++f) {
      Real s[3];
      quadAreaVector(a, &q[4 * f], s);
      for (int k = 0; k < 4; ++k)
        trib[size_t(q[4 * f + k])] += 0.25 * std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    }
    const auto bStart = b.faceNodes("ymin");
    for (Index n : a.faceNodes("ymax")) {
      Index match = -1;
      for (Index m : bStart) {
        Real d = 0;
        for (int i = 0; i < 3; ++i) d += std::abs(a.coords[3 * size_t(n) + i] - b.coords[3 * size_t(m) + i]);
        if (d < 1e-9) match = m;
      }
      EXPECT_GE(match, 0);
      pairs.nodeA.push_back(n);
      pairs.nodeB.push_back(match + off);
      pairs.area.push_back(trib[size_t(n)]);
      pairs.joint.push_back(0);
      area += trib[size_t(n)];
    }
    pairs.y = {kRing};
    checkMesh(mesh);
    SolverOptions opt;
    opt.damping.alpha = alpha;  // mass damping: the static pull comes to rest
    solver = std::make_unique<Solver>(mesh, makeBlocksByRegion(mesh, {{"lining", elastic(35e9, 0.2, 2400)}}), opt);
    solver->fixFaceGroup("held", "xyz");
    const auto pulled = mesh.faceNodes("pulled");
    solver->addLoad({pulled, 1, force / Real(pulled.size()), TimeFunction::constant(1.0)});
    joints = std::make_shared<LiningJoints>(*solver, pairs, jp);
    solver->addContributor(ForcePhase::Interface, joints);
  }
};

JointParams gasket() {
  JointParams jp;
  jp.normalStiffness = 2e9;  // Pa/m
  jp.shearStiffness = 1e9;   // Pa/m
  jp.tensileStrength = 1e9;  // Pa: never reached by the static loads here
  return jp;
}

}  // namespace

TEST(LiningJoints, StaticPullOpensTheJointByForceOverStiffness) {
  for (const Real F : {2e6, -2e6}) {  // a pull, then a push
    const JointParams jp = gasket();
    // critical mass damping of the second ring on the joint's spring, ω = √(k_n A / m): every mode
    // decays at α/2 = ω; 0.05 s is about 40 of its time constants
    TwoRings probe(jp, 0.0);
    Real mass = 0;
    for (Index n = probe.mesh.numNodes() / 2; n < probe.mesh.numNodes(); ++n) mass += probe.solver->state().mass(n);
    const Real omega = std::sqrt(jp.normalStiffness * probe.area / mass);
    TwoRings m(jp, F, 2 * omega);
    Index steps = 0;
    while (m.solver->time() < 0.05) {
      m.solver->step();
      ++steps;
    }
    const JointSummary s = m.joints->summaries(m.solver->state())[0];
    const Real expected = F / (jp.normalStiffness * m.area);
    std::printf(
        "%s %.3g N: opening %.9e m, F/(k_n A) %.9e m (%.2e relative; A %.6f m2), axial force %.9e N, "
        "opening across the joint %.3e to %.3e m, %ld steps\n",
        F > 0 ? "pull" : "push", F, s.opening, expected, s.opening / expected - 1, m.area, s.axialForce, s.openingMin,
        s.openingMax, long(steps));
    EXPECT_NEAR(s.opening / expected, 1.0, 1e-6);
    EXPECT_NEAR(s.axialForce / F, 1.0, 1e-6);
    for (Index p = 0; p < m.joints->numPairs(); ++p) EXPECT_EQ(int(m.joints->state(p)), int(JointState::Closed));
  }
}

TEST(LiningJoints, APullAboveTheTensileStrengthOpensTheJoint) {
  JointParams jp = gasket();
  jp.tensileStrength = 0.5e6;  // Pa
  TwoRings probe(jp, 0.0);
  const Real F = 1.5 * jp.tensileStrength * probe.area;
  TwoRings m(jp, F);
  Real before = 0;
  for (int i = 0; i < 3000; ++i) {
    m.solver->step();
    if (i == 1999) before = m.joints->summaries(m.solver->state())[0].opening;
  }
  const JointSummary s = m.joints->summaries(m.solver->state())[0];
  std::printf("pull 1.5 f_t A: opening %.4e m after 2000 steps, %.4e m after 3000, axial force %.3e N\n", before,
              s.opening, s.axialForce);
  for (Index p = 0; p < m.joints->numPairs(); ++p) EXPECT_EQ(int(m.joints->state(p)), int(JointState::Open));
  EXPECT_EQ(s.axialForce, 0.0);
  EXPECT_GT(s.opening, before);
  EXPECT_GT(before, 0.0);
}

// Node-disjoint pairs computed on the solver's threads, their work summed after in pair order: the
// same bits as the one loop at 1 and 2 threads. The second ring shaken so that the pairs differ
// (a pull and a push round the ring, a shear across it): some stay closed, some open past f_t,
// some slip at μ × compression; each pair predicts from kept terms (PredictionTerms) in all three.
TEST(LiningJoints, PairsOnThreadsGiveTheOneLoopsBits) {
  auto run = [](int threads, bool onThreads, bool& threaded) {
    omp_set_num_threads(threads);
    JointParams jp = gasket();
    jp.tensileStrength = 0.02e6;  // Pa
    jp.friction = 0.3;
    TwoRings m(jp, 0.0);
    m.joints->computeOnThreads(onThreads);
    threaded = m.joints->computedOnThreads();
    for (Index n = m.mesh.numNodes() / 2; n < m.mesh.numNodes(); ++n) {
      const Real x = m.mesh.coords[3 * size_t(n)], z = m.mesh.coords[3 * size_t(n) + 2];
      const Real th = std::atan2(z, x);
      m.solver->state().v(n, 0) = 0.05 * std::sin(2 * th);
      m.solver->state().v(n, 1) = -0.1 + 0.2 * std::cos(3 * th);  // m/s: opens some, closes others
      m.solver->state().v(n, 2) = 0.05 * std::cos(th);
    }
    for (int i = 0; i < 150; ++i) m.solver->step();
    std::vector<Real> out(m.solver->state().uData(), m.solver->state().uData() + 3 * m.mesh.numNodes());
    std::array<Index, 3> count{0, 0, 0};
    for (Index p = 0; p < m.joints->numPairs(); ++p) {
      out.push_back(Real(m.joints->state(p)));
      out.push_back(m.joints->axialForce(p));
      ++count[size_t(m.joints->state(p))];
    }
    out.push_back(m.joints->dissipatedEnergy());
    out.push_back(m.solver->energy().error);
    std::printf("%d thread(s), %s: closed %d, open %d, slipping %d of %d pairs; joints' work %.9e J\n", threads,
                threaded ? "pairs on the threads" : "one loop", int(count[0]), int(count[1]), int(count[2]),
                int(m.joints->numPairs()), -out[out.size() - 2]);
    return std::make_pair(out, count);
  };
  bool t0 = true, t1 = false, t2 = false;
  const auto serial = run(1, false, t0), one = run(1, true, t1), two = run(2, true, t2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_FALSE(t0);
  EXPECT_TRUE(t1 && t2);
  for (Index c : serial.second) EXPECT_GT(c, 0);  // every branch taken
  EXPECT_NE(serial.first[serial.first.size() - 2], 0.0);
  ASSERT_EQ(serial.first.size(), one.first.size());
  ASSERT_EQ(serial.first.size(), two.first.size());
  EXPECT_EQ(std::memcmp(serial.first.data(), one.first.data(), serial.first.size() * sizeof(Real)), 0);
  EXPECT_EQ(std::memcmp(serial.first.data(), two.first.data(), serial.first.size() * sizeof(Real)), 0);
}
