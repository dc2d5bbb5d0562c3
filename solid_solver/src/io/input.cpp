// solid_input.h5 reader/writer (docs/formats.md "## solid_input.h5").
#include "tq/io/input.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "h5util.hpp"
#include "input_staged.hpp"

namespace tq {

namespace {

struct Ctx {
  std::string file;
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError("solid input '" + file + "', " + where + ": " + what);
  }
};

void checkKeys(const Ctx& c, hid_t obj, const std::string& where, const std::set<std::string>& allowed) {
  for (const auto& a : h5::attrNames(obj))
    if (!allowed.count(a)) {
      std::string list;
      for (const auto& k : allowed) list += " " + k;
      c.fail(where, "unknown attribute '" + a + "' (allowed:" + list + ")");
    }
}

void checkMembers(const Ctx& c, hid_t grp, const std::string& where, const std::set<std::string>& allowed) {
  for (const auto& m : h5::members(grp))
    if (!allowed.count(m)) {
      std::string list;
      for (const auto& k : allowed) list += " " + k;
      c.fail(where, "unknown entry '" + m + "' (allowed:" + list + ")");
    }
}

Real num(const Ctx& c, hid_t obj, const std::string& where, const std::string& key, Real def, bool required = false) {
  if (!h5::hasAttr(obj, key)) {
    if (required) c.fail(where, "attribute '" + key + "' is required");
    return def;
  }
  try {
    const Real v = h5::readDoubleAttr(obj, key);
    if (!std::isfinite(v)) c.fail(where, "attribute '" + key + "' is not finite");
    return v;
  } catch (const InputError& e) {
    c.fail(where, e.what());
  }
}

std::string str(const Ctx& c, hid_t obj, const std::string& where, const std::string& key, const std::string& def,
                bool required = false) {
  if (!h5::hasAttr(obj, key)) {
    if (required) c.fail(where, "attribute '" + key + "' is required");
    return def;
  }
  try {
    return h5::readStringAttr(obj, key);
  } catch (const InputError& e) {
    c.fail(where, e.what());
  }
}

int direction(const Ctx& c, const std::string& where, const std::string& d) {
  if (d == "x") return 0;
  if (d == "y") return 1;
  if (d == "z") return 2;
  c.fail(where, "direction '" + d + "' must be one of x, y, z");
}

}  // namespace

SolidInput readSolidInput(const std::string& path) {
  Ctx c{path};
  SolidInput in;
  in.path = path;
  auto f = h5::openFile(path);
  checkKeys(c, f, "root", {"format", "version", "mesh", "condition"});
  const std::string fmt = str(c, f, "root", "format", "", true);
  if (fmt != "tunnelquake-solid-input")
    c.fail("root", "format is '" + fmt + "', expected 'tunnelquake-solid-input'");
  const Real ver = num(c, f, "root", "version", 0, true);
  if (ver != 1 && ver != 2)
    c.fail("root", "version " + std::to_string(int(ver)) + " is not supported (this tq-solid reads 1 and 2)");
  const std::string mesh = str(c, f, "root", "mesh", "", true);
  const auto dir = std::filesystem::path(path).parent_path();
  in.meshPath = std::filesystem::path(mesh).is_absolute() ? mesh : (dir / mesh).string();
  {
    std::set<std::string> rootGroups = {"solver", "damping", "materials", "boundary", "loads", "monitors", "output"};
    if (ver == 2) rootGroups.insert(std::begin(kStagedRootGroups), std::end(kStagedRootGroups));
    checkMembers(c, f, "root", rootGroups);
    if (ver == 1 && h5::hasAttr(f, "condition")) c.fail("root", "attribute 'condition' needs version 2");
  }

  // /solver
  if (!h5::exists(f, "/solver")) c.fail("/solver", "group is required (at least attribute t_end)");
  {
    auto g = h5::openGroup(f, "/solver");
    const std::string w = "/solver";
    checkKeys(c, g, w, {"t_end", "dt", "safety", "integrator", "formulation", "velocity_limit", "gravity_z",
                        "subcycling_levels"});
    in.tEnd = num(c, g, w, "t_end", 0, true);
    if (!(in.tEnd > 0)) c.fail(w, "t_end = " + std::to_string(in.tEnd) + " must be > 0 (s)");
    in.options.dt = num(c, g, w, "dt", 0);
    in.options.safety = num(c, g, w, "safety", 0.9);
    in.options.velocityLimit = num(c, g, w, "velocity_limit", 1e3);
    in.options.gravity[2] = num(c, g, w, "gravity_z", 0);
    {
      const Real lv = num(c, g, w, "subcycling_levels", 0);
      if (!(lv >= 0 && lv <= 8 && lv == std::floor(lv)))
        c.fail(w, "subcycling_levels = " + std::to_string(lv) +
                      " must be a whole number 0..8 (0 = off; n: elements step up to 2^n times the finest step)");
      in.options.subcyclingLevels = int(lv);
    }
    try {
      in.options.integrator = parseIntegrator(str(c, g, w, "integrator", "central_difference"));
      in.formulation = parseFormulation(str(c, g, w, "formulation", "one_point_assumed_strain"));
    } catch (const InputError& e) {
      c.fail(w, e.what());
    }
  }
  // /damping
  if (h5::exists(f, "/damping")) {
    auto g = h5::openGroup(f, "/damping");
    const std::string w = "/damping";
    checkKeys(c, g, w, {"ratio", "f1", "f2", "alpha", "beta"});
    const bool byRatio = h5::hasAttr(g, "ratio");
    const bool byCoef = h5::hasAttr(g, "alpha") || h5::hasAttr(g, "beta");
    if (byRatio && byCoef) c.fail(w, "give either ratio/f1/f2 or alpha/beta, not both");
    try {
      if (byRatio)
        in.options.damping = RayleighDamping::fromRatio(num(c, g, w, "ratio", 0), num(c, g, w, "f1", 0, true),
                                                        num(c, g, w, "f2", 0, true));
      else
        in.options.damping = {num(c, g, w, "alpha", 0), num(c, g, w, "beta", 0)};
    } catch (const InputError& e) {
      c.fail(w, e.what());
    }
    if (in.options.damping.alpha < 0 || in.options.damping.beta < 0) c.fail(w, "alpha and beta must be >= 0");
  }
  // /materials/<region>
  if (!h5::exists(f, "/materials")) c.fail("/materials", "group is required: one subgroup per mesh region");
  {
    auto g = h5::openGroup(f, "/materials");
    for (const auto& region : h5::members(g)) {
      auto mg = h5::openGroup(g, region);
      const std::string w = "/materials/" + region;
      // `model`; `type` is version 1's name for the same choice.
      const std::string type = str(c, mg, w, "type", "elastic"), model = str(c, mg, w, "model", type);
      if (model != "elastic" && model != "mohr_coulomb_damage")
        c.fail(w, "model '" + model + "' is unknown; use elastic or mohr_coulomb_damage");
      if (h5::hasAttr(mg, "type") && h5::hasAttr(mg, "model") && type != model)
        c.fail(w, "attributes type = '" + type + "' and model = '" + model + "' disagree; give model only");
      std::set<std::string> keys = {"type", "E", "nu", "rho"};
      keys.insert(std::begin(kMohrCoulombAttrs), std::end(kMohrCoulombAttrs));  // for the Mohr-Coulomb damage material
      checkKeys(c, mg, w, keys);
      ElasticParams p{num(c, mg, w, "E", 0, true), num(c, mg, w, "nu", 0, true), num(c, mg, w, "rho", 0, true)};
      try {
        ElasticMaterial check(p);
      } catch (const InputError& e) {
        c.fail(w, e.what());
      }
      in.materials.emplace_back(region, p);
      if (model == "mohr_coulomb_damage") {  // eqs. 16-18; the other attributes are ignored for elastic
        MohrCoulombDamageParams mp;
        mp.elastic = p;
        mp.cohesion = num(c, mg, w, "cohesion", 0, true);
        mp.frictionAngle = num(c, mg, w, "friction_angle", 0, true);
        mp.dilationAngle = num(c, mg, w, "dilation_angle", 0);
        mp.tensileStrength = num(c, mg, w, "tensile_strength", 0, true);
        mp.damageConstant = num(c, mg, w, "damage_constant", 100);
        try {
          mp.damageEffect = parseDamageEffect(str(c, mg, w, "damage_effect", "cohesion"));
          MohrCoulombDamageMaterial check(mp);
        } catch (const InputError& e) {
          c.fail(w, e.what());
        }
        in.mohrCoulomb[region] = mp;
      }
    }
  }
  // /boundary/fixed/<face group>
  if (h5::exists(f, "/boundary")) {
    auto g = h5::openGroup(f, "/boundary");
    checkMembers(c, g, "/boundary", {"fixed"});
    if (h5::exists(g, "fixed")) {
      auto fg = h5::openGroup(g, "fixed");
      for (const auto& group : h5::members(fg)) {
        auto gg = h5::openGroup(fg, group);
        const std::string w = "/boundary/fixed/" + group;
        checkKeys(c, gg, w, {"directions"});
        const std::string dirs = str(c, gg, w, "directions", "", true);
        if (dirs.empty() || dirs.find_first_not_of("xyz") != std::string::npos)
          c.fail(w, "directions '" + dirs + "' must be letters from x, y, z (e.g. \"xyz\")");
        in.fixed[group] = dirs;
        in.requiredFaces.push_back(group);
      }
    }
  }
  // /loads/<name>
  if (h5::exists(f, "/loads")) {
    auto g = h5::openGroup(f, "/loads");
    for (const auto& name : h5::members(g)) {
      auto lg = h5::openGroup(g, name);
      const std::string w = "/loads/" + name;
      checkKeys(c, lg, w, {"target", "direction", "force"});
      checkMembers(c, lg, w, {"time", "value"});
      LoadInput l;
      l.name = name;
      l.target = str(c, lg, w, "target", "", true);
      l.direction = direction(c, w, str(c, lg, w, "direction", "", true));
      l.force = num(c, lg, w, "force", 0, true);
      if (h5::exists(lg, "time") != h5::exists(lg, "value")) c.fail(w, "give both datasets time and value, or neither");
      if (h5::exists(lg, "time")) {
        l.function.t = h5::readDoubles(lg, "time");
        l.function.value = h5::readDoubles(lg, "value");
        if (l.function.t.size() != l.function.value.size() || l.function.t.empty())
          c.fail(w, "time and value must have the same non-zero length");
        for (size_t i = 1; i < l.function.t.size(); ++i)
          if (!(l.function.t[i] > l.function.t[i - 1])) c.fail(w, "time must be strictly increasing");
      }
      in.loads.push_back(l);
    }
  }
  // /monitors
  if (h5::exists(f, "/monitors")) {
    auto g = h5::openGroup(f, "/monitors");
    checkMembers(c, g, "/monitors", {"names", "points"});
    const auto names = h5::readStrings(g, "names");
    std::vector<hsize_t> d;
    const auto pts = h5::readDoubles(g, "points", &d);
    if (d.size() != 2 || d[1] != 3 || d[0] != names.size())
      c.fail("/monitors", "points must have shape [M, 3] with M = number of names");
    for (size_t i = 0; i < names.size(); ++i) {
      MonitorInput m;
      m.name = names[i];
      for (int k = 0; k < 3; ++k) m.point[k] = pts[3 * i + k];
      if (m.name.empty() || m.name.find('/') != std::string::npos)
        c.fail("/monitors", "monitor name '" + m.name + "' must be non-empty without '/'");
      in.monitors.push_back(m);
    }
  }
  // /output
  if (h5::exists(f, "/output")) {
    auto g = h5::openGroup(f, "/output");
    const std::string w = "/output";
    checkKeys(c, g, w, {"monitor_dt", "progress_s", "ring_forces", "checkpoint_interval"});
    checkMembers(c, g, w, {"snapshot_times"});
    in.monitorDt = num(c, g, w, "monitor_dt", 0.005);
    in.progressSeconds = num(c, g, w, "progress_s", 5);
    const Real ring = num(c, g, w, "ring_forces", 1);
    if (ring != 0 && ring != 1) c.fail(w, "ring_forces must be 0 or 1");
    in.ringForces = ring != 0;
    if (!(in.monitorDt > 0)) c.fail(w, "monitor_dt must be > 0 (s)");
    in.checkpointInterval = num(c, g, w, "checkpoint_interval", 0);
    if (!(in.checkpointInterval >= 0)) c.fail(w, "checkpoint_interval must be >= 0 (s; 0 = no restart checkpoints)");
    if (h5::exists(g, "snapshot_times")) in.snapshotTimes = h5::readDoubles(g, "snapshot_times");
    std::sort(in.snapshotTimes.begin(), in.snapshotTimes.end());
  }
  if (ver == 2) readStagedInput(f, in);  // stages, in-situ, boundaries, motion (input_staged.cpp)
  return in;
}

void writeSolidInput(const SolidInput& in, const std::string& path, const std::string& meshAttr) {
  auto f = h5::createFile(path);
  h5::writeStringAttr(f, "format", "tunnelquake-solid-input");
  h5::writeIntAttr(f, "version", in.staged.present ? 2 : 1);
  h5::writeStringAttr(f, "mesh", meshAttr);
  {
    auto g = h5::ensureGroup(f, "/solver");
    h5::writeDoubleAttr(g, "t_end", in.tEnd);
    h5::writeDoubleAttr(g, "dt", in.options.dt);
    h5::writeDoubleAttr(g, "safety", in.options.safety);
    h5::writeDoubleAttr(g, "velocity_limit", in.options.velocityLimit);
    h5::writeDoubleAttr(g, "gravity_z", in.options.gravity[2]);
    if (in.options.subcyclingLevels > 0) h5::writeDoubleAttr(g, "subcycling_levels", in.options.subcyclingLevels);
    h5::writeStringAttr(g, "integrator", integratorName(in.options.integrator));
    h5::writeStringAttr(g, "formulation", formulationName(in.formulation));
  }
  {
    auto g = h5::ensureGroup(f, "/damping");
    h5::writeDoubleAttr(g, "alpha", in.options.damping.alpha);
    h5::writeDoubleAttr(g, "beta", in.options.damping.beta);
  }
  for (const auto& [region, p] : in.materials) {
    auto g = h5::ensureGroup(f, "/materials/" + region);
    h5::writeDoubleAttr(g, "E", p.youngsModulus);
    h5::writeDoubleAttr(g, "nu", p.poissonRatio);
    h5::writeDoubleAttr(g, "rho", p.density);
    const auto mc = in.mohrCoulomb.find(region);
    h5::writeStringAttr(g, "model", mc == in.mohrCoulomb.end() ? "elastic" : "mohr_coulomb_damage");
    if (mc != in.mohrCoulomb.end()) {
      const MohrCoulombDamageParams& q = mc->second;
      h5::writeDoubleAttr(g, "cohesion", q.cohesion);
      h5::writeDoubleAttr(g, "friction_angle", q.frictionAngle);
      h5::writeDoubleAttr(g, "dilation_angle", q.dilationAngle);
      h5::writeDoubleAttr(g, "tensile_strength", q.tensileStrength);
      h5::writeDoubleAttr(g, "damage_constant", q.damageConstant);
      h5::writeStringAttr(g, "damage_effect", damageEffectName(q.damageEffect));
    }
  }
  for (const auto& [group, dirs] : in.fixed) {
    auto g = h5::ensureGroup(f, "/boundary/fixed/" + group);
    h5::writeStringAttr(g, "directions", dirs);
  }
  for (const auto& l : in.loads) {
    auto g = h5::ensureGroup(f, "/loads/" + l.name);
    h5::writeStringAttr(g, "target", l.target);
    h5::writeStringAttr(g, "direction", std::string(1, "xyz"[l.direction]));
    h5::writeDoubleAttr(g, "force", l.force);
    h5::writeDoubles(g, "time", l.function.t.data(), {l.function.t.size()});
    h5::writeDoubles(g, "value", l.function.value.data(), {l.function.value.size()});
  }
  if (!in.monitors.empty()) {
    std::vector<std::string> names;
    std::vector<Real> pts;
    for (const auto& m : in.monitors) {
      names.push_back(m.name);
      pts.insert(pts.end(), m.point, m.point + 3);
    }
    h5::writeStrings(f, "/monitors/names", names);
    h5::writeDoubles(f, "/monitors/points", pts.data(), {names.size(), 3});
  }
  auto g = h5::ensureGroup(f, "/output");
  h5::writeDoubleAttr(g, "monitor_dt", in.monitorDt);
  h5::writeDoubleAttr(g, "progress_s", in.progressSeconds);
  if (!in.ringForces) h5::writeIntAttr(g, "ring_forces", 0);
  if (in.checkpointInterval > 0) h5::writeDoubleAttr(g, "checkpoint_interval", in.checkpointInterval);
  if (!in.snapshotTimes.empty())
    h5::writeDoubles(g, "snapshot_times", in.snapshotTimes.data(), {in.snapshotTimes.size()});
  if (in.staged.present) writeStagedInput(f, in);
}

std::unique_ptr<Solver> buildSolver(const SolidInput& in, const Mesh& mesh) {
  std::vector<std::pair<std::string, std::shared_ptr<const Material>>> mats;
  for (const auto& [region, p] : in.materials) {
    const auto mc = in.mohrCoulomb.find(region);
    if (mc != in.mohrCoulomb.end())
      mats.emplace_back(region, std::make_shared<MohrCoulombDamageMaterial>(mc->second));
    else
      mats.emplace_back(region, std::make_shared<ElasticMaterial>(p));
  }
  auto s = std::make_unique<Solver>(mesh, makeBlocksByRegion(mesh, mats, in.formulation), in.options);
  for (const auto& [group, dirs] : in.fixed) s->fixFaceGroup(group, dirs);
  for (const auto& l : in.loads) {
    // Face group: the total force is shared in proportion to the nodes' tributary areas (a
    // uniform traction, consistent nodal forces of bilinear quads). Node set: equal shares.
    std::map<Index, Real> share;
    if (mesh.faces.count(l.target)) {
      const auto& q = mesh.faces.at(l.target);
      Real total = 0;
      for (size_t f = 0; f < q.size() / 4; ++f) {
        const Real* x[4];
        for (int k = 0; k < 4; ++k) x[k] = &mesh.coords[3 * size_t(q[4 * f + k])];
        Real d1[3], d2[3];
        for (int i = 0; i < 3; ++i) {
          d1[i] = x[2][i] - x[0][i];
          d2[i] = x[3][i] - x[1][i];
        }
        const Real area = 0.5 * std::sqrt(std::pow(d1[1] * d2[2] - d1[2] * d2[1], 2) +
                                          std::pow(d1[2] * d2[0] - d1[0] * d2[2], 2) +
                                          std::pow(d1[0] * d2[1] - d1[1] * d2[0], 2));
        for (int k = 0; k < 4; ++k) share[q[4 * f + k]] += 0.25 * area;
        total += area;
      }
      for (auto& [n, a] : share) a /= total;
    } else if (mesh.nodeSets.count(l.target)) {
      const auto& ns = mesh.nodeSets.at(l.target);
      for (Index n : ns) share[n] += 1.0 / Real(ns.size());
    } else {
      throw InputError("solid input '" + in.path + "', /loads/" + l.name + ": target '" + l.target +
                       "' is neither a face group nor a node set of mesh " + mesh.source);
    }
    for (const auto& [n, w] : share) s->addLoad({{n}, l.direction, l.force * w, l.function});
  }
  return s;
}

}  // namespace tq
