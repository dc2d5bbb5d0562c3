// Staged construction with stress release: a fraction λ of the excavation load is released with
// the rock alone, the lining is activated stress-free, and the rest (1 − λ) is released on rock and
// lining together. Checked against the closed form of a thick lining bonded in elastic rock
// (docs/theory.md §2, "Partial stress release before the lining"), with Einstein–Schwartz's
// relative-stiffness solution printed as a second reference.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "input_fixture.hpp"
#include "tq/app/app.hpp"
#include "tq/contact/contact.hpp"
#include "tq/io/mesh.hpp"
#include "tunnel_cases.hpp"

using namespace tq;
using namespace tqcases;

namespace {

/// Einstein & Schwartz (1979), no slip, K = 1: thin ring of radius R (the lining's mid-surface)
/// and thickness t; contact pressure P (1 − a0*), hoop stress −P R (1 − a0*) / t.
ReleaseReference einsteinSchwartz(Real p0, Real lambda, Real a, Real b) {
  const Real t = b - a, R = 0.5 * (a + b), P = (1 - lambda) * p0;
  const Real soil = kEr / (1 - kNur * kNur), liner = kEl / (1 - kNul * kNul);
  const Real C = soil * R / (liner * t);                       // compressibility ratio C*
  const Real F = soil * R * R * R / (liner * t * t * t / 12);  // flexibility ratio F*
  const Real a0 = C * F * (1 - kNur) / (C + F + C * F * (1 - kNur));
  ReleaseReference r;
  r.pc = P * (1 - a0);
  r.hoopIn = r.hoopOut = -P * R * (1 - a0) / t;
  return r;
}

struct ReleaseResult {
  Real hoopIn = 0, hoopOut = 0, pcLame = 0, pcTie = 0;
  Index steps = 0, failedPairs = 0;
  std::string notes;
};

/// The quarter plate with the paper's lining (a = 4.5 m, b = 5.25 m), k = 1, gravity off:
/// in_situ → excavation → lining with release fraction λ, bonded interface.
ReleaseResult stagedRelease(Real p0, Real lambda, Index nTheta, Index nThrough, bool contact = false) {
  tqtest::StagedRun run;
  QuarterSpec qs;
  qs.nTheta = nTheta;
  qs.nLining = nThrough;
  qs.liningT = 0.75;
  run.mesh = quarterPlate(qs);
  run.in.materials = {{"rock", elasticValues({kEr, kNur, kRhor})}, {"lining", elasticValues({kEl, kNul, kRhol})}};
  run.in.fixed = {{"bottom", "z"}, {"xmin", "x"}, {"xmax", "x"}, {"top", "z"}};
  StagedInput& S = run.in.staged;
  S.present = true;
  S.stages.sequence = {"in_situ", "excavation", "lining"};
  S.stages.tolerance = 1e-6;
  S.stages.maxSteps = 200000;
  S.stages.releaseFraction = lambda;
  S.inSitu.present = true;
  S.inSitu.kx = S.inSitu.ky = S.inSitu.kz = 1;
  S.inSitu.surcharge = p0;
  if (contact) {
    S.rockLining.present = true;
    S.rockLining.model = "dynamic_contact";
    S.rockLining.cohesion = 0.5e6;  // the paper's interface
  }
  run.build();
  std::ostringstream log;
  run.stages->runStatics(log);
  const ElementBlock* lin = nullptr;
  for (const auto& blk : run.solver->blocks())
    if (blk->name() == "lining") lin = blk.get();
  const LameFit L = lameFit(run.mesh, *lin);
  const Real a = qs.b - qs.liningT, b = qs.b;
  ReleaseResult res;
  res.hoopIn = L.hoop(a);
  res.hoopOut = L.hoop(b);
  res.pcLame = L.contactPressure(b);
  for (const auto& rep : run.stages->reports()) {
    res.steps += rep.steps;
    if (!rep.note.empty()) res.notes += rep.name + ": " + rep.note + "\n";
  }
  if (const auto* dc = dynamic_cast<const DynamicContact*>(run.stages->rockLiningInterface().get())) {
    for (Index p = 0; p < dc->numPairs(); ++p) res.failedPairs += dc->failed(p) ? 1 : 0;
    return res;
  }
  res.pcTie = tieContactPressure(run, qs, nTheta);
  return res;
}

}  // namespace

// λ = 0 (lining installed before any release), 0.5 and 1 (today's full release before the lining):
// the lining's inner and outer hoop stress and the contact pressure within 2 % of the closed form.
// For λ = 1 the closed form is zero: the measured values must be below 2 % of the λ = 0 values.
TEST(StressRelease, LinedTunnelMatchesClosedForm) {
  const Real p0 = 5e6, a = 4.5, b = 5.25;
  const ReleaseReference full = releaseReference(p0, 0, a, b);
  for (Real lambda : {0.0, 0.5, 1.0}) {
    const ReleaseReference ref = releaseReference(p0, lambda, a, b);
    const ReleaseReference es = einsteinSchwartz(p0, lambda, a, b);
    const ReleaseResult r = stagedRelease(p0, lambda, 12, 3);
    std::printf(
        "stress release λ = %.2f, p0 = %.3g MPa (%d relaxation steps):\n"
        "  inner hoop %.4f MPa (closed form %.4f), outer hoop %.4f MPa (closed form %.4f),\n"
        "  contact pressure %.4f MPa from the interface forces, %.4f MPa from the ring's stresses "
        "(closed form %.4f)\n"
        "  Einstein-Schwartz (no slip, thin ring at the mid-surface): contact pressure %.4f MPa, hoop "
        "%.4f MPa\n",
        lambda, p0 / 1e6, r.steps, r.hoopIn / 1e6, ref.hoopIn / 1e6, r.hoopOut / 1e6, ref.hoopOut / 1e6, r.pcTie / 1e6,
        r.pcLame / 1e6, ref.pc / 1e6, es.pc / 1e6, es.hoopIn / 1e6);
    if (lambda < 1) {
      std::printf(
          "  relative to the closed form: inner hoop %+.2f %%, outer hoop %+.2f %%, contact pressure %+.2f %% "
          "(interface forces) / %+.2f %% (ring); Einstein-Schwartz vs closed form: contact pressure %+.2f %%,"
          " hoop %+.2f %% of the inner, %+.2f %% of the outer\n",
          100 * (r.hoopIn / ref.hoopIn - 1), 100 * (r.hoopOut / ref.hoopOut - 1), 100 * (r.pcTie / ref.pc - 1),
          100 * (r.pcLame / ref.pc - 1), 100 * (es.pc / ref.pc - 1), 100 * (es.hoopIn / ref.hoopIn - 1),
          100 * (es.hoopOut / ref.hoopOut - 1));
      EXPECT_NEAR(r.hoopIn / ref.hoopIn, 1, 0.02);
      EXPECT_NEAR(r.hoopOut / ref.hoopOut, 1, 0.02);
      EXPECT_NEAR(r.pcTie / ref.pc, 1, 0.02);
      EXPECT_NEAR(r.pcLame / ref.pc, 1, 0.02);
      EXPECT_NE(r.notes.find("release fraction"), std::string::npos) << r.notes;
    } else {
      std::printf("  relative to the λ = 0 values: inner hoop %.2e, outer hoop %.2e, contact pressure %.2e\n",
                  r.hoopIn / full.hoopIn, r.hoopOut / full.hoopOut, r.pcTie / full.pc);
      EXPECT_LT(std::abs(r.hoopIn / full.hoopIn), 0.02);
      EXPECT_LT(std::abs(r.hoopOut / full.hoopOut), 0.02);
      EXPECT_LT(std::abs(r.pcTie / full.pc), 0.02);
      EXPECT_LT(std::abs(r.pcLame / full.pc), 0.02);
      EXPECT_EQ(r.notes.find("release fraction"), std::string::npos) << r.notes;  // today's path
    }
  }
}

// The same release through the paper's dynamic contact instead of the tie: it bonds when the lining
// is activated and stays closed under the compression of the release (no pair fails), so the
// lining's stresses match the same closed form within 2 %.
TEST(StressRelease, ThroughTheDynamicContact) {
  const Real p0 = 5e6, a = 4.5, b = 5.25, lambda = 0.5;
  const ReleaseReference ref = releaseReference(p0, lambda, a, b);
  const ReleaseResult r = stagedRelease(p0, lambda, 12, 3, true);
  std::printf(
      "stress release λ = %.2f through the dynamic contact (%d relaxation steps, %d failed pairs): inner "
      "hoop %.4f MPa (%+.2f %%), outer hoop %.4f MPa (%+.2f %%), contact pressure from the ring's stresses "
      "%.4f MPa (%+.2f %%)\n",
      lambda, r.steps, r.failedPairs, r.hoopIn / 1e6, 100 * (r.hoopIn / ref.hoopIn - 1), r.hoopOut / 1e6,
      100 * (r.hoopOut / ref.hoopOut - 1), r.pcLame / 1e6, 100 * (r.pcLame / ref.pc - 1));
  EXPECT_EQ(r.failedPairs, 0);
  EXPECT_NEAR(r.hoopIn / ref.hoopIn, 1, 0.02);
  EXPECT_NEAR(r.hoopOut / ref.hoopOut, 1, 0.02);
  EXPECT_NEAR(r.pcLame / ref.pc, 1, 0.02);
}

// /stages release_fraction through the file: read back as written, and refused outside [0, 1] or
// without the lining stage, naming the attribute.
TEST(StressRelease, ReleaseFractionInput) {
  const auto dir = std::filesystem::temp_directory_path() / ("tq_release_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  QuarterSpec qs;
  qs.nTheta = 2;
  qs.L = 4 * qs.b;
  qs.liningT = 0.75;
  qs.nLining = 1;
  writeMeshH5(quarterPlate(qs), (dir / "mesh.h5").string());
  auto input = [&](Real lambda, std::vector<std::string> seq) {
    SolidInput in;
    in.materials = {{"rock", elasticValues({kEr, kNur, kRhor})}, {"lining", elasticValues({kEl, kNul, kRhol})}};
    in.fixed = {{"bottom", "z"}, {"xmin", "x"}, {"xmax", "x"}, {"top", "z"}};
    in.tEnd = 0.01;
    in.progressSeconds = 100;
    in.staged.present = true;
    in.staged.stages.sequence = std::move(seq);
    in.staged.stages.releaseFraction = lambda;
    in.staged.inSitu.present = true;
    in.staged.inSitu.surcharge = 1e6;
    test::writeInputFile(in, (dir / "solid_input.h5").string(), "mesh.h5");
    std::ostringstream out, err;
    const int rc = runSolid({(dir / "solid_input.h5").string(), "--check"}, out, err);
    return std::make_pair(rc, err.str());
  };
  {
    const auto [rc, msg] = input(0.35, {"in_situ", "excavation", "lining"});
    EXPECT_EQ(rc, 0) << msg;
    const SolidInput back = readSolidInput((dir / "solid_input.h5").string());
    EXPECT_EQ(back.staged.stages.releaseFraction, 0.35);
  }
  {
    const auto [rc, msg] = input(1.5, {"in_situ", "excavation", "lining"});
    EXPECT_EQ(rc, 2);
    EXPECT_NE(msg.find("/stages: release_fraction = 1.5 must lie in [0, 1]"), std::string::npos) << msg;
  }
  {
    const auto [rc, msg] = input(0.5, {"in_situ", "excavation"});
    EXPECT_EQ(rc, 2);
    EXPECT_NE(msg.find("release_fraction < 1"), std::string::npos) << msg;
  }
  std::filesystem::remove_all(dir);
}
