// solid_input.h5 reader (docs/formats.md "## solid_input.h5"): every group, attribute, default and
// bound from the generated table (input_schema.hpp), the stages and boundaries in input_staged.cpp.
#include "tq/io/input.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "h5util.hpp"
#include "input_schema.hpp"
#include "input_staged.hpp"
#include "tq/io/mesh.hpp"
#include "tq/materials/registry.hpp"

namespace tq {

namespace S = input_schema;
namespace K = input_schema::key;

namespace {

/// The material rows the file is read against: its own /schema rows when it has them (each row
/// this tq-solid was built with must be there, declared the same; rows it does not know are
/// parameters added to the table since, read into the regions' maps), else the compiled ones.
std::vector<S::Row> materialRows(const S::Reader& R, hid_t f) {
  std::vector<S::Row> compiled = S::rowsOf(S::kMaterials);
  if (!h5::exists(f, "/schema")) return compiled;
  auto g = h5::openGroup(f, "/schema");
  R.checkGroup(g, "/schema", "/schema");
  const std::string hash = R.text(g, "/schema", K::schema::hash, true);
  if (hash != S::kHash)
    R.fail(
        "/schema",
        "hash " + hash + " is not this tq-solid's " + S::kHash +
            ": the file was written from another "
            "version of the table (scripts/tunnelquake/solver_input_schema.py); rebuild tq-solid or rewrite the input");
  if (!R.has(g, K::schema::material_parameters)) return compiled;
  std::vector<S::Row> rows;
  try {
    for (const auto& text : h5::readStrings(g, K::schema::material_parameters.name))
      rows.push_back(S::parseMaterialRow(text));
  } catch (const InputError& e) {
    R.fail("/schema", e.what());
  }
  for (const auto& c : compiled) {
    const auto it = std::find_if(rows.begin(), rows.end(), [&](const S::Row& r) { return r.name == c.name; });
    if (it == rows.end() || !(*it == c))
      R.fail("/schema",
             "material parameter '" + c.name + "' is " + (it == rows.end() ? "missing" : "declared differently") +
                 " in this file's material_parameters (this tq-solid was built from another version of the table); "
                 "rebuild tq-solid or rewrite the input");
  }
  return rows;
}

void readMaterials(const S::Reader& R, hid_t f, SolidInput& in) {
  const std::vector<S::Row> rows = materialRows(R, f);
  const S::Row* modelRow = nullptr;
  for (const auto& r : rows)
    if (r.name == K::materials::model.name) modelRow = &r;
  if (!modelRow) R.fail("/schema", "material_parameters has no row 'model'");
  auto g = h5::openGroup(f, "/materials");
  R.checkGroup(g, "/materials", "/materials");
  for (const auto& region : h5::members(g)) {
    auto mg = h5::openGroup(g, region);
    const std::string w = "/materials/" + region;
    R.checkGroup(mg, w, S::kMaterials, rows);
    MaterialValues v;
    v.model = R.text(mg, w, *modelRow);
    for (const auto& r : rows) {
      if (&r == modelRow) continue;
      const bool required = r.requiredFor(v.model);
      if (required && !R.has(mg, r))
        R.fail(w, "attribute '" + r.name + "' is required by model " + v.model +
                      (r.caseKey.empty() ? "" : " (case key " + r.caseKey + ")"));
      if (!R.has(mg, r) && !(r.hasDefault && r.readBy(v.model)) && !required) continue;
      if (r.kind == S::Kind::Text)
        v.texts[r.name] = R.text(mg, w, r, required);
      else
        v.numbers[r.name] = R.number(mg, w, r, required);
    }
    try {
      makeMaterial(v);  // a registered model (tq/materials/registry.hpp), its own checks of its parameters
    } catch (const InputError& e) {
      R.fail(w, e.what());
    }
    in.materials.emplace_back(region, v);
  }
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}

}  // namespace

SolidInput readSolidInput(const std::string& path) {
  const S::Reader R(path);
  SolidInput in;
  in.path = path;
  auto f = h5::openFile(path);
  R.checkGroup(f, "root", "/");
  R.requireGroups(f);
  R.text(f, "root", K::root::format, true);
  R.number(f, "root", K::root::version, true);
  const std::string mesh = R.text(f, "root", K::root::mesh, true);
  const auto dir = std::filesystem::path(path).parent_path();
  in.meshPath = std::filesystem::path(mesh).is_absolute() ? mesh : (dir / mesh).string();

  // /solver
  {
    auto g = h5::openGroup(f, "/solver");
    const std::string w = "/solver";
    R.checkGroup(g, w, w);
    in.tEnd = R.number(g, w, K::solver::t_end);
    in.options.dt = R.number(g, w, K::solver::dt);
    in.options.safety = R.number(g, w, K::solver::safety);
    in.options.velocityLimit = R.number(g, w, K::solver::velocity_limit);
    in.options.gravity[2] = R.number(g, w, K::solver::gravity_z);
    in.options.subcyclingLevels = int(R.number(g, w, K::solver::subcycling_levels));
    try {
      in.options.integrator = parseIntegrator(R.text(g, w, K::solver::integrator));
      in.formulation = parseFormulation(R.text(g, w, K::solver::formulation));
    } catch (const InputError& e) {
      R.fail(w, e.what());
    }
  }
  // /damping
  if (const auto g = R.group(f, "/damping", "/damping"); g.valid()) {
    const std::string w = "/damping";
    const bool byRatio = R.has(g, K::damping::ratio);
    const bool byCoef = R.has(g, K::damping::alpha) || R.has(g, K::damping::beta);
    if (byRatio && byCoef) R.fail(w, "give either ratio/f1/f2 or alpha/beta, not both");
    try {
      if (byRatio)
        in.options.damping =
            RayleighDamping::fromRatio(R.number(g, w, K::damping::ratio), R.number(g, w, K::damping::f1, true),
                                       R.number(g, w, K::damping::f2, true));
      else
        in.options.damping = {R.number(g, w, K::damping::alpha), R.number(g, w, K::damping::beta)};
    } catch (const InputError& e) {
      R.fail(w, e.what());
    }
    if (in.options.damping.alpha < 0 || in.options.damping.beta < 0) R.fail(w, "alpha and beta must be >= 0");
  }
  readMaterials(R, f, in);
  // /boundary/fixed/<face group>
  if (const auto g = R.group(f, "/boundary", "/boundary"); g.valid()) {
    if (const auto fg = R.group(g, "fixed", "/boundary/fixed"); fg.valid()) {
      for (const auto& group : h5::members(fg)) {
        auto gg = h5::openGroup(fg, group);
        const std::string w = "/boundary/fixed/" + group;
        R.checkGroup(gg, w, "/boundary/fixed/*");
        const std::string dirs = R.text(gg, w, K::boundary_fixed::directions);
        if (dirs.empty() || dirs.find_first_not_of("xyz") != std::string::npos)
          R.fail(w, "directions '" + dirs + "' must be letters from x, y, z (e.g. \"xyz\")");
        in.fixed[group] = dirs;
        in.requiredFaces.push_back(group);
      }
    }
  }
  // /loads/<name>
  if (const auto g = R.group(f, "/loads", "/loads"); g.valid()) {
    for (const auto& name : h5::members(g)) {
      auto lg = h5::openGroup(g, name);
      const std::string w = "/loads/" + name;
      R.checkGroup(lg, w, "/loads/*");
      LoadInput l;
      l.name = name;
      l.target = R.text(lg, w, K::loads::target);
      l.direction = R.text(lg, w, K::loads::direction)[0] - 'x';
      l.force = R.number(lg, w, K::loads::force);
      if (R.has(lg, K::loads::time) != R.has(lg, K::loads::value))
        R.fail(w, "give both datasets time and value, or neither");
      if (R.has(lg, K::loads::time)) {
        l.function.t = h5::readDoubles(lg, K::loads::time.name);
        l.function.value = h5::readDoubles(lg, K::loads::value.name);
        if (l.function.t.size() != l.function.value.size() || l.function.t.empty())
          R.fail(w, "time and value must have the same non-zero length");
        for (size_t i = 1; i < l.function.t.size(); ++i)
          if (!(l.function.t[i] > l.function.t[i - 1])) R.fail(w, "time must be strictly increasing");
      }
      in.loads.push_back(l);
    }
  }
  // /monitors
  if (const auto g = R.group(f, "/monitors", "/monitors"); g.valid()) {
    const auto names = h5::readStrings(g, K::monitors::names.name);
    std::vector<hsize_t> d;
    const auto pts = h5::readDoubles(g, K::monitors::points.name, &d);
    if (d.size() != 2 || d[1] != 3 || d[0] != names.size())
      R.fail("/monitors", "points must have shape [M, 3] with M = number of names");
    for (size_t i = 0; i < names.size(); ++i) {
      MonitorInput m;
      m.name = names[i];
      for (int k = 0; k < 3; ++k) m.point[k] = pts[3 * i + k];
      if (m.name.empty() || m.name.find('/') != std::string::npos)
        R.fail("/monitors", "monitor name '" + m.name + "' must be non-empty without '/'");
      in.monitors.push_back(m);
    }
  }
  // /output
  if (const auto g = R.group(f, "/output", "/output"); g.valid()) {
    const std::string w = "/output";
    in.monitorDt = R.number(g, w, K::output::monitor_dt);
    in.progressSeconds = R.number(g, w, K::output::progress_s);
    in.ringForces = R.flag(g, w, K::output::ring_forces);
    in.checkpointInterval = R.number(g, w, K::output::checkpoint_interval);
    if (R.has(g, K::output::snapshot_times)) in.snapshotTimes = h5::readDoubles(g, K::output::snapshot_times.name);
    std::sort(in.snapshotTimes.begin(), in.snapshotTimes.end());
  }
  readStagedInput(f, in);  // stages, in-situ stress, boundaries, motion, coupling (input_staged.cpp)
  return in;
}

std::string inputJson(const SolidInput& in) {
  std::ostringstream os;
  os.precision(17);
  os << "{\"path\": " << jsonString(in.path) << ", \"schema\": " << jsonString(S::kHash) << ", \"materials\": {";
  bool firstRegion = true;
  for (const auto& [region, v] : in.materials) {
    os << (firstRegion ? "" : ", ") << jsonString(region) << ": {\"model\": " << jsonString(v.model);
    for (const auto& [k, x] : v.numbers) os << ", " << jsonString(k) << ": " << x;
    for (const auto& [k, t] : v.texts) os << ", " << jsonString(k) << ": " << jsonString(t);
    os << "}";
    firstRegion = false;
  }
  os << "}, \"t_end\": " << in.tEnd << ", \"stages\": " << (in.staged.present ? "true" : "false") << "}";
  return os.str();
}

std::map<Index, Real> loadShares(const SolidInput& in, const Mesh& mesh, const LoadInput& l) {
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
      const Real area =
          0.5 * std::sqrt(std::pow(d1[1] * d2[2] - d1[2] * d2[1], 2) + std::pow(d1[2] * d2[0] - d1[0] * d2[2], 2) +
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
  return share;
}

Mesh readInputMesh(const SolidInput& in) {
  Mesh mesh = readMeshH5(in.meshPath, {in.requiredFaces});
  if (in.options.subcyclingLevels <= 0) return mesh;
  std::vector<Real> speed(mesh.regionNames.size(), 0.0);
  for (const auto& [region, v] : in.materials) {
    const Index r = mesh.regionIndex(region);
    if (r < 0) continue;  // buildSolver refuses it, naming the regions
    const std::shared_ptr<const Material> m = makeMaterial(v);
    speed[size_t(r)] = std::sqrt(m->elasticModuli().pModulus() / m->density());
  }
  setOrderLevels(mesh, speed, in.options.subcyclingLevels);
  return mesh;
}

std::unique_ptr<Solver> buildSolver(const SolidInput& in, const Mesh& mesh) {
  std::vector<std::pair<std::string, std::shared_ptr<const Material>>> mats;
  for (const auto& [region, v] : in.materials) mats.emplace_back(region, makeMaterial(v));
  auto s = std::make_unique<Solver>(mesh, makeBlocksByRegion(mesh, mats, in.formulation), in.options);
  for (const auto& [group, dirs] : in.fixed) s->fixFaceGroup(group, dirs);
  for (const auto& l : in.loads) {
    const std::map<Index, Real> share = loadShares(in, mesh, l);
    for (const auto& [n, w] : share) s->addLoad({{n}, l.direction, l.force * w, l.function});
  }
  return s;
}

}  // namespace tq
