/// @file material_kv.hpp
/// @brief Linear viscoelastic (Kelvin–Voigt) rock: σ = C:ε + τ C:ε̇ (docs/solid_solver.md
///        "Kelvin–Voigt rock"). The viscous stress is the elastic stress of the strain rate times
///        the retardation time τ, so P and S waves see the complex moduli M(1 + iωτ), μ(1 + iωτ):
///        the damping ratio at angular frequency ω is ξ(ω) = ωτ/2, growing with frequency
///        (stiffness-proportional, like Rayleigh β = τ but in this region only).
#pragma once

#include "tq/materials/material.hpp"

namespace tq {

/// Parameters of the Kelvin–Voigt material.
struct KelvinVoigtParams {
  ElasticParams elastic;     ///< E (Pa), ν (-), ρ (kg/m^3)
  Real retardationTime = 0;  ///< τ (s), ≥ 0: η_P = τ M, η_S = τ μ; 0 is the elastic model
};

/// The Kelvin–Voigt parameters of a region's parameter map (docs/formats.md "## solid_input.h5").
KelvinVoigtParams kelvinVoigtParams(const MaterialValues& v);

/// History variables: the viscous stress of the last step per Voigt component (Pa), then the
/// energy it dissipated per unit volume (J/m^3).
namespace kv_history {
enum : int { kViscousXX = 0, kViscousYY, kViscousZZ, kViscousXY, kViscousYZ, kViscousZX, kDissipation, kCount };
}  // namespace kv_history

/// σ^{n+1} = σ_e^n + C:Δε + (τ/Δt) C:Δε, σ_e^n = σ^n − σ_v^n: the elastic part in rate form, the
/// viscous part from the increment's strain rate Δε/Δt (the lagged rate of the central
/// difference, as for Rayleigh's β; the first increment has no rate).
class KelvinVoigtMaterial final : public Material {
 public:
  static constexpr const char* kName = "kelvin_voigt";       ///< the registry's name
  explicit KelvinVoigtMaterial(const KelvinVoigtParams& p);  // throws InputError on bad values
  std::string typeName() const override { return kName; }
  Real density() const override { return params_.elastic.density; }
  ElasticModuli elasticModuli() const override { return moduli_; }
  Real viscousTime() const override { return params_.retardationTime; }
  std::vector<std::string> historyNames() const override;
  int dissipationHistory() const override { return kv_history::kDissipation; }
  void updateStressForElems(const MaterialChunk& chunk) const override;
  const KelvinVoigtParams& params() const { return params_; }

 private:
  KelvinVoigtParams params_;
  ElasticModuli moduli_;
};

/// The registry's factory of the Kelvin–Voigt model (throws InputError on bad values).
std::shared_ptr<const Material> makeKelvinVoigtMaterial(const MaterialValues& v);

}  // namespace tq
