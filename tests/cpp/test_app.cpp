// tq-solid end to end through files: mesh.h5 + solid_input.h5 -> results.h5.
//  - Confined column (rollers on the four sides, fixed base) under a suddenly applied top
//    pressure p: 1-D wave in a bar of constrained modulus M = λ + 2μ (Graff, Wave Motion in Elastic
//    Solids, §1.3): the top moves at p/(ρ c) until the reflection returns at t = 2H/c, so the peak
//    top displacement is 2 p H / M (twice the static value). Tolerance 2 % (dispersion of the
//    discrete wave front, 20 elements over H).
//  - Histories on an even clock: with a monitor interval that is not a multiple of the solver's
//    step, every history row is written at k·monitor_dt exactly (to round-off), and the free
//    vibration of the column after the step load (a fixed-free bar: fundamental f1 = c / 4H,
//    Graff §1.3) peaks in the discrete Fourier transform taken on that axis within one bin 1/T
//    of f1 (rows taken at the first step at or after each k·monitor_dt stand up to one step,
//    here 36 % of monitor_dt, off that axis).
//  - The literal paper integrator (paper_eq3_4) must blow up; the run stops with the step and
//    node, results.h5 keeps status "stopped: ..." and only finite rows.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "input_fixture.hpp"
#include "io/h5util.hpp"
#include "tq/app/app.hpp"
#include "tq/io/input.hpp"
#include "tq/io/mesh.hpp"

using namespace tq;

namespace {

struct Files {
  std::filesystem::path dir;
  Files() {
    dir = std::filesystem::temp_directory_path() / ("tq_app_" + std::to_string(::getpid()) + "_" +
                                                    ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir);
  }
  ~Files() { std::filesystem::remove_all(dir); }
  std::string operator/(const std::string& n) const { return (dir / n).string(); }
};

const Real kE = 8e9, kNu = 0.27, kRho = 2700, kH = 20.0, kP = 1e6, kA = 4.0;

SolidInput columnInput(const Files& f) {
  writeMeshH5(makeBoxMesh({2, 2, 20, 0, 0, 0, 2, 2, kH}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({kE, kNu, kRho})}};
  in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  const auto mod = ElasticModuli::fromYoungPoisson(kE, kNu);
  const Real c = std::sqrt(mod.pModulus() / kRho);
  in.tEnd = 3 * kH / c;
  LoadInput l;
  l.name = "pressure";
  l.target = "top";
  l.direction = 2;
  l.force = -kP * kA;  // total force on the 2 m x 2 m top
  l.function = {{0.0, 1e-9, 1.0}, {0.0, 1.0, 1.0}};
  in.loads = {l};
  in.monitors = {{"top", {1.0, 1.0, kH}}, {"mid", {1.0, 1.0, kH / 2}}};
  in.monitorDt = 1e-4;
  in.snapshotTimes = {kH / c};
  in.progressSeconds = 100;
  return in;
}

}  // namespace

TEST(App, ConfinedColumnStepLoadPeaksAtTwiceTheStaticDisplacement) {
  Files f;
  SolidInput in = columnInput(f);
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  const int rc = runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err);
  ASSERT_EQ(rc, 0) << err.str();
  auto r = h5::openFile(f / "results.h5");
  EXPECT_EQ(h5::readStringAttr(r, "status"), "completed");
  std::vector<hsize_t> d;
  const auto u = h5::readDoubles(r, "/monitors/top/u", &d);
  ASSERT_EQ(d[1], 3u);
  Real peak = 0;
  for (size_t i = 0; i < d[0]; ++i) peak = std::max(peak, -u[3 * i + 2]);
  const auto mod = ElasticModuli::fromYoungPoisson(kE, kNu);
  const Real uStatic = kP * kH / mod.pModulus();
  std::printf("column: peak top displacement / (2 p H / M) = %.4f\n", peak / (2 * uStatic));
  EXPECT_NEAR(peak / (2 * uStatic), 1.0, 0.02) << "peak " << peak << " m";
  const auto e = h5::readDoubles(r, "/energy/history", &d);
  ASSERT_EQ(d[1], 7u);
  EXPECT_LT(e[7 * (d[0] - 1) + 6], 1e-2);  // energy balance closes (step load: work = p Δu)
  EXPECT_TRUE(h5::exists(r, "/snapshots/0/u"));
  EXPECT_TRUE(h5::exists(r, "/timings"));
}

TEST(App, HistoriesAreWrittenOnAnEvenClockAndKeepTheirFrequency) {
  Files f;
  SolidInput in = columnInput(f);
  const auto mod = ElasticModuli::fromYoungPoisson(kE, kNu);
  const Real c = std::sqrt(mod.pModulus() / kRho), f1 = c / (4 * kH);
  in.tEnd = 20 / f1;  // 20 periods: bins of f1 / 20
  in.monitorDt = 1.3e-3;
  in.snapshotTimes = {};
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  ASSERT_EQ(runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err), 0) << err.str();
  auto r = h5::openFile(f / "results.h5");
  const Real dt = h5::readDoubleAttr(r, "dt");
  const Real steps = in.monitorDt / dt;
  ASSERT_GT(std::abs(steps - std::round(steps)), 0.1) << "the interval must not be a multiple of the step";
  std::vector<hsize_t> d;
  const auto t = h5::readDoubles(r, "/monitors/top/time", &d);
  const size_t T = d[0];
  const auto u = h5::readDoubles(r, "/monitors/top/u", &d);
  const auto e = h5::readDoubles(r, "/energy/history", &d);
  ASSERT_EQ(d[0], T);
  Real worst = 0;
  for (size_t k = 0; k < T; ++k) {
    worst = std::max(worst, std::abs(t[k] - Real(k) * in.monitorDt));
    EXPECT_EQ(e[7 * k], t[k]);
  }
  EXPECT_LT(worst, 1e-12 * in.tEnd);
  EXPECT_GE(Real(T - 1) * in.monitorDt, in.tEnd - in.monitorDt - 1e-9);
  // |DFT| of the top displacement (mean removed) on the bins j / (T monitor_dt)
  Real mean = 0;
  for (size_t k = 0; k < T; ++k) mean += u[3 * k + 2] / Real(T);
  const Real span = Real(T) * in.monitorDt;
  Real best = 0, fPeak = 0;
  for (int j = 1; j < int(T / 2); ++j) {
    const Real fj = j / span;
    std::complex<Real> s = 0;
    for (size_t k = 0; k < T; ++k) s += (u[3 * k + 2] - mean) * std::exp(std::complex<Real>(0, -2 * M_PI * fj * t[k]));
    if (std::abs(s) > best) best = std::abs(s), fPeak = fj;
  }
  std::printf(
      "even clock: %zu rows at %.4g s (solver step %.4g s, %.2f steps a row), worst |t_k - k dt_out| %.1e s; "
      "spectral peak %.4f Hz against f1 = c/4H = %.4f Hz (bin %.4f Hz)\n",
      T, in.monitorDt, dt, steps, worst, fPeak, f1, 1 / span);
  EXPECT_LE(std::abs(fPeak - f1), 1 / span);
}

TEST(App, PaperLiteralIntegratorStopsWithLocationAndReadableResults) {
  Files f;
  SolidInput in = columnInput(f);
  in.options.integrator = Integrator::PaperEq34;
  in.tEnd *= 20;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  const int rc = runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err);
  EXPECT_EQ(rc, 3) << out.str() << err.str();
  EXPECT_NE(err.str().find("run stopped at step"), std::string::npos) << err.str();
  EXPECT_NE(err.str().find("paper_eq3_4 is unstable"), std::string::npos) << err.str();
  auto r = h5::openFile(f / "results.h5");
  EXPECT_EQ(h5::readStringAttr(r, "status").rfind("stopped: run stopped at step", 0), 0u);
  std::vector<hsize_t> d;
  const auto u = h5::readDoubles(r, "/monitors/top/u", &d);
  EXPECT_GT(d[0], 10u);
  for (Real x : u) ASSERT_TRUE(std::isfinite(x));
}

TEST(App, BadInputIsReportedWithPathAndFix) {
  Files f;
  SolidInput in = columnInput(f);
  in.options.dt = 1.0;  // far above the stable step
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  std::ostringstream out, err;
  EXPECT_EQ(runSolid({f / "solid_input.h5", "-o", f / "results.h5"}, out, err), 2);
  EXPECT_NE(err.str().find("above the stable limit"), std::string::npos) << err.str();
  // Unknown attribute is rejected with its location.
  in.options.dt = 0;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  {
    auto h = h5::openFile(f / "solid_input.h5", true);
    auto g = h5::openGroup(h, "/solver");
    h5::writeDoubleAttr(g, "t_ned", 1.0);
  }
  std::ostringstream out2, err2;
  EXPECT_EQ(runSolid({f / "solid_input.h5", "--check"}, out2, err2), 2);
  EXPECT_NE(err2.str().find("/solver: unknown attribute 't_ned'"), std::string::npos) << err2.str();
}
