// Seismic boundaries (tests/verification/solid_wave_column,
// solid_free_field_block): the viscoelastic base with the incident wave as equivalent nodal
// forces, the free-field columns, the switch from static supports to dynamic boundaries.
//
// References (VERIFICATION.md "Solid: waves and boundaries"):
//  - uniform half-space, vertical SH / P: surface u(H, t) = 2 u0(t − H/c) (d'Alembert), and
//    nothing comes back after the reflection has left through the base (Lysmer & Kuhlemeyer 1969);
//  - layer on elastic rock: surface/outcrop F2(ω) = 1/[cos(kH) + i α sin(kH)], α = ρs cs/(ρr cr)
//    (Kramer 1996 §7.2; tunnelquake.references.layer_transfer_function with ξ = 0);
//  - a 3D block made of the column's layers, with free-field sides, moves as the 1D column.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <ostream>
#include <sstream>

#include "wave_cases.hpp"

using namespace tq;
using tqtest::GaussPulse;
using tqtest::StagedRun;

using namespace tqcases;

namespace {

struct PulseCase {
  const char* name;
  int dir;  // 0: SH along x, 2: P along z
};

std::ostream& operator<<(std::ostream& os, const PulseCase& p) { return os << p.name; }

class WaveColumn : public ::testing::TestWithParam<PulseCase> {};

}  // namespace

// Uniform column on the viscoelastic base: surface = 2 × incident (peak and L2 within 2 %), and
// after the reflected pulse has left through the base the column is at rest (energy left < 1 %
// of the pulse's). 100 elements over H = 100 m, pulse τ = 15 ms (content up to ~50 Hz, 20
// elements per wavelength at 50 Hz for SH).
TEST_P(WaveColumn, SurfaceIsTwiceIncidentAndNothingComesBack) {
  const PulseCase pc = GetParam();
  const Real H = 100;
  const Real c = pc.dir == 0 ? kCs : kCp;
  const tqcases::WaveColumnResult r = tqcases::waveColumn(pc.dir, 100, 0, H);
  std::printf(
      "wave column %s: peak error %+.3f %%, L2 error %.3f %%, tail energy %.2e of the pulse's (t = %.3f s, "
      "2H/c = %.3f s), energy balance error %.1e\n",
      pc.name, 100 * r.peakErr, 100 * r.l2, r.tailEnergy, r.tEnd, 2 * H / c, r.balance);
  EXPECT_LT(std::abs(r.peakErr), 0.02);
  EXPECT_LT(r.l2, 0.02);
  EXPECT_LT(r.tailEnergy, 0.01);
  EXPECT_LT(r.balance, 0.01);  // kinetic + internal + boundary − external (input) closes
}

INSTANTIATE_TEST_SUITE_P(VerticalIncidence, WaveColumn, ::testing::Values(PulseCase{"SH", 0}, PulseCase{"P", 2}),
                         [](const auto& i) { return std::string(i.param.name); });

// Layer (soil, cs 500 m/s, ρ 1900) of H = 50 m on elastic rock (cs 1500 m/s, ρ 2500: the base's
// half-space), h = 0.5 m, undamped (ξ = 0: |F2| peaks at 1/α = 3.95 at (2n−1) cs/4H).
//  A. Kramer's continuum F2 (surface/outcrop) within 3 % up to the mesh's frequency limit for a
//     resonant layer, f ≤ cs/(40 h) = 25 Hz (README: the linear element's dispersion shifts the
//     layer's phase kH by ≈ kH (kh)²/24; the sharpest peaks tolerate ≈ 0.06 rad for 3 %).
//  B. The exact transfer function of the discrete model itself (lumped-mass linear elements,
//     central difference, the base dashpot on the mean velocity) within 1 % up to λ/8:
//     f ≤ cs/(8 h) = 125 Hz — the boundary adds no error; what separates the model from F2 above
//     25 Hz is the mesh's dispersion.
TEST(WaveColumnLayer, TransferFunctionOfLayerOnRockMatchesKramer) {
  const Real H = 50, h = 0.5, csS = 500, rhoS = 1900, nuS = 0.3, csR = 1500, rhoR = 2500, nuR = 0.25;
  const Real GS = rhoS * csS * csS;
  const Real cpR = csR * std::sqrt(2 * (1 - nuR) / (1 - 2 * nuR));
  GaussPulse pulse;
  pulse.t0 = 0.02;
  pulse.tau = 0.003;
  MotionInput m;
  m.present = true;
  pulse.sample(0.2, 1e-4, m.time, m.ax);
  BottomBoundaryInput b;
  b.distance = 25;
  b.rho = rhoR;
  b.cs = csR;
  b.cp = cpR;
  ColumnRun run;
  run.setUp(H, Index(H / h), {{"soil", {2 * GS * (1 + nuS), nuS, rhoS}}}, 0, m, b);
  Solver& s = *run.solver;
  const Real dt = s.dt();
  const Index top = run.topNode();
  const IncidentMotion& inc = run.stages->seismic()->motion();
  // Reflection coefficient at the base (1 − α)/(1 + α) = 0.60 per round trip of 2H/cs = 0.2 s:
  // after 8 s the response is below 1e-9 of its peak.
  std::vector<Real> t, us, uo;
  while (s.time() < 8.0) {
    s.step();
    t.push_back(s.time());
    us.push_back(s.relativeDisplacement(top, 0));
    uo.push_back(2 * inc.displacement(0, s.time()));  // outcrop = 2 × incident
  }
  const Real alpha = rhoS * csS / (rhoR * csR), Z = rhoR * csR;
  Real worstA = 0, fA = 0, worstB = 0, fB = 0;
  for (Real f = 0.5; f <= csS / (8 * h) + 1e-9; f += 0.25) {
    const std::complex<Real> model = tqtest::dft(t, us, f) / tqtest::dft(t, uo, f);
    const Real w = 2 * M_PI * f, k = w / csS;
    const Real F2 = 1 / std::abs(std::complex<Real>(std::cos(k * H), alpha * std::sin(k * H)));
    // Discrete: interior dispersion (2/Δt)sin(ωΔt/2) = (2cs/h) sin(k_h h/2); standing wave
    // u_j = C cos(k_h (H − z_j)) (free top with half mass); base node (half mass, dashpot Z on the
    // mean velocity i sin(ωΔt)/Δt, input 2 Z v_in with v_in = iω u_in).
    const Real wt = 2 / dt * std::sin(w * dt / 2), wb = std::sin(w * dt) / dt;
    const Real kh = 2 / h * std::asin(wt * h / (2 * csS));
    const std::complex<Real> I(0, 1);
    const std::complex<Real> den = I * wb * Z * std::cos(kh * H) - wt * wt * rhoS * h / 2 * std::cos(kh * H) -
                                   GS / h * (std::cos(kh * (H - h)) - std::cos(kh * H));
    const Real Fh = std::abs(I * w * Z / den);
    const Real errA = std::abs(std::abs(model) / F2 - 1), errB = std::abs(std::abs(model) / Fh - 1);
    if (f <= csS / (40 * h) + 1e-9 && errA > worstA) worstA = errA, fA = f;
    if (errB > worstB) worstB = errB, fB = f;
    if (std::getenv("TQ_PRINT_TF"))
      std::printf("  f %6.2f  |model| %.4f  |F2| %.4f  |F2_h| %.4f\n", f, std::abs(model), F2, Fh);
  }
  std::printf(
      "layer on rock: vs Kramer F2 worst %.2f %% at %.2f Hz (0.5 .. %.0f Hz); vs the discrete model's exact "
      "transfer function worst %.1e at %.2f Hz (0.5 .. %.0f Hz); peaks 1/alpha = %.2f\n",
      100 * worstA, fA, csS / (40 * h), worstB, fB, csS / (8 * h), 1 / alpha);
  EXPECT_LT(worstA, 0.03);
  EXPECT_LT(worstB, 0.01);
}

namespace {

/// 3D block of two layers with free-field sides on all four faces, staged: in-situ stress under
/// gravity, equilibrium, switch, then S + P pulses (z = 2/3 of the horizontal), Rayleigh damping
/// on; the horizontal pulse at `azimuth` degrees from x towards y (x = cos, y = sin).
struct BlockRun : StagedRun {
  /// sharedY: the y faces driven by xmin's column (sharedColumnFaces), their inner nodes moved up
  /// or down by `jitter` of an element's height (in a checkerboard), so that their quads leave the
  /// column's rows as a tunnel's cross-section does.
  void setUp(bool withMotion, bool correction, RayleighDamping damping, Real azimuth = 0, bool sharedY = false,
             Real jitter = 0, BoxSpec box = {4, 3, 24, -20, -15, 0, 40, 30, 60}) {
    mesh = tqtest::twoLayerBox(box, 20.0, "rock", "soil");
    const Real hx = box.lx / box.nx, hz = box.lz / box.nz;
    for (Index n = 0; n < mesh.numNodes(); ++n) {
      Real* x = &mesh.coords[3 * size_t(n)];
      const bool onY = std::abs(x[1] - box.y0) < 1e-9 || std::abs(x[1] - box.y0 - box.ly) < 1e-9;
      const bool inner = x[0] > box.x0 + 1e-9 && x[0] < box.x0 + box.lx - 1e-9 && x[2] > box.z0 + 1e-9 &&
                         x[2] < box.z0 + box.lz - 1e-9 && std::abs(x[2] - 20.0) > 1e-9;
      if (onY && inner) {
        const long parity = std::lround((x[0] - box.x0) / hx) + std::lround((x[2] - box.z0) / hz);
        x[2] += (parity % 2 ? 1 : -1) * jitter * hz;
      }
    }
    in.materials = {{"rock", elasticValues({kE, kNu, kRho})}, {"soil", elasticValues({2 * 0.8e9 * 1.3, 0.3, 1900})}};
    in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
    in.options.damping = damping;
    StagedInput& S = in.staged;
    S.present = true;
    S.stages.sequence = {"in_situ", "seismic"};
    S.stages.tolerance = 1e-6;
    S.stages.equilibriumCorrection = correction;
    S.inSitu.present = true;
    S.inSitu.kx = 1.1;
    S.inSitu.ky = 0.8;
    S.inSitu.kz = 1.0;
    S.inSitu.gravity = 9.81;
    in.options.gravity[2] = -9.81;
    S.bottom.present = true;
    S.bottom.distance = 30;
    S.freeField.present = true;
    S.freeField.faces = {"xmin", "xmax", "ymin", "ymax"};
    if (sharedY) {
      S.freeField.faces = {"xmin", "xmax"};
      S.freeField.sharedColumnFaces = {"ymin", "ymax"};
    }
    S.motion.present = true;
    GaussPulse p;
    p.amplitude = withMotion ? 0.01 : 0.0;
    std::vector<Real> t2, t3;
    const Real c = std::cos(azimuth * M_PI / 180), sn = std::sin(azimuth * M_PI / 180);
    p.sample(1.0, 1e-4, S.motion.time, S.motion.ax, c);
    if (sn != 0) p.sample(1.0, 1e-4, t3, S.motion.ay, sn);
    p.sample(1.0, 1e-4, t2, S.motion.az, 2.0 / 3.0);
    build();
  }
};

/// Each node's nearest level of the column (by height).
std::vector<Index> nearestLevels(const FreeFieldColumn& col, const Mesh& mesh) {
  std::vector<Index> level(size_t(mesh.numNodes()));
  for (Index n = 0; n < mesh.numNodes(); ++n) {
    Index k;
    Real w;
    col.interpolation(mesh.coords[dofIndex(n, 2)], &k, &w);
    level[size_t(n)] = w > 0.5 ? k + 1 : k;
  }
  return level;
}

/// Steps the block's solver to t = 0.35 s against its first free-field column: per component d of
/// `dirs`, the largest |u_node - u_column| at the node's nearest level (the column's u() is u^n of
/// the step just taken, so it is compared with the model's u^n, the displacement before this step's
/// update) into worst[d], and the column's peak |u| into peak[d].
void stepAgainstTheColumn(BlockRun& run, std::initializer_list<int> dirs, Real worst[3], Real peak[3]) {
  Solver& s = *run.solver;
  const FreeFieldColumn& col = run.stages->seismic()->columns()[0];
  const std::vector<Index> level = nearestLevels(col, run.mesh);
  std::vector<Real> uPrev(3 * size_t(run.mesh.numNodes()), 0.0);  // the model's u^n
  while (s.time() < 0.35) {
    s.step();
    for (int d : dirs)
      for (Index k = 0; k < col.numLevels(); ++k) peak[d] = std::max(peak[d], std::abs(col.u(k, d)));
    for (Index n = 0; n < run.mesh.numNodes(); ++n)
      for (int d : dirs) {
        const Real diff = std::abs(uPrev[3 * size_t(n) + d] - col.u(level[size_t(n)], d));
        worst[d] = std::max(worst[d], diff);
        uPrev[3 * size_t(n) + d] = s.relativeDisplacement(n, d);
      }
  }
}

}  // namespace

// Every node of the block at every height follows the 1D free-field column computed alongside
// (the same layers, the same base) within 1 % of the column's peak motion, in x and z.
TEST(FreeField, BlockFollowsTheColumnAtEveryHeight) {
  BlockRun run;
  run.setUp(true, true, RayleighDamping::fromRatio(0.05, 2.0, 20.0));
  std::ostringstream log;
  run.stages->runStatics(log);
  run.stages->switchToDynamics(log);
  Real worst[3] = {0, 0, 0}, peak[3] = {0, 0, 0};
  stepAgainstTheColumn(run, {0, 2}, worst, peak);
  const Solver& s = *run.solver;
  std::printf(
      "free-field block: max |u_node - u_column| / column peak: x %.2e, z %.2e (peaks %.3e, %.3e m); "
      "energy balance error %.2e; %s\n",
      worst[0] / peak[0], worst[2] / peak[2], peak[0], peak[2], s.energy().error,
      run.stages->reports().back().note.c_str());
  EXPECT_LT(worst[0] / peak[0], 0.01);
  EXPECT_LT(worst[2] / peak[2], 0.01);
  EXPECT_GT(peak[0], 0.015);  // the surface doubles the 0.01 m incident pulse
  EXPECT_LT(s.energy().error, 0.01);
}

// A horizontally oblique motion in 3D: the pulse at 30° from x towards y, so the y faces' columns
// carry a motion along their own plane (u_y, as the x faces' carry u_x) and the x faces' an antiplane
// one. Every node at every height follows the 1D free-field column within the x faces' tolerance, 1 %
// of the column's peak, in x, y and z (the column: the same layers and base, the closed form's
// discrete counterpart verified in FreeField.LayerOnRockTransferFunction).
TEST(FreeField, BlockFollowsTheColumnInAnObliqueHorizontalMotion) {
  BlockRun run;
  run.setUp(true, true, RayleighDamping::fromRatio(0.05, 2.0, 20.0), 30.0);
  std::ostringstream log;
  run.stages->runStatics(log);
  run.stages->switchToDynamics(log);
  ASSERT_GE(run.stages->seismic()->columns().size(), 1u);
  Real worst[3] = {0, 0, 0}, peak[3] = {0, 0, 0};
  stepAgainstTheColumn(run, {0, 1, 2}, worst, peak);
  const Solver& s = *run.solver;
  std::printf(
      "free-field block, pulse at 30 deg from x: max |u_node - u_column| / column peak: x %.2e, y %.2e, z %.2e "
      "(peaks %.3e, %.3e, %.3e m); energy balance error %.2e\n",
      worst[0] / peak[0], worst[1] / peak[1], worst[2] / peak[2], peak[0], peak[1], peak[2], s.energy().error);
  for (int d = 0; d < 3; ++d) EXPECT_LT(worst[d] / peak[d], 0.01) << "component " << d;
  EXPECT_NEAR(peak[1] / peak[0], std::tan(M_PI / 6), 0.01 * std::tan(M_PI / 6));  // the motion's own split
  EXPECT_LT(s.energy().error, 0.01);
}

// The y faces as a tunnel's cross-section gives them: quads out of the column's rows (their inner
// nodes moved by 0.1 of an element's height, up and down in a checkerboard), driven by xmin's column
// shared (each node at its own height, each quad by the layer at its centroid), under the pulse at
// 30° from x towards y. The block has no tunnel: every node follows the column interpolated at its
// height within the x faces' tolerance, 1 % of the column's peak, in x, y and z. With the faces not
// moved the shared column gives what their own columns give (round-off).
TEST(FreeField, SharedColumnOnFacesOutOfItsRowsFollowsTheColumn) {
  for (const Real jitter : {0.0, 0.1}) {
    BlockRun run;
    run.setUp(true, true, RayleighDamping::fromRatio(0.05, 2.0, 20.0), 30.0, true, jitter);
    std::ostringstream log;
    run.stages->runStatics(log);
    run.stages->switchToDynamics(log);
    Solver& s = *run.solver;
    const FreeFieldColumn& col = run.stages->seismic()->columns()[0];
    ASSERT_EQ(run.stages->seismic()->columns().size(), 2u);  // xmin's and xmax's: the y faces share xmin's
    std::vector<Index> level(size_t(run.mesh.numNodes()));
    std::vector<Real> weight(size_t(run.mesh.numNodes()));
    for (Index n = 0; n < run.mesh.numNodes(); ++n)
      col.interpolation(run.mesh.coords[3 * size_t(n) + 2], &level[size_t(n)], &weight[size_t(n)]);
    Real worst[3] = {0, 0, 0}, peak[3] = {0, 0, 0};
    std::vector<Real> uPrev(3 * size_t(run.mesh.numNodes()), 0.0);
    while (s.time() < 0.35) {
      s.step();
      for (int d = 0; d < 3; ++d)
        for (Index k = 0; k < col.numLevels(); ++k) peak[d] = std::max(peak[d], std::abs(col.u(k, d)));
      for (Index n = 0; n < run.mesh.numNodes(); ++n) {
        const Index k0 = level[size_t(n)], k1 = std::min<Index>(k0 + 1, col.numLevels() - 1);
        const Real w = weight[size_t(n)];
        for (int d = 0; d < 3; ++d) {
          const Real ucol = (1 - w) * col.u(k0, d) + w * col.u(k1, d);
          worst[d] = std::max(worst[d], std::abs(uPrev[3 * size_t(n) + d] - ucol));
          uPrev[3 * size_t(n) + d] = s.relativeDisplacement(n, d);
        }
      }
    }
    std::printf(
        "free-field block, y faces on xmin's column, their nodes moved %.1f h: max |u_node - u_column| / column "
        "peak: x %.2e, y %.2e, z %.2e; energy balance error %.2e\n",
        jitter, worst[0] / peak[0], worst[1] / peak[1], worst[2] / peak[2], s.energy().error);
    const Real tol = jitter == 0 ? 1e-12 : 0.01;
    for (int d = 0; d < 3; ++d) EXPECT_LT(worst[d] / peak[d], tol) << "component " << d << ", moved " << jitter;
    EXPECT_LT(s.energy().error, 0.01);
  }
}

// A shared column refuses a face whose ground differs from the column's layers (a tunnel's lining
// or an unplugged hole there), naming the face, the quad and the block.
TEST(FreeField, SharedColumnRefusesAFaceOfAnotherMaterial) {
  BlockRun bad;
  bad.setUp(true, true, RayleighDamping::fromRatio(0.05, 2.0, 20.0), 30.0, true, 0.0);
  // One element on the ymin face, away from the x faces, below the layers' interface: now soil.
  Index changed = -1;
  for (Index e = 0; e < bad.mesh.numElems() && changed < 0; ++e) {
    bool onYmin = false, onX = false;
    Real zc = 0;
    for (int k = 0; k < 8; ++k) {
      const Real* x = &bad.mesh.coords[3 * size_t(bad.mesh.connectivity[8 * size_t(e) + k])];
      onYmin |= std::abs(x[1] + 15) < 1e-9;
      onX |= std::abs(std::abs(x[0]) - 20) < 1e-9;
      zc += x[2] / 8;
    }
    if (onYmin && !onX && zc < 10) changed = e;
  }
  ASSERT_GE(changed, 0);
  bad.mesh.region[size_t(changed)] = 1;
  bad.in.staged.inSitu.density = 2000;  // one overburden density: the regions are no longer layers
  bad.build();
  std::ostringstream log;
  bad.stages->runStatics(log);
  try {
    bad.stages->switchToDynamics(log);
    FAIL() << "a quad of another material than the column's layer was accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("face group 'ymin'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("plug the tunnel's ends"), std::string::npos) << msg;
  }
}

// The switch from static supports to dynamic boundaries: with zero input motion the model stays
// at rest after the switch (drift at round-off level relative to the static displacement), because
// each released support is replaced by its reaction and the relaxation's residual is held.
TEST(FreeField, SwitchWithZeroInputStaysAtRest) {
  // The block's in-situ stress is the layered overburden, in equilibrium from the start, so its
  // static settlement is round-off; the drift is measured against the settlement scale ρ g H²/E
  // of the 60 m block instead.
  const Real uStatic = kRho * 9.81 * 60 * 60 / kE;
  Real drift[2];
  for (int corr = 1; corr >= 0; --corr) {
    BlockRun run;
    run.setUp(false, corr == 1, RayleighDamping::fromRatio(0.05, 2.0, 20.0));
    std::ostringstream log;
    run.stages->runStatics(log);
    Solver& s = *run.solver;
    run.stages->switchToDynamics(log);
    Real d = 0;
    for (int k = 0; k < 2000; ++k) {
      s.step();
      for (Index n = 0; n < run.mesh.numNodes(); ++n)
        for (int dd = 0; dd < 3; ++dd) d = std::max(d, std::abs(s.relativeDisplacement(n, dd)));
    }
    drift[corr] = d / uStatic;
    std::printf("switch, zero input, %s: max |u| over 2000 steps / settlement scale %.3e m = %.2e (%s)\n",
                corr ? "residual held" : "reactions only", uStatic, drift[corr],
                run.stages->reports().back().note.c_str());
  }
  EXPECT_LT(drift[1], 1e-10);  // round-off
  EXPECT_LT(drift[0], 1e-3);   // reactions alone: the relaxation residual (tolerance 1e-6) moves it a little
}

// The viscoelastic base's nodes, distinct, are computed on the solver's threads (from
// SeismicBoundaries::kThreadedBaseNodes nodes), their spring work summed after in node order, and
// the free-field sides' terms node by node in the one loop's order (from kThreadedSideNodes): the
// same bits as the one loop at any thread count (a base of 25 x 25 nodes and 480 side nodes, the
// staged block above).
TEST(FreeField, BaseAndSideNodesOnThreadsGiveTheOneLoopsBits) {
  auto run = [](int threads, bool onThreads, bool& threaded) {
    omp_set_num_threads(threads);
    BlockRun run;
    run.setUp(true, true, RayleighDamping::fromRatio(0.05, 2.0, 20.0), 30, false, 0,
              {24, 24, 4, -20, -15, 0, 40, 30, 60});
    std::ostringstream log;
    run.stages->runStatics(log);
    run.stages->switchToDynamics(log);
    run.stages->seismic()->computeBaseOnThreads(onThreads);
    run.stages->seismic()->computeSidesOnThreads(onThreads);
    threaded = run.stages->seismic()->baseOnThreads() && run.stages->seismic()->sidesOnThreads();
    Solver& s = *run.solver;
    while (s.time() < 0.1) s.step();
    std::vector<Real> out(s.state().uData(), s.state().uData() + 3 * run.mesh.numNodes());
    out.push_back(run.stages->seismic()->boundaryEnergy());
    out.push_back(s.energy().error);
    std::printf(
        "%d thread(s), %s: base spring energy %.9e J, peak |u| %.4e m\n", threads,
        threaded ? "base and sides on the threads" : "one loop", out[out.size() - 2],
        *std::max_element(out.begin(), out.end() - 2, [](Real a, Real b) { return std::abs(a) < std::abs(b); }));
    return out;
  };
  bool t0 = true, t1 = false, t2 = false;
  const auto serial = run(1, false, t0), one = run(1, true, t1), two = run(2, true, t2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_FALSE(t0);
  EXPECT_TRUE(t1 && t2);
  EXPECT_NE(serial[serial.size() - 2], 0.0);  // the springs did work
  ASSERT_EQ(serial.size(), one.size());
  ASSERT_EQ(serial.size(), two.size());
  EXPECT_EQ(std::memcmp(serial.data(), one.data(), serial.size() * sizeof(Real)), 0);
  EXPECT_EQ(std::memcmp(serial.data(), two.data(), serial.size() * sizeof(Real)), 0);
}
