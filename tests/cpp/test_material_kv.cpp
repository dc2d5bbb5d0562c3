// Kelvin–Voigt rock (tq/materials/material_kv.hpp): σ = C:ε + τ C:ε̇.
//
//  - One element's update against σ = C:Δε (1 + τ/Δt), then the viscous part gone when the
//    strain stops (exact, round-off).
//  - The stable step: Δt_crit = (2/ω)(√(1+ξ²) − ξ), ξ = τω/2, ω = 2 c_p / h (Belytschko et al.,
//    Nonlinear FE, §6.3, the stiffness-proportional bound with β = τ), and a run at the elastic
//    step that ignores τ explodes while one at 0.9 × the viscous bound does not.
//  - The closed-form attenuation: a harmonic P wave in a 1D column of hex8 (uniaxial strain,
//    constrained modulus M) has the complex wavenumber k = ω / √((M + iωη)/ρ), η = τ M; its
//    amplitude falls by exp(−|Im k| Δz) and its phase advances by Re k Δz between two depths.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <complex>

#include "io/input_schema.hpp"
#include "test_helpers.hpp"
#include "tq/materials/material_kv.hpp"
#include "tq/materials/registry.hpp"

using namespace tq;

namespace {

// cp = 1000 m/s: ρ = 2000 kg/m³, ν = 0.25, M = λ + 2μ = 1.2 E = 2 GPa.
constexpr Real kRho = 2000, kNu = 0.25, kM = 2e9;
const Real kE = kM / 1.2;

KelvinVoigtParams rock(Real tau) { return {{kE, kNu, kRho}, tau}; }

std::shared_ptr<const Material> kv(Real tau) {
  MaterialValues v = elasticValues(rock(tau).elastic);
  v.model = KelvinVoigtMaterial::kName;
  v.numbers[input_schema::key::materials::retardation_time.name] = tau;
  return makeMaterial(v);  // through the registry, as tq-solid builds it
}

// A column of n cubes of side h along z, every node held in x and y (uniaxial strain).
std::unique_ptr<Solver> column(const Mesh& m, std::shared_ptr<const Material> mat, SolverOptions opt) {
  auto s = std::make_unique<Solver>(m, makeBlocksByRegion(m, {{"rock", std::move(mat)}}), opt);
  for (Index n = 0; n < m.numNodes(); ++n) s->fix(n, 0), s->fix(n, 1);
  return s;
}

std::vector<Index> nodesAt(const Mesh& m, Real z) {
  std::vector<Index> out;
  for (Index n = 0; n < m.numNodes(); ++n)
    if (std::abs(m.coords[3 * size_t(n) + 2] - z) < 1e-9) out.push_back(n);
  return out;
}

}  // namespace

TEST(KelvinVoigtMaterial, StressIsElasticPlusRetardationTimeTimesElasticRate) {
  const Real tau = 2e-3, dt = 1e-4;
  const KelvinVoigtMaterial mat(rock(tau));
  const ElasticModuli c = mat.elasticModuli();
  Real de[6] = {1e-6, -2e-6, 0.5e-6, 3e-6, -1e-6, 2e-6}, s[6] = {1e5, 0, 0, 0, 0, 0}, h[kv_history::kCount] = {};
  MaterialChunk ch;
  ch.count = 1;
  ch.dt = dt;
  Real* hist[kv_history::kCount];
  for (int k = 0; k < kv_history::kCount; ++k) hist[k] = &h[k];
  ch.history = hist;
  for (int k = 0; k < 6; ++k) ch.dstrain[k] = &de[k], ch.stress[k] = &s[k];
  mat.updateStressForElems(ch);
  const Real tr = de[0] + de[1] + de[2];
  Real elastic[6];
  for (int k = 0; k < 6; ++k) elastic[k] = k < 3 ? c.lambda * tr + 2 * c.mu * de[k] : c.mu * de[k];
  Real work = 0;
  for (int k = 0; k < 6; ++k) {
    const Real expected = (k == 0 ? 1e5 : 0.0) + elastic[k] * (1 + tau / dt);
    EXPECT_NEAR(s[k], expected, 1e-12 * std::abs(expected) + 1e-9) << "component " << k;
    work += tau / dt * elastic[k] * de[k];
  }
  EXPECT_NEAR(h[kv_history::kDissipation], work, 1e-12 * work);
  // The strain stops: the viscous stress goes, the elastic one stays.
  for (auto& x : de) x = 0;
  mat.updateStressForElems(ch);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(s[k], (k == 0 ? 1e5 : 0.0) + elastic[k], 1e-9) << "component " << k;
  // τ = 0 is the elastic law; τ < 0 is refused naming the key.
  EXPECT_NO_THROW(KelvinVoigtMaterial{rock(0)});
  try {
    KelvinVoigtMaterial bad(rock(-1e-3));
    FAIL() << "negative retardation time accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("retardation_time"), std::string::npos) << e.what();
  }
}

// The viscous bound: with τ ω/2 = 1.27 the critical step is 0.35 of the elastic 2/ω.
TEST(KelvinVoigtMaterial, StableStepAccountsForTheViscosity) {
  const Real h = 2.5, tau = 0.2 / (2 * M_PI * 10);  // ωτ = 0.2 at 10 Hz
  const Mesh m = makeBoxMesh({1, 1, 20, 0, 0, 0, h, h, 20 * h});
  SolverOptions opt;
  auto s = column(m, kv(tau), opt);
  const Real w = 2 * std::sqrt(kM / kRho) / h, xi = 0.5 * tau * w;
  const StableStep st = s->stableStep();
  EXPECT_NEAR(st.dtCritical, (2 / w) * (std::sqrt(1 + xi * xi) - xi), 1e-12 * st.dtCritical);
  EXPECT_NEAR(st.xiMax, xi, 1e-12 * xi);
  EXPECT_LT(st.dtCritical, 0.36 * 2 / w);
  try {
    s->setTimeStep(0.9 * 2 / w);
    FAIL() << "a step above the viscous bound was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("retardation time"), std::string::npos) << e.what();
  }
  // The bound is real: a kick of the top runs 400 steps at 0.9 × it, and explodes at the
  // elastic 0.9 × 2/ω that ignores τ.
  auto kick = [&](Real dt) {
    SolverOptions o;
    o.dt = dt;
    o.allowUnstableStep = true;
    o.velocityLimit = 10;
    auto r = column(m, kv(tau), o);
    for (Index n : nodesAt(m, 20 * h)) r->state().v(n, 2) = 1e-3;
    for (Index n : nodesAt(m, 19 * h)) r->state().v(n, 2) = -1e-3;
    for (int i = 0; i < 400; ++i) r->step();
  };
  EXPECT_NO_THROW(kick(0.9 * st.dtCritical));
  EXPECT_THROW(kick(0.9 * 2 / w), InstabilityError);
  // Subcycling steps elements at their own elastic step: refused with a viscous material.
  try {
    s->checkSubcycling(3);
    FAIL() << "subcycling accepted with a viscous material";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("retardation time"), std::string::npos) << e.what();
  }
  EXPECT_THROW(s->enableSubcycling(3), InputError);
}

// A harmonic P wave at f = 10 Hz driven at the base of a 600 m column (hex8 of side h): the
// amplitude ratio and the phase lag between z = 50 m and z = 150 m (one wavelength), fitted over 5
// periods after the ramp has passed and before the top's reflection returns, and the closed form.
struct PlaneWave {
  Real ratio = 0, expectedRatio = 0, lag = 0, expectedLag = 0;
  EnergyBalance energy;
  Real ratioError() const { return ratio / expectedRatio - 1; }
  Real lagError() const { return lag / expectedLag - 1; }
};

PlaneWave planeWave(Real h, Real omegaTau) {
  const Real f = 10, omega = 2 * M_PI * f, tau = omegaTau / omega;  // ξ(ω) = ωτ/2
  const Real H = 600, z1 = 50, z2 = 150;
  const Mesh m = makeBoxMesh({1, 1, Index(std::lround(H / h)), 0, 0, 0, h, h, H});
  SolverOptions opt;
  auto s = column(m, kv(tau), opt);
  // Base force F(t) = r(t) sin ωt, r a half-cosine ramp over two periods.
  const Real tRamp = 2 / f, tEnd = 1.0;
  TimeFunction F;
  for (Real t = 0; t <= tEnd + 1e-3; t += 1e-4) {
    F.t.push_back(t);
    F.value.push_back((t < tRamp ? 0.5 * (1 - std::cos(M_PI * t / tRamp)) : 1.0) * std::sin(omega * t));
  }
  const auto base = nodesAt(m, 0);
  s->addLoad({base, 2, 1e6 / Real(base.size()), F});
  const Index n1 = nodesAt(m, z1)[0], n2 = nodesAt(m, z2)[0];
  // Least squares of v(t) ≈ a cos ωt + b sin ωt + c over [0.5, 1.0] s (5 periods).
  Real A[2][3][3] = {}, B[2][3] = {};
  while (s->time() < tEnd) {
    s->step();
    const Real t = s->time();
    if (t < 0.5) continue;
    const Real basis[3] = {std::cos(omega * t), std::sin(omega * t), 1};
    const Real v[2] = {s->state().v(n1, 2), s->state().v(n2, 2)};
    for (int p = 0; p < 2; ++p)
      for (int i = 0; i < 3; ++i) {
        B[p][i] += basis[i] * v[p];
        for (int j = 0; j < 3; ++j) A[p][i][j] += basis[i] * basis[j];
      }
  }
  std::complex<Real> phasor[2];
  for (int p = 0; p < 2; ++p) {
    Eigen::Matrix3d a;
    Eigen::Vector3d b;
    for (int i = 0; i < 3; ++i) {
      b(i) = B[p][i];
      for (int j = 0; j < 3; ++j) a(i, j) = A[p][i][j];
    }
    const Eigen::Vector3d x = a.ldlt().solve(b);
    phasor[p] = {x(0), -x(1)};  // v = Re(P e^{iωt}), P = a − i b
  }
  PlaneWave r;
  const std::complex<Real> k = omega / std::sqrt(std::complex<Real>(kM, omega * tau * kM) / kRho);
  r.ratio = std::abs(phasor[1]) / std::abs(phasor[0]);
  r.expectedRatio = std::exp(-std::abs(k.imag()) * (z2 - z1));
  // The phase z2 lags z1 by: arg(P1/P2) in (−π, π] plus the whole periods of Re k Δz.
  r.expectedLag = k.real() * (z2 - z1);
  r.lag = std::arg(phasor[0] / phasor[1]);
  r.lag += 2 * M_PI * std::round((r.expectedLag - r.lag) / (2 * M_PI));
  r.energy = s->energy();
  std::printf(
      "Kelvin-Voigt column, h %.3g m, omega tau %.2g: amplitude ratio %.5f, closed form %.5f (%+.3f %%); "
      "phase lag %.5f rad, closed form %.5f rad (%+.3f %%); %ld steps of %.3g s; dissipated %.4g of %.4g J, "
      "balance %.2g\n",
      h, omegaTau, r.ratio, r.expectedRatio, 100 * r.ratioError(), r.lag, r.expectedLag, 100 * r.lagError(),
      long(s->stepCount()), s->dt(), r.energy.plastic, r.energy.internal, r.energy.error);
  return r;
}

// ξ(10 Hz) = 0.1 and 0.25. Tolerance 1 % on the ratio and on the phase at 40 elements per
// wavelength (h = 2.5 m); the mesh's error falls as h² (20 per wavelength: 0.93 %, 40: 0.28 %,
// 80: 0.074 % on the ratio at ξ = 0.1), asserted as an order above 1.5 from h = 5 to 2.5 m.
TEST(KelvinVoigtMaterial, PlaneWaveAttenuatesAsTheClosedFormSays) {
  for (const Real omegaTau : {0.2, 0.5}) {
    const PlaneWave coarse = planeWave(5.0, omegaTau), fine = planeWave(2.5, omegaTau);
    EXPECT_NEAR(fine.ratioError(), 0.0, 0.01) << "ωτ " << omegaTau;
    EXPECT_NEAR(fine.lagError(), 0.0, 0.01) << "ωτ " << omegaTau;
    EXPECT_GT(std::log2(std::abs(coarse.ratioError() / fine.ratioError())), 1.5) << "ωτ " << omegaTau;
    EXPECT_LT(fine.ratio, 0.6);  // not the elastic answer (1)
    // the viscous work is booked as the material's dissipation; the balance closes
    EXPECT_GT(fine.energy.plastic, 0.5 * fine.energy.internal);
    EXPECT_LT(fine.energy.error, 1e-6);
  }
}
