// solid_input.h5 version 2: stages, in-situ stress, hydrostatic pressure, the rock-lining
// interface, seismic boundaries and the incident motion (docs/formats.md "## solid_input.h5").
#include "input_staged.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "h5util.hpp"

namespace tq {

namespace {

struct Where {
  std::string file;
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError("solid input '" + file + "', " + where + ": " + what);
  }
};

std::string listOf(const std::set<std::string>& s) {
  std::string out;
  for (const auto& k : s) out += " " + k;
  return out;
}

void onlyKeys(const Where& c, hid_t obj, const std::string& w, const std::set<std::string>& allowed) {
  for (const auto& a : h5::attrNames(obj))
    if (!allowed.count(a)) c.fail(w, "unknown attribute '" + a + "' (allowed:" + listOf(allowed) + ")");
}

void onlyMembers(const Where& c, hid_t g, const std::string& w, const std::set<std::string>& allowed) {
  for (const auto& m : h5::members(g))
    if (!allowed.count(m)) c.fail(w, "unknown entry '" + m + "' (allowed:" + listOf(allowed) + ")");
}

Real number(const Where& c, hid_t obj, const std::string& w, const std::string& key, Real def, Real lo = -1e300,
            bool required = false) {
  if (!h5::hasAttr(obj, key)) {
    if (required) c.fail(w, "attribute '" + key + "' is required");
    return def;
  }
  Real v = 0;
  try {
    v = h5::readDoubleAttr(obj, key);
  } catch (const InputError& e) {
    c.fail(w, e.what());
  }
  if (!std::isfinite(v)) c.fail(w, "attribute '" + key + "' is not finite");
  if (v < lo) {
    std::ostringstream os;
    os << "attribute '" << key << "' = " << v << " must be >= " << lo;
    c.fail(w, os.str());
  }
  return v;
}

std::string text(const Where& c, hid_t obj, const std::string& w, const std::string& key, const std::string& def) {
  if (!h5::hasAttr(obj, key)) return def;
  try {
    return h5::readStringAttr(obj, key);
  } catch (const InputError& e) {
    c.fail(w, e.what());
  }
}

/// A list of names: a string-list attribute or one comma-separated string.
std::vector<std::string> names(const Where& c, hid_t obj, const std::string& w, const std::string& key) {
  std::vector<std::string> raw;
  try {
    raw = h5::readStringListAttr(obj, key);
  } catch (const InputError& e) {
    c.fail(w, e.what());
  }
  std::vector<std::string> out;
  for (const auto& r : raw) {
    std::stringstream ss(r);
    std::string item;
    while (std::getline(ss, item, ',')) {
      item.erase(0, item.find_first_not_of(" \t"));
      item.erase(item.find_last_not_of(" \t") + 1);
      if (!item.empty()) out.push_back(item);
    }
  }
  return out;
}

bool flag(const Where& c, hid_t obj, const std::string& w, const std::string& key, bool def) {
  const Real v = number(c, obj, w, key, def ? 1 : 0);
  if (v != 0 && v != 1) c.fail(w, "attribute '" + key + "' must be 0 or 1");
  return v == 1;
}

}  // namespace

void readStagedInput(hid_t f, SolidInput& in) {
  const Where c{in.path};
  StagedInput& S = in.staged;
  S.present = true;
  S.condition = text(c, f, "root", "condition", "");
  // /stages
  if (!h5::exists(f, "/stages"))
    c.fail("/stages", "group is required in version 2 (attribute sequence, e.g. \"in_situ,excavation,lining,"
                      "hydrostatic,seismic\")");
  {
    auto g = h5::openGroup(f, "/stages");
    const std::string w = "/stages";
    onlyKeys(c, g, w, {"sequence", "relaxation_tolerance", "relaxation_max_steps", "mass_scaling",
                       "equilibrium_correction", "lining_region", "release_fraction"});
    onlyMembers(c, g, w, {});
    if (!h5::hasAttr(g, "sequence")) c.fail(w, "attribute 'sequence' is required");
    S.stages.sequence = names(c, g, w, "sequence");
    size_t at = 0;
    for (const auto& s : S.stages.sequence) {
      const auto it = std::find(kStageOrder.begin(), kStageOrder.end(), s);
      if (it == kStageOrder.end())
        c.fail(w, "unknown stage '" + s + "' (stages, in this order: in_situ, excavation, lining, hydrostatic, seismic)");
      const size_t k = size_t(it - kStageOrder.begin());
      if (k < at) c.fail(w, "stage '" + s + "' is out of order or repeated (the order is in_situ, excavation, "
                            "lining, hydrostatic, seismic)");
      at = k + 1;
    }
    if (S.stages.sequence.empty()) c.fail(w, "sequence is empty");
    S.stages.tolerance = number(c, g, w, "relaxation_tolerance", 1e-4, 0);
    if (!(S.stages.tolerance > 0 && S.stages.tolerance < 1)) c.fail(w, "relaxation_tolerance must lie in (0, 1)");
    S.stages.maxSteps = Index(number(c, g, w, "relaxation_max_steps", 50000, 1));
    S.stages.massScaling = flag(c, g, w, "mass_scaling", true);
    S.stages.equilibriumCorrection = flag(c, g, w, "equilibrium_correction", true);
    S.stages.liningRegion = text(c, g, w, "lining_region", "lining");
    S.stages.releaseFraction = number(c, g, w, "release_fraction", 1);
    if (!(S.stages.releaseFraction >= 0 && S.stages.releaseFraction <= 1)) {
      std::ostringstream os;
      os << "release_fraction = " << S.stages.releaseFraction
         << " must lie in [0, 1] (the fraction of the excavation load released before the lining is active; "
            "case: stages.release_fraction)";
      c.fail(w, os.str());
    }
    if (S.stages.releaseFraction < 1 && !(S.stages.has("excavation") && S.stages.has("lining")))
      c.fail(w, "release_fraction < 1 holds part of the excavation load until the lining stage: the sequence needs "
                "both 'excavation' and 'lining' (or set release_fraction to 1)");
  }
  // /in_situ
  if (h5::exists(f, "/in_situ")) {
    auto g = h5::openGroup(f, "/in_situ");
    const std::string w = "/in_situ";
    onlyKeys(c, g, w, {"kx", "ky", "kz", "gravity", "density", "z_top", "surcharge"});
    onlyMembers(c, g, w, {});
    InSituInput& I = S.inSitu;
    I.present = true;
    I.kx = number(c, g, w, "kx", 1, 0);
    I.ky = number(c, g, w, "ky", 1, 0);
    I.kz = number(c, g, w, "kz", 1, 0);
    I.gravity = number(c, g, w, "gravity", 0, 0);
    I.density = number(c, g, w, "density", 0, 0);
    I.zTop = number(c, g, w, "z_top", std::numeric_limits<Real>::quiet_NaN());
    I.surcharge = number(c, g, w, "surcharge", 0, 0);
    if (I.gravity > 0) {
      if (in.options.gravity[2] != 0 && in.options.gravity[2] != -I.gravity)
        c.fail(w, "gravity is given twice (/solver gravity_z and /in_situ gravity) with different values; "
                  "give it once, in /in_situ");
      in.options.gravity[2] = -I.gravity;
    }
  }
  if (S.stages.has("in_situ") && !S.inSitu.present)
    c.fail("/in_situ", "group is required by the in_situ stage (attributes kx, ky, kz, gravity)");
  // /hydrostatic
  if (h5::exists(f, "/hydrostatic")) {
    auto g = h5::openGroup(f, "/hydrostatic");
    const std::string w = "/hydrostatic";
    onlyKeys(c, g, w, {"face", "pressure_at_axis", "unit_weight", "z_axis"});
    onlyMembers(c, g, w, {});
    HydrostaticInput& H = S.hydrostatic;
    H.present = true;
    H.face = text(c, g, w, "face", "lining_inner");
    H.pressureAtAxis = number(c, g, w, "pressure_at_axis", 0, 0, true);
    H.unitWeight = number(c, g, w, "unit_weight", 0, 0);
    H.zAxis = number(c, g, w, "z_axis", 0, -1e300, H.unitWeight > 0);
    in.requiredFaces.push_back(H.face);
  }
  if (S.stages.has("hydrostatic") && !S.hydrostatic.present)
    c.fail("/hydrostatic", "group is required by the hydrostatic stage (pressure_at_axis, unit_weight, z_axis)");
  // /interfaces/rock_lining
  if (h5::exists(f, "/interfaces")) {
    auto g = h5::openGroup(f, "/interfaces");
    onlyMembers(c, g, "/interfaces", {"rock_lining"});
    onlyKeys(c, g, "/interfaces", {});
    if (h5::exists(g, "rock_lining")) {
      auto gg = h5::openGroup(g, "rock_lining");
      const std::string w = "/interfaces/rock_lining";
      onlyKeys(c, gg, w, {"model", "static_friction", "dynamic_friction", "cohesion", "after_failure"});
      onlyMembers(c, gg, w, {});
      InterfaceInput& R = S.rockLining;
      R.present = true;
      R.model = text(c, gg, w, "model", "bonded");
      if (R.model != "bonded" && R.model != "dynamic_contact")
        c.fail(w, "model '" + R.model + "' is not one of bonded, dynamic_contact");
      R.staticFriction = number(c, gg, w, "static_friction", 0.6, 0);
      R.dynamicFriction = number(c, gg, w, "dynamic_friction", 0.6, 0);
      R.cohesion = number(c, gg, w, "cohesion", 0, 0);
      R.afterFailure = text(c, gg, w, "after_failure", "cohesion_lost");
    }
  }
  // /boundaries
  if (h5::exists(f, "/boundaries")) {
    auto g = h5::openGroup(f, "/boundaries");
    onlyMembers(c, g, "/boundaries", {"bottom", "free_field", "periodic"});
    onlyKeys(c, g, "/boundaries", {});
    if (h5::exists(g, "bottom")) {
      auto gg = h5::openGroup(g, "bottom");
      const std::string w = "/boundaries/bottom";
      onlyKeys(c, gg, w, {"face", "type", "distance", "alpha_n", "alpha_t", "rho", "cp", "cs", "column_face"});
      onlyMembers(c, gg, w, {});
      BottomBoundaryInput& B = S.bottom;
      B.present = true;
      B.face = text(c, gg, w, "face", "bottom");
      const std::string type = text(c, gg, w, "type", "viscoelastic");
      if (type != "viscoelastic") c.fail(w, "type '" + type + "' is not available (this tq-solid has: viscoelastic)");
      B.distance = number(c, gg, w, "distance", 0, 0);
      B.alphaN = number(c, gg, w, "alpha_n", 0, 0);
      B.alphaT = number(c, gg, w, "alpha_t", 0, 0);
      B.rho = number(c, gg, w, "rho", 0, 0);
      B.cp = number(c, gg, w, "cp", 0, 0);
      B.cs = number(c, gg, w, "cs", 0, 0);
      if ((B.rho > 0) != (B.cp > 0) || (B.rho > 0) != (B.cs > 0))
        c.fail(w, "give the half-space's rho, cp and cs together, or none (then the elements on the base are used)");
      if (B.rho > 0 && !(B.cp > B.cs * std::sqrt(4.0 / 3.0)))
        c.fail(w, "cp must exceed cs·√(4/3) (a positive bulk modulus)");
      B.columnFace = text(c, gg, w, "column_face", "");
      in.requiredFaces.push_back(B.face);
    }
    if (h5::exists(g, "free_field")) {
      auto gg = h5::openGroup(g, "free_field");
      const std::string w = "/boundaries/free_field";
      onlyKeys(c, gg, w, {"faces"});
      onlyMembers(c, gg, w, {});
      S.freeField.present = true;
      if (!h5::hasAttr(gg, "faces")) c.fail(w, "attribute 'faces' is required (e.g. \"xmin,xmax\")");
      S.freeField.faces = names(c, gg, w, "faces");
      for (const auto& face : S.freeField.faces) in.requiredFaces.push_back(face);
    }
    if (h5::exists(g, "periodic")) {
      auto gg = h5::openGroup(g, "periodic");
      const std::string w = "/boundaries/periodic";
      onlyKeys(c, gg, w, {"faces"});
      onlyMembers(c, gg, w, {});
      S.periodic.present = true;
      if (!h5::hasAttr(gg, "faces")) c.fail(w, "attribute 'faces' is required (two opposite faces, e.g. \"ymin,ymax\")");
      S.periodic.faces = names(c, gg, w, "faces");
      if (S.periodic.faces.size() != 2 || S.periodic.faces[0] == S.periodic.faces[1])
        c.fail(w, "faces must name two different face groups (e.g. \"ymin,ymax\")");
      for (const auto& face : S.periodic.faces) in.requiredFaces.push_back(face);
    }
  }
  // /motion
  if (h5::exists(f, "/motion")) {
    auto g = h5::openGroup(f, "/motion");
    const std::string w = "/motion";
    onlyKeys(c, g, w, {"cutoff_frequency", "convention"});
    onlyMembers(c, g, w, {"time", "ax", "ay", "az"});
    MotionInput& M = S.motion;
    M.present = true;
    M.cutoffFrequency = number(c, g, w, "cutoff_frequency", 0, 0);
    M.convention = text(c, g, w, "convention", "");
    if (!h5::exists(g, "time")) c.fail(w, "dataset 'time' is required (s)");
    M.time = h5::readDoubles(g, "time");
    if (h5::exists(g, "ax")) M.ax = h5::readDoubles(g, "ax");
    if (h5::exists(g, "az")) M.az = h5::readDoubles(g, "az");
    if (h5::exists(g, "ay")) M.ay = h5::readDoubles(g, "ay");
    if (M.time.size() < 2) c.fail(w, "time needs at least two samples");
    for (const auto* v : {&M.ax, &M.ay, &M.az})
      if (!v->empty() && v->size() != M.time.size())
        c.fail(w, "ax, ay and az must have as many samples as time (" + std::to_string(M.time.size()) + ")");
    for (size_t i = 0; i < M.time.size(); ++i) {
      if (!std::isfinite(M.time[i]) || (i > 0 && !(M.time[i] > M.time[i - 1])))
        c.fail(w, "time must be finite and strictly increasing (sample " + std::to_string(i) + ")");
      for (const auto* v : {&M.ax, &M.ay, &M.az})
        if (!v->empty() && !std::isfinite((*v)[i])) c.fail(w, "a non-finite acceleration at sample " + std::to_string(i));
    }
  }
  if (S.stages.has("seismic") && !S.bottom.present && !S.freeField.present && S.motion.present)
    c.fail("/boundaries", "the motion needs a base to enter through: add /boundaries/bottom");
  // /coupling (dynamic_water: the water through the coupler; docs/coupler.md "Solid adapter")
  if (h5::exists(f, "/coupling")) {
    auto g = h5::openGroup(f, "/coupling");
    const std::string w = "/coupling";
    onlyKeys(c, g, w, {"scheme", "window", "window_size", "windows", "tolerance", "max_iterations", "acceleration",
                       "initial_relaxation", "predictor", "reuse", "transport", "address_file", "token", "timeout", "connect_timeout", "face",
                       "mesh", "map", "map_tolerance", "write_fields", "participant", "partner",
                       "absolute_tolerance_velocity", "absolute_tolerance_displacement",
                       "absolute_tolerance_force", "energy_limit", "energy_floor", "window_force_weight",
                       "volume_law", "bulk_modulus", "water_density", "water_ends", "axial_density"});
    onlyMembers(c, g, w, {});
    CouplingInput& C = S.coupling;
    C.present = true;
    C.scheme = text(c, g, w, "scheme", C.scheme);
    if (C.scheme != "explicit" && C.scheme != "paper" && C.scheme != "implicit")
      c.fail(w, "scheme '" + C.scheme + "' is not one of explicit, paper, implicit");
    C.windowSteps = Index(number(c, g, w, "window", 1, 1));
    C.windowSize = number(c, g, w, "window_size", 0, 0);
    C.windows = Index(number(c, g, w, "windows", 0, 0));
    C.tolerance = number(c, g, w, "tolerance", C.tolerance, 0);
    C.absoluteTolVelocity = number(c, g, w, "absolute_tolerance_velocity", 0, 0);
    C.absoluteTolDisplacement = number(c, g, w, "absolute_tolerance_displacement", 0, 0);
    C.absoluteTolForce = number(c, g, w, "absolute_tolerance_force", 0, 0);
    C.maxIterations = Index(number(c, g, w, "max_iterations", Real(C.maxIterations), 1));
    C.energyLimit = number(c, g, w, "energy_limit", 0, 0);
    C.energyFloor = number(c, g, w, "energy_floor", 0, 0);
    C.windowForceWeight = number(c, g, w, "window_force_weight", C.windowForceWeight, 0.5);
    if (C.windowForceWeight > 1)
      c.fail(w, "window_force_weight " + std::to_string(C.windowForceWeight) +
                    " is above 1 (0.5: linear ramp to the window-end force, 1: the end force held)");
    C.acceleration = text(c, g, w, "acceleration", C.acceleration);
    if (C.acceleration != "none" && C.acceleration != "constant" && C.acceleration != "aitken" &&
        C.acceleration != "iqn-ils")
      c.fail(w, "acceleration '" + C.acceleration + "' is not one of none, constant, aitken, iqn-ils");
    C.initialRelaxation = number(c, g, w, "initial_relaxation", C.initialRelaxation, 0);
    C.predictor = text(c, g, w, "predictor", C.predictor);
    if (C.predictor != "constant" && C.predictor != "linear")
      c.fail(w, "predictor '" + C.predictor + "' is not one of constant, linear");
    else if (C.predictor != "constant" && C.scheme != "implicit")
      c.fail(w, "predictor " + C.predictor + " needs scheme implicit (the " + C.scheme +
                    " scheme has no iterations to start); use predictor constant");
    C.reuse = Index(number(c, g, w, "reuse", 0, 0));
    if (C.reuse > 0 && (C.scheme != "implicit" || C.acceleration != "iqn-ils"))
      c.fail(w, "reuse " + std::to_string(C.reuse) + " keeps IQN-ILS columns: it needs scheme implicit and "
                "acceleration iqn-ils; use reuse 0");
    C.transport = text(c, g, w, "transport", C.transport);
    if (C.transport != "tcp" && C.transport != "mpi") c.fail(w, "transport '" + C.transport + "' is not tcp or mpi");
    C.addressFile = text(c, g, w, "address_file", "");
    if (C.transport == "tcp" && C.addressFile.empty())
      c.fail(w, "attribute 'address_file' is required with transport tcp (the file where tq-solid publishes its "
                "port for the fluid)");
    C.token = text(c, g, w, "token", "");
    if (C.token.empty()) c.fail(w, "attribute 'token' is required (the per-run secret given to both sides)");
    C.timeout = number(c, g, w, "timeout", C.timeout, 0);
    if (!(C.timeout > 0)) c.fail(w, "timeout must be > 0 s");
    C.connectTimeout = number(c, g, w, "connect_timeout", 0, 0);
    C.face = text(c, g, w, "face", C.face);
    C.mesh = text(c, g, w, "mesh", C.mesh);
    C.map = text(c, g, w, "map", C.map);
    if (C.map != "coincident" && C.map != "projection") c.fail(w, "map '" + C.map + "' is not coincident or projection");
    C.mapTolerance = number(c, g, w, "map_tolerance", C.mapTolerance, 0);
    if (h5::hasAttr(g, "write_fields")) C.writeFields = names(c, g, w, "write_fields");
    for (const auto& fld : C.writeFields)
      if (fld != "velocity" && fld != "displacement")
        c.fail(w, "write_fields: '" + fld + "' is not velocity or displacement");
    if (C.writeFields.empty()) c.fail(w, "write_fields is empty (give velocity, displacement or both)");
    C.participant = text(c, g, w, "participant", C.participant);
    C.partner = text(c, g, w, "partner", C.partner);
    if (C.windowForceWeight != 0.5 && (C.scheme != "implicit" || C.windowSteps == 1))
      c.fail(w, "window_force_weight " + std::to_string(C.windowForceWeight) +
                    " weights the force across the steps of an implicit window of several steps; with scheme " +
                    C.scheme + " and " + std::to_string(C.windowSteps) +
                    "-step windows it would have no effect; leave it out (0.5) or use scheme implicit with "
                    "window > 1");
    C.volumeLaw = text(c, g, w, "volume_law", C.volumeLaw);
    if (C.volumeLaw != "none" && C.volumeLaw != "compressible" && C.volumeLaw != "incompressible")
      c.fail(w, "volume_law '" + C.volumeLaw + "' is not one of none, compressible, incompressible");
    C.bulkModulus = number(c, g, w, "bulk_modulus", 0, 0);
    if (C.volumeLaw == "compressible" && !(C.bulkModulus > 0))
      c.fail(w, "volume_law compressible needs bulk_modulus > 0 (Pa; water 2.2e9)");
    C.waterDensity = number(c, g, w, "water_density", 0, 0);
    if (C.waterDensity > 0 && C.volumeLaw == "none")
      c.fail(w, "water_density (the water's translation carried by the solid) needs a volume_law (a closed "
                "section); leave it out");
    C.waterEnds = text(c, g, w, "water_ends", C.waterEnds);
    if (C.waterEnds != "closed" && C.waterEnds != "open")
      c.fail(w, "water_ends '" + C.waterEnds + "' is not one of closed, open");
    C.axialDensity = number(c, g, w, "axial_density", 0, 0);
    if (C.waterEnds == "open" && C.volumeLaw != "none" && !(C.axialDensity > 0))
      c.fail(w, "water_ends open with a volume_law needs axial_density > 0 (kg/m³: the water's density, which "
                "the axial flow between the planes of the wetted face carries)");
    if (C.windowSteps > 1 && C.scheme == "paper")
      c.fail(w, "a window of " + std::to_string(C.windowSteps) + " solid steps needs scheme explicit or implicit (the "
                "paper scheme's two passes are made for one-step windows); use window 1");
    if (!S.stages.has("seismic"))
      c.fail(w, "the coupling runs in the seismic stage, which /stages sequence does not have");
    in.requiredFaces.push_back(C.face);
  }
}

void writeStagedInput(hid_t f, const SolidInput& in) {
  const StagedInput& S = in.staged;
  if (!S.condition.empty()) h5::writeStringAttr(f, "condition", S.condition);
  {
    auto g = h5::ensureGroup(f, "/stages");
    std::string seq;
    for (const auto& s : S.stages.sequence) seq += (seq.empty() ? "" : ",") + s;
    h5::writeStringAttr(g, "sequence", seq);
    h5::writeDoubleAttr(g, "relaxation_tolerance", S.stages.tolerance);
    h5::writeIntAttr(g, "relaxation_max_steps", S.stages.maxSteps);
    h5::writeIntAttr(g, "mass_scaling", S.stages.massScaling ? 1 : 0);
    h5::writeIntAttr(g, "equilibrium_correction", S.stages.equilibriumCorrection ? 1 : 0);
    h5::writeStringAttr(g, "lining_region", S.stages.liningRegion);
    h5::writeDoubleAttr(g, "release_fraction", S.stages.releaseFraction);
  }
  if (S.inSitu.present) {
    auto g = h5::ensureGroup(f, "/in_situ");
    const InSituInput& I = S.inSitu;
    h5::writeDoubleAttr(g, "kx", I.kx);
    h5::writeDoubleAttr(g, "ky", I.ky);
    h5::writeDoubleAttr(g, "kz", I.kz);
    h5::writeDoubleAttr(g, "gravity", I.gravity);
    h5::writeDoubleAttr(g, "density", I.density);
    if (std::isfinite(I.zTop)) h5::writeDoubleAttr(g, "z_top", I.zTop);
    h5::writeDoubleAttr(g, "surcharge", I.surcharge);
  }
  if (S.hydrostatic.present) {
    auto g = h5::ensureGroup(f, "/hydrostatic");
    h5::writeStringAttr(g, "face", S.hydrostatic.face);
    h5::writeDoubleAttr(g, "pressure_at_axis", S.hydrostatic.pressureAtAxis);
    h5::writeDoubleAttr(g, "unit_weight", S.hydrostatic.unitWeight);
    h5::writeDoubleAttr(g, "z_axis", S.hydrostatic.zAxis);
  }
  if (S.rockLining.present) {
    auto g = h5::ensureGroup(f, "/interfaces/rock_lining");
    h5::writeStringAttr(g, "model", S.rockLining.model);
    h5::writeDoubleAttr(g, "static_friction", S.rockLining.staticFriction);
    h5::writeDoubleAttr(g, "dynamic_friction", S.rockLining.dynamicFriction);
    h5::writeDoubleAttr(g, "cohesion", S.rockLining.cohesion);
    h5::writeStringAttr(g, "after_failure", S.rockLining.afterFailure);
  }
  if (S.bottom.present) {
    auto g = h5::ensureGroup(f, "/boundaries/bottom");
    const BottomBoundaryInput& B = S.bottom;
    h5::writeStringAttr(g, "face", B.face);
    h5::writeStringAttr(g, "type", "viscoelastic");
    if (B.distance > 0) h5::writeDoubleAttr(g, "distance", B.distance);
    if (B.alphaN > 0) h5::writeDoubleAttr(g, "alpha_n", B.alphaN);
    if (B.alphaT > 0) h5::writeDoubleAttr(g, "alpha_t", B.alphaT);
    if (B.rho > 0) {
      h5::writeDoubleAttr(g, "rho", B.rho);
      h5::writeDoubleAttr(g, "cp", B.cp);
      h5::writeDoubleAttr(g, "cs", B.cs);
    }
    if (!B.columnFace.empty()) h5::writeStringAttr(g, "column_face", B.columnFace);
  }
  if (S.freeField.present) {
    auto g = h5::ensureGroup(f, "/boundaries/free_field");
    h5::writeStringListAttr(g, "faces", S.freeField.faces);
  }
  if (S.periodic.present) {
    auto g = h5::ensureGroup(f, "/boundaries/periodic");
    h5::writeStringListAttr(g, "faces", S.periodic.faces);
  }
  if (S.coupling.present) {
    auto g = h5::ensureGroup(f, "/coupling");
    const CouplingInput& C = S.coupling;
    h5::writeStringAttr(g, "scheme", C.scheme);
    h5::writeIntAttr(g, "window", C.windowSteps);
    h5::writeDoubleAttr(g, "window_size", C.windowSize);
    h5::writeIntAttr(g, "windows", C.windows);
    h5::writeDoubleAttr(g, "tolerance", C.tolerance);
    h5::writeDoubleAttr(g, "absolute_tolerance_velocity", C.absoluteTolVelocity);
    h5::writeDoubleAttr(g, "absolute_tolerance_displacement", C.absoluteTolDisplacement);
    h5::writeDoubleAttr(g, "absolute_tolerance_force", C.absoluteTolForce);
    h5::writeIntAttr(g, "max_iterations", C.maxIterations);
    if (C.energyLimit > 0) h5::writeDoubleAttr(g, "energy_limit", C.energyLimit);
    if (C.energyFloor > 0) h5::writeDoubleAttr(g, "energy_floor", C.energyFloor);
    if (C.windowForceWeight != 0.5) h5::writeDoubleAttr(g, "window_force_weight", C.windowForceWeight);
    if (C.volumeLaw != "none") {
      h5::writeStringAttr(g, "volume_law", C.volumeLaw);
      h5::writeDoubleAttr(g, "bulk_modulus", C.bulkModulus);
      if (C.waterDensity > 0) h5::writeDoubleAttr(g, "water_density", C.waterDensity);
      if (C.waterEnds != "closed") {
        h5::writeStringAttr(g, "water_ends", C.waterEnds);
        h5::writeDoubleAttr(g, "axial_density", C.axialDensity);
      }
    }
    h5::writeStringAttr(g, "acceleration", C.acceleration);
    h5::writeDoubleAttr(g, "initial_relaxation", C.initialRelaxation);
    h5::writeStringAttr(g, "predictor", C.predictor);
    if (C.reuse > 0) h5::writeIntAttr(g, "reuse", C.reuse);
    h5::writeStringAttr(g, "transport", C.transport);
    h5::writeStringAttr(g, "address_file", C.addressFile);
    h5::writeStringAttr(g, "token", C.token);
    h5::writeDoubleAttr(g, "timeout", C.timeout);
    h5::writeDoubleAttr(g, "connect_timeout", C.connectTimeout);
    h5::writeStringAttr(g, "face", C.face);
    h5::writeStringAttr(g, "mesh", C.mesh);
    h5::writeStringAttr(g, "map", C.map);
    h5::writeDoubleAttr(g, "map_tolerance", C.mapTolerance);
    h5::writeStringListAttr(g, "write_fields", C.writeFields);
    h5::writeStringAttr(g, "participant", C.participant);
    h5::writeStringAttr(g, "partner", C.partner);
  }
  if (S.motion.present) {
    auto g = h5::ensureGroup(f, "/motion");
    const MotionInput& M = S.motion;
    h5::writeDoubles(g, "time", M.time.data(), {M.time.size()});
    if (!M.ax.empty()) h5::writeDoubles(g, "ax", M.ax.data(), {M.ax.size()});
    if (!M.ay.empty()) h5::writeDoubles(g, "ay", M.ay.data(), {M.ay.size()});
    if (!M.az.empty()) h5::writeDoubles(g, "az", M.az.data(), {M.az.size()});
    if (M.cutoffFrequency > 0) h5::writeDoubleAttr(g, "cutoff_frequency", M.cutoffFrequency);
    if (!M.convention.empty()) h5::writeStringAttr(g, "convention", M.convention);
  }
}

}  // namespace tq
