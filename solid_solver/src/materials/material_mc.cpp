// Mohr–Coulomb elastoplastic damage material (paper eqs. 16–18; docs/theory.md §3).
#include "tq/materials/material_mc.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "materials/eigen_sym3.hpp"
#include "materials/parameter_names.hpp"

namespace tq {

MohrCoulombDamageParams mohrCoulombDamageParams(const MaterialValues& v) {
  namespace M = material_parameter;
  MohrCoulombDamageParams p;
  p.elastic = elasticParams(v);
  p.cohesion = v.number(M::cohesion);
  p.frictionAngle = v.number(M::friction_angle);
  p.dilationAngle = v.number(M::dilation_angle);
  p.tensileStrength = v.number(M::tensile_strength);
  p.damageConstant = v.number(M::damage_constant);
  p.damageEffect = parseDamageEffect(v.text(M::damage_effect));
  return p;
}

MaterialValues mohrCoulombDamageValues(const MohrCoulombDamageParams& p) {
  namespace M = material_parameter;
  MaterialValues v = elasticValues(p.elastic);
  v.model = MohrCoulombDamageMaterial::kName;
  v.numbers[M::cohesion] = p.cohesion;
  v.numbers[M::friction_angle] = p.frictionAngle;
  v.numbers[M::dilation_angle] = p.dilationAngle;
  v.numbers[M::tensile_strength] = p.tensileStrength;
  v.numbers[M::damage_constant] = p.damageConstant;
  v.texts[M::damage_effect] = damageEffectName(p.damageEffect);
  return v;
}

std::shared_ptr<const Material> makeMohrCoulombDamageMaterial(const MaterialValues& v) {
  return std::make_shared<MohrCoulombDamageMaterial>(mohrCoulombDamageParams(v));
}

DamageEffect parseDamageEffect(const std::string& n) {
  if (n == "cohesion") return DamageEffect::Cohesion;
  if (n == "cohesion_and_stiffness") return DamageEffect::CohesionAndStiffness;
  throw InputError("damage_effect '" + n +
                   "' is unknown; use cohesion (default: eq. 16, damage reduces the cohesion only) or "
                   "cohesion_and_stiffness (effective-stress damage: stiffness, cohesion and tensile "
                   "strength all scaled by 1 - D)");
}

std::string damageEffectName(DamageEffect e) {
  return e == DamageEffect::Cohesion ? "cohesion" : "cohesion_and_stiffness";
}

namespace {

constexpr Real kDeg = M_PI / 180.0;

Real flowFactor(Real angleDeg) {
  const Real s = std::sin(angleDeg * kDeg);
  return (1 + s) / (1 - s);
}

// ---- the yield planes in sorted principal space (σ1 ≤ σ2 ≤ σ3, tension positive) -----------
// F_j(σ) = a_j·σ − k_j (violated when > 0), plastic potential gradient b_j; k_j is the surface's
// cohesion term on the shear planes (before T3) and its cut-off on the tension planes.
enum Plane : int { S13 = 0, S12, S23, T3, T2, T1, kPlanes };
static_assert(kPlanes == MohrCoulombReturnTables::kPlanes, "the tables hold every plane");

// The normals a_j and the elastic return directions C : b_j of a surface's planes.
void setPlanes(const MohrCoulombSurface& s, MohrCoulombReturnTables& T) {
  auto set = [&](int j, Real a0, Real a1, Real a2, Real b0, Real b1, Real b2) {
    T.a[j][0] = a0, T.a[j][1] = a1, T.a[j][2] = a2;
    const Real b[3] = {b0, b1, b2};
    const Real tr = b0 + b1 + b2;
    for (int i = 0; i < 3; ++i) T.Db[j][i] = s.lambda * tr + 2 * s.mu * b[i];
  };
  const Real Np = s.nPhi, Nq = s.nPsi;
  set(S13, -1, 0, Np, -1, 0, Nq);  // main shear plane (σ1, σ3)
  set(S12, -1, Np, 0, -1, Nq, 0);  // its partner on the edge σ2 = σ3
  set(S23, 0, -1, Np, 0, -1, Nq);  // its partner on the edge σ1 = σ2
  set(T3, 0, 0, 1, 0, 0, 1);       // tension cut-off on σ3 (associated)
  set(T2, 0, 1, 0, 0, 1, 0);       // ... on σ2 (edge σ2 = σ3 = σt)
  set(T1, 1, 0, 0, 1, 0, 0);       // ... on σ1 (apex σ1 = σ2 = σ3 = σt)
}

// Active sets tried in order; the first that satisfies the Kuhn–Tucker conditions (multipliers
// ≥ 0, the result inside all planes and still sorted) is the return. Planes meeting at one corner
// in more than three ways (σ2 = σ3 = σt with σ1 on the shear plane: S13, S12, T3, T2) are covered
// by every three-plane subset, whose cones triangulate the corner's cone of return directions.
struct ActiveSet {
  int n;
  int j[3];
};
constexpr ActiveSet kSets[] = {
    {1, {S13, 0, 0}},   {1, {T3, 0, 0}},    {2, {S13, S12, 0}},  {2, {S13, S23, 0}},
    {2, {S13, T3, 0}},  {2, {T3, T2, 0}},   {3, {S13, S23, T3}}, {3, {S13, S12, T3}},
    {3, {S12, T3, T2}}, {3, {S13, T3, T2}}, {3, {S13, S12, T2}}, {3, {T3, T2, T1}},
};
constexpr int kNumSets = int(sizeof(kSets) / sizeof(kSets[0]));

// Gaussian elimination with partial pivoting of an active set's n×n system G x = r (n ≤ 3), split
// in two: the matrix's part (it depends only on the return tables) and the right-hand side's,
// which repeats the matrix's row operations in their order.
using ReturnSet = MohrCoulombReturnTables::Set;

bool factorSmall(int n, Real G[3][3], ReturnSet& S) {
  int idx[3] = {0, 1, 2};
  Real scale = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) scale = std::max(scale, std::abs(G[i][j]));
  if (!(scale > 0)) return false;
  for (int c = 0; c < n; ++c) {
    int piv = c;
    for (int i = c + 1; i < n; ++i)
      if (std::abs(G[idx[i]][c]) > std::abs(G[idx[piv]][c])) piv = i;
    std::swap(idx[c], idx[piv]);
    S.pivot[c] = piv;
    const Real d = G[idx[c]][c];
    if (std::abs(d) <= 1e-13 * scale) return false;  // degenerate active set
    for (int i = c + 1; i < n; ++i) {
      const Real f = G[idx[i]][c] / d;
      S.factor[c][i] = f;
      for (int j = c; j < n; ++j) G[idx[i]][j] -= f * G[idx[c]][j];
    }
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) S.reduced[i][j] = G[i][j];
  return true;
}

void solveFactored(int n, const ReturnSet& S, Real r[3], Real x[3]) {
  int idx[3] = {0, 1, 2};
  for (int c = 0; c < n; ++c) {
    std::swap(idx[c], idx[S.pivot[c]]);
    for (int i = c + 1; i < n; ++i) r[idx[i]] -= S.factor[c][i] * r[idx[c]];
  }
  for (int c = n - 1; c >= 0; --c) {
    Real s = r[idx[c]];
    for (int j = c + 1; j < n; ++j) s -= S.reduced[idx[c]][j] * x[j];
    x[c] = s / S.reduced[idx[c]][c];
  }
}

// Smallest and largest principal value of a symmetric 3x3 (Voigt) in closed form: the
// deviator's invariants J2, J3 and the Lode angle, σ = p + 2√(J2/3) cos(α − 2πk/3) with
// α = ⅓ acos(J3 / (2 (J2/3)^{3/2})). Where two principal values nearly coincide, acos loses half
// the digits (relative error up to ≈ 1e-8 of the deviator's size), so a caller compares with a
// margin well above that.
void principalRange(const Real s[6], Real& smin, Real& smax, Real& size) {
  const Real p = (s[XX] + s[YY] + s[ZZ]) * (1.0 / 3);
  const Real dx = s[XX] - p, dy = s[YY] - p, dz = s[ZZ] - p;
  const Real j2 = 0.5 * (dx * dx + dy * dy + dz * dz) + s[XY] * s[XY] + s[YZ] * s[YZ] + s[ZX] * s[ZX];
  const Real r = std::sqrt(j2 * (1.0 / 3));
  size = std::abs(p) + 2 * r;
  if (!(r > 0)) {
    smin = smax = p;
    return;
  }
  const Real j3 =
      dx * (dy * dz - s[YZ] * s[YZ]) - s[XY] * (s[XY] * dz - s[YZ] * s[ZX]) + s[ZX] * (s[XY] * s[YZ] - dy * s[ZX]);
  const Real x = std::clamp(j3 / (2 * r * r * r), Real(-1), Real(1));
  const Real a = std::acos(x) * (1.0 / 3);
  smax = p + 2 * r * std::cos(a);
  smin = p + 2 * r * std::cos(a + 2 * M_PI / 3);
}

// Bounds of the largest and smallest principal value without trigonometry, for a batch of
// symmetric 3x3 (Voigt, component q of item l at t[q][l]): σ = p + 2r c with r = √(J2/3) and c a
// root of the Chebyshev cubic φ(c) = 4c³ − 3c − x, x = J3 / (2 r³) = cos 3α. The largest root lies
// in [½, 1], where φ is increasing and convex: Newton's method started above it stays above it
// (each iterate is an upper bound); the smallest lies in [−1, −½], where φ is increasing and
// concave: started below it, Newton stays below. The starts: 6δ² + 4δ³ = 1 + x for c = ½ + δ, so
// c ≤ ½ + √((1 + x)/6) (and ≤ 1); by symmetry the smallest root is at least −½ − √((1 − x)/6).
// Three steps leave c within 2e-9 of the root (from 0.06 at the start); where two roots coincide
// the computed x carries the same half-digit loss as acos's form (principalRange), so a caller
// compares with a margin. The loop vectorises (no branches, no library calls but sqrt; the file is
// compiled with -fno-trapping-math, which lets the compiler turn selects around divisions into
// blends: solid_solver/CMakeLists.txt).
constexpr Index kBoundBatch = 64;

// The block constants of the elastic trial, its inscribed-cone test and the bounds' test.
struct TrialConstants {
  Real lam, mu, stiffF, Np, slope, kc0, c0, st0, cotPhi, sqrt23;
};

// inside[l] 1 where the bounds of item l (damage D[l]) lie inside the surface by at least the
// margin 2e-6 of the stress scale (twice the closed form's: updateStressForElems), else 0.
inline __attribute__((always_inline)) void principalBounds(const TrialConstants& k, const Real (*t)[kBoundBatch],
                                                           const Real* __restrict D, Index n, Real* __restrict inside) {
  const Real Np = k.Np, stiffF = k.stiffF, kc0 = k.kc0, c0 = k.c0, st0 = k.st0, cotPhi = k.cotPhi;
  const Real* __restrict sxxP = t[XX];
  const Real* __restrict syyP = t[YY];
  const Real* __restrict szzP = t[ZZ];
  const Real* __restrict sxyP = t[XY];
  const Real* __restrict syzP = t[YZ];
  const Real* __restrict szxP = t[ZX];
#pragma omp simd
  for (Index l = 0; l < n; ++l) {
    const Real sxx = sxxP[l], syy = syyP[l], szz = szzP[l], sxy = sxyP[l], syz = syzP[l], szx = szxP[l];
    const Real p = (sxx + syy + szz) * (1.0 / 3);
    const Real dx = sxx - p, dy = syy - p, dz = szz - p;
    const Real j2 = 0.5 * (dx * dx + dy * dy + dz * dz) + sxy * sxy + syz * syz + szx * szx;
    const Real r = std::sqrt(j2 * (1.0 / 3));
    const Real j3 = dx * (dy * dz - syz * syz) - sxy * (sxy * dz - syz * szx) + szx * (sxy * syz - dy * szx);
    const Real r3 = 2 * r * r * r;
    // Every value computed unconditionally (selects, divisions by a positive stand-in where a
    // step is not taken), so the loop vectorises.
    Real x = j3 / (r3 > 0 ? r3 : 1.0);
    x = x > 1 ? 1.0 : x;
    x = x < -1 ? -1.0 : x;
    const Real up = 0.5 + std::sqrt((1 + x) * (1.0 / 6)), dn = 0.5 + std::sqrt((1 - x) * (1.0 / 6));
    Real hi = up < 1 ? up : 1.0, lo = -(dn < 1 ? dn : 1.0);
    auto newton = [&]() {
      const Real fh = (4 * hi * hi - 3) * hi - x, dh = 12 * hi * hi - 3;
      const Real fl = (4 * lo * lo - 3) * lo - x, dl = 12 * lo * lo - 3;
      hi -= (fh > 0 ? fh : 0.0) / (dh > 0 ? dh : 1.0);
      lo -= (fl < 0 ? fl : 0.0) / (dl > 0 ? dl : 1.0);
    };
    newton();
    newton();
    newton();
    const Real smax = p + 2 * r * hi, smin = p + 2 * r * lo, size = std::abs(p) + 2 * r;
    const Real kc = (1 - D[l]) * kc0, tCut = (1 - stiffF * D[l]) * st0, tApex = (1 - D[l]) * c0 * cotPhi;
    const Real tension = tCut < tApex ? tCut : tApex, absT = tension < 0 ? -tension : tension;
    const Real scale = size > kc ? (size > absT ? size : absT) : (kc > absT ? kc : absT);
    const Real margin = 2e-6 * scale;
    const bool okShear = Np * smax - smin - kc < -(Np + 1) * margin, okTension = smax - tension < -margin;
    inside[l] = (okShear && okTension) ? 1.0 : 0.0;
  }
}

// Σ_i d_i v_i v_iᵀ in Voigt form (engineering shear when `engineering`).
void spectralToVoigt(const Real d[3], const Real v[3][3], bool engineering, Real out[6]) {
  const Real g = engineering ? 2.0 : 1.0;
  for (int k = 0; k < 6; ++k) out[k] = 0;
  for (int i = 0; i < 3; ++i) {
    const Real x = v[0][i], y = v[1][i], z = v[2][i];
    out[XX] += d[i] * x * x;
    out[YY] += d[i] * y * y;
    out[ZZ] += d[i] * z * z;
    out[XY] += g * d[i] * x * y;
    out[YZ] += g * d[i] * y * z;
    out[ZX] += g * d[i] * z * x;
  }
}

}  // namespace

// ---- return mapping in principal space ------------------------------------------------------

MohrCoulombReturnTables MohrCoulombSurface::returnTables() const {
  MohrCoulombReturnTables T;
  setPlanes(*this, T);
  T.youngs = mu * (3 * lambda + 2 * mu) / (lambda + mu);
  T.poisson = lambda / (2 * (lambda + mu));
  static_assert(kNumSets == MohrCoulombReturnTables::kSets, "the tables hold every active set");
  for (int s = 0; s < kNumSets; ++s) {
    const ActiveSet& A = kSets[s];
    Real G[3][3] = {};
    for (int i = 0; i < A.n; ++i) {
      for (int j = 0; j < A.n; ++j) {
        const int pi = A.j[i], pj = A.j[j];
        G[i][j] = T.a[pi][0] * T.Db[pj][0] + T.a[pi][1] * T.Db[pj][1] + T.a[pi][2] * T.Db[pj][2];
      }
    }
    T.sets[s].solvable = factorSmall(A.n, G, T.sets[s]);
  }
  return T;
}

PrincipalReturn MohrCoulombSurface::returnMap(const Real t[3], int hint) const {
  return returnMap(returnTables(), t, hint);
}

PrincipalReturn MohrCoulombSurface::returnMap(const MohrCoulombReturnTables& T, const Real t[3], int hint) const {
  PrincipalReturn r;
  for (int i = 0; i < 3; ++i) r.sigma[i] = t[i];
  const Real fs = shear(t), ft = tensile(t);
  if (fs <= 0 && ft <= 0) return r;
  const Real scale = std::max({std::abs(t[0]), std::abs(t[1]), std::abs(t[2]), cohesionTerm, std::abs(tension),
                               std::numeric_limits<Real>::min()});
  const Real tolF = 1e-11 * scale * nPhi;  // Pa
  int best = -1;
  Real bestViolation = std::numeric_limits<Real>::infinity(), bestSig[3] = {0, 0, 0};
  for (int q = -1; q < kNumSets; ++q) {
    if (q == hint) continue;  // already tried first
    const int s = q < 0 ? hint : q;
    if (s < 0) continue;
    const ActiveSet& A = kSets[s];
    const ReturnSet& S = T.sets[s];
    if (!S.solvable) continue;
    Real rhs[3], x[3] = {0, 0, 0};
    for (int i = 0; i < A.n; ++i) {
      const int pi = A.j[i];
      const Real k = pi < T3 ? cohesionTerm : tension;
      rhs[i] = T.a[pi][0] * t[0] + T.a[pi][1] * t[1] + T.a[pi][2] * t[2] - k;
    }
    solveFactored(A.n, S, rhs, x);
    Real sig[3] = {t[0], t[1], t[2]};
    Real xmax = 0;
    for (int j = 0; j < A.n; ++j) {
      xmax = std::max(xmax, std::abs(x[j]));
      for (int i = 0; i < 3; ++i) sig[i] -= x[j] * T.Db[A.j[j]][i];
    }
    // Kuhn–Tucker: multipliers ≥ 0, inside every plane, principal order kept.
    Real violation = 0;
    for (int j = 0; j < A.n; ++j) violation = std::max(violation, -x[j] / std::max(xmax, 1e-300) * scale);
    violation = std::max(violation, shear(sig));
    violation = std::max(violation, tensile(sig));
    violation = std::max(violation, sig[0] - sig[1]);
    violation = std::max(violation, sig[1] - sig[2]);
    if (violation <= tolF) {
      best = s;
      for (int i = 0; i < 3; ++i) bestSig[i] = sig[i];
      break;
    }
    if (violation < bestViolation) {  // kept only as a fallback for round-off at region borders
      bestViolation = violation;
      best = s;
      for (int i = 0; i < 3; ++i) bestSig[i] = sig[i];
    }
  }
  if (best < 0) throw std::runtime_error("Mohr-Coulomb return: no active set solved (degenerate parameters)");
  for (int i = 0; i < 3; ++i) r.sigma[i] = bestSig[i];
  r.activeSet = best;
  // Plastic strain increment Δε^p = C⁻¹ (σ^tr − σ) in principal form (unique even where the
  // multipliers of a corner are not).
  const Real E = T.youngs, nu = T.poisson;
  const Real d[3] = {t[0] - r.sigma[0], t[1] - r.sigma[1], t[2] - r.sigma[2]};
  for (int i = 0; i < 3; ++i) r.plastic[i] = (d[i] - nu * (d[(i + 1) % 3] + d[(i + 2) % 3])) / E;
  return r;
}

// ---- the material -----------------------------------------------------------------------------

MohrCoulombDamageMaterial::MohrCoulombDamageMaterial(const MohrCoulombDamageParams& p) : params_(p) {
  auto bad = [](const std::string& what, Real v, const std::string& fix) {
    std::ostringstream os;
    os << "mohr_coulomb_damage material: " << what << " = " << v << " is invalid; " << fix;
    throw InputError(os.str());
  };
  ElasticMaterial check(p.elastic);  // E, ν, ρ checks with their messages
  if (!(p.cohesion >= 0) || !std::isfinite(p.cohesion))
    bad("cohesion", p.cohesion, "give c in Pa (>= 0), e.g. 0.55e6 for the paper's rock");
  if (!(p.frictionAngle >= 0 && p.frictionAngle < 90))
    bad("friction_angle", p.frictionAngle, "give φ in degrees in [0, 90), e.g. 37");
  if (!(p.dilationAngle >= 0 && p.dilationAngle <= p.frictionAngle))
    bad("dilation_angle", p.dilationAngle, "give ψ in degrees between 0 and the friction angle (default 0)");
  if (!(p.tensileStrength >= 0) || !std::isfinite(p.tensileStrength))
    bad("tensile_strength", p.tensileStrength, "give σt in Pa (>= 0), e.g. 1.27e6 for the paper's lining");
  if (!(p.damageConstant >= 0) || !std::isfinite(p.damageConstant))
    bad("damage_constant", p.damageConstant, "give R >= 0 (0 switches damage off; default 100)");
  moduli_ = ElasticModuli::fromYoungPoisson(p.elastic.youngsModulus, p.elastic.poissonRatio);
  nPhi_ = flowFactor(p.frictionAngle);
  nPsi_ = flowFactor(p.dilationAngle);
  sqrtNPhi_ = std::sqrt(nPhi_);
  // φ = 0 (Tresca): no apex; a large finite value keeps 0 × cot φ = 0 for c = 0.
  cotPhi_ = p.frictionAngle > 0 ? 1 / std::tan(p.frictionAngle * kDeg) : std::numeric_limits<Real>::max();
  dpSlope_ = std::sqrt(1 + nPhi_ * nPhi_ - (nPhi_ - 1) * (nPhi_ - 1) / 3);
  tables_ = surface(0).returnTables();
}

std::vector<std::string> MohrCoulombDamageMaterial::historyNames() const {
  return {"plastic_strain_xx", "plastic_strain_yy", "plastic_strain_zz", "plastic_strain_xy", "plastic_strain_yz",
          "plastic_strain_zx", "kappa_1",           "kappa_2",           "kappa_3",           "damage",
          "dissipation"};
}

MohrCoulombSurface MohrCoulombDamageMaterial::surface(Real D) const {
  MohrCoulombSurface s;
  const bool stiff = params_.damageEffect == DamageEffect::CohesionAndStiffness;
  s.lambda = moduli_.lambda;
  s.mu = moduli_.mu;
  if (stiff) {  // nominal stiffness (1 - D) C
    s.lambda *= 1 - D;
    s.mu *= 1 - D;
  }
  s.nPhi = nPhi_;
  s.nPsi = nPsi_;
  const Real c = (1 - D) * params_.cohesion;
  s.cohesionTerm = 2 * c * sqrtNPhi_;
  const Real st = stiff ? (1 - D) * params_.tensileStrength : params_.tensileStrength;
  s.tension = std::min(st, c * cotPhi_);  // the cut-off cannot lie beyond the apex c cot φ
  return s;
}

Real MohrCoulombDamageMaterial::damageFrom(const Real kappa[3]) const {
  const Real R = params_.damageConstant;
  Real sum = 0;
  for (int i = 0; i < 3; ++i) {
    const Real Di = -std::expm1(-R * kappa[i]);  // 1 - exp(-R κ_i), accurate for small R κ
    sum += Di * Di;
  }
  return std::min(Real(1), std::sqrt(sum));
}

namespace {

// Elastic trial of n ≤ kBoundBatch elements, written over their stress in place (σ^n kept in
// `old`), and the inscribed-cone test (inside[l] 1 or 0). One loop the compiler vectorises; its
// instances differ only in the vector width (no fused multiply-add: the same values).
inline __attribute__((always_inline)) void trialBody(const TrialConstants& k, Index n, const Real* __restrict Dp,
                                                     const Real* const* de, Real* const* st,
                                                     Real (*__restrict old)[kBoundBatch], Real* __restrict inside) {
  const Real lam = k.lam, mu = k.mu, stiffF = k.stiffF, Np = k.Np, slope = k.slope, kc0 = k.kc0, c0 = k.c0, st0 = k.st0,
             cotPhi = k.cotPhi, sqrt23 = k.sqrt23;
  const Real* __restrict ex = de[XX];
  const Real* __restrict ey = de[YY];
  const Real* __restrict ez = de[ZZ];
  const Real* __restrict gxy = de[XY];
  const Real* __restrict gyz = de[YZ];
  const Real* __restrict gzx = de[ZX];
  // σ^n read and the trial written in place (element by element: no dependence between lanes).
  Real* sx = st[XX];
  Real* sy = st[YY];
  Real* sz = st[ZZ];
  Real* sxyq = st[XY];
  Real* syzq = st[YZ];
  Real* szxq = st[ZX];
#pragma omp simd
  for (Index l = 0; l < n; ++l) {
    const Real D = Dp[l];
    const Real f = 1 - stiffF * D;
    const Real exx = ex[l], eyy = ey[l], ezz = ez[l];
    const Real t = exx + eyy + ezz;
    const Real o[6] = {sx[l], sy[l], sz[l], sxyq[l], syzq[l], szxq[l]};
    const Real sxx = o[XX] + f * (lam * t + 2 * mu * exx);
    const Real syy = o[YY] + f * (lam * t + 2 * mu * eyy);
    const Real szz = o[ZZ] + f * (lam * t + 2 * mu * ezz);
    const Real sxy = o[XY] + f * mu * gxy[l];
    const Real syz = o[YZ] + f * mu * gyz[l];
    const Real szx = o[ZX] + f * mu * gzx[l];
    const Real p = (sxx + syy + szz) * (1.0 / 3);
    const Real dx = sxx - p, dy = syy - p, dz = szz - p;
    const Real sn = std::sqrt(dx * dx + dy * dy + dz * dz + 2 * (sxy * sxy + syz * syz + szx * szx));
    const Real cD = (1 - D) * c0;
    const Real tCut = (1 - stiffF * D) * st0, tApex = cD * cotPhi;
    const Real tension = tCut < tApex ? tCut : tApex;
    const bool okShear = (Np - 1) * p + slope * sn <= (1 - D) * kc0;
    const bool okTension = p + sqrt23 * sn <= tension;
    inside[l] = (okShear && okTension) ? 1.0 : 0.0;
    for (int q = 0; q < 6; ++q) old[q][l] = o[q];
    sx[l] = sxx;
    sy[l] = syy;
    sz[l] = szz;
    sxyq[l] = sxy;
    syzq[l] = syz;
    szxq[l] = szx;
  }
}

void trialGeneric(const TrialConstants& k, Index n, const Real* Dp, const Real* const* de, Real* const* st,
                  Real (*old)[kBoundBatch], Real* inside) {
  trialBody(k, n, Dp, de, st, old, inside);
}
__attribute__((target("avx2"))) void trialAvx2(const TrialConstants& k, Index n, const Real* Dp, const Real* const* de,
                                               Real* const* st, Real (*old)[kBoundBatch], Real* inside) {
  trialBody(k, n, Dp, de, st, old, inside);
}
void boundsGeneric(const TrialConstants& k, const Real (*t)[kBoundBatch], const Real* D, Index n, Real* inside) {
  principalBounds(k, t, D, n, inside);
}
__attribute__((target("avx2"))) void boundsAvx2(const TrialConstants& k, const Real (*t)[kBoundBatch], const Real* D,
                                                Index n, Real* inside) {
  principalBounds(k, t, D, n, inside);
}
// 8 lanes, still without FMA: this file is compiled with -ffp-contract=off (AVX-512F brings FMA
// with it), so each lane makes the generic path's operations.
__attribute__((target("avx512f,avx512dq,avx512vl,avx2"))) void trialAvx512(const TrialConstants& k, Index n,
                                                                           const Real* Dp, const Real* const* de,
                                                                           Real* const* st, Real (*old)[kBoundBatch],
                                                                           Real* inside) {
  trialBody(k, n, Dp, de, st, old, inside);
}
__attribute__((target("avx512f,avx512dq,avx512vl,avx2"))) void boundsAvx512(const TrialConstants& k,
                                                                            const Real (*t)[kBoundBatch], const Real* D,
                                                                            Index n, Real* inside) {
  principalBounds(k, t, D, n, inside);
}

}  // namespace

void MohrCoulombDamageMaterial::updateStressForElems(const MaterialChunk& c) const {
  using namespace mc_history;
  const bool stiff = params_.damageEffect == DamageEffect::CohesionAndStiffness;
  const Real Np = nPhi_, st0 = params_.tensileStrength;
  const Real cotPhi = cotPhi_, c0 = params_.cohesion;
  const Real* __restrict dmg = c.history[kDamage];
  // 1. Elastic trial for every element, and a cheap test against an inscribed cone: the largest
  //    principal stress is at most p + √(2/3)|s| and Nφσ3 − σ1 at most (Nφ−1)p + slope |s|.
  //    Elements that pass stay elastic (the common case costs a few flops more than Hooke, in
  //    a loop the compiler vectorises); the others are decomposed and returned if outside.
  constexpr Index kBlock = kBoundBatch;
  // AVX2 without FMA: 4 lanes with the very operations of the 2-lane generic path (bit for bit);
  // TQ_SOLID_SIMD=generic asks for the generic path, as it does of the element kernel.
  static const bool kMaterialAvx2 = eigenSym3x4Available();  // once, on the first use
  // The trial and the bounds on 8 lanes where the element kernel runs its AVX-512 path (the same
  // bits as on 4).
  const bool avx512 = kMaterialAvx2 && c.lanes == 8;
  const TrialConstants tk{
      moduli_.lambda, moduli_.mu,          stiff ? 1.0 : 0.0, Np, dpSlope_, 2 * c0 * sqrtNPhi_, c0, st0,
      cotPhi,         std::sqrt(2.0 / 3.0)};
  alignas(64) Real old[6][kBlock];  // σ^n of the block (the trial replaces it in c.stress)
  alignas(64) Real inside[kBlock];
  Index suspect[kBlock];
  for (Index e0 = 0; e0 < c.count; e0 += kBlock) {
    const Index n = std::min<Index>(kBlock, c.count - e0);
    const Real* de[6];
    Real* st[6];
    for (int q = 0; q < 6; ++q) {
      de[q] = c.dstrain[q] + e0;
      st[q] = c.stress[q] + e0;
    }
    if (avx512)
      trialAvx512(tk, n, dmg + e0, de, st, old, inside);
    else if (kMaterialAvx2)
      trialAvx2(tk, n, dmg + e0, de, st, old, inside);
    else
      trialGeneric(tk, n, dmg + e0, de, st, old, inside);
    Index nSuspect = 0;
    for (Index l = 0; l < n; ++l)
      if (inside[l] == 0) suspect[nSuspect++] = l;
    // 2. The others: most are still inside (the cone is a loose bound near the surface's
    //    corners). Bounds of their principal range (principalBounds, a vectorised loop over the
    //    suspects packed together) decide most of those, with twice the margin of the next test;
    //    then the closed-form principal range, with a margin of 1e-6 of the stress scale (far
    //    above its round-off); the rest get the exact eigen-decomposition and the return mapping.
    //    The trial written above is their answer when inside. An element the bounds pass has the
    //    range's values at least the margin inside too (the bounds lie outside the exact range,
    //    the range's error is below 1e-8 of the scale), so the bounds change no decision.
    if (nSuspect == 0) continue;
    alignas(64) Real packed[6][kBoundBatch];
    alignas(64) Real pD[kBoundBatch], bounded[kBoundBatch];
    for (int q = 0; q < 6; ++q)
      for (Index k = 0; k < nSuspect; ++k) packed[q][k] = c.stress[q][e0 + suspect[k]];
    for (Index k = 0; k < nSuspect; ++k) pD[k] = dmg[e0 + suspect[k]];
    if (avx512)
      boundsAvx512(tk, packed, pD, nSuspect, bounded);
    else if (kMaterialAvx2)
      boundsAvx2(tk, packed, pD, nSuspect, bounded);
    else
      boundsGeneric(tk, packed, pD, nSuspect, bounded);
    Index plastic[kBlock], nPlastic = 0;  // lanes of the block outside or too near the surface
    for (Index k = 0; k < nSuspect; ++k) {
      if (bounded[k] != 0) continue;
      const Index e = e0 + suspect[k];
      const Real t[6] = {packed[XX][k], packed[YY][k], packed[ZZ][k], packed[XY][k], packed[YZ][k], packed[ZX][k]};
      const MohrCoulombSurface sD = surface(dmg[e]);  // the nominal stress's surface (both effects)
      Real range[3], size;                            // smallest, (unused), largest
      principalRange(t, range[0], range[2], size);
      range[1] = range[0];
      const Real margin = 1e-6 * std::max({size, sD.cohesionTerm, std::abs(sD.tension)});
      if (sD.shear(range) < -(Np + 1) * margin && sD.tensile(range) < -margin) continue;
      plastic[nPlastic++] = suspect[k];
    }
    // 3. Their trial's eigen-decomposition four at a time (eigenSym3x4: each the scalar one's
    //    bits), then the return mapping, damage and history of each.
    for (Index g = 0; g < nPlastic; g += 4) {
      const int m = int(std::min<Index>(4, nPlastic - g));
      Real sig[4][6], de[4][6], trial[4][6], ev[4][3], V[4][3][3];
      bool open[4] = {false, false, false, false};
      for (int j = 0; j < m; ++j) {
        const Index e = e0 + plastic[g + j];
        for (int q = 0; q < 6; ++q) {
          sig[j][q] = old[q][plastic[g + j]];
          de[j][q] = c.dstrain[q][e];
        }
        open[j] = plasticTrial(sig[j], de[j], dmg[e], trial[j]);
      }
      if (kMaterialAvx2 && m > 1) {
        Real t4[6][4] = {};  // lanes without a trial: the zero matrix (no rotation)
        for (int j = 0; j < m; ++j)
          if (open[j])
            for (int q = 0; q < 6; ++q) t4[q][j] = trial[j][q];
        eigenSym3x4(t4, ev, V);
      } else {
        for (int j = 0; j < m; ++j)
          if (open[j]) eigenSym3(trial[j], ev[j], V[j]);
      }
      for (int j = 0; j < m; ++j) {
        const Index e = e0 + plastic[g + j];
        if (open[j]) plasticFinish(sig[j], de[j], c.history, e, trial[j], ev[j], V[j]);
        for (int q = 0; q < 6; ++q) c.stress[q][e] = sig[j][q];
      }
    }
  }
}

bool MohrCoulombDamageMaterial::plasticTrial(Real s[6], const Real de[6], Real Dn, Real trial[6]) const {
  const bool stiff = params_.damageEffect == DamageEffect::CohesionAndStiffness;
  const Real lam = moduli_.lambda, mu = moduli_.mu;
  if (stiff && Dn >= 1) {  // fully damaged: no stiffness, no stress
    for (int q = 0; q < 6; ++q) s[q] = 0;
    return false;
  }
  // Nominal for `cohesion`, effective σ/(1 − D) for `cohesion_and_stiffness` (plasticity then runs
  // on the undamaged surface).
  const Real tr = de[XX] + de[YY] + de[ZZ];
  const Real toEff = stiff ? 1 / (1 - Dn) : 1;
  for (int q = 0; q < 3; ++q) trial[q] = s[q] * toEff + lam * tr + 2 * mu * de[q];
  for (int q = 3; q < 6; ++q) trial[q] = s[q] * toEff + mu * de[q];
  return true;
}

void MohrCoulombDamageMaterial::plasticFinish(Real s[6], const Real de[6], Real* const* h, Index e, const Real trial[6],
                                              const Real ev[3], const Real V[3][3]) const {
  using namespace mc_history;
  const bool stiff = params_.damageEffect == DamageEffect::CohesionAndStiffness;
  const Real mu = moduli_.mu, E = params_.elastic.youngsModulus, nu = params_.elastic.poissonRatio;
  const Real Dn = h[kDamage][e];
  // Elastic energy density ½ σ : C⁻¹ : σ / (1 − D) of a nominal stress (0 when fully damaged).
  auto energy = [&](const Real x[6], Real D) {
    if (D >= 1) return Real(0);
    const Real exx = (x[XX] - nu * (x[YY] + x[ZZ])) / E, eyy = (x[YY] - nu * (x[ZZ] + x[XX])) / E,
               ezz = (x[ZZ] - nu * (x[XX] + x[YY])) / E;
    return 0.5 * (x[XX] * exx + x[YY] * eyy + x[ZZ] * ezz + (x[XY] * x[XY] + x[YZ] * x[YZ] + x[ZX] * x[ZX]) / mu) /
           (stiff ? 1 - D : 1);
  };
  Real old[6];
  for (int q = 0; q < 6; ++q) old[q] = s[q];
  const Real toEff = stiff ? 1 / (1 - Dn) : 1;
  const Real kappaOld[3] = {h[kKappa1][e], h[kKappa2][e], h[kKappa3][e]};
  Real kappa[3] = {kappaOld[0], kappaOld[1], kappaOld[2]};
  auto kappaAfter = [&](const PrincipalReturn& r, Real out[3]) {
    const Real m = (r.plastic[0] + r.plastic[1] + r.plastic[2]) / 3;
    for (int i = 0; i < 3; ++i) out[i] = kappaOld[i] + std::abs(r.plastic[i] - m);
  };
  const bool damageOn = params_.damageConstant > 0;
  PrincipalReturn ret;
  Real Dnew = Dn;
  if (stiff) {
    ret = surface(0).returnMap(tables_, ev);  // undamaged surface in effective stress
    if (ret.activeSet < 0) {                  // inside after all: elastic
      for (int q = 0; q < 6; ++q) s[q] = trial[q] / toEff;
      return;
    }
    kappaAfter(ret, kappa);
    if (damageOn) Dnew = std::max(Dn, damageFrom(kappa));
  } else {
    ret = surface(Dn).returnMap(tables_, ev);
    if (ret.activeSet < 0) {
      for (int q = 0; q < 6; ++q) s[q] = trial[q];
      return;
    }
    kappaAfter(ret, kappa);
    if (damageOn) {
      // Implicit damage: D = G(D), G(D) = damage after a return on the surface of cohesion
      // (1 − D) c. G is continuous with G(D_n) ≥ D_n and G(1) ≤ 1, so h(D) = G(D) − D has a root
      // in [D_n, 1]: one fixed-point step, then secant steps kept inside the bracket [lo, hi]
      // (h(lo) ≥ 0 ≥ h(hi)), bisection when a secant step would leave it.
      auto G = [&](Real D, PrincipalReturn& r, Real kap[3]) {
        r = surface(D).returnMap(tables_, ev, r.activeSet);
        kappaAfter(r, kap);
        return std::max(Dn, damageFrom(kap));
      };
      const Real tol = 1e-14;
      Real g = std::max(Dn, damageFrom(kappa));
      Real D0 = Dn, h0 = g - Dn, lo = Dn, hi = 1;
      if (h0 > tol) {
        Real D1 = g;
        g = G(D1, ret, kappa);
        Real h1 = g - D1;
        (h1 >= 0 ? lo : hi) = D1;
        for (int it = 0; it < 100 && std::abs(h1) > tol && hi - lo > tol; ++it) {
          Real D2 = h1 != h0 ? D1 - h1 * (D1 - D0) / (h1 - h0) : 0.5 * (lo + hi);
          if (!(D2 > lo && D2 < hi)) D2 = 0.5 * (lo + hi);
          D0 = D1;
          h0 = h1;
          D1 = D2;
          g = G(D1, ret, kappa);
          h1 = g - D1;
          (h1 >= 0 ? lo : hi) = D1;
        }
      }
      Dnew = g;
    }
  }
  // σ^{n+1} = σ^tr + Σ_i (σ_i − σ_i^tr) v_i v_iᵀ (the increment form keeps the unchanged part of
  // the trial exactly); Δε^p = Σ_i Δε^p_i v_i v_iᵀ.
  Real dsig[3] = {ret.sigma[0] - ev[0], ret.sigma[1] - ev[1], ret.sigma[2] - ev[2]}, dS[6], dEp[6];
  spectralToVoigt(dsig, V, false, dS);
  spectralToVoigt(ret.plastic, V, true, dEp);
  const Real toNominal = stiff ? 1 - Dnew : 1;
  for (int q = 0; q < 6; ++q) s[q] = (trial[q] + dS[q]) * toNominal;
  for (int q = 0; q < 6; ++q) h[kPlasticXX + q][e] += dEp[q];
  h[kKappa1][e] = kappa[0];
  h[kKappa2][e] = kappa[1];
  h[kKappa3][e] = kappa[2];
  h[kDamage][e] = Dnew;
  // Dissipated energy density: stress work of the step minus the change of the elastic energy
  // (exactly what the element's stress work books beyond the stored energy).
  Real work = 0;
  for (int q = 0; q < 6; ++q) work += 0.5 * (old[q] + s[q]) * de[q];
  h[kDissipation][e] += work - (energy(s, Dnew) - energy(old, Dn));
}

}  // namespace tq
