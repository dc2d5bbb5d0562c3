// The staged analysis' parts one by one: incident-motion integration, tied nodes,
// in-situ stress against gravity, mass-scaled relaxation, lining activation, the version 2 input
// through tq-solid end to end, and bad input.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "input_fixture.hpp"
#include "io/h5util.hpp"
#include "staged_helpers.hpp"
#include "test_helpers.hpp"
#include "tq/app/app.hpp"
#include "tq/boundaries/boundaries.hpp"
#include "tq/io/mesh.hpp"

using namespace tq;

namespace {

struct Files {
  std::filesystem::path dir;
  Files() {
    dir = std::filesystem::temp_directory_path() / ("tq_staged_" + std::to_string(::getpid()) + "_" +
                                                    ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir);
  }
  ~Files() { std::filesystem::remove_all(dir); }
  std::string operator/(const std::string& n) const { return (dir / n).string(); }
};

}  // namespace

// a(t) piecewise linear between samples -> v, u exact (quadratic, cubic), also between samples;
// zero before the first sample, v held after the last.
TEST(IncidentMotion, IntegratesPiecewiseLinearAccelerationExactly) {
  const std::vector<Real> t = {0.0, 0.1, 0.25, 0.4};
  const std::vector<Real> a = {0.0, 2.0, -1.0, 0.5};
  IncidentMotion m(t, a, {}, {});
  // Reference by fine trapezoid/Simpson integration of the same piecewise-linear function.
  auto acc = [&](Real x) {
    for (size_t k = 0; k + 1 < t.size(); ++k)
      if (x >= t[k] && x <= t[k + 1]) return a[k] + (a[k + 1] - a[k]) * (x - t[k]) / (t[k + 1] - t[k]);
    return 0.0;
  };
  Real v = 0, u = 0;
  const int n = 320000;
  const Real h = 0.4 / n;  // up to the last sample (a drops to 0 there)
  Real worstV = 0, worstU = 0;
  for (int i = 0; i < n; ++i) {
    const Real x = i * h;
    const Real a0 = acc(x), a1 = acc(x + h);
    u += v * h + h * h * (a0 / 3 + a1 / 6);
    v += 0.5 * h * (a0 + a1);
    worstV = std::max(worstV, std::abs(v - m.velocity(0, x + h)));
    worstU = std::max(worstU, std::abs(u - m.displacement(0, x + h)));
  }
  EXPECT_LT(worstV, 1e-12);
  EXPECT_LT(worstU, 1e-12);
  EXPECT_NEAR(m.velocity(0, 0.55), m.velocity(0, 0.4), 1e-15);  // held after the record
  EXPECT_NEAR(m.displacement(0, 0.55), m.displacement(0, 0.4) + 0.15 * m.velocity(0, 0.4), 1e-15);
  EXPECT_EQ(m.velocity(2, 0.2), 0.0);       // empty component
  EXPECT_EQ(m.acceleration(0, 0.45), 0.0);  // after the record
  EXPECT_NEAR(m.acceleration(0, 0.175), 0.5, 1e-14);
}

// Two free elastic bars end to end with the touching end nodes duplicated and tied: the tied pair
// moves as one node (equal increments), the exchange forces cancel, momentum is conserved, and the
// result equals the same bar meshed with shared nodes.
TEST(TiedNodes, TiedBarsMoveLikeOneBar) {
  auto bar = [](bool split) {
    BoxSpec b{1, 1, 4, 0, 0, 0, 1, 1, 4};
    Mesh m = makeBoxMesh(b);
    if (!split) return m;
    // Duplicate the nodes at z = 2 for the upper two elements.
    const Index N = m.numNodes();
    std::vector<Index> dup(size_t(N), -1);
    for (Index e = 0; e < m.numElems(); ++e) {
      Real zc = 0;
      for (int k = 0; k < 8; ++k) zc += 0.125 * m.coords[3 * size_t(m.connectivity[8 * size_t(e) + k]) + 2];
      if (zc < 2) continue;
      for (int k = 0; k < 8; ++k) {
        Index& n = m.connectivity[8 * size_t(e) + k];
        if (std::abs(m.coords[3 * size_t(n) + 2] - 2) > 1e-12) continue;
        if (dup[size_t(n)] < 0) {
          dup[size_t(n)] = m.numNodes();
          m.coords.insert(m.coords.end(),
                          {m.coords[3 * size_t(n)], m.coords[3 * size_t(n) + 1], m.coords[3 * size_t(n) + 2]});
          m.rockLiningPairs.insert(m.rockLiningPairs.end(), {n, dup[size_t(n)]});
        }
        n = dup[size_t(n)];
      }
    }
    return m;
  };
  Real uTop[2];
  for (int split = 0; split < 2; ++split) {
    const Mesh m = bar(split == 1);
    Solver s(m, makeBlocksByRegion(m, {{"rock", tqtest::elastic(1e9, 0.25, 2000)}}), SolverOptions{});
    // A uniaxial bar: x and y fixed everywhere (a free one-element-wide bar has modes above the
    // element estimate of the stable step), z free, load on the top.
    for (Index n = 0; n < m.numNodes(); ++n) {
      s.fix(n, 0);
      s.fix(n, 1);
    }
    const auto top = m.faceNodes("top");
    for (Index n : top) s.addLoad({{n}, 2, 1e5, TimeFunction::constant(1.0)});
    std::shared_ptr<TiedNodeGroups> tie;
    if (split) {
      tie = std::make_shared<TiedNodeGroups>("tie", TiedNodeGroups::pairs(m.rockLiningPairs));
      tie->install(s);
      s.addContributor(ForcePhase::Interface, tie);
    }
    for (int k = 0; k < 300; ++k) {
      s.step();
      if (split)
        for (Index g = 0; g < tie->numGroups(); ++g) {
          const Index a = tie->begin(g)[0], b = tie->begin(g)[1];
          for (int d = 0; d < 3; ++d) {
            ASSERT_NEAR(s.state().u(a, d), s.state().u(b, d), 1e-14 * (1 + std::abs(s.state().u(a, d))));
            ASSERT_NEAR(tie->force(2 * g)[d] + tie->force(2 * g + 1)[d], 0, 1e-9);
          }
        }
    }
    // Momentum = impulse of the applied load.
    Real p = 0;
    for (Index n = 0; n < m.numNodes(); ++n) p += s.state().mass(n) * s.state().v(n, 2);
    EXPECT_NEAR(p / (4 * 1e5 * s.time()), 1, 1e-9);
    uTop[split] = s.state().u(top[0], 2);
  }
  EXPECT_NEAR(uTop[1] / uTop[0], 1, 1e-12);
}

namespace {

/// Uniform block under gravity with rollers on the sides and a fixed base.
tqtest::StagedRun gravityBlock(Real kx, bool massScaling, const std::vector<std::string>& seq) {
  tqtest::StagedRun run;
  run.mesh = makeBoxMesh({3, 2, 12, 0, 0, 0, 30, 20, 60});
  run.in.materials = {{"rock", elasticValues({8e9, 0.27, 2700})}};
  run.in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  StagedInput& S = run.in.staged;
  S.present = true;
  S.stages.sequence = seq;
  S.stages.tolerance = 1e-8;
  S.stages.massScaling = massScaling;
  S.inSitu.present = true;
  S.inSitu.kx = kx;
  S.inSitu.ky = 0.8;
  S.inSitu.kz = 1.0;
  S.inSitu.gravity = 9.81;
  run.in.options.gravity[2] = -9.81;
  run.build();
  return run;
}

}  // namespace

// σz = −ρ g (z_top − z) balances gravity exactly on a layered mesh (sign convention: compression
// negative, gravity −z), whatever kx, ky (the sides are rollers): the in-situ stage starts in
// equilibrium and nothing moves.
TEST(InSitu, OverburdenStressBalancesGravity) {
  auto run = gravityBlock(1.1, true, {"in_situ", "seismic"});
  std::ostringstream log;
  run.stages->runStatics(log);
  // At the first check, 10 steps in; the stage adds no load, so the reference is 1e-6 of the
  // model's force scale: a ratio of 1e-8 is a residual of 1e-14 of the forces (round-off).
  const Real ratio = run.stages->reports()[0].ratio;
  Real umax = 0;
  for (Index n = 0; n < run.mesh.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) umax = std::max(umax, std::abs(run.solver->state().u(n, d)));
  const Real uScale = 2700 * 9.81 * 60 * 60 / 8e9;  // ρ g H² / E
  std::printf("in-situ under gravity: unbalanced ratio after 10 steps %.2e, max |u| after the stage / (ρgH²/E) %.2e\n",
              ratio, umax / uScale);
  EXPECT_EQ(run.stages->reports()[0].steps, 10);
  EXPECT_LT(ratio, 1e-8);
  EXPECT_LT(umax / uScale, 1e-10);
  const auto& b = *run.solver->blocks()[0];
  // Bottom element: centroid at z = 2.5 m: σz = −ρ g (60 − 2.5), σx = 1.1 σz.
  Index e0 = 0;
  Real zmin = 1e9;
  for (Index e = 0; e < b.numElems(); ++e) {
    Real zc = 0;
    for (int k = 0; k < 8; ++k) zc += 0.125 * run.mesh.coords[3 * size_t(b.node(e, k)) + 2];
    if (zc < zmin) zmin = zc, e0 = e;
  }
  EXPECT_NEAR(b.stress(e0, ZZ) / (-2700 * 9.81 * (60 - zmin)), 1, 1e-12);
  EXPECT_NEAR(b.stress(e0, XX) / b.stress(e0, ZZ), 1.1, 1e-12);
  EXPECT_NEAR(b.stress(e0, YY) / b.stress(e0, ZZ), 0.8, 1e-12);
}

// Mass scaling changes the path of the relaxation, not its end: the same equilibrium as the
// unscaled relaxation (a block with a surface load patch and an uneven mesh), in fewer steps.
TEST(Relaxation, MassScalingReachesTheSameEquilibrium) {
  Real u[2];
  Index steps[2];
  for (int scaled = 0; scaled < 2; ++scaled) {
    BoxSpec bs{6, 1, 6, 0, 0, 0, 6, 1, 6};
    Mesh m = makeBoxMesh(bs);
    // Grade the mesh towards the top: element heights from 0.25 to 2 m.
    for (Index n = 0; n < m.numNodes(); ++n) {
      Real& z = m.coords[3 * size_t(n) + 2];
      z = 6 * std::pow(z / 6, 0.35);
    }
    m.slice = true;
    SolverOptions opt;
    opt.gravity[2] = -9.81;
    Solver s(m, makeBlocksByRegion(m, {{"rock", tqtest::elastic(8e9, 0.27, 2700)}}), opt);
    s.fixFaceGroup("bottom", "xyz");
    s.fixFaceGroup("xmin", "x");
    s.fixFaceGroup("xmax", "x");
    RelaxParams rp;
    rp.tolerance = 1e-10;
    rp.maxSteps = 400000;
    rp.massScaling = scaled == 1;
    const RelaxResult r = s.relax(rp);
    ASSERT_TRUE(r.converged);
    steps[scaled] = r.steps;
    u[scaled] = s.state().u(m.faceNodes("top")[0], 2);
    // The true masses are back afterwards.
    Real mass = 0;
    for (Index n = 0; n < m.numNodes(); ++n) mass += s.state().mass(n);
    EXPECT_NEAR(mass / (2700 * 36), 1, 1e-12);
  }
  std::printf("relaxation: settlement %.6e (unscaled, %d steps) vs %.6e (mass-scaled, %d steps)\n", u[0], steps[0],
              u[1], steps[1]);
  EXPECT_NEAR(u[1] / u[0], 1, 1e-7);
  EXPECT_LT(steps[1], steps[0]);
}

// The external force of gravity and the folded constant loads is summed once and reused while they
// stay the same: it follows every change of what it is summed from. After each change, f_ext is
// m g + the constant loads exactly (summed in the order they were added): a new constant load, a
// changed mass, the masses relax() scales (gravity keeps the true ones) and those it puts back.
TEST(ExternalForce, GravityAndConstantLoadsFollowEveryChangeOfWhatTheyAreSummedFrom) {
  Mesh m = makeBoxMesh(BoxSpec{3, 1, 2, 0, 0, 0, 3, 1, 2});
  SolverOptions opt;
  opt.gravity[2] = -9.81;
  Solver s(m, makeBlocksByRegion(m, {{"rock", tqtest::elastic(8e9, 0.27, 2700)}}), opt);
  const Index N = m.numNodes();
  std::vector<std::vector<Real>> loads;
  auto expectExact = [&](const char* after, const Real g[3]) {
    s.computeForces(true);
    for (Index n = 0; n < N; ++n)
      for (int d = 0; d < 3; ++d) {
        Real f = s.state().mass(n) * g[d];
        for (const auto& l : loads) f += l[dofIndex(n, d)];
        ASSERT_EQ(s.state().fExt(n, d), f) << after << ": node " << n << " direction " << d;
      }
  };
  const Real g[3] = {0, 0, -9.81};
  expectExact("the first step", g);
  for (int k = 0; k < 2; ++k) {  // a constant load added, folded into the same pass
    std::vector<Real> f(3 * size_t(N));
    for (size_t i = 0; i < f.size(); ++i) f[i] = Real(1000 * (k + 1)) * std::sin(Real(i) + k);
    loads.push_back(f);
    s.addContributor(ForcePhase::Loads, std::make_shared<ConstantNodalForces>("load", f));
    expectExact("a constant load added", g);
  }
  s.state().addMass(N / 2, 12.5);  // a mass changed
  expectExact("a mass changed", g);
  std::vector<Real> trueMass(static_cast<size_t>(N));
  for (Index n = 0; n < N; ++n) trueMass[size_t(n)] = s.state().mass(n);
  RelaxParams rp;  // scales the masses while it runs, gravity on the true ones; puts them back
  rp.massScaling = true;
  rp.maxSteps = 3;
  s.relax(rp);
  for (Index n = 0; n < N; ++n) ASSERT_EQ(s.state().mass(n), trueMass[size_t(n)]);
  expectExact("relax() with scaled masses", g);
}

// The whole v2 path through files: mesh.h5 + solid_input.h5 (stages in_situ -> seismic, viscoelastic
// base, free-field sides, motion) -> tq-solid -> results.h5 with the stage reports, a completed
// status, the surface at twice the incident pulse, a closed energy balance; --capabilities says
// staged-seismic; the λ/8 warning appears for a coarse mesh.
TEST(StagedApp, BlockUnderPulseThroughFiles) {
  Files f;
  const Real H = 60;
  Mesh m = makeBoxMesh({4, 2, 24, 0, 0, 0, 20, 10, H});
  writeMeshH5(m, f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({5e9, 0.25, 2000})}};
  in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  in.tEnd = 0.3;
  in.monitors = {{"surface", {10, 5, H}}};
  in.monitorDt = 1e-3;
  in.progressSeconds = 100;
  StagedInput& S = in.staged;
  S.present = true;
  S.condition = "no_water";
  S.stages.sequence = {"in_situ", "seismic"};
  S.inSitu.present = true;
  S.inSitu.kx = 1.1;
  S.inSitu.ky = 0.8;
  S.inSitu.gravity = 9.81;
  S.bottom.present = true;
  S.freeField.present = true;
  S.freeField.faces = {"xmin", "xmax", "ymin", "ymax"};
  S.motion.present = true;
  S.motion.cutoffFrequency = 20;
  tqtest::GaussPulse p;
  p.sample(0.5, 1e-3, S.motion.time, S.motion.ax);
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  ASSERT_EQ(runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err), 0) << out.str() << err.str();
  EXPECT_NE(out.str().find("stage in_situ"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("switch to the seismic stage"), std::string::npos) << out.str();
  EXPECT_EQ(out.str().find("λ_min/8"), std::string::npos) << out.str();  // 5 m ≤ 1000/(8·20) m
  auto r = h5::openFile(f / "results.h5");
  EXPECT_EQ(h5::readStringAttr(r, "status"), "completed");
  EXPECT_TRUE(h5::exists(r, "/stages/0_in_situ"));
  EXPECT_TRUE(h5::exists(r, "/stages/1_switch"));
  std::vector<hsize_t> d;
  const auto u = h5::readDoubles(r, "/monitors/surface/u", &d);
  const auto t = h5::readDoubles(r, "/monitors/surface/time");
  const IncidentMotion inc(S.motion.time, S.motion.ax, {}, {});
  const Real cs = std::sqrt(5e9 / 2.5 / 2 / 2000);
  Real peak = 0, peakRef = 0;
  for (size_t i = 0; i < d[0]; ++i) {
    peak = std::max(peak, std::abs(u[3 * i]));
    peakRef = std::max(peakRef, std::abs(2 * inc.displacement(0, t[i] - H / cs)));
  }
  std::printf("staged app: surface peak / (2 × incident peak) = %.4f\n", peak / peakRef);
  EXPECT_NEAR(peak / peakRef, 1, 0.02);
  const auto e = h5::readDoubles(r, "/energy/history", &d);
  EXPECT_LT(e[7 * (d[0] - 1) + 6], 0.01);
  std::ostringstream o2, e2;
  EXPECT_EQ(runSolid({"--capabilities"}, o2, e2), 0);
  EXPECT_NE(o2.str().find("staged-seismic"), std::string::npos);
}

TEST(StagedApp, WarnsWhenElementsExceedAnEighthOfTheShortestWavelength) {
  Files f;
  writeMeshH5(makeBoxMesh({2, 1, 4, 0, 0, 0, 40, 20, 40}), f / "mesh.h5");  // 20 m x 20 m x 10 m elements
  SolidInput in;
  in.materials = {{"rock", elasticValues({5e9, 0.25, 2000})}};  // cs = 1000 m/s: λ/8 at 20 Hz = 6.25 m
  in.tEnd = 0.01;
  in.progressSeconds = 100;
  in.staged.present = true;
  in.staged.stages.sequence = {"seismic"};
  in.staged.bottom.present = true;
  in.staged.motion.present = true;
  in.staged.motion.cutoffFrequency = 20;
  in.staged.motion.time = {0, 1};
  in.staged.motion.ax = {0, 0};
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  EXPECT_EQ(runSolid({f / "solid_input.h5", "--check"}, out, err), 0) << err.str();
  EXPECT_NE(out.str().find("8 of 8 elements are larger than λ_min/8"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("6.25 m"), std::string::npos) << out.str();
}

// Bad input stops with a message naming what, where and the fix.
TEST(StagedApp, BadInputIsReportedClearly) {
  Files f;
  auto base = [&]() {
    SolidInput in;
    in.materials = {{"rock", elasticValues({5e9, 0.25, 2000})}};
    in.tEnd = 0.01;
    in.progressSeconds = 100;
    in.staged.present = true;
    in.staged.stages.sequence = {"seismic"};
    in.staged.bottom.present = true;
    return in;
  };
  auto run = [&](const SolidInput& in, const Mesh& m) {
    writeMeshH5(m, f / "mesh.h5");
    test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
    std::ostringstream out, err;
    const int rc = runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err);
    return std::make_pair(rc, err.str());
  };
  // 1. A mesh with no bottom group.
  {
    Mesh m = makeBoxMesh({1, 1, 2, 0, 0, 0, 1, 1, 2});
    m.faces.erase("bottom");
    const auto [rc, msg] = run(base(), m);
    EXPECT_EQ(rc, 2);
    EXPECT_NE(msg.find("face group 'bottom' is missing"), std::string::npos) << msg;
    EXPECT_NE(msg.find("physical group"), std::string::npos) << msg;
  }
  // 2. A free-field face that is not horizontally layered (two materials side by side in a layer).
  {
    Mesh m = makeBoxMesh({1, 2, 2, 0, 0, 0, 1, 2, 2});
    m.regionNames = {"rock", "lining"};
    for (Index e = 0; e < m.numElems(); ++e) {
      Real yc = 0;
      for (int k = 0; k < 8; ++k) yc += 0.125 * m.coords[3 * size_t(m.connectivity[8 * size_t(e) + k]) + 1];
      m.region[size_t(e)] = yc < 1 ? 0 : 1;
    }
    SolidInput in = base();
    in.materials.push_back({"lining", elasticValues({28e9, 0.17, 2500})});
    in.staged.freeField.present = true;
    in.staged.freeField.faces = {"xmin"};
    const auto [rc, msg] = run(in, m);
    EXPECT_EQ(rc, 2);
    EXPECT_NE(msg.find("two materials in the layer"), std::string::npos) << msg;
  }
  // 3. Stages out of order; 4. motion times not increasing (edited in the file).
  {
    SolidInput in = base();
    in.staged.stages.sequence = {"excavation", "in_situ", "seismic"};
    const auto [rc, msg] = run(in, makeBoxMesh({1, 1, 2, 0, 0, 0, 1, 1, 2}));
    EXPECT_EQ(rc, 2);
    EXPECT_NE(msg.find("/stages: stage 'in_situ' is out of order"), std::string::npos) << msg;
  }
  {
    SolidInput in = base();
    in.staged.motion.present = true;
    in.staged.motion.time = {0, 0.2, 0.1};
    in.staged.motion.ax = {0, 1, 0};
    const auto [rc, msg] = run(in, makeBoxMesh({1, 1, 2, 0, 0, 0, 1, 1, 2}));
    EXPECT_EQ(rc, 2);
    EXPECT_NE(msg.find("/motion: time must be finite and strictly increasing (sample 2)"), std::string::npos) << msg;
  }
  // 5. An unknown attribute in a v2 group is rejected with its path.
  {
    SolidInput in = base();
    writeMeshH5(makeBoxMesh({1, 1, 2, 0, 0, 0, 1, 1, 2}), f / "mesh.h5");
    test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
    {
      auto h = h5::openFile(f / "solid_input.h5", true);
      auto g = h5::openGroup(h, "/boundaries/bottom");
      h5::writeDoubleAttr(g, "distnace", 10.0);
    }
    std::ostringstream out, err;
    EXPECT_EQ(runSolid({f / "solid_input.h5", "--check"}, out, err), 2);
    EXPECT_NE(err.str().find("/boundaries/bottom: unknown attribute 'distnace'"), std::string::npos) << err.str();
  }
}

// A seismic run that goes unstable (a step above the critical one, let through for the test) stops
// at the first exploding value with the step, the node and where it is, before anything overflows.
TEST(StagedRun, UnstableSeismicRunStopsWithStepAndLocation) {
  tqtest::StagedRun run;
  run.mesh = makeBoxMesh({2, 1, 10, 0, 0, 0, 10, 5, 25});
  run.in.materials = {{"rock", elasticValues({5e9, 0.25, 2000})}};
  run.in.options.allowUnstableStep = true;
  run.in.staged.present = true;
  run.in.staged.stages.sequence = {"seismic"};
  run.in.staged.bottom.present = true;
  run.in.staged.freeField.present = true;
  run.in.staged.freeField.faces = {"xmin", "xmax"};
  run.in.staged.motion.present = true;
  tqtest::GaussPulse p;
  p.sample(0.3, 1e-3, run.in.staged.motion.time, run.in.staged.motion.ax);
  run.in.options.dt = 0;
  run.build();
  run.solver->setTimeStep(1.2 * run.solver->stableStep().dtCritical);
  std::ostringstream log;
  run.stages->runStatics(log);
  run.stages->switchToDynamics(log);
  try {
    run.solver->runUntil(5.0);
    FAIL() << "the run should have stopped";
  } catch (const InstabilityError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("run stopped at step"), std::string::npos) << msg;
    EXPECT_NE(msg.find("at node"), std::string::npos) << msg;
    EXPECT_NE(msg.find("above the critical step"), std::string::npos) << msg;
  }
  for (Index n = 0; n < run.mesh.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) ASSERT_TRUE(std::isfinite(run.solver->state().u(n, d)));
}
