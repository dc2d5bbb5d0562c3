/// @file material_mc.hpp
/// @brief Mohr–Coulomb elastoplastic material with tension cut-off and damage (paper eqs. 16–18;
///        docs/theory.md §3). Small strain, rate form, stresses tension positive; principal
///        stresses sorted σ1 ≤ σ2 ≤ σ3 (σ1 the most compressive, the paper's convention).
///
///  Yield (violated when > 0), with the damaged cohesion c_D = (1 − D) c:
///    shear    F_s = Nφ σ3 − σ1 − 2 c_D √Nφ          (= −f^s of eq. 16)
///    tension  F_t = σ3 − σt_eff,  σt_eff = min(σt, c_D cot φ)   (f^t of eq. 16; the cut-off
///             cannot lie beyond the Mohr–Coulomb apex c_D cot φ)
///  Flow: shear potential g_s = Nψ σ3 − σ1 (dilation angle ψ, default 0), tension associated.
///  Return: exact closest-point-type return in principal space (planes, edges, corners, apex
///  found by the active set that satisfies all Kuhn–Tucker conditions; σ^{n+1} = σ^tr − C:Δε^p).
///  Damage: κ_i = Σ |Δe^p_i| (cumulative plastic deviatoric strain along principal direction i),
///  D_i = 1 − exp(−R κ_i), D = min(1, √(D1² + D2² + D3²)); implicit in D (the returned stress
///  lies on the surface of the damaged cohesion of the end of the step); irreversible.
#pragma once

#include "tq/materials/material.hpp"

namespace tq {

/// What damage reduces (docs/theory.md §3).
enum class DamageEffect {
  /// Default, eq. (16) as written: the cohesion only, c_D = (1 − D) c. Stiffness, friction and
  /// σt are kept; the tensile capacity still falls once c_D cot φ < σt (the apex caps σt).
  Cohesion,
  /// Effective-stress damage (Lemaitre): σ = (1 − D) C : (ε − ε^p). Eq. (16) holds in the
  /// nominal stress with c_D = (1 − D) c, and the cut-off becomes (1 − D) σt; the stiffness is
  /// (1 − D) C. Plasticity runs on the effective stress σ/(1 − D) with the undamaged strengths.
  CohesionAndStiffness,
};
/// Parse "cohesion" | "cohesion_and_stiffness" (throws InputError).
DamageEffect parseDamageEffect(const std::string& name);
std::string damageEffectName(DamageEffect e);

/// Parameters of the Mohr–Coulomb damage material (all SI; angles in degrees as in the input).
struct MohrCoulombDamageParams {
  ElasticParams elastic;      ///< E (Pa), ν (-), ρ (kg/m^3)
  Real cohesion = 0;          ///< c (Pa), ≥ 0
  Real frictionAngle = 0;     ///< φ (degrees), 0 ≤ φ < 90
  Real dilationAngle = 0;     ///< ψ (degrees), 0 ≤ ψ ≤ φ; default 0 (no plastic volume change)
  Real tensileStrength = 0;   ///< σt (Pa), ≥ 0; capped at the apex c cot φ
  Real damageConstant = 100;  ///< R in eq. (18) (-); 0 switches damage off (perfect plasticity)
  DamageEffect damageEffect = DamageEffect::Cohesion;
};

/// The Mohr-Coulomb damage parameters of a region's parameter map (docs/formats.md "## solid_input.h5").
MohrCoulombDamageParams mohrCoulombDamageParams(const MaterialValues& v);
/// The parameter map of a Mohr-Coulomb damage region: the inverse of mohrCoulombDamageParams.
MaterialValues mohrCoulombDamageValues(const MohrCoulombDamageParams& p);

/// Names of the history variables, in order (one array each in the element block).
namespace mc_history {
enum : int {
  kPlasticXX = 0,  ///< plastic strain ε^p_xx (-)
  kPlasticYY,      ///< ε^p_yy
  kPlasticZZ,      ///< ε^p_zz
  kPlasticXY,      ///< engineering γ^p_xy = 2 ε^p_xy
  kPlasticYZ,      ///< γ^p_yz
  kPlasticZX,      ///< γ^p_zx
  kKappa1,         ///< κ1: cumulative plastic deviatoric strain along σ1 (most compressive) (-)
  kKappa2,         ///< κ2 along σ2
  kKappa3,         ///< κ3 along σ3 (most tensile)
  kDamage,         ///< D ∈ [0, 1]
  kDissipation,    ///< energy dissipated by plasticity and damage per unit volume (J/m^3)
  kCount
};
}  // namespace mc_history

/// Result of a return in principal space (exposed for tests).
struct PrincipalReturn {
  Real sigma[3] = {0, 0, 0};    ///< returned principal stresses, ascending (Pa)
  Real plastic[3] = {0, 0, 0};  ///< plastic strain increment along the same directions (-)
  int activeSet = -1;           ///< -1 elastic; otherwise the candidate index (docs)
};

/// The parts of a principal-space return that depend only on the elastic constants and the flow
/// factors (not on the cohesion or the cut-off): the yield planes' normals, their return
/// directions C : b and each active set's Gaussian elimination, pivots and multipliers. A material
/// whose return constants do not change with damage builds them once (MohrCoulombSurface::
/// returnTables); a return with them makes the very operations of one without (the same bits).
struct MohrCoulombReturnTables {
  static constexpr int kPlanes = 6;  ///< S13, S12, S23, T3, T2, T1 (material_mc.cpp)
  static constexpr int kSets = 12;   ///< the active sets, in the order they are tried
  struct Set {
    bool solvable = false;     ///< false where the set's system is degenerate
    int pivot[3] = {0, 1, 2};  ///< the row swapped into place at each column
    Real factor[3][3] = {};    ///< factor[c][i]: the multiple of pivot row c taken from row i
    Real reduced[3][3] = {};   ///< the eliminated matrix, by original row
  };
  Real a[kPlanes][3] = {};   ///< plane normals in sorted principal space
  Real Db[kPlanes][3] = {};  ///< return directions C : b_j (principal)
  Real youngs = 0, poisson = 0;
  Set sets[kSets];
};

/// Mohr–Coulomb surface with fixed strengths (one step, one element): the pure geometry of the
/// return, separated from damage so that it can be tested on its own.
struct MohrCoulombSurface {
  Real lambda = 0, mu = 0;  ///< elastic Lamé constants of the return (Pa)
  Real nPhi = 1;            ///< Nφ = (1 + sin φ)/(1 − sin φ)
  Real nPsi = 1;            ///< Nψ = (1 + sin ψ)/(1 − sin ψ)
  Real cohesionTerm = 0;    ///< 2 c √Nφ (Pa)
  Real tension = 0;         ///< σt_eff = min(σt, apex) (Pa)
  /// F_s and F_t at sorted principal stresses (Pa).
  Real shear(const Real s[3]) const { return nPhi * s[2] - s[0] - cohesionTerm; }
  Real tensile(const Real s[3]) const { return s[2] - tension; }
  /// Return sorted trial principal stresses to the surface (no-op if inside). `hint`: an active
  /// set to try first (the previous result of a nearby return). Throws std::runtime_error only if
  /// no candidate solves at all (degenerate parameters).
  PrincipalReturn returnMap(const Real trial[3], int hint = -1) const;
  /// The same return with tables built by returnTables() of a surface of the same λ, μ, Nφ, Nψ.
  PrincipalReturn returnMap(const MohrCoulombReturnTables& tables, const Real trial[3], int hint = -1) const;
  /// This surface's return tables (its strengths aside).
  MohrCoulombReturnTables returnTables() const;
};

/// Mohr–Coulomb elastoplastic damage material (eqs. 16–18).
class MohrCoulombDamageMaterial final : public Material {
 public:
  static constexpr const char* kName = "mohr_coulomb_damage";            ///< the registry's name
  explicit MohrCoulombDamageMaterial(const MohrCoulombDamageParams& p);  // throws InputError
  std::string typeName() const override { return kName; }
  Real density() const override { return params_.elastic.density; }
  ElasticModuli elasticModuli() const override { return moduli_; }
  std::vector<std::string> historyNames() const override;
  int dissipationHistory() const override { return mc_history::kDissipation; }
  void updateStressForElems(const MaterialChunk& chunk) const override;

  const MohrCoulombDamageParams& params() const { return params_; }
  /// The surface for damage D (cohesion and cut-off reduced as the damage effect says; for
  /// cohesion_and_stiffness this is the surface of the nominal stress).
  MohrCoulombSurface surface(Real damage) const;
  /// D from the cumulative plastic deviatoric strains κ (eqs. 17–18), clamped to [0, 1].
  Real damageFrom(const Real kappa[3]) const;

 private:
  /// The trial stress of an element whose trial may lie outside the surface (nominal for
  /// `cohesion`, effective for `cohesion_and_stiffness`); false for a fully damaged element under
  /// `cohesion_and_stiffness`, whose stress is then 0 (set here).
  bool plasticTrial(Real stressOld[6], const Real dstrain[6], Real damage, Real trial[6]) const;
  /// The rest of the update, from the trial's principal values ev (ascending) and directions
  /// (columns of V): the return, the damage, the history and the dissipation of element e.
  void plasticFinish(Real stressOld[6], const Real dstrain[6], Real* const* hist, Index e, const Real trial[6],
                     const Real ev[3], const Real V[3][3]) const;

  MohrCoulombDamageParams params_;
  ElasticModuli moduli_;
  MohrCoulombReturnTables tables_;  // of surface(0): damage changes only the strengths of a return
  Real nPhi_ = 1, nPsi_ = 1, sqrtNPhi_ = 1, cotPhi_ = 0;
  Real dpSlope_ = 0;  // √(1 + Nφ² − (Nφ−1)²/3): inscribed-cone bound of the shear function
};

/// The registry's factory of the Mohr-Coulomb damage model (throws InputError on bad values).
std::shared_ptr<const Material> makeMohrCoulombDamageMaterial(const MaterialValues& v);

}  // namespace tq
