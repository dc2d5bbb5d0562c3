// Linear viscoelastic (Kelvin–Voigt) rock: σ = C:ε + τ C:ε̇ (docs/solid_solver.md).
#include "tq/materials/material_kv.hpp"

#include <cmath>
#include <sstream>

#include "materials/parameter_names.hpp"

namespace tq {

KelvinVoigtParams kelvinVoigtParams(const MaterialValues& v) {
  namespace M = material_parameter;
  return {elasticParams(v), v.number(M::retardation_time)};
}

std::shared_ptr<const Material> makeKelvinVoigtMaterial(const MaterialValues& v) {
  return std::make_shared<KelvinVoigtMaterial>(kelvinVoigtParams(v));
}

KelvinVoigtMaterial::KelvinVoigtMaterial(const KelvinVoigtParams& p) : params_(p) {
  moduli_ = ElasticMaterial(p.elastic).elasticModuli();  // checks E, ν, ρ
  if (!(p.retardationTime >= 0) || !std::isfinite(p.retardationTime)) {
    std::ostringstream os;
    os << "kelvin_voigt material: retardation_time = " << p.retardationTime
       << " s is invalid; give τ >= 0 in s (damping ratio ξ = ωτ/2 at angular frequency ω: ξ = 5 % at 5 Hz is "
          "τ = 3.2e-3 s)";
    throw InputError(os.str());
  }
}

std::vector<std::string> KelvinVoigtMaterial::historyNames() const {
  return {"viscous_xx", "viscous_yy", "viscous_zz", "viscous_xy", "viscous_yz", "viscous_zx", "dissipation"};
}

void KelvinVoigtMaterial::updateStressForElems(const MaterialChunk& c) const {
  const Real lam = moduli_.lambda, mu = moduli_.mu, twoMu = 2 * mu;
  const Real rate = c.dt > 0 ? params_.retardationTime / c.dt : 0;  // τ/Δt: C:Δε -> viscous stress
  Real* __restrict dis = c.history[kv_history::kDissipation];
  for (Index e = 0; e < c.count; ++e) {
    const Real tr = c.dstrain[XX][e] + c.dstrain[YY][e] + c.dstrain[ZZ][e];
    Real work = 0;
    for (int k = 0; k < 6; ++k) {
      const Real de = c.dstrain[k][e];
      const Real dElastic = k < 3 ? lam * tr + twoMu * de : mu * de;  // C:Δε, engineering shear strains
      const Real viscous = rate * dElastic;
      Real& sv = c.history[kv_history::kViscousXX + k][e];
      c.stress[k][e] += dElastic + viscous - sv;
      sv = viscous;
      work += viscous * de;
    }
    dis[e] += work;
  }
}

}  // namespace tq
