// Reinforced concrete with smeared bars (docs/solid_solver.md "Reinforced concrete lining").
#include "tq/materials/material_rc.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "materials/parameter_names.hpp"

namespace tq {

ReinforcedConcreteParams reinforcedConcreteParams(const MaterialValues& v) {
  namespace P = material_parameter;  // the table's names (solver_input_table.py)
  ReinforcedConcreteParams p;
  p.elastic = elasticParams(v);
  p.fc = v.number(P::fc);
  p.fct = v.number(P::fct);
  auto opt = [&](const char* name, Real def) {
    const auto it = v.numbers.find(name);
    return it == v.numbers.end() ? def : it->second;
  };
  p.epsC2 = opt(P::eps_c2, p.epsC2);
  p.epsCu2 = opt(P::eps_cu2, p.epsCu2);
  p.beta = opt(P::tension_stiffening_beta, p.beta);
  p.Es = opt(P::Es, p.Es);
  p.fy = opt(P::fy, p.fy);
  p.asInnerHoop = opt(P::As_inner_hoop, 0);
  p.asOuterHoop = opt(P::As_outer_hoop, 0);
  p.asInnerAxial = opt(P::As_inner_axial, 0);
  p.asOuterAxial = opt(P::As_outer_axial, 0);
  p.axisDistance = opt(P::axis_distance, p.axisDistance);
  p.centreX = opt(P::ring_centre_x, 0);
  p.centreZ = opt(P::ring_centre_z, 0);
  p.innerRadius = v.number(P::ring_inner_radius);
  p.thickness = v.number(P::ring_thickness);
  p.layers = v.number(P::ring_layers);
  return p;
}

std::shared_ptr<const Material> makeReinforcedConcreteMaterial(const MaterialValues& v) {
  return std::make_shared<ReinforcedConcreteMaterial>(reinforcedConcreteParams(v));
}

namespace rc_law {

namespace {
// Parabola–rectangle (EN 1992-1-1 eq. 3.17) magnitude at compressive strain a ≥ 0, 0 once crushed.
Real parabolaRectangle(const ReinforcedConcreteParams& p, Real a) {
  if (a <= 0) return 0;
  if (a < p.epsC2) {
    const Real u = 1 - a / p.epsC2;
    return p.fc * (1 - (p.exponent == 2 ? u * u : std::pow(u, p.exponent)));
  }
  if (a <= p.epsCu2) return p.fc;
  return 0;  // crushed (εcu2 passed)
}

// Tension branch on loading at e > 0 (Pa).
Real tensionEnvelope(const ReinforcedConcreteParams& p, Real e, Real rho) {
  const Real E = p.elastic.youngsModulus, epsCr = p.fct / E;
  if (e <= epsCr) return E * e;
  if (!(rho > 0)) {  // plain: linear softening to 0 at plainSoftening × εcr
    const Real eTu = p.plainSoftening * epsCr;
    return e >= eTu ? 0 : p.fct * (eTu - e) / (eTu - epsCr);
  }
  // A tie of unit area with steel ratio ρ (bars not deducted): EN 1992-1-1 eq. (7.18)–(7.19),
  // ε_m = ζ ε_s2 + (1 − ζ) ε_s1, ζ = 1 − β (N_cr/N)². With k = ρE_s/(E + ρE_s), N_cr = f_ct/(1 − k)
  // and ε_sr = N_cr/(ρE_s), q = ε_m/ε_sr gives x = N_cr/N from β(1 − k)x² + q x − 1 = 0, and the
  // concrete's mean stress σ_c = N − ρE_s ε_m = β(1 − k) N_cr x.
  const Real rEs = rho * p.Es, k = rEs / (E + rEs), nCr = p.fct / (1 - k), epsSr = nCr / rEs;
  const Real q = e / epsSr, b = p.beta * (1 - k);
  if (q <= 1 - b) return nCr - rEs * e;  // β < 1: the crack forms at N = N_cr
  const Real x = b > 0 ? (-q + std::sqrt(q * q + 4 * b)) / (2 * b) : 0;
  return b * nCr * x;
}
}  // namespace

Real concrete(const ReinforcedConcreteParams& p, Real e, Real eMax, Real eMinAbs, Real rho) {
  const Real E = p.elastic.youngsModulus;
  if (e >= 0) {
    if (eMax <= p.fct / E) return E * e;
    return tensionEnvelope(p, eMax, rho) / eMax * e;  // secant to the origin
  }
  const Real a = -e;
  if (eMinAbs > p.epsCu2) return 0;
  const Real envelope = std::min(E * a, parabolaRectangle(p, a));
  if (a >= eMinAbs) return -envelope;
  const Real top = std::min(E * eMinAbs, parabolaRectangle(p, eMinAbs));
  return -top / eMinAbs * a;  // unloading: secant to the origin
}

Real steel(const ReinforcedConcreteParams& p, Real eps, Real& epsPlastic) {
  Real s = p.Es * (eps - epsPlastic);
  if (std::abs(s) > p.fy) {
    s = std::copysign(p.fy, s);
    epsPlastic = eps - s / p.Es;
  }
  return s;
}

Real steelRatio(const ReinforcedConcreteParams& p, Real r, Real asInner, Real asOuter) {
  const Real h = p.thickness / p.layers;
  const int n = int(std::lround(p.layers));
  const int row = std::clamp(int(std::floor((r - p.innerRadius) / h)), 0, n - 1);
  auto share = [&](Real rb) {                       // this row's share of a layer at radius rb
    const Real s = (rb - p.innerRadius) / h - 0.5;  // in row-centre units
    const Real lo = std::clamp(std::floor(s), 0.0, Real(n - 1));
    if (s <= 0) return row == 0 ? 1.0 : 0.0;
    if (s >= n - 1) return row == n - 1 ? 1.0 : 0.0;
    const Real w = s - lo;
    if (row == int(lo)) return 1 - w;
    if (row == int(lo) + 1) return w;
    return 0.0;
  };
  return (asInner * share(p.innerRadius + p.axisDistance) +
          asOuter * share(p.innerRadius + p.thickness - p.axisDistance)) /
         h;
}

namespace {
// Each face's stiffening zone: h_c,ef = min(2a, h/2) in bending, widened to h/2 as the section
// becomes a tie (share 1).
Real bandWidth(const ReinforcedConcreteParams& p, Real share) {
  const Real b0 = std::min(2 * p.axisDistance, 0.5 * p.thickness);
  return b0 + std::clamp(share, Real(0), Real(1)) * (0.5 * p.thickness - b0);
}
// The element row's radial extent [lo, hi] from the inner face.
void rowExtent(const ReinforcedConcreteParams& p, Real r, Real& lo, Real& hi) {
  const Real h = p.thickness / p.layers;
  const int row = std::clamp(int(std::floor((r - p.innerRadius) / h)), 0, int(std::lround(p.layers)) - 1);
  lo = row * h;
  hi = lo + h;
}
}  // namespace

Real stiffeningRatio(const ReinforcedConcreteParams& p, Real r, Real asInner, Real asOuter, Real share) {
  const Real band = bandWidth(p, share);
  Real lo, hi, rho = 0;
  rowExtent(p, r, lo, hi);
  if (lo < band) rho += asInner / band;
  if (hi > p.thickness - band) rho += asOuter / band;
  return rho;
}

Real bandFraction(const ReinforcedConcreteParams& p, Real r, Real share) {
  const Real band = bandWidth(p, share);
  Real lo, hi;
  rowExtent(p, r, lo, hi);
  const Real in = std::max(Real(0), std::min(hi, band) - lo) + std::max(Real(0), hi - std::max(lo, p.thickness - band));
  return std::min(Real(1), in / (hi - lo));
}

Real sectionShare(Real strainInner, Real strainOuter) {
  const Real hi = std::max(strainInner, strainOuter), lo = std::min(strainInner, strainOuter);
  if (!(hi > 0)) return 0;
  return std::clamp(2 * lo / hi, Real(0), Real(1));
}

}  // namespace rc_law

ReinforcedConcreteMaterial::ReinforcedConcreteMaterial(const ReinforcedConcreteParams& p) : params_(p) {
  concrete_ = ElasticMaterial(p.elastic).elasticModuli();  // checks E, ν, ρ
  auto bad = [](const std::string& what, Real v, const std::string& fix) {
    std::ostringstream os;
    os << "reinforced_concrete material: " << what << " = " << v << " is invalid; " << fix;
    throw InputError(os.str());
  };
  if (!(p.fc > 0)) bad("fc", p.fc, "give the concrete's compressive strength in Pa (> 0), e.g. 30e6");
  if (!(p.fct > 0)) bad("fct", p.fct, "give the concrete's tensile strength in Pa (> 0), e.g. 2.9e6");
  if (!(p.epsC2 > 0 && p.epsCu2 >= p.epsC2)) bad("eps_c2", p.epsC2, "need 0 < eps_c2 <= eps_cu2 (2e-3, 3.5e-3)");
  if (!(p.beta >= 0 && p.beta <= 1)) bad("tension_stiffening_beta", p.beta, "β lies in [0, 1] (1 short-term)");
  if (!(p.Es > 0) || !(p.fy > 0)) bad("Es or fy", p.Es, "give the steel's modulus and yield strength in Pa");
  if (!(p.thickness > 0) || !(p.innerRadius > 0)) bad("ring_thickness", p.thickness, "give the lining's geometry in m");
  if (!(p.layers >= 1) || std::abs(p.layers - std::round(p.layers)) > 1e-9)
    bad("ring_layers", p.layers, "give the number of elements through the lining's thickness");
  for (Real a : {p.asInnerHoop, p.asOuterHoop, p.asInnerAxial, p.asOuterAxial})
    if (!(a >= 0)) bad("a bar area", a, "give areas per metre in m^2/m (>= 0)");
  if (!(p.axisDistance > 0 && 2 * p.axisDistance < p.thickness))
    bad("axis_distance", p.axisDistance, "the bars' axis lies inside the lining: 0 < axis_distance < thickness/2");
  // Stable step: the stiffest element's constrained modulus with its bars.
  Real rhoMax = 0;
  for (int i = 0; i < int(std::lround(p.layers)); ++i) {
    const Real r = p.innerRadius + (i + 0.5) * p.thickness / p.layers;
    rhoMax = std::max({rhoMax, rc_law::steelRatio(p, r, p.asInnerHoop, p.asOuterHoop),
                       rc_law::steelRatio(p, r, p.asInnerAxial, p.asOuterAxial)});
  }
  const Real scale = 1 + rhoMax * p.Es / concrete_.pModulus();
  moduli_ = {concrete_.lambda * scale, concrete_.mu * scale};
}

std::vector<std::string> ReinforcedConcreteMaterial::historyNames() const {
  return {"cos_theta",
          "sin_theta",
          "rho_hoop",
          "rho_axial",
          "strain_xx",
          "strain_yy",
          "strain_zz",
          "strain_xy",
          "strain_yz",
          "strain_zx",
          "tension_max_hoop",
          "tension_max_axial",
          "compression_max_hoop",
          "compression_max_axial",
          "steel_plastic_hoop",
          "steel_plastic_axial",
          "stiffening_rho_hoop",
          "stiffening_rho_axial",
          "band_fraction_hoop",
          "band_fraction_axial",
          "face_row_inner",
          "face_row_outer",
          "section_share_hoop",
          "section_share_axial",
          "damage",
          "hourglass_scale"};
}

namespace {
// Sets every element's face-row partners (history kFaceInner/kFaceOuter: 1 + index, -1 none): the
// innermost and the outermost element on its ray (same angle about the ring centre and same y
// within a quarter of a row's thickness). By the extremes, not by rows from the radius: a coarse
// ring's element centres lie inside the arc (by r (1 − cos(Δθ/2)), half a thin row at 11°).
void findFaceRows(const ReinforcedConcreteParams& p, Index count, const Real* const centre[3], Real* const* h) {
  const Real rMid = p.innerRadius + 0.5 * p.thickness, tol = 0.25 * p.thickness / p.layers;
  struct Entry {
    Real theta, y, r;
    Index e;
  };
  std::vector<Entry> all(static_cast<size_t>(count));
  for (Index e = 0; e < count; ++e) {
    const Real dx = centre[0][e] - p.centreX, dz = centre[2][e] - p.centreZ;
    all[size_t(e)] = {std::atan2(dz, dx), centre[1][e], std::hypot(dx, dz), e};
  }
  std::vector<Entry> sorted = all;
  std::sort(sorted.begin(), sorted.end(), [](const Entry& a, const Entry& b) { return a.theta < b.theta; });
  const Real dTheta = tol / rMid, twoPi = 2 * std::acos(Real(-1));
  for (const Entry& me : all) {
    Index in = -1, out = -1;
    Real rIn = 0, rOut = 0;
    for (Real shift : {Real(0), twoPi, -twoPi}) {  // a ray at ±π may be stored as its twin
      const Real t = me.theta + shift;
      auto it = std::lower_bound(sorted.begin(), sorted.end(), t - dTheta,
                                 [](const Entry& a, Real v) { return a.theta < v; });
      for (; it != sorted.end() && it->theta <= t + dTheta; ++it) {
        if (std::hypot((it->theta - t) * rMid, it->y - me.y) >= tol) continue;
        if (in < 0 || it->r < rIn) in = it->e, rIn = it->r;
        if (out < 0 || it->r > rOut) out = it->e, rOut = it->r;
      }
    }
    // One element through the thickness has no section to read: bending's zone.
    const bool ok = in >= 0 && out >= 0 && in != out;
    h[rc_history::kFaceInner][me.e] = ok ? Real(in + 1) : -1;
    h[rc_history::kFaceOuter][me.e] = ok ? Real(out + 1) : -1;
  }
}
}  // namespace

void ReinforcedConcreteMaterial::initHistory(Index count, const Real* const centre[3], Real* const* h) const {
  for (Index e = 0; e < count; ++e) {
    const Real dx = centre[0][e] - params_.centreX, dz = centre[2][e] - params_.centreZ;
    const Real r = std::hypot(dx, dz);
    h[rc_history::kCos][e] = r > 0 ? dx / r : 1;
    h[rc_history::kSin][e] = r > 0 ? dz / r : 0;
    h[rc_history::kRhoHoop][e] = rc_law::steelRatio(params_, r, params_.asInnerHoop, params_.asOuterHoop);
    h[rc_history::kRhoAxial][e] = rc_law::steelRatio(params_, r, params_.asInnerAxial, params_.asOuterAxial);
    h[rc_history::kStiffeningHoop][e] = rc_law::stiffeningRatio(params_, r, params_.asInnerHoop, params_.asOuterHoop);
    h[rc_history::kStiffeningAxial][e] =
        rc_law::stiffeningRatio(params_, r, params_.asInnerAxial, params_.asOuterAxial);
    h[rc_history::kBandFractionHoop][e] = h[rc_history::kBandFractionAxial][e] = rc_law::bandFraction(params_, r);
    h[rc_history::kHourglassScale][e] = 1;
  }
  // A single element (re-activated) leaves its face rows to blockPass, which has the whole block.
  if (count > 1) findFaceRows(params_, count, centre, h);
}

void ReinforcedConcreteMaterial::blockPass(Index count, const Real* const centre[3], Real* const* h) const {
  namespace H = rc_history;
  bool search = false;
  for (Index e = 0; e < count && !search; ++e) search = h[H::kFaceInner][e] == 0 || h[H::kFaceOuter][e] == 0;
  if (search) findFaceRows(params_, count, centre, h);
  auto hoop = [&](Index e) {  // the element's hoop strain, from its total strain of the last update
    const Real cs = h[H::kCos][e], sn = h[H::kSin][e];
    return sn * sn * h[H::kEpsXX][e] + cs * cs * h[H::kEpsZZ][e] - cs * sn * h[H::kEpsZX][e];
  };
  for (Index e = 0; e < count; ++e) {
    const Index a = Index(h[H::kFaceInner][e]) - 1, b = Index(h[H::kFaceOuter][e]) - 1;
    Real sHoop = 0, sAxial = 0;
    if (a >= 0 && b >= 0) {
      sHoop = rc_law::sectionShare(hoop(a), hoop(b));
      sAxial = rc_law::sectionShare(h[H::kEpsYY][a], h[H::kEpsYY][b]);
    }
    if (sHoop == h[H::kSectionShareHoop][e] && sAxial == h[H::kSectionShareAxial][e]) continue;
    h[H::kSectionShareHoop][e] = sHoop;
    h[H::kSectionShareAxial][e] = sAxial;
    const Real r = std::hypot(centre[0][e] - params_.centreX, centre[2][e] - params_.centreZ);
    h[H::kStiffeningHoop][e] = rc_law::stiffeningRatio(params_, r, params_.asInnerHoop, params_.asOuterHoop, sHoop);
    h[H::kStiffeningAxial][e] = rc_law::stiffeningRatio(params_, r, params_.asInnerAxial, params_.asOuterAxial, sAxial);
    h[H::kBandFractionHoop][e] = rc_law::bandFraction(params_, r, sHoop);
    h[H::kBandFractionAxial][e] = rc_law::bandFraction(params_, r, sAxial);
  }
}

void ReinforcedConcreteMaterial::updateStressForElems(const MaterialChunk& c) const {
  namespace H = rc_history;
  const Real lam = concrete_.lambda, mu = concrete_.mu, twoMu = 2 * mu, E = params_.elastic.youngsModulus;
  const Real epsCr = params_.fct / E;
  Real* const* h = c.history;
  for (Index e = 0; e < c.count; ++e) {
    Real eps[6];
    for (int k = 0; k < 6; ++k) eps[k] = (h[H::kEpsXX + k][e] += c.dstrain[k][e]);
    const Real tr = eps[XX] + eps[YY] + eps[ZZ];
    Real s[6] = {lam * tr + twoMu * eps[XX],
                 lam * tr + twoMu * eps[YY],
                 lam * tr + twoMu * eps[ZZ],
                 mu * eps[XY],
                 mu * eps[YZ],
                 mu * eps[ZX]};
    // Hoop direction t = (−sin θ, 0, cos θ); axial a = y.
    const Real cs = h[H::kCos][e], sn = h[H::kSin][e];
    const Real ttXX = sn * sn, ttZZ = cs * cs, ttZX = -cs * sn;
    const Real epsT = ttXX * eps[XX] + ttZZ * eps[ZZ] + ttZX * eps[ZX];  // γ_zx = 2ε_zx
    const Real epsA = eps[YY];
    const Real sigT = ttXX * s[XX] + ttZZ * s[ZZ] + 2 * ttZX * s[ZX];
    const Real sigA = s[YY];
    auto direction = [&](Real sigElastic, Real epsTotal, int kTen, int kCom, int kPl, int kRho, int kTs, int kBf) {
      const Real eq = sigElastic / E;  // equivalent uniaxial strain
      Real& eMax = h[kTen][e];
      Real& eMin = h[kCom][e];
      if (eq > eMax) eMax = eq;
      if (-eq > eMin) eMin = -eq;
      const Real rho = h[kRho][e];
      const Real rhoEff = h[kTs][e];
      const Real plain = rc_law::concrete(params_, eq, eMax, eMin, 0);
      Real sig = plain;
      if (rhoEff > 0) {
        Real tie = rc_law::concrete(params_, eq, eMax, eMin, rhoEff);
        if (tie > 0)  // the bars at a crack carry the stiffening stress too: σ_s,crack ≤ f_y
          tie = std::min(tie, std::max(Real(0), rhoEff * (params_.fy - params_.Es * epsTotal)));
        const Real f = h[kBf][e];
        sig = f * tie + (1 - f) * plain;
      }
      if (eq > 0 && eMax > params_.fct / E)  // cracked and open: the secant's loss (history-monotone)
        h[H::kDamage][e] = std::max(h[H::kDamage][e], std::clamp(1 - sig / (E * eq), Real(0), Real(1)));
      if (rho > 0) sig += rho * rc_law::steel(params_, epsTotal, h[kPl][e]);
      // The element's secant ratio in this direction, composite stress over the elastic one of
      // the same strains (concrete and bars), once past the elastic range: its hourglass
      // stiffness follows it (smallest so far, as the concrete's secant unloading keeps it).
      if (eMax > epsCr || -eq > epsCr || h[kPl][e] != 0) {
        const Real elastic = sigElastic + rho * params_.Es * epsTotal;
        if (std::abs(elastic) > 0)
          h[H::kHourglassScale][e] =
              std::min(h[H::kHourglassScale][e], std::clamp(sig / elastic, rc_law::kHourglassFloor, Real(1)));
      }
      return sig - sigElastic;  // the correction to the elastic stress in this direction
    };
    const Real dT = direction(sigT, epsT, H::kTensionHoop, H::kCompressionHoop, H::kPlasticHoop, H::kRhoHoop,
                              H::kStiffeningHoop, H::kBandFractionHoop);
    const Real dA = direction(sigA, epsA, H::kTensionAxial, H::kCompressionAxial, H::kPlasticAxial, H::kRhoAxial,
                              H::kStiffeningAxial, H::kBandFractionAxial);
    c.stress[XX][e] = s[XX] + dT * ttXX;
    c.stress[ZZ][e] = s[ZZ] + dT * ttZZ;
    c.stress[ZX][e] = s[ZX] + dT * ttZX;
    c.stress[YY][e] = s[YY] + dA;
    c.stress[XY][e] = s[XY];
    c.stress[YZ][e] = s[YZ];
  }
}

}  // namespace tq
