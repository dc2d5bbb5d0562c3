#include "tq/materials/material.hpp"

#include <cmath>
#include <sstream>

#include "materials/parameter_names.hpp"

namespace tq {

Real MaterialValues::number(const std::string& name) const {
  const auto it = numbers.find(name);
  if (it == numbers.end()) throw InputError("material " + model + ": parameter '" + name + "' is not given");
  return it->second;
}

const std::string& MaterialValues::text(const std::string& name) const {
  const auto it = texts.find(name);
  if (it == texts.end()) throw InputError("material " + model + ": parameter '" + name + "' is not given");
  return it->second;
}

ElasticParams elasticParams(const MaterialValues& v) {
  namespace M = material_parameter;
  return {v.number(M::E), v.number(M::nu), v.number(M::rho)};
}

MaterialValues elasticValues(const ElasticParams& p) {
  namespace M = material_parameter;
  MaterialValues v;
  v.model = ElasticMaterial::kName;
  v.numbers = {{M::E, p.youngsModulus}, {M::nu, p.poissonRatio}, {M::rho, p.density}};
  return v;
}

std::shared_ptr<const Material> makeElasticMaterial(const MaterialValues& v) {
  return std::make_shared<ElasticMaterial>(elasticParams(v));
}

ElasticModuli ElasticModuli::fromYoungPoisson(Real E, Real nu) {
  ElasticModuli m;
  m.mu = E / (2 * (1 + nu));
  m.lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
  return m;
}

ElasticMaterial::ElasticMaterial(const ElasticParams& p) : params_(p) {
  auto bad = [](const std::string& what, Real v, const std::string& fix) {
    std::ostringstream os;
    os << "elastic material: " << what << " = " << v << " is invalid; " << fix;
    throw InputError(os.str());
  };
  if (!(p.youngsModulus > 0) || !std::isfinite(p.youngsModulus))
    bad("E", p.youngsModulus, "give Young's modulus in Pa (> 0), e.g. 8e9 for the paper's rock");
  if (!(p.poissonRatio > -1 && p.poissonRatio < 0.5))
    bad("nu", p.poissonRatio, "Poisson's ratio must lie in (-1, 0.5)");
  if (!(p.density > 0) || !std::isfinite(p.density))
    bad("rho", p.density, "give the density in kg/m^3 (> 0), e.g. 2700");
  moduli_ = ElasticModuli::fromYoungPoisson(p.youngsModulus, p.poissonRatio);
}

void ElasticMaterial::updateStressForElems(const MaterialChunk& c) const {
  const Real lam = moduli_.lambda, mu = moduli_.mu, twoMu = 2 * mu;
  const Real* __restrict exx = c.dstrain[XX];
  const Real* __restrict eyy = c.dstrain[YY];
  const Real* __restrict ezz = c.dstrain[ZZ];
  const Real* __restrict gxy = c.dstrain[XY];
  const Real* __restrict gyz = c.dstrain[YZ];
  const Real* __restrict gzx = c.dstrain[ZX];
  Real* __restrict sxx = c.stress[XX];
  Real* __restrict syy = c.stress[YY];
  Real* __restrict szz = c.stress[ZZ];
  Real* __restrict sxy = c.stress[XY];
  Real* __restrict syz = c.stress[YZ];
  Real* __restrict szx = c.stress[ZX];
#pragma omp simd
  for (Index e = 0; e < c.count; ++e) {
    const Real tr = exx[e] + eyy[e] + ezz[e];
    sxx[e] += lam * tr + twoMu * exx[e];
    syy[e] += lam * tr + twoMu * eyy[e];
    szz[e] += lam * tr + twoMu * ezz[e];
    sxy[e] += mu * gxy[e];
    syz[e] += mu * gyz[e];
    szx[e] += mu * gzx[e];
  }
}

}  // namespace tq
