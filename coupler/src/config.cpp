// Coupling configuration: names, validation, and the item-by-item comparison of the handshake.
#include "tq/coupler/config.hpp"

#include <array>
#include <cmath>
#include <set>
#include <sstream>
#include <utility>

#include "tq/coupler/errors.hpp"

namespace tq::coupler {

namespace {

/// An enum's names in the order its values are offered ("use a, b or c").
template <class E, size_t N>
using Names = std::array<std::pair<E, const char*>, N>;

template <class E, size_t N>
const char* nameIn(const Names<E, N>& names, E k) {
  for (const auto& [value, name] : names)
    if (value == k) return name;
  return "?";
}

/// The value named `s`, or a ConfigError naming `what` and every name it could have been.
template <class E, size_t N>
E parseIn(const Names<E, N>& names, const std::string& s, const char* what) {
  for (const auto& [value, name] : names)
    if (s == name) return value;
  std::string options;
  for (size_t i = 0; i < N; ++i) options += (i == 0 ? "" : i + 1 == N ? " or " : ", ") + std::string(names[i].second);
  throw ConfigError("unknown " + std::string(what) + " '" + s + "': use " + options);
}

constexpr Names<SchemeKind, 3> kSchemes{
    {{SchemeKind::Explicit, "explicit"}, {SchemeKind::Paper, "paper"}, {SchemeKind::Implicit, "implicit"}}};
constexpr Names<AccelerationKind, 4> kAccelerations{{{AccelerationKind::None, "none"},
                                                     {AccelerationKind::Constant, "constant"},
                                                     {AccelerationKind::Aitken, "aitken"},
                                                     {AccelerationKind::IqnIls, "iqn-ils"}}};
constexpr Names<PredictorKind, 3> kPredictors{
    {{PredictorKind::Constant, "constant"}, {PredictorKind::Linear, "linear"}, {PredictorKind::Damped, "damped"}}};
constexpr Names<ResidualScale, 2> kResidualScales{
    {{ResidualScale::Current, "current"}, {ResidualScale::Largest, "largest"}}};
constexpr Names<MapKind, 2> kMapKinds{{{MapKind::Coincident, "coincident"}, {MapKind::Projection, "projection"}}};

}  // namespace

const char* schemeName(SchemeKind k) { return nameIn(kSchemes, k); }
const char* accelerationName(AccelerationKind k) { return nameIn(kAccelerations, k); }
const char* predictorName(PredictorKind k) { return nameIn(kPredictors, k); }
const char* residualScaleName(ResidualScale k) { return nameIn(kResidualScales, k); }
const char* mapKindName(MapKind k) { return nameIn(kMapKinds, k); }
SchemeKind parseScheme(const std::string& s) { return parseIn(kSchemes, s, "coupling scheme"); }
AccelerationKind parseAcceleration(const std::string& s) { return parseIn(kAccelerations, s, "acceleration"); }
PredictorKind parsePredictor(const std::string& s) { return parseIn(kPredictors, s, "predictor"); }
ResidualScale parseResidualScale(const std::string& s) { return parseIn(kResidualScales, s, "residual scale"); }
MapKind parseMapKind(const std::string& s) { return parseIn(kMapKinds, s, "interface map"); }

void CouplingConfig::validate() const {
  auto bad = [](const std::string& m) { throw ConfigError("coupling configuration: " + m); };
  if (first.empty() || second.empty()) bad("both participant names (first, second) are needed");
  if (first == second) bad("the two participants have the same name '" + first + "'");
  if (!(windowSize > 0) || !std::isfinite(windowSize))
    bad("window size must be a positive time in s, got " + std::to_string(windowSize));
  if (scheme == SchemeKind::Implicit) {
    if (maxIterations < 2) bad("implicit scheme needs max iterations >= 2");
    if (!(tolerance > 0)) bad("implicit scheme needs a positive tolerance");
  } else if (predictor != PredictorKind::Constant) {
    bad(std::string("predictor ") + predictorName(predictor) + " needs the implicit scheme (the " + schemeName(scheme) +
        " scheme has no iterations to start); use predictor constant");
  } else if (residualScale != ResidualScale::Current) {
    bad(std::string("residual scale ") + residualScaleName(residualScale) + " needs the implicit scheme (the " +
        schemeName(scheme) + " scheme tests no convergence); use residual scale current");
  }
  if (!(initialRelaxation > 0 && initialRelaxation <= 1))
    bad("initial relaxation must be in (0, 1], got " + std::to_string(initialRelaxation));
  if (reuse < 0 || reuse > 1000) bad("reuse must be 0 to 1000 windows, got " + std::to_string(reuse));
  if (reuse > 0 && (scheme != SchemeKind::Implicit || acceleration != AccelerationKind::IqnIls))
    bad("reuse " + std::to_string(reuse) +
        " keeps IQN-ILS columns: it needs scheme implicit and "
        "acceleration iqn-ils; use reuse 0");
  std::set<std::string> names;
  for (const auto& m : meshes) {
    if (m.name.empty()) bad("a mesh without a name");
    if (!names.insert(m.name).second) bad("mesh '" + m.name + "' declared twice");
    if (!m.mappingSide.empty() && m.mappingSide != first && m.mappingSide != second)
      bad("mesh '" + m.name + "': mapping side '" + m.mappingSide + "' is not a participant");
    if (!(m.tolerance > 0)) bad("mesh '" + m.name + "': tolerance must be positive");
  }
  std::set<std::pair<std::string, std::string>> fnames;
  for (const auto& f : fields) {
    if (!names.count(f.mesh)) bad("field '" + f.name + "' on unknown mesh '" + f.mesh + "'");
    if (!fnames.insert({f.mesh, f.name}).second) bad("field '" + f.name + "' on mesh '" + f.mesh + "' declared twice");
    if (f.components < 1 || f.components > 9) bad("field '" + f.name + "': components must be 1..9");
    if (f.writer != first && f.writer != second)
      bad("field '" + f.name + "': writer '" + f.writer + "' is not a participant");
    if (!(f.absoluteTolerance >= 0) || !std::isfinite(f.absoluteTolerance))
      bad("field '" + f.name + "': absolute tolerance must be >= 0 and finite, got " +
          std::to_string(f.absoluteTolerance));
  }
}

const MeshSpec& CouplingConfig::mesh(const std::string& name) const {
  for (const auto& m : meshes)
    if (m.name == name) return m;
  throw ConfigError("unknown interface mesh '" + name + "'");
}

int CouplingConfig::fieldIndex(const std::string& m, const std::string& n) const {
  for (std::size_t i = 0; i < fields.size(); ++i)
    if (fields[i].mesh == m && fields[i].name == n) return int(i);
  return -1;
}

std::string CouplingConfig::partnerOf(const std::string& p) const {
  if (p == first) return second;
  if (p == second) return first;
  throw ConfigError("participant '" + p + "' is not in the coupling configuration (which has '" + first + "' and '" +
                    second + "')");
}

std::string describeDifferences(const CouplingConfig& a, const CouplingConfig& b, const std::string& partner) {
  std::ostringstream s;
  s.precision(17);
  auto diff = [&](const std::string& what, const auto& mine, const auto& theirs) {
    if (!(mine == theirs)) s << "\n  - " << what << ": here " << mine << ", " << partner << " has " << theirs;
  };
  diff("units", a.units, b.units);
  diff("first participant", a.first, b.first);
  diff("second participant", a.second, b.second);
  diff("scheme", std::string(schemeName(a.scheme)), std::string(schemeName(b.scheme)));
  diff("window size (s)", a.windowSize, b.windowSize);
  diff("number of windows", a.maxWindows, b.maxWindows);
  diff("max iterations", a.maxIterations, b.maxIterations);
  diff("tolerance", a.tolerance, b.tolerance);
  diff("acceleration", std::string(accelerationName(a.acceleration)), std::string(accelerationName(b.acceleration)));
  diff("initial relaxation", a.initialRelaxation, b.initialRelaxation);
  diff("predictor", std::string(predictorName(a.predictor)), std::string(predictorName(b.predictor)));
  diff("residual scale", std::string(residualScaleName(a.residualScale)),
       std::string(residualScaleName(b.residualScale)));
  diff("reuse (windows)", a.reuse, b.reuse);
  diff("number of meshes", a.meshes.size(), b.meshes.size());
  for (std::size_t i = 0; i < std::min(a.meshes.size(), b.meshes.size()); ++i) {
    const auto &x = a.meshes[i], &y = b.meshes[i];
    const std::string p = "mesh #" + std::to_string(i) + " ";
    diff(p + "name", x.name, y.name);
    diff(p + "'" + x.name + "' map", std::string(mapKindName(x.mapping)), std::string(mapKindName(y.mapping)));
    diff(p + "'" + x.name + "' mapping side", a.mappingSideOf(x), b.mappingSideOf(y));
    diff(p + "'" + x.name + "' tolerance (m)", x.tolerance, y.tolerance);
  }
  diff("number of fields", a.fields.size(), b.fields.size());
  for (std::size_t i = 0; i < std::min(a.fields.size(), b.fields.size()); ++i) {
    const auto &x = a.fields[i], &y = b.fields[i];
    const std::string p = "field #" + std::to_string(i) + " ";
    diff(p + "mesh", x.mesh, y.mesh);
    diff(p + "name", x.name, y.name);
    diff(p + "'" + x.name + "' components", x.components, y.components);
    diff(p + "'" + x.name + "' writer", x.writer, y.writer);
    diff(p + "'" + x.name + "' constraint",
         std::string(x.constraint == MapConstraint::Consistent ? "consistent" : "conservative"),
         std::string(y.constraint == MapConstraint::Consistent ? "consistent" : "conservative"));
    diff(p + "'" + x.name + "' absolute tolerance", x.absoluteTolerance, y.absoluteTolerance);
  }
  return s.str();
}

}  // namespace tq::coupler
