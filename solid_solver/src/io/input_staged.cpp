// solid_input.h5's staged groups: stages, in-situ stress, hydrostatic pressure, the rock-lining
// interface, seismic boundaries, the incident motion and the water coupling (docs/formats.md
// "## solid_input.h5"); defaults and bounds from the generated table (input_schema.hpp).
#include "input_staged.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "h5util.hpp"
#include "input_schema.hpp"
#include "tq/contact/contact.hpp"
#include "tq/contact/joints.hpp"

namespace tq {

namespace K = input_schema::key;

ContactParams contactParamsFrom(const InterfaceInput& in) {
  ContactParams p;
  p.model = parseInterfaceModel(in.model);
  p.staticFriction = in.staticFriction;
  p.dynamicFriction = in.dynamicFriction;
  p.cohesion = in.cohesion;
  p.afterFailure = parseAfterFailure(in.afterFailure);
  p.check();
  return p;
}

JointParams jointParamsFrom(const JointsInput& in) {
  JointParams p;
  p.normalStiffness = in.normalStiffness;
  p.shearStiffness = in.shearStiffness;
  p.tensileStrength = in.tensileStrength;
  p.friction = in.friction;
  p.check();
  return p;
}

JointPairs readJointPairs(const std::string& meshPath) {
  const std::string where = "lining joints of mesh '" + meshPath + "'";
  auto f = h5::openFile(meshPath);
  if (!h5::exists(f, "/interfaces/lining_joints"))
    throw InputError(where +
                     ": the mesh has no joints (/interfaces/lining_joints); re-mesh with the case's "
                     "lining_joints (tunnelquake mesh --force) or remove /interfaces/lining_joints from the input");
  std::vector<hsize_t> d;
  const auto pairs = h5::readInts(f, "/interfaces/lining_joints", &d);
  if (d.size() != 2 || d[1] != 2) throw InputError(where + ": /interfaces/lining_joints must have shape [P, 2]");
  JointPairs jp;
  const size_t P = pairs.size() / 2;
  for (size_t p = 0; p < P; ++p) {
    jp.nodeA.push_back(pairs[2 * p]);
    jp.nodeB.push_back(pairs[2 * p + 1]);
  }
  jp.area = h5::readDoubles(f, "/interfaces/lining_joint_area");
  jp.joint = h5::readInts(f, "/interfaces/lining_joint_index");
  jp.y = h5::readDoubles(f, "/interfaces/lining_joint_y");
  return jp;
}

void readStagedInput(hid_t f, SolidInput& in) {
  const input_schema::Reader c(in.path);
  StagedInput& S = in.staged;
  S.present = true;
  S.condition = c.text(f, "root", K::root::condition);
  S.inputFingerprint = c.text(f, "root", K::root::input_fingerprint);
  // /stages (absent: one dynamic stage from rest, and none of the groups below)
  const bool staged = h5::exists(f, "/stages");
  if (staged) {
    auto g = h5::openGroup(f, "/stages");
    const std::string w = "/stages";
    c.checkGroup(g, w, w);
    S.stages.sequence = c.names(g, w, K::stages::sequence);
    size_t at = 0;
    for (const auto& s : S.stages.sequence) {
      const auto it = std::find(kStageOrder.begin(), kStageOrder.end(), s);
      if (it == kStageOrder.end())
        c.fail(w, "unknown stage '" + s +
                      "' (stages, in this order: in_situ, excavation, lining, hydrostatic, fault_offset, seismic)");
      const size_t k = size_t(it - kStageOrder.begin());
      if (k < at)
        c.fail(w, "stage '" + s +
                      "' is out of order or repeated (the order is in_situ, excavation, "
                      "lining, hydrostatic, fault_offset, seismic)");
      at = k + 1;
    }
    if (S.stages.sequence.empty()) c.fail(w, "sequence is empty");
    S.stages.tolerance = c.number(g, w, K::stages::relaxation_tolerance);
    S.stages.maxSteps = Index(c.number(g, w, K::stages::relaxation_max_steps));
    S.stages.massScaling = c.flag(g, w, K::stages::mass_scaling);
    S.stages.equilibriumCorrection = c.flag(g, w, K::stages::equilibrium_correction);
    S.stages.liningRegion = c.text(g, w, K::stages::lining_region);
    S.stages.releaseFraction = c.number(g, w, K::stages::release_fraction);
    if (S.stages.releaseFraction < 1 && !(S.stages.has("excavation") && S.stages.has("lining")))
      c.fail(w,
             "release_fraction < 1 holds part of the excavation load until the lining stage: the sequence needs "
             "both 'excavation' and 'lining' (or set release_fraction to 1)");
  }
  // /in_situ
  if (const auto g = c.group(f, "/in_situ", "/in_situ"); g.valid()) {
    const std::string w = "/in_situ";
    InSituInput& I = S.inSitu;
    I.present = true;
    I.kx = c.number(g, w, K::in_situ::kx);
    I.ky = c.number(g, w, K::in_situ::ky);
    I.kz = c.number(g, w, K::in_situ::kz);
    I.gravity = c.number(g, w, K::in_situ::gravity);
    I.density = c.number(g, w, K::in_situ::density);
    I.zTop = c.has(g, K::in_situ::z_top) ? c.number(g, w, K::in_situ::z_top) : std::numeric_limits<Real>::quiet_NaN();
    I.surcharge = c.number(g, w, K::in_situ::surcharge);
    if (I.gravity > 0) {
      if (in.options.gravity[2] != 0 && in.options.gravity[2] != -I.gravity)
        c.fail(w,
               "gravity is given twice (/solver gravity_z and /in_situ gravity) with different values; "
               "give it once, in /in_situ");
      in.options.gravity[2] = -I.gravity;
    }
  }
  if (S.stages.has("in_situ") && !S.inSitu.present)
    c.fail("/in_situ", "group is required by the in_situ stage (attributes kx, ky, kz, gravity)");
  // /hydrostatic
  if (const auto g = c.group(f, "/hydrostatic", "/hydrostatic"); g.valid()) {
    const std::string w = "/hydrostatic";
    HydrostaticInput& H = S.hydrostatic;
    H.present = true;
    H.face = c.text(g, w, K::hydrostatic::face);
    H.pressureAtAxis = c.number(g, w, K::hydrostatic::pressure_at_axis, true);
    H.unitWeight = c.number(g, w, K::hydrostatic::unit_weight);
    H.zAxis = c.number(g, w, K::hydrostatic::z_axis, H.unitWeight > 0);
    in.requiredFaces.push_back(H.face);
  }
  if (S.stages.has("hydrostatic") && !S.hydrostatic.present)
    c.fail("/hydrostatic", "group is required by the hydrostatic stage (pressure_at_axis, unit_weight, z_axis)");
  // /fault_offset: the prescribed displacement of the fault_offset stage
  if (const auto g = c.group(f, "/fault_offset", "/fault_offset"); g.valid()) {
    const std::string w = "/fault_offset";
    FaultOffsetInput& F = S.faultOffset;
    namespace KF = K::fault_offset;
    for (const auto* key : {&KF::nodes, &KF::displacement})
      if (!h5::exists(g, key->name))
        c.fail(w, std::string("dataset '") + key->name + "' is required (docs/formats.md \"solid_input.h5\")");
    F.present = true;
    F.nodes = h5::readInts(g, KF::nodes.name);
    std::vector<hsize_t> dims;
    F.displacement = h5::readDoubles(g, KF::displacement.name, &dims);
    if (dims.size() != 2 || dims[0] != hsize_t(F.nodes.size()) || dims[1] != 3)
      c.fail(w, "displacement must be [N, 3] with N = " + std::to_string(F.nodes.size()) + " (the nodes' count)");
    for (Real x : F.displacement)
      if (!std::isfinite(x)) c.fail(w, "displacement holds a non-finite value");
    F.increments = Index(c.number(g, w, KF::increments));
    if (F.nodes.empty()) c.fail(w, "nodes is empty; give the nodes to move or leave /fault_offset out");
    F.riseTime = c.number(g, w, KF::rise_time);
    F.startTime = c.number(g, w, KF::start_time);
    if (F.dynamic()) {
      if (!S.stages.has("seismic"))
        c.fail(w, "a slip with rise_time > 0 is imposed in the seismic stage, which /stages sequence does not have");
      if (S.stages.has("fault_offset"))
        c.fail(w,
               "a slip with rise_time > 0 is imposed in the seismic stage, not by a fault_offset stage: remove "
               "fault_offset from /stages sequence or set rise_time to 0");
    } else if (!S.stages.has("fault_offset")) {
      c.fail(w, "the offset is imposed by the fault_offset stage, which /stages sequence does not have");
    }
  }
  if (S.stages.has("fault_offset") && !S.faultOffset.present)
    c.fail("/fault_offset", "group is required by the fault_offset stage (datasets nodes, displacement)");
  // /interfaces/rock_lining
  if (const auto g = c.group(f, "/interfaces", "/interfaces"); g.valid()) {
    if (const auto gg = c.group(g, "rock_lining", "/interfaces/rock_lining"); gg.valid()) {
      const std::string w = "/interfaces/rock_lining";
      InterfaceInput& R = S.rockLining;
      R.present = true;
      R.model = c.text(gg, w, K::interfaces_rock_lining::model);
      R.staticFriction = c.number(gg, w, K::interfaces_rock_lining::static_friction);
      R.dynamicFriction = c.number(gg, w, K::interfaces_rock_lining::dynamic_friction);
      R.cohesion = c.number(gg, w, K::interfaces_rock_lining::cohesion);
      R.afterFailure = c.text(gg, w, K::interfaces_rock_lining::after_failure);
    }
    if (const auto gg = c.group(g, "lining_joints", "/interfaces/lining_joints"); gg.valid()) {
      const std::string w = "/interfaces/lining_joints";
      JointsInput& J = S.liningJoints;
      J.present = true;
      J.normalStiffness = c.number(gg, w, K::interfaces_lining_joints::normal_stiffness);
      J.shearStiffness = c.number(gg, w, K::interfaces_lining_joints::shear_stiffness);
      J.tensileStrength = c.number(gg, w, K::interfaces_lining_joints::tensile_strength);
      J.friction = c.number(gg, w, K::interfaces_lining_joints::friction);
    }
  }
  // /boundaries
  if (const auto g = c.group(f, "/boundaries", "/boundaries"); g.valid()) {
    if (const auto gg = c.group(g, "bottom", "/boundaries/bottom"); gg.valid()) {
      const std::string w = "/boundaries/bottom";
      BottomBoundaryInput& B = S.bottom;
      B.present = true;
      B.face = c.text(gg, w, K::boundaries_bottom::face);
      c.text(gg, w, K::boundaries_bottom::type);  // its choices: the bases this tq-solid has
      B.distance = c.number(gg, w, K::boundaries_bottom::distance);
      B.alphaN = c.number(gg, w, K::boundaries_bottom::alpha_n);
      B.alphaT = c.number(gg, w, K::boundaries_bottom::alpha_t);
      B.rho = c.number(gg, w, K::boundaries_bottom::rho);
      B.cp = c.number(gg, w, K::boundaries_bottom::cp);
      B.cs = c.number(gg, w, K::boundaries_bottom::cs);
      if ((B.rho > 0) != (B.cp > 0) || (B.rho > 0) != (B.cs > 0))
        c.fail(w, "give the half-space's rho, cp and cs together, or none (then the elements on the base are used)");
      if (B.rho > 0 && !(B.cp > B.cs * std::sqrt(4.0 / 3.0)))
        c.fail(w, "cp must exceed cs·√(4/3) (a positive bulk modulus)");
      B.columnFace = c.text(gg, w, K::boundaries_bottom::column_face);
      in.requiredFaces.push_back(B.face);
    }
    if (const auto gg = c.group(g, "free_field", "/boundaries/free_field"); gg.valid()) {
      const std::string w = "/boundaries/free_field";
      S.freeField.present = true;
      S.freeField.faces = c.names(gg, w, K::boundaries_free_field::faces);
      for (const auto& face : S.freeField.faces) in.requiredFaces.push_back(face);
      S.freeField.sharedColumnFaces = c.names(gg, w, K::boundaries_free_field::shared_column_faces);
      for (const auto& face : S.freeField.sharedColumnFaces) in.requiredFaces.push_back(face);
    }
    if (const auto gg = c.group(g, "periodic", "/boundaries/periodic"); gg.valid()) {
      const std::string w = "/boundaries/periodic";
      S.periodic.present = true;
      S.periodic.faces = c.names(gg, w, K::boundaries_periodic::faces);
      if (S.periodic.faces.size() != 2 || S.periodic.faces[0] == S.periodic.faces[1])
        c.fail(w, "faces must name two different face groups (e.g. \"ymin,ymax\")");
      for (const auto& face : S.periodic.faces) in.requiredFaces.push_back(face);
    }
  }
  // /motion
  if (const auto g = c.group(f, "/motion", "/motion"); g.valid()) {
    const std::string w = "/motion";
    MotionInput& M = S.motion;
    M.present = true;
    M.cutoffFrequency = c.number(g, w, K::motion::cutoff_frequency);
    M.convention = c.text(g, w, K::motion::convention);
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
        if (!v->empty() && !std::isfinite((*v)[i]))
          c.fail(w, "a non-finite acceleration at sample " + std::to_string(i));
    }
  }
  // /drm: the free field on a domain-reduction layer (tq/boundaries/drm.hpp); the layer itself is
  // checked against the mesh and the materials when the stages are built.
  if (const auto g = c.group(f, "/drm", "/drm"); g.valid()) {
    const std::string w = "/drm";
    DrmFreeField& D = S.drm;
    namespace KD = K::drm;
    for (const auto* key : {&KD::nodes, &KD::internal, &KD::time, &KD::u, &KD::v, &KD::a})
      if (!h5::exists(g, key->name))
        c.fail(w, std::string("dataset '") + key->name + "' is required (docs/formats.md \"solid_input.h5\", /drm)");
    D.nodes = h5::readInts(g, KD::nodes.name);
    for (Index flag : h5::readInts(g, KD::internal.name)) {
      if (flag != 0 && flag != 1) c.fail(w, "internal must hold 0 (outer node e) or 1 (inner node b)");
      D.internal.push_back(std::uint8_t(flag));
    }
    D.time = h5::readDoubles(g, KD::time.name);
    const std::vector<hsize_t> want = {hsize_t(D.time.size()), hsize_t(D.nodes.size()), 3};
    for (auto [key, arr] : {std::pair{&KD::u, &D.u}, {&KD::v, &D.v}, {&KD::a, &D.a}}) {
      std::vector<hsize_t> dims;
      *arr = h5::readDoubles(g, key->name, &dims);
      if (dims != want)
        c.fail(w, std::string(key->name) + " must be [T, N, 3] = [" + std::to_string(want[0]) + ", " +
                      std::to_string(want[1]) + ", 3] (time samples, nodes, components)");
    }
    if (!S.stages.has("seismic"))
      c.fail(w, "the DRM layer's forces act in the seismic stage, which /stages sequence does not have");
    if (D.nodes.empty()) c.fail(w, "nodes is empty; give the layer's nodes or leave /drm out");
  }
  if (S.stages.has("seismic") && !S.bottom.present && !S.freeField.present && S.motion.present)
    c.fail("/boundaries", "the motion needs a base to enter through: add /boundaries/bottom");
  // /coupling (dynamic_water: the water through the coupler; docs/coupler.md "Solid adapter")
  if (const auto g = c.group(f, "/coupling", "/coupling"); g.valid()) {
    const std::string w = "/coupling";
    CouplingInput& C = S.coupling;
    C.present = true;
    C.scheme = c.text(g, w, K::coupling::scheme);
    C.windowSteps = Index(c.number(g, w, K::coupling::window));
    C.windowSize = c.number(g, w, K::coupling::window_size);
    C.windows = Index(c.number(g, w, K::coupling::windows));
    C.checkpointWindows = Index(c.number(g, w, K::coupling::checkpoint_windows));
    C.tolerance = c.number(g, w, K::coupling::tolerance);
    C.absoluteTolVelocity = c.number(g, w, K::coupling::absolute_tolerance_velocity);
    C.absoluteTolDisplacement = c.number(g, w, K::coupling::absolute_tolerance_displacement);
    C.absoluteTolForce = c.number(g, w, K::coupling::absolute_tolerance_force);
    C.maxIterations = Index(c.number(g, w, K::coupling::max_iterations));
    C.energyLimit = c.number(g, w, K::coupling::energy_limit);
    C.energyFloor = c.number(g, w, K::coupling::energy_floor);
    C.windowForceWeight = c.number(g, w, K::coupling::window_force_weight);
    C.defectCorrection = c.number(g, w, K::coupling::defect_correction);
    C.acceleration = c.text(g, w, K::coupling::acceleration);
    C.initialRelaxation = c.number(g, w, K::coupling::initial_relaxation);
    C.predictor = c.text(g, w, K::coupling::predictor);
    if (C.predictor != "constant" && C.scheme != "implicit")
      c.fail(w, "predictor " + C.predictor + " needs scheme implicit (the " + C.scheme +
                    " scheme has no iterations to start); use predictor constant");
    C.residualScale = c.text(g, w, K::coupling::residual_scale);
    if (C.residualScale != "current" && C.scheme != "implicit")
      c.fail(w, "residual_scale " + C.residualScale + " needs scheme implicit (the " + C.scheme +
                    " scheme tests no convergence); use residual_scale current");
    C.reuse = Index(c.number(g, w, K::coupling::reuse));
    if (C.reuse > 0 && (C.scheme != "implicit" || C.acceleration != "iqn-ils"))
      c.fail(w, "reuse " + std::to_string(C.reuse) +
                    " keeps IQN-ILS columns: it needs scheme implicit and "
                    "acceleration iqn-ils; use reuse 0");
    C.transport = c.text(g, w, K::coupling::transport);
    C.addressFile = c.text(g, w, K::coupling::address_file);
    if (C.transport == "tcp" && C.addressFile.empty())
      c.fail(w,
             "attribute 'address_file' is required with transport tcp (the file where tq-solid publishes its "
             "port for the fluid)");
    C.token = c.text(g, w, K::coupling::token);
    if (C.token.empty()) c.fail(w, "attribute 'token' is required (the per-run secret given to both sides)");
    C.timeout = c.number(g, w, K::coupling::timeout);
    C.connectTimeout = c.number(g, w, K::coupling::connect_timeout);
    C.face = c.text(g, w, K::coupling::face);
    C.mesh = c.text(g, w, K::coupling::mesh);
    C.map = c.text(g, w, K::coupling::map);
    C.mapTolerance = c.number(g, w, K::coupling::map_tolerance);
    C.writeFields = c.names(g, w, K::coupling::write_fields);
    for (const auto& fld : C.writeFields)
      if (fld != "velocity" && fld != "displacement")
        c.fail(w, "write_fields: '" + fld + "' is not velocity or displacement");
    if (C.writeFields.empty()) c.fail(w, "write_fields is empty (give velocity, displacement or both)");
    C.participant = c.text(g, w, K::coupling::participant);
    C.partner = c.text(g, w, K::coupling::partner);
    if (C.windowForceWeight != 0.5 && (C.scheme != "implicit" || C.windowSteps == 1))
      c.fail(w, "window_force_weight " + std::to_string(C.windowForceWeight) +
                    " weights the force across the steps of an implicit window of several steps; with scheme " +
                    C.scheme + " and " + std::to_string(C.windowSteps) +
                    "-step windows it would have no effect; leave it out (0.5) or use scheme implicit with "
                    "window > 1");
    if (C.defectCorrection > 0 && (C.scheme != "implicit" || C.windowSteps == 1))
      c.fail(w, "defect_correction " + std::to_string(C.defectCorrection) +
                    " carries an implicit window's accepted defect into the next window of several "
                    "steps; with scheme " +
                    C.scheme + " and " + std::to_string(C.windowSteps) +
                    "-step windows there is none to carry; leave it out (0) or use scheme implicit with window > 1");
    C.volumeLaw = c.text(g, w, K::coupling::volume_law);
    C.bulkModulus = c.number(g, w, K::coupling::bulk_modulus);
    if (C.volumeLaw == "compressible" && !(C.bulkModulus > 0))
      c.fail(w, "volume_law compressible needs bulk_modulus > 0 (Pa: the case's water.bulk_modulus)");
    C.waterDensity = c.number(g, w, K::coupling::water_density);
    if (C.waterDensity > 0 && C.volumeLaw == "none")
      c.fail(w,
             "water_density (the water's translation carried by the solid) needs a volume_law (a closed "
             "section); leave it out");
    C.waterEnds = c.text(g, w, K::coupling::water_ends);
    C.axialDensity = c.number(g, w, K::coupling::axial_density);
    if (C.waterEnds == "open" && C.volumeLaw != "none" && !(C.axialDensity > 0))
      c.fail(w,
             "water_ends open with a volume_law needs axial_density > 0 (kg/m³: the water's density, which "
             "the axial flow between the planes of the wetted face carries)");
    C.endYmin = c.text(g, w, K::coupling::end_ymin);
    C.endYmax = c.text(g, w, K::coupling::end_ymax);
    C.surgeTankAreaYmin = c.number(g, w, K::coupling::surge_tank_area_ymin);
    C.surgeTankAreaYmax = c.number(g, w, K::coupling::surge_tank_area_ymax);
    for (const auto& [end, kind, area] : {std::tuple{"end_ymin", C.endYmin, C.surgeTankAreaYmin},
                                          std::tuple{"end_ymax", C.endYmax, C.surgeTankAreaYmax}}) {
      const std::string areaKey = std::string("surge_tank_area_") + (end + 4);
      if (kind == "surge_tank" && !(area > 0))
        c.fail(w, std::string(end) + " surge_tank needs " + areaKey + " > 0 (m²: the tank's free-surface area)");
      if (kind != "surge_tank" && area != 0)
        c.fail(w, areaKey + " " + std::to_string(area) + " is the area of a surge tank, but " + end + " is " + kind +
                      "; leave it out or make " + end + " surge_tank");
      if (kind != "reservoir" && C.waterEnds != "open")
        c.fail(w, std::string(end) + " " + kind + " closes one end of an open water column; it needs water_ends open");
    }
    if (C.endYmin == "valve" && C.endYmax == "valve")
      c.fail(w,
             "end_ymin and end_ymax are both valve: the column has no end that fixes its pressure; use water_ends "
             "closed (one uniform pressure) or make one end a reservoir or a surge tank");
    C.subtractMeanPressure = c.flag(g, w, K::coupling::subtract_mean_pressure);
    C.symmetryYmax = c.flag(g, w, K::coupling::symmetry_ymax);
    if (C.subtractMeanPressure && (C.volumeLaw == "none" || C.waterEnds != "closed"))
      c.fail(w,
             "subtract_mean_pressure 1 (the water sends its wall pressure less its mean) needs the solid to carry "
             "that uniform part: a volume_law with water_ends closed, but volume_law is " +
                 C.volumeLaw + " and water_ends " + C.waterEnds +
                 "; write the settings from one case (fluid_case.coupling_settings) or leave it out");
    if (C.windowSteps > 1 && C.scheme == "paper")
      c.fail(w, "a window of " + std::to_string(C.windowSteps) +
                    " solid steps needs scheme explicit or implicit (the "
                    "paper scheme's two passes are made for one-step windows); use window 1");
    if (!S.stages.has("seismic"))
      c.fail(w, "the coupling runs in the seismic stage, which /stages sequence does not have");
    in.requiredFaces.push_back(C.face);
  }
  if (!staged) {
    if (S.inSitu.present || S.hydrostatic.present || S.rockLining.present || S.bottom.present || S.freeField.present ||
        S.periodic.present || S.motion.present || S.coupling.present || S.faultOffset.present)
      c.fail("/stages",
             "group is required with the staged groups (attribute sequence, e.g. \"in_situ,excavation,"
             "lining,hydrostatic,seismic\")");
    S.present = false;
  }
}

}  // namespace tq
