/// @file material_rc.hpp
/// @brief Reinforced concrete with smeared reinforcement for the lining's one-point hex8 elements
///        (docs/solid_solver.md "Reinforced concrete lining"). Concrete and steel act in the
///        hoop (θ) and axial (y) directions of a ring about the tunnel axis (y, centre (x_c, z_c)
///        in the x–z plane): concrete by an equivalent-uniaxial total-strain law (parabola–rectangle
///        in compression, cracking at f_ct, tension stiffening of EN 1992-1-1 §7.4.3 in a zone
///        about each bar layer that widens to the whole section as the section becomes a tie
///        (blockPass), linear softening in the rest), steel elastic–perfectly
///        plastic bars smeared over the elements whose radial extent holds the bar layer. The
///        element's stress is the composite one (concrete + ρ σ_s), so the ring forces integrated
///        from the element stresses include the bars.
#pragma once

#include "tq/materials/material.hpp"

namespace tq {

/// Parameters of the reinforced-concrete material (SI units).
struct ReinforcedConcreteParams {
  ElasticParams elastic;                    ///< concrete E (Pa), ν (-), ρ (kg/m^3)
  Real fc = 0;                              ///< compressive strength of the parabola–rectangle (Pa, > 0)
  Real fct = 0;                             ///< tensile strength (Pa, > 0)
  Real epsC2 = 2.0e-3;                      ///< strain at the top of the parabola (-)
  Real epsCu2 = 3.5e-3;                     ///< ultimate compressive strain: beyond it the concrete has crushed (-)
  Real exponent = 2.0;                      ///< parabola exponent n (-)
  Real plainSoftening = 2;                  ///< plain concrete softens linearly to 0 at this multiple of f_ct/E
  Real beta = 1.0;                          ///< β of EN 1992-1-1 eq. (7.19): 1 short-term, 0.5 sustained/repeated
  Real Es = 200e9;                          ///< steel modulus (Pa)
  Real fy = 500e6;                          ///< steel yield strength (Pa)
  Real asInnerHoop = 0, asOuterHoop = 0;    ///< hoop bar area per metre of tunnel (m^2/m)
  Real asInnerAxial = 0, asOuterAxial = 0;  ///< axial bar area per metre of circumference (m^2/m)
  Real axisDistance = 0.05;                 ///< face to bar centroid (m), both faces
  Real centreX = 0, centreZ = 0;            ///< ring centre in the x–z plane (m)
  Real innerRadius = 0;                     ///< lining inner radius (m)
  Real thickness = 0;                       ///< lining thickness (m)
  Real layers = 1;                          ///< elements through the thickness (equal radial extents)
};

/// History variables, per element.
namespace rc_history {
enum : int {
  kCos = 0,   ///< cos θ of the element centre about the ring centre
  kSin,       ///< sin θ (θ from +x towards +z)
  kRhoHoop,   ///< hoop steel ratio of the element (bar area / element's radial extent)
  kRhoAxial,  ///< axial steel ratio
  kEpsXX,     ///< total strain, 6 Voigt components (engineering shears)
  kEpsYY,
  kEpsZZ,
  kEpsXY,
  kEpsYZ,
  kEpsZX,
  kTensionHoop,        ///< largest equivalent uniaxial tensile strain reached, hoop (-)
  kTensionAxial,       ///< axial
  kCompressionHoop,    ///< largest equivalent uniaxial compressive strain reached (> 0), hoop
  kCompressionAxial,   ///< axial
  kPlasticHoop,        ///< steel plastic strain, hoop
  kPlasticAxial,       ///< axial
  kStiffeningHoop,     ///< ρ_eff of the tension-stiffening tie (0: plain softening), hoop
  kStiffeningAxial,    ///< axial
  kBandFractionHoop,   ///< the part of the element's radial extent inside the stiffening zone, hoop
  kBandFractionAxial,  ///< axial
  kFaceInner,  ///< 1 + the block index of the inner face row's element of this section (-1: none, 0: not searched)
  kFaceOuter,  ///< the outer face row's
  kSectionShareHoop,   ///< s (0–1): how far the section is a tie, from its face rows' hoop strains (blockPass)
  kSectionShareAxial,  ///< axial
  kDamage,  ///< "damage": the concrete's largest loss of secant stiffness in tension, 1 − σ_c/(E e) (0 uncracked; the
            ///< crack pattern)
  kHourglassScale,  ///< the element's smallest composite secant ratio σ/σ_elastic over both directions (1 elastic):
                    ///< the factor on its hourglass stiffness
  kCount
};
}  // namespace rc_history

/// The element-level laws, public for the tests and the section integration.
namespace rc_law {
/// The smallest factor on an element's hourglass stiffness (a crushed or open-cracked element
/// keeps this much of it, so that its hourglass modes keep some stiffness).
constexpr Real kHourglassFloor = 0.05;
/// Concrete's uniaxial stress (Pa, tension positive) at equivalent uniaxial strain e with the
/// loading memory (largest tension eMax ≥ 0, largest compression eMinAbs ≥ 0 reached, including
/// this e); rho: the steel ratio of the element in that direction (0: plain softening).
Real concrete(const ReinforcedConcreteParams& p, Real e, Real eMax, Real eMinAbs, Real rho);
/// The tension-stiffening tie's ratio ρ_eff = A_s / h_c,ef of an element whose centre lies at
/// radius r within h_c,ef = min(2a, h/2) of a face (a the axis distance: the concrete symmetric
/// about the bar, the bar at its centroid as in the tie of EN 1992-1-1 Fig. 7.1), 0 elsewhere:
/// the band's concrete stiffens, the rest softens as plain concrete (docs/solid_solver.md). The
/// section share s (0–1, sectionShare) widens each face's zone from h_c,ef to h/2: at s = 1 (a section
/// wholly in tension) the whole section is the tie of its bars, as EN 1992-1-1 §7.4.3's N_cr/N takes it.
Real stiffeningRatio(const ReinforcedConcreteParams& p, Real r, Real asInner, Real asOuter, Real share = 0);
/// The part (0–1) of the radial extent of the element centred at r that lies in a stiffening zone:
/// the zone's tie law acts on it, plain softening on the rest (a coarse mesh keeps the zone's force).
Real bandFraction(const ReinforcedConcreteParams& p, Real r, Real share = 0);
/// How far a section is a tie (0 bending, 1 tension) from the strains of its two face rows (the
/// element rows at the inner and outer face, one direction): with ψ = min/max of the two (the
/// larger > 0), s = clamp(2ψ, 0, 1): one face compressed (ψ ≤ 0) 0, both faces stretched with
/// the smaller at least half the larger 1, linear between.
Real sectionShare(Real strainInner, Real strainOuter);
/// Steel's uniaxial stress (Pa) at strain eps, plastic strain updated in place (elastic–perfectly plastic).
Real steel(const ReinforcedConcreteParams& p, Real eps, Real& epsPlastic);
/// The hoop or axial steel ratio of an element whose centre lies at radius r from the ring centre:
/// each bar layer is shared between the two element rows whose centres straddle it so that the
/// smeared force has the bar's radius as its centroid (all of it in the face row when the bar lies
/// outside the row's centre).
Real steelRatio(const ReinforcedConcreteParams& p, Real r, Real asInner, Real asOuter);
}  // namespace rc_law

/// Reinforced concrete with smeared bars, total-strain form in the ring's hoop and axial directions.
class ReinforcedConcreteMaterial final : public Material {
 public:
  static constexpr const char* kName = "reinforced_concrete";              ///< the registry's name
  explicit ReinforcedConcreteMaterial(const ReinforcedConcreteParams& p);  // throws InputError
  std::string typeName() const override { return kName; }
  Real density() const override { return params_.elastic.density; }
  /// Concrete's elastic moduli with the bars' axial stiffness on the constrained modulus (the
  /// stable step sees the stiffest element: ρ_max E_s added).
  ElasticModuli elasticModuli() const override { return moduli_; }
  std::vector<std::string> historyNames() const override;
  void initHistory(Index count, const Real* const centre[3], Real* const* history) const override;
  bool hasBlockPass() const override { return true; }
  /// The hourglass stiffness follows the element's secant stiffness (history kHourglassScale).
  int hourglassScaleHistory() const override { return rc_history::kHourglassScale; }
  /// Each element's section share s (hoop, axial) from its section's face rows (their strains of
  /// the last update), and from it the element's stiffening ratio and zone fraction. The face rows
  /// are found once (and after an element is re-activated) among the block's elements: the
  /// element of the first and of the last row whose centre lies on this element's ray (same
  /// angle about the ring centre and same y within a quarter of a row's thickness). Where none is
  /// found (an unstructured lining), s = 0: bending's zone. (Refused on MPI ranks, whose
  /// blocks split the ring's face rows.)
  void blockPass(Index count, const Real* const centre[3], Real* const* history) const override;
  void updateStressForElems(const MaterialChunk& chunk) const override;
  const ReinforcedConcreteParams& params() const { return params_; }

 private:
  ReinforcedConcreteParams params_;
  ElasticModuli moduli_;    ///< with the steel: wave speed bound
  ElasticModuli concrete_;  ///< the concrete's own
};

/// The reinforced-concrete parameters of a region's parameter map.
ReinforcedConcreteParams reinforcedConcreteParams(const MaterialValues& v);
/// The registry's factory of the reinforced-concrete model.
std::shared_ptr<const Material> makeReinforcedConcreteMaterial(const MaterialValues& v);

}  // namespace tq
