// solid_input.h5 and results.h5 for the nonlinear parts: Mohr–Coulomb material
// attributes read back as written and bad ones rejected with their path; tq-solid runs a column
// whose rock yields and writes damage, plastic strain and the dissipation term, and closes its
// energy balance (1 %); the contact's per-pair state, opening and slip reach results.h5.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <sstream>

#include "input_fixture.hpp"
#include "io/h5util.hpp"
#include "mc_helpers.hpp"
#include "test_folder.hpp"
#include "test_helpers.hpp"
#include "tq/app/app.hpp"
#include "tq/contact/contact.hpp"
#include "tq/io/input.hpp"
#include "tq/io/mesh.hpp"
#include "tq/io/results.hpp"
#include "tq/io/staged_input.hpp"

using namespace tq;
using namespace tqtest;

namespace {

struct Files : tqtest::TestFolder {
  Files() : TestFolder("tq_nl_") {}
};

// A confined column (rollers on the sides, fixed base) of weak rock under a suddenly applied top
// pressure: the dynamic overshoot drives the deviatoric stress past the Mohr–Coulomb surface.
SolidInput weakColumn(const Files& f) {
  writeMeshH5(makeBoxMesh({2, 2, 10, 0, 0, 0, 2, 2, 10}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", mohrCoulombDamageValues(mohrCoulomb({8e9, 0.27, 2700}, 0.05e6, 10, 0.1e6, 100))}};
  in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  in.tEnd = 0.01;
  in.loads = {test::suddenPressure("top", -1e6 * 4.0)};
  in.monitors = {{"top", {1.0, 1.0, 10.0}}, {"base", {1.0, 1.0, 0.5}}};
  in.monitorDt = 1e-4;
  in.snapshotTimes = {0.01};
  in.progressSeconds = 100;
  return in;
}

}  // namespace

TEST(SolidNonlinearInput, MohrCoulombAttributesRoundTripAndBadOnesAreRejected) {
  Files f;
  SolidInput in = weakColumn(f);
  MohrCoulombDamageParams mp = mohrCoulombDamageParams(in.materials[0].second);
  mp.dilationAngle = 5;
  mp.damageEffect = DamageEffect::CohesionAndStiffness;
  in.materials[0].second = mohrCoulombDamageValues(mp);
  test::writeInputFile(in, f / "in.h5", "mesh.h5");
  const SolidInput back = readSolidInput(f / "in.h5");
  ASSERT_EQ(back.materials.size(), 1u);
  ASSERT_EQ(back.materials[0].first, "rock");
  ASSERT_EQ(back.materials[0].second.model, "mohr_coulomb_damage");
  const MohrCoulombDamageParams q = mohrCoulombDamageParams(back.materials[0].second);
  EXPECT_EQ(q.cohesion, 0.05e6);
  EXPECT_EQ(q.frictionAngle, 10.0);
  EXPECT_EQ(q.dilationAngle, 5.0);
  EXPECT_EQ(q.tensileStrength, 0.1e6);
  EXPECT_EQ(q.damageConstant, 100.0);
  EXPECT_EQ(q.damageEffect, DamageEffect::CohesionAndStiffness);
  EXPECT_EQ(q.elastic.youngsModulus, 8e9);
  {  // a misspelt damage effect names the group and the choices
    auto h = h5::openFile(f / "in.h5", true);
    auto g = h5::openGroup(h, "/materials/rock");
    h5::writeStringAttr(g, "damage_effect", "stiffness");
  }
  test::expectInputError([&] { readSolidInput(f / "in.h5"); }, "bad damage_effect accepted",
                         {"/materials/rock", "cohesion_and_stiffness"});
  {
    auto h = h5::openFile(f / "in.h5", true);
    auto g = h5::openGroup(h, "/materials/rock");
    h5::writeStringAttr(g, "damage_effect", "cohesion");
    h5::writeStringAttr(g, "model", "mohr_coulomb");
  }
  EXPECT_THROW(readSolidInput(f / "in.h5"), InputError);
  // Interface parameters from /interfaces/rock_lining.
  InterfaceInput ii;
  ii.model = "dynamic_contact";
  ii.cohesion = 0.5e6;
  ii.afterFailure = "cohesion_kept";
  const ContactParams cp = contactParamsFrom(ii);
  EXPECT_EQ(cp.afterFailure, AfterFailure::CohesionKept);
  ii.afterFailure = "kept";
  EXPECT_THROW(contactParamsFrom(ii), InputError);
}

TEST(SolidNonlinearApp, YieldingColumnWritesDamageAndDissipationAndClosesTheBalance) {
  Files f;
  const SolidInput in = weakColumn(f);
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  ASSERT_EQ(runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err), 0) << out.str() << err.str();
  auto r = h5::openFile(f / "results.h5");
  std::vector<hsize_t> d;
  const auto D = h5::readDoubles(r, "/snapshots/0/damage", &d);
  ASSERT_EQ(d[0], 40u);
  Real dmax = 0;
  for (Real x : D) {
    EXPECT_GE(x, 0.0);
    EXPECT_LE(x, 1.0);
    dmax = std::max(dmax, x);
  }
  EXPECT_GT(dmax, 0.0);
  const auto ep = h5::readDoubles(r, "/snapshots/0/plastic_strain", &d);
  EXPECT_EQ(d[1], 6u);
  const auto diss = h5::readDoubles(r, "/energy/dissipation", &d);
  ASSERT_EQ(d[1], 3u);
  const Real plastic = diss[3 * (d[0] - 1) + 1];
  const auto e = h5::readDoubles(r, "/energy/history", &d);
  const Real error = e[7 * (d[0] - 1) + 6], external = e[7 * (d[0] - 1) + 5];
  std::printf(
      "yielding column: max damage %.3e, plastic dissipation %.4e J of external work %.4e J, "
      "balance error %.2e\n",
      dmax, plastic, external, error);
  EXPECT_GT(plastic, 0.01 * external);
  EXPECT_LT(error, 0.01);
  const auto md = h5::readDoubles(r, "/monitors/top/damage", &d);
  EXPECT_EQ(d[1], 1u);
  EXPECT_GT(md.size(), 10u);
  // The monitor's damage history never decreases.
  for (size_t i = 1; i < md.size(); ++i) EXPECT_GE(md[i], md[i - 1]);
}

TEST(SolidNonlinearResults, ContactStateOpeningAndSlipReachResults) {
  Files f;
  // Two 2 m x 2 m x 0.5 m elements, the lining one sliding on the fixed rock one.
  Mesh r = makeBoxMesh({1, 1, 1, 0, 0, -0.5, 2, 2, 0.5, "rock"});
  const Mesh l = makeBoxMesh({1, 1, 1, 0, 0, 0, 2, 2, 0.5, "lining"});
  Mesh m = r;
  m.coords.insert(m.coords.end(), l.coords.begin(), l.coords.end());
  for (Index c : l.connectivity) m.connectivity.push_back(c + 8);
  m.regionNames = {"rock", "lining"};
  m.region.push_back(1);
  m.faces.clear();
  for (Index q : l.faces.at("bottom")) m.faces["lining_outer"].push_back(q + 8);
  for (Index k = 0; k < 4; ++k) {
    m.rockLiningPairs.push_back(4 + k);
    m.rockLiningPairs.push_back(8 + k);
  }
  SolverOptions opt;
  opt.safety = 0.75;
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(8e9, 0.27, 2700)}, {"lining", elastic(28e9, 0.17, 2500)}}), opt);
  for (Index n = 0; n < 8; ++n)
    for (int dd = 0; dd < 3; ++dd) s.fix(n, dd);
  const std::vector<Index> bottom = {8, 9, 10, 11};
  s.addLoad({bottom, 2, -1e6, TimeFunction::constant(1.0)});
  s.addLoad({bottom, 0, 1.5e6, TimeFunction::constant(1.0)});  // 6 MN > μs N + c A = 2.4 + 2 MN
  ContactParams cp;
  auto contact = std::make_shared<DynamicContact>(s, rockLiningPairs(m), cp);
  s.addContributor(ForcePhase::Interface, contact);
  SolidInput in;
  in.path = "<memory>";
  in.monitorDt = 0;  // a row per sample() call, at its own time
  {
    ResultsWriter w(f / "results.h5", in, s);
    for (int i = 0; i < 50; ++i) {
      s.step();
      w.sample(s);
    }
    w.snapshot(s);
  }
  auto h = h5::openFile(f / "results.h5");
  std::vector<hsize_t> d;
  const auto pairs = h5::readInts(h, "/interface/pairs", &d);
  EXPECT_EQ(d[0], 4u);
  EXPECT_EQ(d[1], 2u);
  const auto hist = h5::readDoubles(h, "/interface/history", &d);
  ASSERT_EQ(d[1], 7u);
  EXPECT_EQ(hist[7 * (d[0] - 1) + 3], 4.0);  // all four slipping
  const auto state = h5::readInts(h, "/snapshots/0/interface/state", &d);
  const auto slip = h5::readDoubles(h, "/snapshots/0/interface/slip", &d);
  const auto opening = h5::readDoubles(h, "/snapshots/0/interface/opening", &d);
  for (Index p = 0; p < 4; ++p) {
    EXPECT_EQ(state[size_t(p)], Index(PairState::Slipping));
    EXPECT_NEAR(slip[size_t(p)], contact->slip(p, s.state()), 1e-15);
    EXPECT_GT(slip[size_t(p)], 0.0);
    EXPECT_NEAR(opening[size_t(p)], 0.0, 1e-12);
  }
  const auto diss = h5::readDoubles(h, "/energy/dissipation", &d);
  EXPECT_GT(diss[3 * (d[0] - 1) + 2], 0.0);  // friction dissipation
  EXPECT_NEAR(diss[3 * (d[0] - 1) + 2], s.energy().interface, 1e-9 * s.energy().interface);
}
