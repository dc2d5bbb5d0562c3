// The solid on MPI ranks: the partition (recursive coordinate bisection by element cost), a rank's
// layout (frontier, owners), and tq-solid on 1, 2, 3 and 4 ranks (oversubscribed where the machine
// has fewer cores) against the same run as one process: every monitored quantity equal to round-off.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "input_fixture.hpp"
#include "io/h5util.hpp"
#include "tq/io/mesh.hpp"
#include "tq/materials/material_mc.hpp"
#include "tq/parallel/partition.hpp"
#include "tq/parallel/rank_exchange.hpp"
#include "tq/parallel/rank_layout.hpp"
#include "tunnel_cases.hpp"

using namespace tq;

namespace {

struct Files {
  std::filesystem::path dir;
  Files() {
    dir = std::filesystem::temp_directory_path() / ("tq_ranks_" + std::to_string(::getpid()) + "_" +
                                                    ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir);
  }
  ~Files() { std::filesystem::remove_all(dir); }
  std::string operator/(const std::string& n) const { return (dir / n).string(); }
};

// Two regions of a box: the half at x > 6 (across its longest axis) weighs 3 times the other.
Mesh twoRegionBox() {
  Mesh m = makeBoxMesh({12, 8, 10, 0, 0, 0, 12, 8, 10, "rock"});
  m.regionNames = {"rock", "stiff"};
  for (Index e = 0; e < m.numElems(); ++e) {
    Real x = 0;
    for (int k = 0; k < 8; ++k) x += 0.125 * m.coords[3 * size_t(m.connectivity[8 * size_t(e) + k])];
    m.region[size_t(e)] = x > 6 ? 1 : 0;
  }
  return m;
}

}  // namespace

TEST(RankPartition, BisectionBalancesTheElementCostForAnyNumberOfParts) {
  const Mesh m = twoRegionBox();
  std::vector<Real> w(size_t(m.numElems()));
  for (Index e = 0; e < m.numElems(); ++e) w[size_t(e)] = m.region[size_t(e)] == 1 ? 3.0 : 1.0;
  for (int parts : {1, 2, 3, 4, 5, 7, 8}) {
    const std::vector<int> part = partitionRcb(m, w, parts);
    const std::vector<Real> pw = partWeights(part, w, parts);
    Real total = 0;
    for (Real x : pw) total += x;
    // Each cut misses its target by at most one element's weight (3); the largest part is within
    // that times the depth of the bisection tree of the mean.
    const Real mean = total / parts, worst = *std::max_element(pw.begin(), pw.end());
    EXPECT_LE(worst - mean, 3.0 * std::ceil(std::log2(double(parts)) + 1)) << parts << " parts";
    for (int p = 0; p < parts; ++p) EXPECT_GT(pw[size_t(p)], 0) << "part " << p << " of " << parts << " is empty";
    EXPECT_EQ(part, partitionRcb(m, w, parts)) << "the partition depends on the mesh and weights alone";
  }
  // Weighted: the cut of two parts lies in the heavy half, at x = 6 + 6/3 (half the weight: 480 light
  // elements and 160 heavy ones), not at x = 6.
  const std::vector<int> two = partitionRcb(m, w, 2);
  Index heavyInFirst = 0, lightInFirst = 0;
  for (Index e = 0; e < m.numElems(); ++e)
    if (two[size_t(e)] == 0) (m.region[size_t(e)] == 1 ? heavyInFirst : lightInFirst)++;
  EXPECT_EQ(lightInFirst, m.numElems() / 2);
  EXPECT_EQ(heavyInFirst, m.numElems() / 6);
  EXPECT_THROW(partitionRcb(m, w, m.numElems() + 1), InputError);
}

TEST(RankLayout, FrontierListsAgreeBetweenNeighboursAndEachNodeHasOneOwner) {
  const Mesh m = twoRegionBox();
  const std::vector<Real> w(size_t(m.numElems()), 1.0);
  for (int ranks : {2, 3, 4}) {
    const std::vector<int> part = partitionRcb(m, w, ranks);
    std::vector<RankLayout> L;
    for (int r = 0; r < ranks; ++r) L.push_back(makeRankLayout(m, part, r, ranks));
    std::vector<int> owners(size_t(m.numNodes()), 0);
    Index elems = 0;
    for (int r = 0; r < ranks; ++r) {
      elems += L[size_t(r)].mesh.numElems();
      for (size_t i = 0; i < L[size_t(r)].owned.size(); ++i)
        owners[size_t(L[size_t(r)].globalNode[i])] += L[size_t(r)].owned[i];
      for (const RankNeighbour& nb : L[size_t(r)].neighbours) {
        // The same global nodes in the same order on both sides.
        const RankLayout& other = L[size_t(nb.rank)];
        const auto it = std::find_if(other.neighbours.begin(), other.neighbours.end(),
                                     [&](const RankNeighbour& x) { return x.rank == r; });
        ASSERT_NE(it, other.neighbours.end());
        ASSERT_EQ(nb.nodes.size(), it->nodes.size());
        for (size_t k = 0; k < nb.nodes.size(); ++k)
          EXPECT_EQ(L[size_t(r)].globalNode[size_t(nb.nodes[k])], other.globalNode[size_t(it->nodes[k])]);
      }
    }
    EXPECT_EQ(elems, m.numElems());
    for (Index n = 0; n < m.numNodes(); ++n) EXPECT_EQ(owners[size_t(n)], 1) << "node " << n << ", " << ranks;
  }
}

#ifdef TQ_TEST_MPIEXEC

namespace {

// Every dataset under a group (recursively): path -> values.
// The datasets written in single precision (the ring forces), by path.
std::set<std::string> gSinglePrecision;

void readAll(hid_t f, const std::string& group, std::map<std::string, std::vector<double>>& out) {
  for (const std::string& name : h5::members(h5::openGroup(f, group))) {
    const std::string path = group + "/" + name;
    H5O_info_t info;
#if H5_VERSION_GE(1, 12, 0)
    H5Oget_info_by_name(f, path.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT);
#else
    H5Oget_info_by_name(f, path.c_str(), &info, H5P_DEFAULT);
#endif
    if (info.type == H5O_TYPE_GROUP)
      readAll(f, path, out);
    else if (info.type == H5O_TYPE_DATASET) {
      out[path] = h5::readDoubles(f, path);
      const hid_t d = H5Dopen2(f, path.c_str(), H5P_DEFAULT), t = H5Dget_type(d);
      if (H5Tget_class(t) == H5T_FLOAT && H5Tget_size(t) == 4) gSinglePrecision.insert(path);
      H5Tclose(t);
      H5Dclose(d);
    }
  }
}

const std::vector<std::string> kHistories = {"/monitors", "/energy"};

std::map<std::string, std::vector<double>> monitored(const std::string& results,
                                                     const std::vector<std::string>& groups = kHistories) {
  h5::quiet();
  auto f = h5::openFile(results);
  EXPECT_EQ(h5::readStringAttr(f, "status"), "completed") << results;
  std::map<std::string, std::vector<double>> out;
  for (const std::string& g : groups)
    if (H5Lexists(f, g.c_str(), H5P_DEFAULT) > 0) readAll(f, g, out);
  return out;
}

int run(const std::string& cmd) { return std::system((cmd + " > /dev/null 2>&1").c_str()); }

// mpiexec with N ranks, oversubscribed where the machine has fewer cores (root: allowed, as in the
// project's containers).
std::string mpiexec(int ranks) {
  return std::string(TQ_TEST_MPIEXEC) + (::geteuid() == 0 ? " --allow-run-as-root" : "") +
         " --oversubscribe --bind-to none --mca mpi_yield_when_idle 1 --mca odls_base_sigkill_timeout 5 -np " +
         std::to_string(ranks) + " ";
}

// The largest difference between two runs' values of each dataset, and its largest magnitude (a
// value NaN in one run only: an infinite difference).
std::map<std::string, std::pair<double, double>> differences(const std::map<std::string, std::vector<double>>& a,
                                                             const std::map<std::string, std::vector<double>>& b) {
  std::map<std::string, std::pair<double, double>> out;
  for (const auto& [path, x] : a) {
    const auto& y = b.at(path);
    EXPECT_EQ(x.size(), y.size()) << path;
    double scale = 0, diff = 0;
    for (size_t i = 0; i < x.size() && i < y.size(); ++i) {
      scale = std::max(scale, std::abs(x[i]));
      if (std::isnan(x[i]) != std::isnan(y[i])) diff = std::numeric_limits<double>::infinity();
      diff = std::max(diff, std::abs(x[i] - y[i]));
    }
    out[path] = {diff, scale};
  }
  return out;
}

// The datasets that hold sums over the whole model's elements, nodes or pairs taken every step
// (/energy: the balance's terms and the material's dissipation; /interface/history: the pairs'
// dissipated energy beside their counts): one process adds them chunk by chunk, the ranks add
// their parts' sums in rank order, so they differ in the last bits (adding them in the one-process
// order would need every element's and node's terms gathered every step). Nothing in the motion
// reads them.
bool isEnergySum(const std::string& path) { return path.rfind("/energy/", 0) == 0 || path == "/interface/history"; }

// tq-solid as one process and on 1-4 ranks (or those given): every monitored value (every dataset
// under `groups`) bitwise equal to the one-process run but the energy sums (isEnergySum), which
// differ by under 1e-13 of the largest magnitude of their series. Bitwise by design: each node's
// internal force and mass are summed from its elements' values in the one-process order on every
// rank that holds it, and the relaxation's sums node by node in the global numbering (docs/
// architecture.md "The solid on ranks"); a wrong or missing frontier term, pair force or boundary
// term differs at the level of the quantity itself.
void compareRanks(const Files& f, const std::string& label, const std::vector<int>& rankCounts = {1, 2, 3, 4},
                  const std::vector<std::string>& groups = kHistories) {
  const std::string exe = TQ_TEST_SOLID_EXE, in = f / "solid_input.h5";
  ASSERT_EQ(run(exe + " " + in + " --threads 1 -o " + (f / "plain.h5")), 0);
  const auto plain = monitored(f / "plain.h5", groups);
  ASSERT_FALSE(plain.empty());
  for (const auto& [path, x] : plain)  // the balance at every written row (the kinetic energy summed there)
    if (path.rfind("/energy/", 0) == 0)
      EXPECT_TRUE(std::all_of(x.begin(), x.end(), [](double e) { return std::isfinite(e); })) << label << ": " << path;
  for (int ranks : rankCounts) {
    const std::string out = f / ("ranks" + std::to_string(ranks) + ".h5");
    ASSERT_EQ(run(mpiexec(ranks) + exe + " " + in + " --distributed --threads 1 -o " + out), 0)
        << label << " on " << ranks << " ranks";
    const auto got = monitored(out, groups);
    if (ranks > 1) {  // the copies of a frontier node agree bitwise on every rank that holds it
      auto r = h5::openFile(out);
      auto g = h5::openGroup(r, "/ranks");
      EXPECT_GT(h5::readDoubleAttr(g, "frontier_node_copies"), 0);
      EXPECT_EQ(h5::readDoubleAttr(g, "frontier_copies_max_difference"), 0.0) << label << ", " << ranks;
    }
    ASSERT_EQ(got.size(), plain.size());
    double worst = 0;
    std::string where;
    size_t bitwise = 0;
    for (const auto& [path, ds] : differences(plain, got)) {
      const auto [diff, scale] = ds;
      if (diff == 0) ++bitwise;
      if (ranks == 1 || !isEnergySum(path)) {
        EXPECT_EQ(diff, 0.0) << label << " on " << ranks << " ranks: " << path << " differs from one process by "
                             << diff << " (" << diff / scale << " of its largest magnitude): the sums are bitwise "
                             << "the one-process sums by design";
        continue;
      }
      const double rel = scale > 0 ? diff / scale : diff;
      if (rel > worst) worst = rel, where = path;
    }
    std::cout << "[ranks] " << label << ", " << ranks << " rank(s): " << bitwise << " of " << plain.size()
              << " datasets bitwise; the energy sums' largest relative difference " << worst
              << (where.empty() ? "" : " (" + where + ")") << "\n";
    EXPECT_LT(worst, 1e-13) << label << " on " << ranks << " ranks, at " << where;
  }
}

}  // namespace

// An elastic box under gravity, a ramped top load and a sideways load on one face: bending, shear
// and waves crossing every partition boundary.
TEST(RankRuns, ElasticBoxMonitorsEqualOnOneToFourRanks) {
  Files f;
  writeMeshH5(makeBoxMesh({10, 6, 8, 0, 0, 0, 10, 6, 8}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({8e9, 0.27, 2700})}};
  in.fixed = {{"bottom", "xyz"}};
  in.options.gravity[2] = -9.81;
  in.options.damping = {2.0, 1e-5};
  in.tEnd = 0.06;
  LoadInput top;
  top.name = "top";
  top.target = "top";
  top.direction = 2;
  top.force = -6e7;
  top.function = {{0.0, 0.02, 1.0}, {0.0, 1.0, 1.0}};
  LoadInput side = top;
  side.name = "side";
  side.target = "xmax";
  side.direction = 1;
  side.force = 2e7;
  in.loads = {top, side};
  in.monitors = {{"corner", {10, 6, 8}}, {"middle", {5, 3, 4}}, {"low", {2, 1, 1}}, {"cut", {5, 2, 6}}};
  in.monitorDt = 1e-3;
  in.progressSeconds = 100;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  compareRanks(f, "elastic box");
}

// A confined column of weak rock under a suddenly applied top pressure: the dynamic overshoot
// drives it past the Mohr–Coulomb surface, and damage grows.
TEST(RankRuns, MohrCoulombDamageColumnMonitorsEqualOnOneToFourRanks) {
  Files f;
  writeMeshH5(makeBoxMesh({4, 4, 12, 0, 0, 0, 2, 2, 6}), f / "mesh.h5");
  SolidInput in;
  MohrCoulombDamageParams mp;
  mp.elastic = {8e9, 0.27, 2700};
  mp.cohesion = 0.05e6;
  mp.frictionAngle = 10;
  mp.tensileStrength = 0.1e6;
  mp.damageConstant = 100;
  in.materials = {{"rock", mohrCoulombDamageValues(mp)}};
  in.fixed = {{"bottom", "xyz"}, {"xmin", "x"}, {"xmax", "x"}, {"ymin", "y"}, {"ymax", "y"}};
  in.tEnd = 0.02;
  LoadInput l;
  l.name = "pressure";
  l.target = "top";
  l.direction = 2;
  l.force = -1e6 * 4.0;
  l.function = {{0.0, 1e-9, 1.0}, {0.0, 1.0, 1.0}};
  in.loads = {l};
  in.monitors = {{"top", {1.0, 1.0, 6.0}}, {"mid", {0.5, 1.5, 3.0}}, {"base", {1.0, 1.0, 0.25}}};
  in.monitorDt = 2e-4;
  in.progressSeconds = 100;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  compareRanks(f, "Mohr-Coulomb damage column");
  // The case does what it is for: damage at the monitors.
  auto r = h5::openFile(f / "ranks4.h5");
  bool damaged = false;
  std::map<std::string, std::vector<double>> all;
  readAll(r, "/monitors", all);
  for (const auto& [path, v] : all)
    if (path.find("damage") != std::string::npos)
      for (double x : v) damaged = damaged || x > 1e-3;
  EXPECT_TRUE(damaged) << "no damage at any monitor: the case does not test the damage on ranks";
}

// A run that goes unstable on one rank's part stops every rank: exit 3, the message of the rank
// that saw it, the results file with the status "stopped: ..." (no rank left waiting).
TEST(RankRuns, AnInstabilityOnOneRankStopsEveryRankWithTheStatusWritten) {
  Files f;
  writeMeshH5(makeBoxMesh({12, 4, 4, 0, 0, 0, 12, 4, 4}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({8e9, 0.27, 2700})}};
  in.fixed = {{"xmin", "xyz"}};
  in.options.velocityLimit = 1e-3;  // the pull on xmax exceeds it within a few steps
  in.tEnd = 0.05;
  LoadInput pull;
  pull.name = "pull";
  pull.target = "xmax";
  pull.direction = 0;
  pull.force = 1e9;
  in.loads = {pull};
  in.monitors = {{"end", {12, 2, 2}}};
  in.monitorDt = 1e-3;
  in.progressSeconds = 100;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  const std::string log = f / "log.txt", res = f / "r.h5";
  const int rc = std::system((mpiexec(3) + TQ_TEST_SOLID_EXE + " " + (f / "solid_input.h5") + " --distributed -o " +
                              res + " > " + log + " 2>&1")
                                 .c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 3);
  std::ifstream is(log);
  std::stringstream ss;
  ss << is.rdbuf();
  EXPECT_NE(ss.str().find("exploding"), std::string::npos) << ss.str();
  auto r = h5::openFile(res);
  EXPECT_EQ(h5::readStringAttr(r, "status").rfind("stopped: ", 0), 0u) << h5::readStringAttr(r, "status");
}

namespace {

// A slice mesh (corners 4-7 of each element its corners 0-3 moved by the slice's width along y)
// extruded into `layers` slices along y: a 3D model, not plane strain. Its faces are the slice's
// faces along each layer, ymin on the first and ymax on the last; its rock-lining pairs, the
// slice's at every layer's plane; the rock of the middle layer is region "weak_rock", so that the
// response varies along the tunnel.
Mesh extrudeSlice(const Mesh& s, int layers) {
  const Index N = s.numNodes();
  std::vector<Index> baseOf(size_t(N), -1), top(size_t(N), 0), baseIndex(size_t(N), -1);
  Index nb = 0;
  for (Index e = 0; e < s.numElems(); ++e)
    for (int v = 0; v < 4; ++v) {
      const Index b = s.connectivity[8 * size_t(e) + size_t(v)], t = s.connectivity[8 * size_t(e) + 4 + size_t(v)];
      baseOf[size_t(b)] = b, baseOf[size_t(t)] = b, top[size_t(t)] = 1;
    }
  for (Index n = 0; n < N; ++n)
    if (baseOf[size_t(n)] == n) baseIndex[size_t(n)] = nb++;
  const Real width = s.coords[3 * size_t(s.connectivity[4]) + 1] - s.coords[3 * size_t(s.connectivity[0]) + 1];
  auto node = [&](Index n, int layer) {
    return Index(layer + top[size_t(n)]) * nb + baseIndex[size_t(baseOf[size_t(n)])];
  };
  Mesh m;
  m.source = s.source + " extruded";
  m.regionNames = s.regionNames;
  m.regionNames.push_back("weak_rock");
  m.coords.resize(3 * size_t(nb) * size_t(layers + 1));
  for (int l = 0; l <= layers; ++l)
    for (Index n = 0; n < N; ++n)
      if (baseOf[size_t(n)] == n) {
        const size_t i = 3 * size_t(node(n, l));
        m.coords[i] = s.coords[3 * size_t(n)];
        m.coords[i + 1] = l * width;
        m.coords[i + 2] = s.coords[3 * size_t(n) + 2];
      }
  for (int l = 0; l < layers; ++l)
    for (Index e = 0; e < s.numElems(); ++e) {
      for (int k = 0; k < 8; ++k) m.connectivity.push_back(node(s.connectivity[8 * size_t(e) + size_t(k)], l));
      const Index r = s.region[size_t(e)];
      m.region.push_back(r == 0 && l == layers / 2 ? Index(m.regionNames.size() - 1) : r);
    }
  for (const auto& [name, quads] : s.faces)
    for (int l = 0; l < layers; ++l) {
      if ((name == "ymin" && l > 0) || (name == "ymax" && l < layers - 1)) continue;
      for (Index n : quads) m.faces[name].push_back(node(n, name == "ymax" ? layers - 1 : name == "ymin" ? 0 : l));
    }
  for (int l = 0; l <= layers; ++l)
    for (size_t p = 0; p + 1 < s.rockLiningPairs.size(); p += 2)
      if (!top[size_t(s.rockLiningPairs[p])]) {
        m.rockLiningPairs.push_back(node(s.rockLiningPairs[p], l));
        m.rockLiningPairs.push_back(node(s.rockLiningPairs[p + 1], l));
      }
  return m;
}

// The staged tunnel of the tests below (a quarter of a lined tunnel with contact and damage, shaken
// by a pulse), written to f/solid_input.h5 and f/mesh.h5, with restart checkpoints every
// `checkpointInterval` s (0: none) and snapshots at `snapshots`; its mesh. layers > 0: extruded
// into that many slices along y (extrudeSlice), its middle layer's rock weaker. subcycling > 0: the
// lining 3 elements through its thickness (finer than the rock next to it), the slices 2 m long,
// stepped with that many subcycling levels.
Mesh writeStagedTunnel(const Files& f, Real checkpointInterval = 0, const std::vector<Real>& snapshots = {},
                       int layers = 0, int subcycling = 0) {
  tqcases::QuarterSpec qs;
  qs.nTheta = 8;
  qs.L = 6 * qs.b;
  qs.liningT = 0.75;
  qs.nLining = subcycling > 0 ? 3 : 1;
  if (subcycling > 0) {  // the rock's elements up to 2 m along the tunnel: 4 levels
    qs.width = 2.0;
    qs.nTheta = 16;  // enough chunks that a level's slab order differs from the block's at some node
  }
  const Mesh mesh = layers > 0 ? extrudeSlice(tqcases::quarterPlate(qs), layers) : tqcases::quarterPlate(qs);
  writeMeshH5(mesh, f / "mesh.h5");
  SolidInput in;
  MohrCoulombDamageParams rock, lining;
  rock.elastic = {8e9, 0.27, 2700};
  rock.cohesion = 0.15e6;
  rock.frictionAngle = 30;
  rock.tensileStrength = 0.1e6;
  rock.damageConstant = 100;
  lining.elastic = {28e9, 0.17, 2500};
  lining.cohesion = 1.8e6;
  lining.frictionAngle = 40;
  lining.tensileStrength = 0.3e6;
  lining.damageConstant = 100;
  in.materials = {{"rock", mohrCoulombDamageValues(rock)}, {"lining", mohrCoulombDamageValues(lining)}};
  in.fixed = {{"bottom", "z"}, {"xmin", "x"}, {"xmax", "x"}};
  if (layers > 0) {
    MohrCoulombDamageParams weak = rock;
    weak.cohesion = 0.05e6;
    weak.tensileStrength = 0.03e6;
    in.materials.push_back({"weak_rock", mohrCoulombDamageValues(weak)});
    in.fixed["ymin"] = "y";
    in.fixed["ymax"] = "y";
  }
  in.options.gravity[2] = -9.81;
  in.options.damping = {1.0, 0.0};
  in.options.subcyclingLevels = subcycling;
  in.tEnd = 0.045;
  StagedInput& S = in.staged;
  S.present = true;
  S.stages.sequence = {"in_situ", "excavation", "lining", "seismic"};
  S.stages.tolerance = 1e-3;
  S.inSitu.present = true;
  S.inSitu.kx = 1.2;
  S.inSitu.gravity = 9.81;
  S.inSitu.surcharge = 2e6;
  S.rockLining.present = true;
  S.rockLining.model = "dynamic_contact";
  S.rockLining.cohesion = 0.02e6;
  S.bottom.present = true;
  S.freeField.present = true;
  S.freeField.faces = {"xmax"};
  S.motion.present = true;
  for (Real t = 0; t <= 0.045 + 1e-12; t += 1e-3) {  // a 25 Hz pulse, 0.8 g across, 0.5 g vertical
    const Real a = 8.0 * std::sin(2 * M_PI * 25 * t) * std::exp(-std::pow((t - 0.02) / 0.008, 2));
    S.motion.time.push_back(t);
    S.motion.ax.push_back(a);
    S.motion.az.push_back(0.6 * a);
  }
  const Real y = layers > 0 ? 0.5 * qs.width * layers : 0.25;  // the middle
  in.monitors = {
      {"crown", {0.0, y, 4.9}}, {"springline", {4.9, y, 0.3}}, {"haunch", {3.5, y, 3.5}}, {"rock", {8.0, y, 8.0}}};
  if (layers > 0) in.monitors.push_back({"end_crown", {0.0, 0.0, 4.9}});
  in.monitorDt = 1e-3;
  in.progressSeconds = 100;
  in.checkpointInterval = checkpointInterval;
  in.snapshotTimes = snapshots;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  return mesh;
}

}  // namespace

namespace {

// The staged tunnel (writeStagedTunnel: `layers` 0, the plane-strain slice; more, a 3D model) as
// one process and on `rankCounts` ranks: every dataset of /monitors, /interface and /ring_forces
// bitwise, the energy sums to round-off (compareRanks); the pairs cross the partitions, the
// ground and the lining are damaged and pairs slip or open.
void stagedTunnelOnRanks(int layers, const std::vector<int>& rankCounts, const std::string& label, int subcycling = 0) {
  Files f;
  const Mesh mesh = writeStagedTunnel(f, 0, {}, layers, subcycling);
  // The pairs cross the partitions: some pair's rock node is used by the elements of other ranks
  // than its lining node (those ranks then hold both, the layout's `together` groups).
  {
    const std::vector<Real> cost = elementCosts(mesh, readSolidInput(f / "solid_input.h5"));
    Index crossing = 0;
    for (int ranks : rankCounts) {
      if (ranks == 1) continue;
      const std::vector<int> part = partitionRcb(mesh, cost, ranks);
      std::vector<std::set<int>> users(size_t(mesh.numNodes()));
      for (Index e = 0; e < mesh.numElems(); ++e)
        for (int k = 0; k < 8; ++k) users[size_t(mesh.connectivity[8 * size_t(e) + k])].insert(part[size_t(e)]);
      Index here = 0;
      for (size_t p = 0; p < mesh.rockLiningPairs.size(); p += 2)
        here += users[size_t(mesh.rockLiningPairs[p])] != users[size_t(mesh.rockLiningPairs[p + 1])];
      std::cout << "[ranks] " << label << ", " << ranks << " ranks: " << here << " of "
                << mesh.rockLiningPairs.size() / 2 << " rock-lining pairs cross the partition\n";
      crossing += here;
    }
    EXPECT_GT(crossing, 0) << "no rock-lining pair crosses a partition: the case does not test that";
  }
  compareRanks(f, label, rankCounts, {"/monitors", "/energy", "/interface", "/ring_forces"});
  // The case does what it is for: damage, and pairs that slipped or opened.
  auto r = h5::openFile(f / ("ranks" + std::to_string(rankCounts.back()) + ".h5"));
  std::map<std::string, std::vector<double>> all;
  readAll(r, "/monitors", all);
  double damage = 0;
  for (const auto& [path, v] : all)
    if (path.find("damage") != std::string::npos)
      for (double x : v) damage = std::max(damage, x);
  EXPECT_GT(damage, 1e-3) << "no damage at any monitor";
  const std::vector<double> history = h5::readDoubles(r, "/interface/history");
  double failed = 0;  // columns: time, bonded, separated, slipping, stuck, inactive, dissipated
  for (size_t i = 0; i + 7 <= history.size(); i += 7) failed = std::max(failed, history[i + 2] + history[i + 3]);
  EXPECT_GT(failed, 0) << "no pair separated or slipped";
  if (subcycling > 0) {  // the levels in use: nodes on each, chunks of elements on more than one
    auto p = h5::openFile(f / "plain.h5");
    auto g = h5::openGroup(p, "/subcycling");
    const int levels = int(h5::readDoubleAttr(g, "levels"));
    EXPECT_GE(levels, subcycling) << "the case does not subcycle on every level";
    int chunkLevels = 0;
    std::cout << "[ranks] " << label << ": levels 0-" << levels << ", nodes";
    for (int l = 0; l <= levels; ++l) {
      const double nn = h5::readDoubleAttr(g, "nodes_level_" + std::to_string(l));
      std::cout << " " << nn;
      EXPECT_GT(nn, 0) << "level " << l;
      chunkLevels += h5::readDoubleAttr(g, "elements_level_" + std::to_string(l)) > 0;
    }
    std::cout << ", cost fraction " << h5::readDoubleAttr(g, "cost_fraction") << "\n";
    EXPECT_GE(chunkLevels, 2) << "every element evaluated at the same steps";
    for (int ranks : rankCounts) {  // the ranks report the same levels
      auto q = h5::openFile(f / ("ranks" + std::to_string(ranks) + ".h5"));
      auto h = h5::openGroup(q, "/subcycling");
      EXPECT_EQ(h5::readDoubleAttr(h, "cost_fraction"), h5::readDoubleAttr(g, "cost_fraction")) << ranks;
      for (int l = 0; l <= levels; ++l)
        EXPECT_EQ(h5::readDoubleAttr(h, "nodes_level_" + std::to_string(l)),
                  h5::readDoubleAttr(g, "nodes_level_" + std::to_string(l)))
            << ranks << " ranks, level " << l;
    }
  }
}

}  // namespace

// The staged analysis on ranks: in-situ stress, excavation, the lining installed with the dynamic
// contact on the rock-lining pairs, then an earthquake through a viscoelastic base and a free-field
// side, both rock and lining Mohr-Coulomb with damage. A quarter of a lined tunnel (plane strain),
// small enough for 5 runs in seconds; a strong pulse, a weak interface and weak rock, so that pairs
// slip or open and the ground yields, and the pairs cross the partition boundaries on 3 and more
// ranks. Every monitored value (monitors with damage and accelerations, the interface's pair
// counts, the lining's ring forces) bitwise equal to the one-process run; the energy sums
// (isEnergySum) to 2e-15 of their peak (2, 3, 8 ranks).
TEST(RankRuns, StagedTunnelWithContactAndDamageEqualOnOneToEightRanks) {
  stagedTunnelOnRanks(0, {1, 2, 3, 8}, "staged tunnel with contact and damage");
}

// The same tunnel as a 3D model: the slice extruded into 3 slices along the tunnel (240 elements),
// the middle one's rock weaker, on rollers at both ends; on 1, 2, 3, 4 and 8 ranks.
TEST(RankRuns, ThreeDimensionalTunnelWithContactAndDamageBitwiseOnOneToEightRanks) {
  stagedTunnelOnRanks(3, {1, 2, 3, 4, 8}, "3D tunnel with contact and damage");
}

// The same 3D tunnel subcycled (multi-rate stepping): its lining 3 elements through the thickness,
// finer than the rock, the rock's nodes stepping up to 8 times the lining's step. Each element is
// evaluated at the steps one process evaluates it (a rank's chunk lies in one of the one-process
// chunks and takes its level) and each node's force at a step of level L is summed from the
// elements due at L in the one-process order of that level: every monitored value bitwise, the
// energy sums to round-off, on 1, 2, 3, 4 and 8 ranks.
TEST(RankRuns, SubcycledThreeDimensionalTunnelWithContactAndDamageBitwiseOnOneToEightRanks) {
  stagedTunnelOnRanks(3, {1, 2, 3, 4, 8}, "subcycled 3D tunnel with contact and damage", 3);
}

namespace {

// The pid of the process of rank `rank` among the children of `parent` (mpiexec starts its ranks
// as its own children, each with OMPI_COMM_WORLD_RANK in its environment), or -1.
pid_t rankProcess(pid_t parent, int rank) {
  for (const auto& e : std::filesystem::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream st(e.path() / "stat");
    std::string line;
    std::getline(st, line);
    const size_t close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 2));
    char state = 0;
    pid_t ppid = -1;
    rest >> state >> ppid;
    if (ppid != parent) continue;
    std::ifstream env(e.path() / "environ", std::ios::binary);
    std::string var;
    while (std::getline(env, var, '\0'))
      if (var == "OMPI_COMM_WORLD_RANK=" + std::to_string(rank)) return pid_t(std::stol(name));
  }
  return -1;
}

// Running (a zombie whose parent has not reaped it yet counts as ended).
bool alive(pid_t pid) {
  std::ifstream st("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(st, line)) return false;
  const size_t close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] != 'Z' && line[close + 2] != 'X';
}

}  // namespace

// A rank killed mid-run (SIGKILL: it cannot say anything) stops the whole run: mpirun ends the
// other ranks, rank 0 writes the results file's status on its way out ("stopped: ..."), the samples
// written so far stay readable, and no rank is left running.
TEST(RankRuns, AKilledRankStopsEveryRankWithTheStatusWritten) {
  Files f;
  writeMeshH5(makeBoxMesh({12, 6, 6, 0, 0, 0, 12, 6, 6}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({8e9, 0.27, 2700})}};
  in.fixed = {{"xmin", "xyz"}};
  in.tEnd = 100;  // far longer than the test waits
  LoadInput tip;
  tip.name = "tip";
  tip.target = "xmax";
  tip.direction = 2;
  tip.force = -1e5;
  in.loads = {tip};
  in.monitors = {{"tip", {12, 3, 3}}};
  in.monitorDt = 1e-4;
  in.progressSeconds = 0.2;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  const std::string log = f / "log.txt", res = f / "r.h5", pidFile = f / "pid";
  ASSERT_EQ(std::system(("(" + mpiexec(3) + TQ_TEST_SOLID_EXE + " " + (f / "solid_input.h5") + " --distributed -o " +
                         res + " > " + log + " 2>&1 & echo $! > " + pidFile + ")")
                            .c_str()),
            0);
  pid_t mpirun = -1;
  std::ifstream(pidFile) >> mpirun;
  ASSERT_GT(mpirun, 0);
  const auto readLog = [&] {
    std::ifstream is(log);
    std::stringstream ss;
    ss << is.rdbuf();
    return ss.str();
  };
  // Stepping: rank 0 has printed progress (samples written), rank 2 is there.
  pid_t victim = -1;
  for (int i = 0; i < 600 && (victim < 0 || readLog().find("  t = ") == std::string::npos); ++i) {
    ::usleep(100000);
    if (victim < 0) victim = rankProcess(mpirun, 2);
  }
  ASSERT_GT(victim, 0) << "rank 2 not found\n" << readLog();
  ASSERT_NE(readLog().find("  t = "), std::string::npos) << readLog();
  const pid_t rank0 = rankProcess(mpirun, 0), rank1 = rankProcess(mpirun, 1);
  ASSERT_EQ(::kill(victim, SIGKILL), 0);
  for (int i = 0; i < 300 && alive(mpirun); ++i) ::usleep(100000);
  EXPECT_FALSE(alive(mpirun)) << "mpirun still running 30 s after a rank was killed";
  EXPECT_FALSE(rank0 > 0 && alive(rank0)) << "rank 0 left running";
  EXPECT_FALSE(rank1 > 0 && alive(rank1)) << "rank 1 left running";
  h5::quiet();
  auto r = h5::openFile(res);
  const std::string status = h5::readStringAttr(r, "status");
  EXPECT_EQ(status.rfind("stopped: ", 0), 0u) << status << "\n" << readLog();
  EXPECT_NE(status.find("ended by signal"), std::string::npos) << status;
  EXPECT_GT(h5::readDoubles(r, "/monitors/tip/time").size(), 1u) << "the samples before the kill are kept";
}

// Restart checkpoints on ranks: the staged tunnel (contact, damage, seismic boundaries) on 3 ranks
// writes one every 0.01 s. Rank 2 killed (SIGKILL) after 60 % of the steps stops the run with the
// results file's status written and the last checkpoint kept; a resume on 2 ranks is refused before
// anything is written, naming the 3 it needs; `--resume` on 3 ranks ends with every history, snapshot
// and the interface's record bitwise equal to the run that was never stopped (the same rank count:
// the same partition, the same sums in the same order, and every part's whole state restored).
TEST(RankRuns, AKilledRankRunResumesOnItsRanksBitwiseEqualToAnUninterruptedRun) {
  Files f;
  writeStagedTunnel(f, 0.01, {0.015, 0.035});
  const std::string exe = TQ_TEST_SOLID_EXE, in = f / "solid_input.h5";
  const auto command = [&](int ranks, const std::string& out, const std::string& dir, const std::string& extra) {
    return mpiexec(ranks) + "-x TQ_RANK_FAULT " + exe + " " + in + " --distributed --threads 1 -o " + out +
           " --checkpoint-dir " + dir + extra;
  };
  const auto readLog = [](const std::string& path) {
    std::ifstream is(path);
    std::stringstream ss;
    ss << is.rdbuf();
    return ss.str();
  };
  const std::vector<std::string> groups = {"/monitors", "/energy", "/interface", "/ring_forces", "/snapshots"};
  ::unsetenv("TQ_RANK_FAULT");
  ASSERT_EQ(run(command(3, f / "whole.h5", f / "whole_checkpoints", "")), 0);
  const auto whole = monitored(f / "whole.h5", groups);
  long long steps = 0;
  {
    auto w = h5::openFile(f / "whole.h5");
    steps = h5::readIntAttr(h5::openGroup(w, "/timings"), "steps");
    EXPECT_EQ(h5::readDoubleAttr(h5::openGroup(w, "/timings"), "checkpoints"), 4.0) << "t = 0.01, 0.02, 0.03, 0.04";
  }
  ASSERT_GT(steps, 20);
  EXPECT_FALSE(std::filesystem::exists(f / "whole_checkpoints/checkpoint.json")) << "a completed run keeps none";

  const std::string res = f / "r.h5", dir = f / "checkpoints", log = f / "log.txt";
  ::setenv("TQ_RANK_FAULT", ("2:" + std::to_string(steps * 6 / 10)).c_str(), 1);
  const int killed = std::system((command(3, res, dir, "") + " > " + log + " 2>&1").c_str());
  ::unsetenv("TQ_RANK_FAULT");
  EXPECT_NE(WEXITSTATUS(killed), 0) << readLog(log);
  h5::quiet();
  const auto status = [&] { return h5::readStringAttr(h5::openFile(res), "status"); };
  EXPECT_EQ(status().rfind("stopped: ", 0), 0u) << status() << "\n" << readLog(log);
  EXPECT_NE(status().find("ended by signal"), std::string::npos) << status();
  ASSERT_TRUE(std::filesystem::exists(dir + "/checkpoint.json")) << readLog(log);

  const int other = std::system((command(2, res, dir, " --resume") + " > " + log + " 2>&1").c_str());
  EXPECT_EQ(WEXITSTATUS(other), 2);
  EXPECT_NE(readLog(log).find("written by the run on 3 ranks; resume it on 3 ranks (--ranks 3)"), std::string::npos)
      << readLog(log);
  EXPECT_EQ(status().rfind("stopped: ", 0), 0u) << "a refused resume left the results file as it was";

  ASSERT_EQ(std::system((command(3, res, dir, " --resume") + " > " + log + " 2>&1").c_str()), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("resumed from checkpoint 2 at t = 0.02"), std::string::npos) << readLog(log);
  const auto resumed = monitored(res, groups);
  ASSERT_EQ(resumed.size(), whole.size());
  EXPECT_TRUE(whole.count("/snapshots/1/u") || whole.count("/snapshots/1/displacement"))
      << "the snapshots are compared";
  for (const auto& [path, x] : whole) {
    const auto& y = resumed.at(path);
    ASSERT_EQ(x.size(), y.size()) << path;
    EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)), 0)
        << path << " differs from the uninterrupted run";
  }
}

// What does not run on ranks yet is refused before anything runs, by name, with the fix.
TEST(RankRuns, WhatDoesNotRunOnRanksIsRefusedWithTheReason) {
  Files f;
  writeMeshH5(makeBoxMesh({2, 2, 2, 0, 0, 0, 2, 2, 2}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({8e9, 0.27, 2700})}};
  in.fixed = {{"bottom", "xyz"}};
  in.tEnd = 0.01;
  in.progressSeconds = 100;
  in.options.integrator = Integrator::PaperEq34;
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  const std::string log = f / "log.txt";
  const int rc = std::system((mpiexec(2) + TQ_TEST_SOLID_EXE + " " + (f / "solid_input.h5") + " --distributed -o " +
                              (f / "r.h5") + " > " + log + " 2>&1")
                                 .c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  std::ifstream is(log);
  std::stringstream ss;
  ss << is.rdbuf();
  EXPECT_NE(ss.str().find("paper_eq3_4"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("does not run on ranks"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("without --ranks"), std::string::npos) << ss.str();
}

#endif
