// The solid on MPI ranks: the partition (recursive coordinate bisection by element cost), a rank's
// layout (frontier, owners), and tq-solid on 1, 2, 3 and 4 ranks (oversubscribed where the machine
// has fewer cores) against the same run as one process: every monitored quantity equal to round-off.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
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
    else if (info.type == H5O_TYPE_DATASET)
      out[path] = h5::readDoubles(f, path);
  }
}

std::map<std::string, std::vector<double>> monitored(const std::string& results) {
  h5::quiet();
  auto f = h5::openFile(results);
  EXPECT_EQ(h5::readStringAttr(f, "status"), "completed") << results;
  std::map<std::string, std::vector<double>> out;
  readAll(f, "/monitors", out);
  readAll(f, "/energy", out);
  return out;
}

int run(const std::string& cmd) { return std::system((cmd + " > /dev/null 2>&1").c_str()); }

// mpiexec with N ranks, oversubscribed where the machine has fewer cores (root: allowed, as in the
// project's containers).
std::string mpiexec(int ranks) {
  return std::string(TQ_TEST_MPIEXEC) + (::geteuid() == 0 ? " --allow-run-as-root" : "") +
         " --oversubscribe --bind-to none --mca mpi_yield_when_idle 1 -np " + std::to_string(ranks) + " ";
}

// tq-solid as one process and on 1-4 ranks: the largest difference of any monitored value relative
// to the largest magnitude of its series.
void compareRanks(const Files& f, const std::string& label) {
  const std::string exe = TQ_TEST_SOLID_EXE, in = f / "solid_input.h5";
  ASSERT_EQ(run(exe + " " + in + " --threads 1 -o " + (f / "plain.h5")), 0);
  const auto plain = monitored(f / "plain.h5");
  ASSERT_FALSE(plain.empty());
  for (int ranks : {1, 2, 3, 4}) {
    const std::string out = f / ("ranks" + std::to_string(ranks) + ".h5");
    ASSERT_EQ(run(mpiexec(ranks) + exe + " " + in + " --distributed --threads 1 -o " + out), 0)
        << label << " on " << ranks << " ranks";
    const auto got = monitored(out);
    if (ranks > 1) {  // the copies of a frontier node agree bitwise on every rank that holds it
      auto r = h5::openFile(out);
      auto g = h5::openGroup(r, "/ranks");
      EXPECT_GT(h5::readDoubleAttr(g, "frontier_node_copies"), 0);
      EXPECT_EQ(h5::readDoubleAttr(g, "frontier_copies_max_difference"), 0.0) << label << ", " << ranks;
    }
    ASSERT_EQ(got.size(), plain.size());
    double worst = 0;
    std::string where;
    for (const auto& [path, a] : plain) {
      const auto& b = got.at(path);
      ASSERT_EQ(a.size(), b.size()) << path;
      double scale = 0, diff = 0;
      for (size_t i = 0; i < a.size(); ++i) {
        scale = std::max(scale, std::abs(a[i]));
        diff = std::max(diff, std::abs(a[i] - b[i]));
      }
      if (ranks == 1) EXPECT_EQ(diff, 0.0) << path << ": one rank is the plain run, bitwise";
      const double rel = scale > 0 ? diff / scale : diff;
      if (rel > worst) worst = rel, where = path;
    }
    std::cout << "[ranks] " << label << ", " << ranks << " rank(s): largest relative difference " << worst
              << (where.empty() ? "" : " (" + where + ")") << "\n";
    EXPECT_LT(worst, 1e-10) << label << " on " << ranks << " ranks, at " << where;
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

TEST(RankRuns, StagedInputIsRefusedOnRanksWithTheReason) {
  Files f;
  writeMeshH5(makeBoxMesh({2, 2, 2, 0, 0, 0, 2, 2, 2}), f / "mesh.h5");
  SolidInput in;
  in.materials = {{"rock", elasticValues({8e9, 0.27, 2700})}};
  in.tEnd = 0.01;
  in.progressSeconds = 100;
  in.staged.present = true;
  in.staged.stages.sequence = {"seismic"};
  in.staged.bottom.present = true;
  in.staged.motion.present = true;
  in.staged.motion.time = {0, 1};
  in.staged.motion.ax = {0, 0};
  test::writeInputFile(in, f / "solid_input.h5", "mesh.h5");
  const std::string log = f / "log.txt";
  const int rc = std::system((mpiexec(2) + TQ_TEST_SOLID_EXE + " " + (f / "solid_input.h5") + " --distributed -o " +
                              (f / "r.h5") + " > " + log + " 2>&1")
                                 .c_str());
  EXPECT_NE(rc, 0);
  std::ifstream is(log);
  std::stringstream ss;
  ss << is.rdbuf();
  EXPECT_NE(ss.str().find("does not run on ranks yet"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("the seismic boundaries"), std::string::npos) << ss.str();
}

#endif
