#pragma once
/// @file config.hpp
/// What both participants must agree on. `tunnelquake run` writes the same configuration for
/// both sides; the handshake compares the two copies item by item and refuses to couple when
/// any differs.

#include <cstdint>
#include <string>
#include <vector>

#include "tq/coupler/maps.hpp"

namespace tq::coupler {

/// Coupling scheme per window (ARCHITECTURE.md §5).
enum class SchemeKind : std::uint8_t {
  /// Serial (Gauss–Seidel) staggered: one exchange each way per window, no iterations.
  Explicit = 0,
  /// The paper's §2.2.3 predictor–corrector: exactly two passes per window (predictor,
  /// corrector), no convergence test; both sides roll back between the passes.
  Paper = 1,
  /// Serial implicit: passes repeated until the relative residual is below `tolerance`.
  Implicit = 2,
};

/// Acceleration of the fixed-point iteration, applied by the second participant to the data it
/// writes (normally the fluid force).
enum class AccelerationKind : std::uint8_t {
  None = 0,      ///< plain fixed-point iteration
  Constant = 1,  ///< constant under-relaxation by `initialRelaxation`
  Aitken = 2,    ///< Aitken's dynamic relaxation, restarted each window at `initialRelaxation`
  IqnIls = 3,    ///< interface quasi-Newton, inverse least squares (Degroote et al. 2009)
};

/// What the implicit scheme's relative residual of a field is measured against (the second
/// participant's convergence test).
enum class ResidualScale : std::uint8_t {
  /// ‖a‖ of the pass itself: every window converges to the tolerance of its own values.
  Current = 0,
  /// the larger of ‖a‖ of the pass and the largest ‖a‖ of the field in any earlier accepted
  /// window: after the strongest motion a window converges to the tolerance of the largest
  /// values the interface has carried, not of its own smaller ones.
  Largest = 1,
};

/// First iterate of an implicit window (the data the second participant writes, normally the
/// fluid force). Both participants must start the window's pass 0 from the same value.
enum class PredictorKind : std::uint8_t {
  /// x⁰_{w+1} = x_w: the last window's converged value; a window needs at least 2 passes.
  Constant = 0,
  /// x⁰_{w+1} = 2 x_w − x_{w−1} (x_{−1} = the initial values): linear extrapolation of the
  /// values the first participant applied in the last pass of each window; a window whose pass-0 fixed-point residual
  /// ‖H(x⁰) − x⁰‖ is already below
  /// the tolerance completes after that single pass (docs/coupler.md "Predictor").
  Linear = 1,
  /// x⁰_{w+1} = x_w + ¾ (x_w − x_{w−1}): the linear extrapolation with three quarters of its slope.
  /// As a recursion of windows accepted in one pass its roots are 1 and ¾ (linear's: 1 twice), so
  /// a slope error from an accepted residual decays by ¾ a window instead of persisting; pass 0
  /// ends the window as with Linear.
  Damped = 2,
};

/// Whether the predictor extrapolates the applied values (Linear, Damped): both sides start pass 0
/// from extrapolatedValue(), and a window whose pass-0 residual is within the tolerance ends there.
constexpr bool extrapolates(PredictorKind k) { return k != PredictorKind::Constant; }

/// The first iterate of window w+1 from the values applied in windows w and w−1, value by value
/// (Linear or Damped). One function for both participants, so that they start from the same value.
inline double extrapolatedValue(PredictorKind k, double applied, double previous) {
  return k == PredictorKind::Damped ? applied + 0.75 * (applied - previous) : 2.0 * applied - previous;
}

const char* schemeName(SchemeKind k);
const char* predictorName(PredictorKind k);
PredictorKind parsePredictor(const std::string& s);
const char* residualScaleName(ResidualScale k);
ResidualScale parseResidualScale(const std::string& s);
const char* accelerationName(AccelerationKind k);
const char* mapKindName(MapKind k);
SchemeKind parseScheme(const std::string& s);
AccelerationKind parseAcceleration(const std::string& s);
MapKind parseMapKind(const std::string& s);

/// One named interface mesh. Each participant gives its own vertices for it; the participant
/// named `mappingSide` maps between its vertices and the partner's.
struct MeshSpec {
  std::string name;
  MapKind mapping = MapKind::Coincident;
  std::string mappingSide;  ///< empty: the first participant maps
  double tolerance = 1e-6;  ///< m: coincidence tolerance, or largest projection distance
};

/// One named vector field on an interface mesh, written by one participant, read by the other.
struct FieldSpec {
  std::string mesh;
  std::string name;
  int components = 3;
  std::string writer;  ///< participant name
  /// Consistent for motion-like data (interpolated), conservative for force-like data
  /// (totals preserved).
  MapConstraint constraint = MapConstraint::Consistent;
  /// Implicit scheme: absolute convergence floor in the field's own units (m/s, m, N), on the
  /// root mean square of the residual over the field's values: a pass whose residual of this
  /// field is below it counts as converged for this field whatever the relative residual
  /// (a wall at rest, round-off sized motion). 0 = none (relative test only).
  double absoluteTolerance = 0.0;
};

struct CouplingConfig {
  std::string first;   ///< participant that sends first in every window (the solid)
  std::string second;  ///< the other (the fluid); it tests convergence and accelerates
  std::string units = "SI(m,kg,s,N,Pa)";
  SchemeKind scheme = SchemeKind::Implicit;
  double windowSize = 0.0;  ///< s, coupling window Δt_c
  std::uint64_t maxWindows = 0;
  int maxIterations = 20;   ///< implicit only; the paper scheme always does 2
  double tolerance = 1e-4;  ///< implicit: relative residual of every exchanged field
  AccelerationKind acceleration = AccelerationKind::Aitken;
  double initialRelaxation = 0.5;
  PredictorKind predictor = PredictorKind::Constant;     ///< implicit only
  ResidualScale residualScale = ResidualScale::Current;  ///< implicit only
  /// IQN-ILS: the secant columns of this many earlier windows are kept (IQN-ILS(reuse)), so a
  /// window's first correction is already a quasi-Newton step; 0 = each window starts afresh.
  int reuse = 0;
  std::vector<MeshSpec> meshes;
  std::vector<FieldSpec> fields;

  /// Throws ConfigError naming the offending item.
  void validate() const;
  const MeshSpec& mesh(const std::string& name) const;
  int fieldIndex(const std::string& mesh, const std::string& name) const;  ///< -1 if none
  std::string partnerOf(const std::string& participant) const;
  std::string mappingSideOf(const MeshSpec& m) const { return m.mappingSide.empty() ? first : m.mappingSide; }
};

/// Human-readable list of the differences between two configurations ("" when equal).
std::string describeDifferences(const CouplingConfig& mine, const CouplingConfig& theirs,
                                const std::string& partnerName);

}  // namespace tq::coupler
