/// @file material.hpp
/// @brief Constitutive models. A material updates the stress of a chunk of elements of one block
///        from their strain increments; the loop calls it once per chunk (no virtual call per
///        element), so a nonlinear model (Mohr-Coulomb with damage) plugs in as another
///        subclass with its own parameter struct and history variables.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tq/core/types.hpp"

namespace tq {

/// Voigt order of the 6 stress/strain components used everywhere in tq-solid:
/// xx, yy, zz, xy, yz, zx. Strains in engineering form (γ_xy = 2 ε_xy). Tension positive
/// (the paper's compression-negative convention).
enum Voigt : int { XX = 0, YY = 1, ZZ = 2, XY = 3, YZ = 4, ZX = 5 };

/// Isotropic elastic moduli derived from (E, ν).
struct ElasticModuli {
  Real lambda = 0;  ///< Lamé's first parameter λ (Pa)
  Real mu = 0;      ///< shear modulus G = μ (Pa)
  Real bulk() const { return lambda + 2.0 * mu / 3.0; }
  Real pModulus() const { return lambda + 2.0 * mu; }  ///< constrained modulus λ + 2μ (Pa)
  static ElasticModuli fromYoungPoisson(Real E, Real nu);
};

/// Parameters of the linear elastic material.
struct ElasticParams {
  Real youngsModulus = 0;  ///< E (Pa), > 0
  Real poissonRatio = 0;   ///< ν (-), -1 < ν < 0.5
  Real density = 0;        ///< ρ (kg/m^3), > 0
};

/// A region's material as solid_input.h5 gives it: the model's name and its parameters by name
/// (the table's material rows; docs/formats.md "## solid_input.h5"). A model's parameters are
/// taken from it by name; parameters a model does not read stay in the map.
struct MaterialValues {
  std::string model;
  std::map<std::string, Real> numbers;
  std::map<std::string, std::string> texts;
  Real number(const std::string& name) const;  ///< throws InputError when absent
  const std::string& text(const std::string& name) const;
};

/// The elastic parameters (E, nu, rho) of a region's parameter map.
ElasticParams elasticParams(const MaterialValues& v);
/// The parameter map of an elastic region (model "elastic"; E, nu, rho): the inverse of
/// elasticParams, for inputs built in code.
MaterialValues elasticValues(const ElasticParams& p);

/// One chunk of elements handed to a material: strain increments in, stresses updated in place.
struct MaterialChunk {
  Index count = 0;                 ///< number of elements in the chunk
  const Real* dstrain[6] = {};     ///< strain increment Δε per Voigt component, [count] each
  Real* stress[6] = {};            ///< σ^n on entry, σ^{n+1} on exit (Pa), [count] each
  Real* const* history = nullptr;  ///< one [count] array per history variable (historyNames())
  Real dt = 0;                     ///< time step of the increment (s)
  int lanes = 0;                   ///< the element kernel's vector width (8: its AVX-512 path); 0 unknown
};

/// Constitutive model of one element block.
class Material {
 public:
  virtual ~Material() = default;
  /// Type name as written in solid_input.h5 (e.g. "elastic").
  virtual std::string typeName() const = 0;
  /// Mass density ρ (kg/m^3).
  virtual Real density() const = 0;
  /// Initial (elastic) moduli: wave speeds for the stable step, hourglass stiffness, and the
  /// stiffness-proportional damping stress.
  virtual ElasticModuli elasticModuli() const = 0;
  /// Names of per-element history variables (each gets one contiguous array in the block).
  virtual std::vector<std::string> historyNames() const { return {}; }
  /// Index (into historyNames()) of the history variable that accumulates the energy dissipated
  /// per unit volume (J/m^3, plasticity and damage), or -1 when the material dissipates nothing.
  /// The solver sums V times it for the energy balance's dissipation term.
  virtual int dissipationHistory() const { return -1; }
  /// Index (into historyNames()) of a per-element factor (0, 1] on the one-point element's
  /// hourglass stiffness, which the material keeps at its current stiffness relative to
  /// elasticModuli() (1: elastic), or -1 for none: the hourglass stiffness stays elastic.
  virtual int hourglassScaleHistory() const { return -1; }
  /// True when σ = C ε exactly (lets the fully integrated reference element be used).
  virtual bool isLinearElastic() const { return false; }
  /// Retardation time τ (s) of a viscous stress τ C:ε̇ the material adds to its elastic one (the
  /// Kelvin–Voigt model), 0 for none. It damps like stiffness-proportional Rayleigh damping with
  /// β = τ, so the solver shortens the stable step for it (Solver::stableStep).
  virtual Real viscousTime() const { return 0; }
  /// Set a material's per-element history from the elements' centres (x, y, z arrays of `count`)
  /// when a block is built and when an element is (re)activated: e.g. the directions of smeared
  /// reinforcement. Default: nothing (history starts at 0).
  virtual void initHistory(Index count, const Real* const centre[3], Real* const* history) const {
    (void)count, (void)centre, (void)history;
  }
  /// True when the material needs blockPass before each update of the block's stresses.
  virtual bool hasBlockPass() const { return false; }
  /// A serial pass over the whole block before the chunks' stress updates of one force
  /// evaluation: a material whose element law reads other elements' state (the reinforced
  /// lining's section: the strains of its face rows) derives it here from their history, i.e. from
  /// the last update, so the chunks' updates stay independent of their order and thread count.
  /// centre: the element centres (x, y, z arrays of `count`). Default: nothing.
  virtual void blockPass(Index count, const Real* const centre[3], Real* const* history) const {
    (void)count, (void)centre, (void)history;
  }
  /// Update the stresses of a chunk of elements from their strain increments.
  virtual void updateStressForElems(const MaterialChunk& chunk) const = 0;
};

/// Hooke's law in rate form: σ^{n+1} = σ^n + C : Δε.
class ElasticMaterial final : public Material {
 public:
  static constexpr const char* kName = "elastic";    ///< the registry's name (materials/registry.cpp)
  explicit ElasticMaterial(const ElasticParams& p);  // throws InputError on bad values
  std::string typeName() const override { return kName; }
  Real density() const override { return params_.density; }
  ElasticModuli elasticModuli() const override { return moduli_; }
  bool isLinearElastic() const override { return true; }
  void updateStressForElems(const MaterialChunk& chunk) const override;
  const ElasticParams& params() const { return params_; }

 private:
  ElasticParams params_;
  ElasticModuli moduli_;
};

/// The registry's factory of the elastic model (throws InputError on bad values).
std::shared_ptr<const Material> makeElasticMaterial(const MaterialValues& v);

}  // namespace tq
