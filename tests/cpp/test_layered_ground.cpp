// Layered ground: the free-field column of two layers on elastic rock against the closed-form
// transfer function, and the in-situ overburden of horizontal layers.
//
// References and tolerances:
//  - Vertically incident SH through horizontal layers on an elastic half-space (Kramer 1996,
//    Geotechnical Earthquake Engineering, §7.2.1.5, "layered, damped soil on elastic rock";
//    Roesset 1977): in layer m, u = A_m e^{i(ωt + k_m z)} + B_m e^{i(ωt − k_m z)} (z depth from
//    the layer's top), A_1 = B_1 at the free surface, and across the interface under layer m
//      A_{m+1} = ½ A_m (1 + α_m) e^{i k_m h_m} + ½ B_m (1 − α_m) e^{−i k_m h_m}
//      B_{m+1} = ½ A_m (1 − α_m) e^{i k_m h_m} + ½ B_m (1 + α_m) e^{−i k_m h_m}
//    with α_m = G_m k_m / (G_{m+1} k_{m+1}). The surface over the incident wave in the rock is
//    |u_surface / u_incident| = 2 |A_1 / A_rock|. Mass-proportional damping α M (the column's
//    damping model) makes k_m = (ω / c_m) √(1 − i α/ω) in the layers; the rock below the base is
//    undamped (the base's dashpot ρc and input force 2ρc v_in are an undamped half-space).
//    Tolerance: 2 % from 0.5 to 15 Hz on a column of λ/27 elements at 15 Hz (the linear
//    element's dispersion shifts the layers' phase k h by about k h (k Δz)²/24; it is the only
//    error, and it falls as Δz², which the coarser column shows).
//  - The same layers in a slice of the ground (one element thick along y, plane strain) with
//    free-field x faces, the viscoelastic base and its y faces tied periodic, driven by an SH wave
//    polarised along y (the tunnel's axis): antiplane shear, which the plane-strain u_y = 0
//    forbids and the periodic tie allows. Its ground surface against the same closed form, within
//    the same 2 %, and every node against the 1D free-field column within 1 % of its peak.
//  - In-situ stress: σ_z(z) = −g ∫_z^{z_top} ρ dζ over the layers above (hand value, to
//    round-off), and the stage starts in equilibrium (nothing moves).
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdio>
#include <sstream>
#include <vector>

#include "input_fixture.hpp"
#include "staged_helpers.hpp"
#include "tq/boundaries/free_field.hpp"
#include "tq/core/constraints.hpp"
#include "tq/io/mesh.hpp"

using namespace tq;

namespace {

using Cx = std::complex<Real>;

struct Layer {
  Real rho, cs, nu, thickness, h;  // h: element height in the column
};

/// 2 |A_1 / A_N| for the layers (top down) on the half-space (rho, cs), with mass-proportional
/// damping alpha in the layers.
Real closedForm(const std::vector<Layer>& layers, Real rhoR, Real csR, Real alpha, Real f) {
  const Real w = 2 * M_PI * f;
  const Cx damp = std::sqrt(Cx(1, -alpha / w));
  Cx A = 1, B = 1;
  for (size_t m = 0; m < layers.size(); ++m) {
    const Layer& L = layers[m];
    const Cx k = w / L.cs * damp;
    const Real G = L.rho * L.cs * L.cs;
    Cx kb, Gb;
    if (m + 1 < layers.size()) {
      kb = w / layers[m + 1].cs * damp;
      Gb = layers[m + 1].rho * layers[m + 1].cs * layers[m + 1].cs;
    } else {
      kb = w / csR;
      Gb = rhoR * csR * csR;
    }
    const Cx a = G * k / (Gb * kb);
    const Cx e = std::exp(Cx(0, 1) * k * L.thickness);
    const Cx An = 0.5 * A * (1.0 + a) * e + 0.5 * B * (1.0 - a) / e;
    const Cx Bn = 0.5 * A * (1.0 - a) * e + 0.5 * B * (1.0 + a) / e;
    A = An;
    B = Bn;
  }
  return 2 / std::abs(A);
}

/// DFT of a record sampled every dt from t = 0, at frequency f (a rotating phasor).
Cx dft(const std::vector<Real>& x, Real dt, Real f) {
  const Cx step = std::exp(Cx(0, -2 * M_PI * f * dt));
  Cx ph = 1, s = 0;
  for (Real v : x) {
    s += v * ph;
    ph *= step;
  }
  return s;
}

struct Result {
  Real worst = 0, fWorst = 0, peak = 0;
};

/// The column of `layers` (elements of height h / refine) on the half-space, driven by an
/// incident SH velocity pulse; |V_surface / V_incident| against the closed form over 0.5-15 Hz.
Result runColumn(const std::vector<Layer>& layers, Real rhoR, Real csR, Real nuR, Real alpha, Real refine,
                 Real courant) {
  std::vector<Real> z = {0};
  std::vector<ColumnLayer> col;
  Real dt = 1e300;
  for (auto it = layers.rbegin(); it != layers.rend(); ++it) {  // the column is built bottom up
    const Index n = Index(std::lround(it->thickness / (it->h / refine)));
    const Real G = it->rho * it->cs * it->cs, lam = 2 * G * it->nu / (1 - 2 * it->nu);
    const Real cp = std::sqrt((lam + 2 * G) / it->rho), h = it->thickness / Real(n);
    dt = std::min(dt, courant * h / cp);  // the P wave sets the explicit step, as in the model
    const Real z0 = z.back();
    for (Index i = 1; i <= n; ++i) {
      z.push_back(z0 + it->thickness * Real(i) / Real(n));
      col.push_back({it->rho, lam, G});
    }
  }
  const Real cpR = csR * std::sqrt(2 * (1 - nuR) / (1 - 2 * nuR));
  RayleighDamping damping;
  damping.alpha = alpha;
  FreeFieldColumn c(z, col, {rhoR, cpR, csR}, damping);
  // Incident velocity v(t) = exp(−((t − t0)/τ)²), given as its derivative sampled every 0.1 ms:
  // flat enough to 15 Hz (|V| ≥ 0.6 of its low-frequency level).
  const Real t0 = 0.1, tau = 0.015;
  std::vector<Real> ts, ax;
  for (Real t = 0; t <= 0.3; t += 1e-4) {
    const Real s = (t - t0) / tau;
    ts.push_back(t);
    ax.push_back(-2 * s / tau * std::exp(-s * s));
  }
  IncidentMotion motion(ts, ax, {}, {});
  // Reflections lose 60 % or more of their amplitude at each interface and at the base: after
  // 8 s the response is below 1e-10 of its peak, so the records' transforms are complete.
  const Index top = c.numLevels() - 1;
  const Index steps = Index(8.0 / dt);
  std::vector<Real> vs, vi;
  vs.reserve(size_t(steps));
  vi.reserve(size_t(steps));
  for (Index n = 0; n < steps; ++n) {
    const Real t = Real(n) * dt;
    c.advance(t, dt, motion);
    vs.push_back(c.vMean(top, 0));
    vi.push_back(motion.velocity(0, t));
  }
  Result r;
  for (Real f = 0.5; f <= 15 + 1e-9; f += 0.02) {
    const Real model = std::abs(dft(vs, dt, f)) / std::abs(dft(vi, dt, f));
    const Real exact = closedForm(layers, rhoR, csR, alpha, f);
    const Real err = std::abs(model / exact - 1);
    r.peak = std::max(r.peak, exact);
    if (err > r.worst) r.worst = err, r.fWorst = f;
    if (std::getenv("TQ_PRINT_TF")) std::printf("  f %6.2f  |model| %.4f  |exact| %.4f\n", f, model, exact);
  }
  return r;
}

// Weathered rock (cs 400 m/s, 20 m, elements 1 m) over rock (cs 800 m/s, 40 m, elements 2 m) on
// an elastic half-space (cs 1600 m/s): λ/27 at 15 Hz in both layers.
const std::vector<Layer> kLayers = {{2000, 400, 0.30, 20, 1.0}, {2300, 800, 0.25, 40, 2.0}};
constexpr Real kRhoR = 2500, kCsR = 1600, kNuR = 0.25;

}  // namespace

TEST(LayeredColumn, TwoLayersOnRockMatchTheClosedFormTransferFunction) {
  // Undamped (|u_s/u_i| peaks at 2 × 3.4) and with the default mass-proportional damping
  // (5 % at 1.5 Hz: α = 0.94 /s), at the column's own stable step (Courant 0.9 on the P wave)
  // and at a third of it (a model whose lining sets a smaller step).
  const Real alpha5 = 2 * 0.05 * 2 * M_PI * 1.5;
  for (Real alpha : {0.0, alpha5})
    for (Real courant : {0.9, 0.3}) {
      const Result r = runColumn(kLayers, kRhoR, kCsR, kNuR, alpha, 1, courant);
      std::printf(
          "two layers on rock, alpha %.3f /s, Courant %.1f: worst |T| error %.2f %% at %.2f Hz "
          "(0.5-15 Hz, peak |T| %.2f)\n",
          alpha, courant, 100 * r.worst, r.fWorst, r.peak);
      EXPECT_LT(r.worst, 0.02) << "alpha " << alpha << ", Courant " << courant;
    }
}

TEST(LayeredColumn, TransferFunctionErrorFallsAsTheElementHeightSquared) {
  // Twice the element height: four times the error (second order), the error is the mesh's.
  const Result fine = runColumn(kLayers, kRhoR, kCsR, kNuR, 0, 1, 0.9);
  const Result coarse = runColumn(kLayers, kRhoR, kCsR, kNuR, 0, 0.5, 0.9);
  std::printf("undamped: elements h %.2f %% at %.2f Hz, 2h %.2f %% at %.2f Hz, ratio %.2f\n", 100 * fine.worst,
              fine.fWorst, 100 * coarse.worst, coarse.fWorst, coarse.worst / fine.worst);
  EXPECT_GT(coarse.worst / fine.worst, 3.0);
  EXPECT_LT(coarse.worst / fine.worst, 5.0);
}

// The slice is 1 m thick, 20 m wide (4 elements) and 60 m high in 1 m element layers: the column
// test's 20 m of weathered rock over 40 m of rock, on its half-space (given on /boundaries/bottom).
TEST(LayeredSlice, AxialShWaveThroughAPeriodicSliceMatchesTheClosedForm) {
  const Layer& soil = kLayers[0];
  const Layer& rock = kLayers[1];
  auto young = [](const Layer& L) { return 2 * L.rho * L.cs * L.cs * (1 + L.nu); };
  tqtest::StagedRun run;
  run.mesh = tqtest::twoLayerBox({4, 1, 60, -10, 0, 0, 20, 1, 60}, rock.thickness, "rock", "soil");
  run.mesh.slice = true;
  run.in.materials = {{"rock", elasticValues({young(rock), rock.nu, rock.rho})},
                      {"soil", elasticValues({young(soil), soil.nu, soil.rho})}};
  run.in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}};
  const Real alpha = 2 * 0.05 * 2 * M_PI * 1.5;  // the default mass-proportional damping
  run.in.options.damping.alpha = alpha;
  StagedInput& S = test::inSituUnderGravity(run.in, {"in_situ", "seismic"}, 9.81, 1.1, 0.8);
  S.stages.tolerance = 1e-8;
  S.bottom.present = true;
  S.bottom.distance = 30;
  S.bottom.rho = kRhoR;
  S.bottom.cs = kCsR;
  S.bottom.cp = kCsR * std::sqrt(2 * (1 - kNuR) / (1 - 2 * kNuR));
  S.freeField.present = true;
  S.freeField.faces = {"xmin", "xmax"};
  S.periodic.present = true;
  S.periodic.faces = {"ymin", "ymax"};
  // The incident velocity pulse of the column test, polarised along y.
  const Real t0 = 0.1, tau = 0.015;
  S.motion.present = true;
  for (Real t = 0; t <= 0.3; t += 1e-4) {
    const Real q = (t - t0) / tau;
    S.motion.time.push_back(t);
    S.motion.ay.push_back(-2 * q / tau * std::exp(-q * q));
  }
  const IncidentMotion incident(S.motion.time, {}, S.motion.ay, {});
  run.build();
  std::ostringstream log;
  run.stages->runStatics(log);
  run.stages->switchToDynamics(log);
  Solver& s = *run.solver;
  const FreeFieldColumn& col = run.stages->seismic()->columns()[0];
  Index top = -1;
  std::vector<Index> level(size_t(run.mesh.numNodes()));
  for (Index n = 0; n < run.mesh.numNodes(); ++n) {
    const Real z = run.mesh.coords[3 * size_t(n) + 2];
    if (z > 60 - 1e-9 && top < 0) top = n;
    Index k;
    Real w;
    col.interpolation(z, &k, &w);
    level[size_t(n)] = w > 0.5 ? k + 1 : k;
  }
  ASSERT_GE(top, 0);
  if (std::getenv("TQ_PRINT_LOG")) std::printf("%s", log.str().c_str());
  std::vector<Real> ts, vs, vi, uPrev(size_t(run.mesh.numNodes()), 0.0);
  Real worstCol = 0, peakCol = 0, inPlane = 0;
  while (s.time() < 8.0) {
    s.step();
    const Real t = s.time();
    ts.push_back(t);
    vs.push_back(s.velocityAt(top, 1));
    vi.push_back(incident.velocity(1, t));
    for (Index k = 0; k < col.numLevels(); ++k) peakCol = std::max(peakCol, std::abs(col.u(k, 1)));
    for (Index n = 0; n < run.mesh.numNodes(); ++n) {
      // the column's u() is u^n of the step just taken: the model's value before this step
      worstCol = std::max(worstCol, std::abs(uPrev[size_t(n)] - col.u(level[size_t(n)], 1)));
      uPrev[size_t(n)] = s.relativeDisplacement(n, 1);
      inPlane = std::max({inPlane, std::abs(s.relativeDisplacement(n, 0)), std::abs(s.relativeDisplacement(n, 2))});
    }
  }
  Real worst = 0, fWorst = 0;
  for (Real f = 0.5; f <= 15 + 1e-9; f += 0.02) {
    const Real model = std::abs(tqtest::dft(ts, vs, f)) / std::abs(tqtest::dft(ts, vi, f));
    const Real exact = closedForm(kLayers, kRhoR, kCsR, alpha, f);
    if (std::abs(model / exact - 1) > worst) worst = std::abs(model / exact - 1), fWorst = f;
  }
  std::printf(
      "periodic slice, SH along y: worst |T| error %.2f %% at %.2f Hz (0.5-15 Hz); max |u_y - u_column| / "
      "column peak %.2e (peak %.3e m); largest in-plane |u| %.1e m; %s\n",
      100 * worst, fWorst, worstCol / peakCol, peakCol, inPlane, run.stages->reports().back().note.c_str());
  EXPECT_LT(worst, 0.02);
  EXPECT_LT(worstCol / peakCol, 0.01);
  EXPECT_LT(inPlane, 1e-6 * peakCol);  // an SH wave along y moves nothing in the x-z plane
}

// Periodic faces must face each other with the same node layout: a slice's y faces pair; an x
// face with a y face is refused naming both.
TEST(LayeredSlice, PeriodicFacesThatDoNotFaceEachOtherAreRefused) {
  const Mesh m = makeBoxMesh({3, 1, 4, 0, 0, 0, 3, 1, 4});
  EXPECT_EQ(TiedNodeGroups::periodicPairs(m, "ymin", "ymax").size(), size_t(4 * 5));
  for (const auto& p : TiedNodeGroups::periodicPairs(m, "ymin", "ymax")) {
    EXPECT_DOUBLE_EQ(m.coords[3 * size_t(p[0])], m.coords[3 * size_t(p[1])]);
    EXPECT_DOUBLE_EQ(m.coords[3 * size_t(p[0]) + 2], m.coords[3 * size_t(p[1]) + 2]);
  }
  test::expectInputError([&] { TiedNodeGroups::periodicPairs(m, "xmin", "ymax"); },
                         "expected an x face and a y face to be refused", {"'xmin' and 'ymax'", "not opposite"});
}

// A block of two layers (lower 'rock' ρ 2600, upper 'weathered' ρ 2000, interface 20 m below the
// surface at z = 40 m) under gravity: every element's σ_z is the layered overburden
// −g (ρ_w (z_top − max(z, z_i)) + ρ_r max(z_i − z, 0)) to round-off, and the in-situ stage
// starts in equilibrium.
TEST(InSitu, OverburdenOfHorizontalLayersIsTheIntegralOfTheirDensities) {
  tqtest::StagedRun run;
  const BoxSpec box{2, 2, 30, 0, 0, 0, 20, 20, 60};
  const Real zi = 40, rhoR = 2600, rhoW = 2000, g = 9.81;
  run.mesh = tqtest::twoLayerBox(box, zi, "rock", "weathered");
  run.in.materials = {{"rock", elasticValues({20e9, 0.25, rhoR})}, {"weathered", elasticValues({2e9, 0.3, rhoW})}};
  run.in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  StagedInput& S = test::inSituUnderGravity(run.in, {"in_situ"}, g, 1.1, 0.8);
  S.stages.tolerance = 1e-8;
  run.build();
  std::ostringstream log;
  run.stages->runStatics(log);
  Real worst = 0;
  for (const auto& b : run.solver->blocks())
    for (Index e = 0; e < b->numElems(); ++e) {
      Real zc = 0;
      for (int k = 0; k < 8; ++k) zc += 0.125 * run.mesh.coords[3 * size_t(b->node(e, k)) + 2];
      const Real hand = -g * (rhoW * (60 - std::max(zc, zi)) + rhoR * std::max(zi - zc, 0.0));
      worst = std::max(worst, std::abs(b->stress(e, ZZ) / hand - 1));
      EXPECT_NEAR(b->stress(e, XX), 1.1 * b->stress(e, ZZ), 1e-9 * std::abs(hand));
    }
  Real umax = 0;
  for (Index n = 0; n < run.mesh.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) umax = std::max(umax, std::abs(run.solver->state().u(n, d)));
  std::printf("layered overburden: worst relative error of sigma_z %.1e, largest displacement %.1e m\n", worst, umax);
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(umax, 1e-9);
}

// Regions side by side with different densities have no single overburden: refused, naming both.
TEST(InSitu, RegionsBesideEachOtherWithDifferentDensitiesAreRefused) {
  tqtest::StagedRun run;
  run.mesh = makeBoxMesh({2, 2, 4, 0, 0, 0, 20, 20, 40});
  run.mesh.regionNames = {"rock", "dyke"};
  for (Index e = 0; e < run.mesh.numElems(); ++e) {
    Real xc = 0;
    for (int k = 0; k < 8; ++k) xc += 0.125 * run.mesh.coords[3 * size_t(run.mesh.connectivity[8 * size_t(e) + k])];
    run.mesh.region[size_t(e)] = xc < 10 ? 0 : 1;
  }
  run.in.materials = {{"rock", elasticValues({20e9, 0.25, 2600})}, {"dyke", elasticValues({20e9, 0.25, 2900})}};
  run.in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  test::inSituUnderGravity(run.in, {"in_situ"}, 9.81);
  run.build();
  std::ostringstream log;
  test::expectInputError([&] { run.stages->runStatics(log); }, "expected the overburden to be refused",
                         {"'rock'", "'dyke'", "/in_situ density"});
}
