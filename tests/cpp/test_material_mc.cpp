// Mohr–Coulomb elastoplastic damage material (paper eqs. 16–18), material point without a mesh.
// References (VERIFICATION.md "Solid: material and interface"):
//  - strength: σ1 = σ3 Nφ − 2c√Nφ (σ1 most compressive, compression negative), tension cut-off
//    σ3 = σt, capped by the apex c cot φ; uniaxial tension of a material whose cut-off lies beyond
//    the apex fails on the Mohr–Coulomb line at 2c/√Nφ.
//  - return mapping: Kuhn–Tucker conditions (σ^tr − σ = Σ Δλ_j C:b_j, Δλ_j ≥ 0 on the active
//    planes only, σ on or inside every plane); with associated flow the return is the closest
//    point of the elastic domain in the energy norm (Simo & Hughes 1998, §3.4). Checked on random
//    trials against an independent brute-force construction.
// Tolerances: the (peak on the line 0.5 %, on the surface 1e-8 relative); the closed-form
// return is exact to round-off, so most checks are far tighter.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>

#include "materials/eigen_sym3.hpp"
#include "mc_helpers.hpp"

using namespace tq;
using namespace tqtest;

namespace {

// ---- independent description of the planes in sorted principal space (test-side) ----------
struct TestPlane {
  Real a[3], b[3], k;
};
std::vector<TestPlane> planes(const MohrCoulombSurface& s) {
  const Real N = s.nPhi, Q = s.nPsi, k = s.cohesionTerm, t = s.tension;
  return {{{-1, 0, N}, {-1, 0, Q}, k}, {{-1, N, 0}, {-1, Q, 0}, k}, {{0, -1, N}, {0, -1, Q}, k},
          {{0, 0, 1}, {0, 0, 1}, t},   {{0, 1, 0}, {0, 1, 0}, t},   {{1, 0, 0}, {1, 0, 0}, t}};
}

Real value(const TestPlane& p, const Real s[3]) { return p.a[0] * s[0] + p.a[1] * s[1] + p.a[2] * s[2] - p.k; }

// Is r = Σ_j x_j D b_j with x_j ≥ 0 over some subset (≤ 3) of the given planes? Brute force with
// least squares on every subset.
bool inCone(const std::vector<TestPlane>& act, const MohrCoulombSurface& s, const Real r[3], Real tol) {
  const int n = int(act.size());
  auto Db = [&](int j, Eigen::Vector3d& v) {
    const Real tr = act[j].b[0] + act[j].b[1] + act[j].b[2];
    for (int i = 0; i < 3; ++i) v(i) = s.lambda * tr + 2 * s.mu * act[j].b[i];
  };
  const Eigen::Vector3d rv(r[0], r[1], r[2]);
  if (rv.norm() <= tol) return true;
  for (int mask = 1; mask < (1 << n); ++mask) {
    std::vector<int> idx;
    for (int j = 0; j < n; ++j)
      if (mask & (1 << j)) idx.push_back(j);
    if (idx.size() > 3) continue;
    Eigen::MatrixXd A(3, idx.size());
    for (size_t c = 0; c < idx.size(); ++c) {
      Eigen::Vector3d v;
      Db(idx[c], v);
      A.col(Eigen::Index(c)) = v;
    }
    const Eigen::VectorXd x = A.colPivHouseholderQr().solve(rv);
    if ((A * x - rv).norm() > tol) continue;
    if (x.minCoeff() >= -1e-9 * x.cwiseAbs().maxCoeff()) return true;
  }
  return false;
}

void sortedRandom(std::mt19937& rng, Real scale, Real out[3]) {
  std::uniform_real_distribution<Real> U(-1, 1);
  for (int i = 0; i < 3; ++i) out[i] = scale * (U(rng) - 0.6);  // mostly compression
  std::sort(out, out + 3);
}

}  // namespace

TEST(MohrCoulombReturn, RandomTrialsLandOnTheSurfaceAndSatisfyKuhnTucker) {
  std::mt19937 rng(42);
  int returned = 0, corners = 0;
  for (auto base : {paperRock(), paperLining()})
    for (Real psi : {0.0, 10.0, base.frictionAngle})
      for (Real D : {0.0, 0.5, 0.97}) {
        base.dilationAngle = psi;
        MohrCoulombDamageMaterial mat(base);
        const MohrCoulombSurface s = mat.surface(D);
        const auto P = planes(s);
        for (int n = 0; n < 4000; ++n) {
          Real t[3];
          sortedRandom(rng, n % 2 ? 4e6 : 30e6, t);
          if (n % 7 == 0) t[1] = t[2];  // exactly repeated principal stresses
          if (n % 11 == 0) t[0] = t[1];
          const PrincipalReturn r = s.returnMap(t);
          const Real scale = std::abs(t[0]) + std::abs(t[2]) + s.cohesionTerm + s.tension;
          if (r.activeSet < 0) {
            EXPECT_LE(std::max(s.shear(t), s.tensile(t)), 0.0);
            continue;
          }
          ++returned;
          const Real f = std::max(s.shear(r.sigma), s.tensile(r.sigma));
          ASSERT_NEAR(f / scale, 0.0, 1e-12) << "psi " << psi << " D " << D;  // on the surface
          ASSERT_LE(r.sigma[0], r.sigma[1] + 1e-12 * scale);
          ASSERT_LE(r.sigma[1], r.sigma[2] + 1e-12 * scale);
          std::vector<TestPlane> act;
          for (const auto& p : P) {
            ASSERT_LE(value(p, r.sigma), 1e-11 * scale);
            if (value(p, r.sigma) > -1e-9 * scale) act.push_back(p);
          }
          if (act.size() >= 3) ++corners;
          const Real res[3] = {t[0] - r.sigma[0], t[1] - r.sigma[1], t[2] - r.sigma[2]};
          ASSERT_TRUE(inCone(act, s, res, 1e-9 * std::sqrt(res[0] * res[0] + res[1] * res[1] + res[2] * res[2])))
              << "return direction not in the cone of the active planes: trial " << t[0] << " " << t[1] << " " << t[2]
              << " -> " << r.sigma[0] << " " << r.sigma[1] << " " << r.sigma[2] << " (set " << r.activeSet << ", psi "
              << psi << ", D " << D << ")";
        }
      }
  EXPECT_GT(returned, 30000);
  EXPECT_GT(corners, 1000);  // edges, corners and apexes were exercised
}

// The material builds its return tables (the planes' return directions and each active set's
// elimination) once, from its undamaged surface, and returns every damaged surface with them: damage
// changes a return's strengths (cohesion term, cut-off) but not its elastic constants or flow
// factors under the `cohesion` effect, and the `cohesion_and_stiffness` effect returns on the
// undamaged surface. So the tables of a damaged surface must equal those of the undamaged one, and a
// return with the undamaged surface's tables must give the bits of one that builds its own.
TEST(MohrCoulombReturn, TablesOfTheUndamagedSurfaceGiveADamagedSurfacesReturnBitForBit) {
  auto sameTables = [](const MohrCoulombReturnTables& x, const MohrCoulombReturnTables& y) {
    bool same = x.youngs == y.youngs && x.poisson == y.poisson;
    for (int j = 0; j < MohrCoulombReturnTables::kPlanes; ++j)
      for (int i = 0; i < 3; ++i) same = same && x.a[j][i] == y.a[j][i] && x.Db[j][i] == y.Db[j][i];
    for (int s = 0; s < MohrCoulombReturnTables::kSets; ++s) {
      const auto &p = x.sets[s], &q = y.sets[s];
      same = same && p.solvable == q.solvable;
      for (int i = 0; i < 3; ++i) {
        same = same && p.pivot[i] == q.pivot[i];
        for (int j = 0; j < 3; ++j)
          same = same && p.factor[i][j] == q.factor[i][j] && p.reduced[i][j] == q.reduced[i][j];
      }
    }
    return same;
  };
  std::mt19937 rng(11);
  int returned = 0;
  // A weak, soft rock unlike the paper's besides its two materials
  for (auto base : {paperRock(), paperLining(), mohrCoulomb({2e9, 0.33, 2200}, 0.2e6, 25, 0.1e6, 300)})
    for (Real psi : {0.0, 12.0}) {
      base.dilationAngle = psi;
      const MohrCoulombDamageMaterial mat(base);
      const MohrCoulombReturnTables undamaged = mat.surface(0).returnTables();
      for (Real D : {0.25, 0.9}) {
        const MohrCoulombSurface s = mat.surface(D);
        ASSERT_TRUE(sameTables(s.returnTables(), undamaged)) << "psi " << psi << " D " << D;
        for (int n = 0; n < 2000; ++n) {
          Real t[3];
          sortedRandom(rng, n % 2 ? 3e6 : 25e6, t);
          if (n % 5 == 0) t[1] = t[2];
          const PrincipalReturn own = s.returnMap(t), shared = s.returnMap(undamaged, t);
          returned += own.activeSet >= 0;
          ASSERT_EQ(own.activeSet, shared.activeSet);
          ASSERT_EQ(0, std::memcmp(own.sigma, shared.sigma, sizeof own.sigma));
          ASSERT_EQ(0, std::memcmp(own.plastic, shared.plastic, sizeof own.plastic));
        }
      }
    }
  EXPECT_GT(returned, 6000);
}

TEST(MohrCoulombReturn, AssociatedReturnIsTheClosestPointInTheEnergyNorm) {
  auto p = paperLining();
  p.dilationAngle = p.frictionAngle;
  MohrCoulombDamageMaterial mat(p);
  const MohrCoulombSurface s = mat.surface(0.2);
  const Real E = p.elastic.youngsModulus, nu = p.elastic.poissonRatio;
  auto dist = [&](const Real a[3], const Real b[3]) {  // Δσ · C⁻¹ Δσ (principal, isotropic)
    const Real d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    Real e = 0;
    for (int i = 0; i < 3; ++i) e += d[i] * (d[i] - nu * (d[(i + 1) % 3] + d[(i + 2) % 3])) / E;
    return e;
  };
  // Points of the boundary of the elastic domain (sorted space): the shear face and the cut-off.
  std::mt19937 rng(7);
  std::uniform_real_distribution<Real> U(0, 1);
  auto boundaryPoint = [&](Real out[3]) {
    const Real apexT = s.tension, s1min = s.nPhi * s.tension - s.cohesionTerm;
    if (U(rng) < 0.5) {  // shear face σ1 = Nφσ3 − k, σ3 ≤ σt, σ1 ≤ σ2 ≤ σ3
      out[2] = apexT - 40e6 * U(rng) * U(rng);
      out[0] = s.nPhi * out[2] - s.cohesionTerm;
      out[1] = out[0] + (out[2] - out[0]) * U(rng);
    } else {  // cut-off σ3 = σt, σ1 ≥ Nφσt − k
      out[2] = apexT;
      out[0] = s1min + (apexT - s1min) * U(rng);
      out[1] = out[0] + (apexT - out[0]) * U(rng);
    }
  };
  std::vector<std::array<Real, 3>> bnd(20000);
  for (auto& b : bnd) boundaryPoint(b.data());
  for (int n = 0; n < 400; ++n) {
    Real t[3];
    sortedRandom(rng, 20e6, t);
    const PrincipalReturn r = s.returnMap(t);
    if (r.activeSet < 0) continue;
    const Real dr = dist(t, r.sigma);
    for (const auto& b : bnd)
      ASSERT_GE(dist(t, b.data()), dr * (1 - 1e-9)) << "trial " << t[0] << " " << t[1] << " " << t[2];
  }
}

// Triaxial compression: confinement σxx = σyy = −p held, axial strain ε_zz decreased in small
// steps; the peak axial stress must lie on σ1 = σ3 Nφ − 2c√Nφ with σ3 = −p.
TEST(MohrCoulombDamage, TriaxialCompressionPeaksOnTheMohrCoulombLine) {
  for (const auto& base : {paperRock(), paperLining()})
    for (Real R : {0.0, 100.0}) {
      auto p = base;
      p.damageConstant = R;
      auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
      const Real Np = nPhi(p.frictionAngle);
      for (Real conf : {0.0, 2e6, 5e6, 10e6}) {
        MaterialPoint mp(mat);
        const bool ctrl[6] = {true, true, true, false, false, false};
        const Real hydro[6] = {-conf, -conf, -conf, 0, 0, 0}, zero[6] = {0, 0, 0, 0, 0, 0};
        mp.applyMixed(zero, ctrl, hydro);
        const bool ctrlAx[6] = {true, true, false, false, false, false};
        Real peak = 0, last = 0;
        const Real expected = -conf * Np - 2 * p.cohesion * std::sqrt(Np);
        for (int i = 0; i < 6000; ++i) {
          // Coarse steps while clearly elastic, steps of 2e-7 from 97 % of the strength on.
          const Real dz = mp.stress[ZZ] > 0.97 * expected ? -1e-5 : -2e-7;
          const Real de[6] = {0, 0, dz, 0, 0, 0};
          mp.applyMixed(de, ctrlAx, hydro);
          peak = std::min(peak, mp.stress[ZZ]);
          last = mp.stress[ZZ];
          ASSERT_NEAR(mp.stress[XX], -conf, 1e-6 * (conf + 1e6));
        }
        std::printf("triaxial %s R %.0f confinement %.0f MPa: peak %.6f MPa, Mohr-Coulomb %.6f MPa (%+.2e)\n",
                    p.elastic.youngsModulus > 1e10 ? "lining" : "rock", R, conf / 1e6, peak / 1e6, expected / 1e6,
                    peak / expected - 1);
        EXPECT_NEAR(peak / expected, 1.0, 5e-3) << "R " << R << " confinement " << conf;
        EXPECT_NEAR(peak / expected, 1.0, 2e-4);  // what it achieves with steps of 2e-7
        if (R == 0) {
          EXPECT_NEAR(last / expected, 1.0, 1e-10);  // perfect plasticity: stays on the line
          EXPECT_EQ(mp.h(mc_history::kDamage), 0.0);
        } else {
          EXPECT_GT(last, peak);  // softening: cohesion lost with damage
          EXPECT_GT(mp.h(mc_history::kDamage), 0.0);
          // The softened stress lies on the line of the damaged cohesion.
          const Real D = mp.h(mc_history::kDamage);
          const Real soft = -conf * Np - 2 * (1 - D) * p.cohesion * std::sqrt(Np);
          EXPECT_NEAR(last, soft, 1e-9 * std::abs(expected));
        }
      }
    }
}

// Uniaxial tension: the lining's cut-off (1.27 MPa) is inside its Mohr–Coulomb apex, so σ caps at
// σt; the rock's σt (1.20 MPa) lies beyond its apex c cot φ = 0.73 MPa, so it caps on the
// Mohr–Coulomb line 2c/√Nφ = 0.549 MPa.
TEST(MohrCoulombDamage, UniaxialTensionCapsAtTheTensileStrength) {
  for (int which = 0; which < 2; ++which)
    for (Real R : {0.0, 100.0}) {
      auto p = which == 0 ? paperLining(R) : paperRock(R);
      auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
      const Real Np = nPhi(p.frictionAngle);
      const Real cap = which == 0 ? p.tensileStrength : 2 * p.cohesion / std::sqrt(Np);
      MaterialPoint mp(mat);
      const bool ctrl[6] = {true, true, false, false, false, false};
      const Real zero[6] = {0, 0, 0, 0, 0, 0};
      Real peak = 0, Dpeak = 0;
      for (int i = 0; i < 3000; ++i) {
        const Real de[6] = {0, 0, 1e-7, 0, 0, 0};
        mp.applyMixed(de, ctrl, zero);
        if (mp.stress[ZZ] > peak) {
          peak = mp.stress[ZZ];
          Dpeak = mp.h(mc_history::kDamage);
        }
      }
      // The lining's cut-off does not depend on D until the apex (1 − D) c cot φ drops below σt;
      // the rock's Mohr–Coulomb cap already carries the damage of the first plastic step.
      const Real capD = which == 0 ? cap : 2 * (1 - Dpeak) * p.cohesion / std::sqrt(Np);
      std::printf(
          "uniaxial tension %s R %.0f: peak %.6f MPa, cap %.6f MPa (%+.2e; with the damage at the peak %+.2e)\n",
          which == 0 ? "lining" : "rock", R, peak / 1e6, cap / 1e6, peak / cap - 1, peak / capD - 1);
      EXPECT_NEAR(peak / capD, 1.0, 1e-8) << (which == 0 ? "lining" : "rock") << " R " << R;
      EXPECT_NEAR(peak / cap, 1.0, 1e-4);
      if (R == 0) EXPECT_NEAR(mp.stress[ZZ] / cap, 1.0, 1e-10);  // no damage: holds the cap
    }
}

// Every plastic step of a random strain path ends on the surface of the step's damage, the damage
// never decreases and stays in [0, 1], κ_i never decrease, and the dissipation never decreases
// by more than round-off. Both damage effects, R = 100 and a brittle R = 2000.
TEST(MohrCoulombDamage, CyclicLoadingDamageIsMonotoneBoundedAndStressOnSurface) {
  for (auto effect : {DamageEffect::Cohesion, DamageEffect::CohesionAndStiffness})
    for (Real R : {100.0, 2000.0}) {
      auto p = paperLining(R);
      p.damageEffect = effect;
      auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
      MaterialPoint mp(mat);
      std::mt19937 rng(3);
      std::normal_distribution<Real> G(0, 1);
      Real dir[6];
      for (auto& x : dir) x = G(rng);
      Real Dprev = 0, kprev[3] = {0, 0, 0};
      int plasticSteps = 0;
      const int steps = 6000;
      for (int i = 0; i < steps; ++i) {
        if (i % 500 == 0)
          for (auto& x : dir) x = G(rng);
        const Real amp = 2e-3 * std::cos(2 * M_PI * i / 1000.0) * (2 * M_PI / 1000.0);  // cyclic, growing path
        Real de[6];
        for (int k = 0; k < 6; ++k) de[k] = amp * dir[k] * (1 + i / 2000.0);
        const Real ep0 = mp.h(mc_history::kPlasticXX) + mp.h(mc_history::kPlasticZX) + mp.h(mc_history::kKappa1) +
                         mp.h(mc_history::kKappa3);
        mp.apply(de);
        const Real D = mp.h(mc_history::kDamage);
        ASSERT_GE(D, Dprev);
        ASSERT_LE(D, 1.0);
        for (int k = 0; k < 3; ++k) {
          ASSERT_GE(mp.h(mc_history::kKappa1 + k), kprev[k]);
          kprev[k] = mp.h(mc_history::kKappa1 + k);
        }
        Dprev = D;
        const Real ep1 = mp.h(mc_history::kPlasticXX) + mp.h(mc_history::kPlasticZX) + mp.h(mc_history::kKappa1) +
                         mp.h(mc_history::kKappa3);
        if (ep1 != ep0 && D < 1) {  // a plastic step: on the surface of damage D
          ++plasticSteps;
          Real pr[3];
          principal(mp.stress, pr);
          const MohrCoulombSurface s = mat->surface(D);
          const Real scale = std::abs(pr[0]) + std::abs(pr[2]) + p.cohesion;
          ASSERT_NEAR(std::max(s.shear(pr), s.tensile(pr)) / scale, 0.0, 1e-8) << "step " << i;
        }
      }
      EXPECT_GT(plasticSteps, 150);
      EXPECT_GT(Dprev, 0.5);  // the path damages the material substantially
      EXPECT_GT(mp.h(mc_history::kDissipation), 0.0);
      if (R == 2000.0) EXPECT_EQ(Dprev, 1.0);  // and a brittle one completely
    }
}

// With the damage constant 0 the model is perfectly plastic: a long shear path at constant
// confinement holds the same stress, D stays 0, and every plastic step dissipates τ_y Δγ^p.
TEST(MohrCoulombDamage, DamageOffIsPerfectPlasticity) {
  auto p = paperRock(0);
  auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
  MaterialPoint mp(mat);
  // Pure shear: τ_y = c cos φ where Nφ τ + τ = 2c√Nφ (the tension cut-off is not reached).
  const Real tauY = p.cohesion * std::cos(p.frictionAngle * M_PI / 180);
  const auto m = mat->elasticModuli();
  for (int i = 0; i < 400; ++i) {
    const Real de[6] = {0, 0, 0, 0, 0, 1e-6};
    mp.apply(de);
  }
  EXPECT_NEAR(mp.stress[ZX] / tauY, 1.0, 1e-12);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(mp.stress[k] / tauY, 0.0, 1e-12);
  EXPECT_EQ(mp.h(mc_history::kDamage), 0.0);
  const Real gp = 400e-6 - tauY / m.mu;  // plastic engineering shear strain
  EXPECT_NEAR(mp.h(mc_history::kPlasticZX) / gp, 1.0, 1e-9);
  // Dissipation τ_y γ^p (the trapezoid rule is exact on the plateau; one partial step at yield).
  EXPECT_NEAR(mp.h(mc_history::kDissipation) / (tauY * gp), 1.0, 1e-3);
}

// Effective-stress damage: unloading stiffness is (1 − D) times the elastic one; with damage
// reducing the cohesion only, the unloading stiffness stays elastic.
TEST(MohrCoulombDamage, StiffnessEffectScalesTheUnloadingModulus) {
  for (auto effect : {DamageEffect::Cohesion, DamageEffect::CohesionAndStiffness}) {
    auto p = paperLining(500);
    p.damageEffect = effect;
    auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
    MaterialPoint mp(mat);
    for (int i = 0; i < 2000; ++i) {
      const Real de[6] = {0, 0, 0, 0, 0, 1e-6};
      mp.apply(de);
    }
    const Real D = mp.h(mc_history::kDamage);
    ASSERT_GT(D, 0.1);
    const Real s0 = mp.stress[ZX];
    const Real de[6] = {0, 0, 0, 0, 0, -1e-7};  // unload
    mp.apply(de);
    const Real slope = (mp.stress[ZX] - s0) / -1e-7;
    const Real G = mat->elasticModuli().mu;
    EXPECT_NEAR(slope / G, effect == DamageEffect::Cohesion ? 1.0 : 1 - D, 1e-9) << damageEffectName(effect);
  }
}

// The chunk update decides most elements elastic by a cheap screen (an inscribed cone, then the
// closed-form principal range with a margin of 1e-6 of the stress scale) before the exact
// decomposition. At the surface's edge a screen that errs shows: stress states 1e-5 (relative)
// inside the surface must come back unchanged, 1e-5 outside must return onto it. Lode angles
// include the triaxial edges (two principal stresses equal, where a closed-form eigenvalue loses
// half its digits), tension and shear parts of the surface, damaged and undamaged, both damage
// effects; the inside/outside reference is Eigen's eigen-solver (mc_helpers.hpp).
TEST(MohrCoulombDamage, ChunkScreenKeepsStatesJustInsideAndReturnsStatesJustOutside) {
  for (auto effect : {DamageEffect::Cohesion, DamageEffect::CohesionAndStiffness})
    for (const auto& params : {paperRock(), paperLining()})
      for (Real D : {0.0, 0.3}) {
        auto p = params;
        p.damageEffect = effect;
        auto mat = std::make_shared<MohrCoulombDamageMaterial>(p);
        // surface(D) is the surface of the nominal stress for both effects (its cohesion and, for
        // cohesion_and_stiffness, its tensile strength scaled by 1 − D).
        const MohrCoulombSurface surf = mat->surface(D);
        auto f = [&](const Real s[6]) {  // largest plane value of the nominal stress s
          Real pr[3];
          principal(s, pr);
          return std::max(surf.shear(pr), surf.tensile(pr));
        };
        std::mt19937 rng(11);
        std::normal_distribution<Real> G(0, 1);
        constexpr int kN = 64;  // one chunk, half just inside, half just outside
        std::vector<std::array<Real, 6>> in(kN);
        for (int e = 0; e < kN; ++e) {
          // Principal values p0 + r (cos of three Lode angles), every 4th on a triaxial edge.
          const Real lode = e % 4 == 0   ? 0.0
                            : e % 4 == 1 ? M_PI / 3
                                         : std::uniform_real_distribution<Real>(0, M_PI / 3)(rng);
          const Real p0 = (e % 8 < 4 ? -3e6 : 0.2e6) * std::abs(1 + 0.3 * G(rng));
          Real dev[3] = {std::cos(lode), std::cos(lode - 2 * M_PI / 3), std::cos(lode + 2 * M_PI / 3)};
          Eigen::Matrix3d R = Eigen::Quaterniond(G(rng), G(rng), G(rng), G(rng)).normalized().toRotationMatrix();
          auto stressAt = [&](Real r, Real s[6]) {
            Eigen::Matrix3d m =
                R * Eigen::Vector3d(p0 + r * dev[0], p0 + r * dev[1], p0 + r * dev[2]).asDiagonal() * R.transpose();
            s[XX] = m(0, 0), s[YY] = m(1, 1), s[ZZ] = m(2, 2), s[XY] = m(0, 1), s[YZ] = m(1, 2), s[ZX] = m(2, 0);
          };
          Real lo = 0, hi = 1e8, s[6];  // the deviator's size on the surface, by bisection
          stressAt(lo, s);
          if (f(s) >= 0) {  // the mean stress alone is beyond the tension apex: shift it back
            e--;
            continue;
          }
          for (int it = 0; it < 200; ++it) {
            const Real mid = 0.5 * (lo + hi);
            stressAt(mid, s);
            (f(s) < 0 ? lo : hi) = mid;
          }
          // Distances from the surface across the screen's tiers (the principal-range bounds, the
          // closed-form range, the eigen-decomposition within their margins).
          const Real dist = e / 2 % 3 == 0 ? 1e-4 : e / 2 % 3 == 1 ? 1e-5 : 1e-7;
          const Real rs = 0.5 * (lo + hi), shift = (e % 2 == 0 ? -dist : dist) * (std::abs(p0) + rs);
          stressAt(rs + shift, s);
          std::copy(s, s + 6, in[size_t(e)].begin());
        }
        // The chunk: every element at its state with no strain increment (trial = state).
        std::vector<Real> de(6 * kN, 0.0), st(6 * kN);
        std::vector<std::vector<Real>> hist(mat->historyNames().size(), std::vector<Real>(kN, 0.0));
        for (auto& x : hist[mc_history::kDamage]) x = D;
        std::vector<Real*> hp;
        for (auto& h : hist) hp.push_back(h.data());
        MaterialChunk c;
        c.count = kN;
        for (int k = 0; k < 6; ++k) {
          for (int e = 0; e < kN; ++e) st[size_t(k * kN + e)] = in[size_t(e)][size_t(k)];
          c.dstrain[k] = &de[size_t(k * kN)];
          c.stress[k] = &st[size_t(k * kN)];
        }
        c.history = hp.data();
        mat->updateStressForElems(c);
        for (int e = 0; e < kN; ++e) {
          Real out[6];
          for (int k = 0; k < 6; ++k) out[k] = st[size_t(k * kN + e)];
          const Real* s0 = in[size_t(e)].data();
          Real pr[3];
          principal(s0, pr);
          const Real scale = std::abs(pr[0]) + std::abs(pr[2]) + p.cohesion;
          const std::string what =
              damageEffectName(effect) + ", D " + std::to_string(D) + ", element " + std::to_string(e);
          if (e % 2 == 0) {  // inside: unchanged, no history
            ASSERT_LT(f(s0), 0) << what;
            // cohesion_and_stiffness decomposes the effective stress σ / (1 − D): round-off
            const bool effective = effect == DamageEffect::CohesionAndStiffness;
            for (int k = 0; k < 6; ++k)
              if (effective)
                ASSERT_NEAR(out[k], s0[k], 1e-15 * scale) << what << ", component " << k;
              else
                ASSERT_EQ(out[k], s0[k]) << what << ", component " << k;
          } else {  // outside: back onto the surface of the (possibly grown) damage
            ASSERT_GT(f(s0), 0) << what;
            const MohrCoulombSurface s1 = mat->surface(hist[mc_history::kDamage][size_t(e)]);
            Real po[3];
            principal(out, po);
            ASSERT_NEAR(std::max(s1.shear(po), s1.tensile(po)) / scale, 0.0, 1e-8) << what;
            ASSERT_GT(hist[mc_history::kKappa1][size_t(e)] + hist[mc_history::kKappa2][size_t(e)] +
                          hist[mc_history::kKappa3][size_t(e)],
                      0.0)
                << what;
          }
        }
      }
}

TEST(MohrCoulombDamage, BadParametersAreRejectedWithTheFix) {
  auto p = paperRock();
  p.dilationAngle = 45;
  try {
    MohrCoulombDamageMaterial m(p);
    FAIL() << "dilation above friction accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dilation_angle"), std::string::npos);
  }
  p = paperRock();
  p.cohesion = -1;
  EXPECT_THROW(MohrCoulombDamageMaterial{p}, InputError);
  EXPECT_THROW(parseDamageEffect("stiffness"), InputError);
}

// The return mapping's eigen-decomposition of the trial stress four elements at a time
// (eigenSym3x4, AVX2 without FMA) gives eigenSym3's bits in every lane, whatever the other lanes
// hold: lanes converging after different numbers of sweeps, a zero pivot in some lanes only,
// diagonal, zero and repeated-eigenvalue matrices, scales from 1 Pa to 1e9 Pa. Each result is an
// eigenbasis: |A v - lambda v| within 1e-13 of the matrix's size, the vectors orthonormal to 1e-14.
TEST(PrincipalStresses, FourAtOnceGiveTheOneMatrixJacobisBits) {
  if (!eigenSym3x4Available()) GTEST_SKIP() << "this CPU has no AVX2 (or TQ_SOLID_SIMD=generic)";
  std::mt19937 rng(7);
  std::uniform_real_distribution<Real> U(-1, 1), logScale(0, 9);
  std::vector<std::array<Real, 6>> mats = {
      {1, 2, 3, 0, 0, 0},          {0, 0, 0, 0, 0, 0}, {5, 5, 5, 1e-9, 0, 0},   {4, 1, 1, 0, 2, 0},
      {-3e6, -3e6, -1e6, 0, 0, 0}, {2, 2, 2, 1, 1, 1}, {1, -1, 0, 0, 0, 1e-20}, {7, 7, 3, 0, 0, 0},
  };
  for (int i = 0; i < 400; ++i) {
    const Real scale = std::pow(10.0, logScale(rng));
    std::array<Real, 6> m;
    for (Real& x : m) x = scale * U(rng);
    if (i % 5 == 0) m[XY] = 0;      // a zero first pivot
    if (i % 7 == 0) m[YY] = m[XX];  // two equal diagonal terms
    mats.push_back(m);
  }
  int compared = 0;
  for (size_t g = 0; g + 4 <= mats.size(); g += 4) {
    Real s4[6][4], ev4[4][3], V4[4][3][3];
    for (int l = 0; l < 4; ++l)
      for (int q = 0; q < 6; ++q) s4[q][l] = mats[g + size_t(l)][size_t(q)];
    eigenSym3x4(s4, ev4, V4);
    for (int l = 0; l < 4; ++l) {
      const auto& m = mats[g + size_t(l)];
      Real ev[3], V[3][3];
      eigenSym3(m.data(), ev, V);
      EXPECT_EQ(std::memcmp(ev, ev4[l], sizeof ev), 0) << "matrix " << g + size_t(l);
      EXPECT_EQ(std::memcmp(V, V4[l], sizeof V), 0) << "matrix " << g + size_t(l);
      const Real A[3][3] = {{m[XX], m[XY], m[ZX]}, {m[XY], m[YY], m[YZ]}, {m[ZX], m[YZ], m[ZZ]}};
      Real size = 0;
      for (Real x : m) size = std::max(size, std::abs(x));
      for (int i = 0; i < 3; ++i) {
        EXPECT_LE(ev[i], i < 2 ? ev[i + 1] : ev[i]);  // ascending
        for (int r = 0; r < 3; ++r) {
          const Real av = A[r][0] * V[0][i] + A[r][1] * V[1][i] + A[r][2] * V[2][i];
          EXPECT_LE(std::abs(av - ev[i] * V[r][i]), 1e-13 * std::max(size, 1e-300));
        }
        for (int j = 0; j < 3; ++j) {
          const Real d = V[0][i] * V[0][j] + V[1][i] * V[1][j] + V[2][i] * V[2][j];
          EXPECT_NEAR(d, i == j ? 1.0 : 0.0, 1e-14);
        }
      }
      ++compared;
    }
  }
  EXPECT_EQ(compared, 408);
}
