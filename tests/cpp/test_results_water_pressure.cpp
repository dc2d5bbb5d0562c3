// results.h5 water pressure at the monitors (paper Fig. 5): ResultsWriter::addWaterPressure
// turns the interface force the water coupling adds into the pressure at the wetted node nearest
// each monitor. Reference: a uniform pressure p on the inner face of a ring slice, applied as the
// consistent nodal forces F = −p Σ S_q/4 (S_q the quads' area vectors, out of the solid), must be
// read back as p at every monitor (to round-off); a tangential force adds nothing; the node is the
// wetted one nearest the monitor point and the normal points from the lining into the water.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "io/h5util.hpp"
#include "test_helpers.hpp"
#include "tq/core/solver.hpp"
#include "tq/io/results.hpp"

using namespace tq;

TEST(ResultsWaterPressure, UniformPressureOnARingIsReadBackAtEveryMonitor) {
  RingSpec spec;
  spec.rInner = 4.5;
  spec.rOuter = 5.25;
  spec.nRadial = 2;
  spec.nAround = 24;
  const Mesh mesh = makeRingSliceMesh(spec);
  Solver solver(mesh, makeBlocksByRegion(mesh, {{"lining", tqtest::elastic(28e9, 0.17, 2500)}}), SolverOptions{});
  const std::vector<Index> nodes = mesh.faceNodes("inner");
  const Real p = 0.466e6, tangential = 3.0e4;  // Pa; N per node along the hoop
  std::vector<Real> force(3 * nodes.size(), 0.0);
  const auto& quads = mesh.faces.at("inner");
  for (size_t q = 0; q + 3 < quads.size(); q += 4) {
    Real d1[3], d2[3];
    for (int d = 0; d < 3; ++d) {
      d1[d] = mesh.coords[3 * size_t(quads[q + 2]) + d] - mesh.coords[3 * size_t(quads[q]) + d];
      d2[d] = mesh.coords[3 * size_t(quads[q + 3]) + d] - mesh.coords[3 * size_t(quads[q + 1]) + d];
    }
    const Real s[3] = {0.5 * (d1[1] * d2[2] - d1[2] * d2[1]), 0.5 * (d1[2] * d2[0] - d1[0] * d2[2]),
                       0.5 * (d1[0] * d2[1] - d1[1] * d2[0])};
    for (int k = 0; k < 4; ++k) {
      const size_t j = size_t(std::lower_bound(nodes.begin(), nodes.end(), quads[q + size_t(k)]) - nodes.begin());
      for (int d = 0; d < 3; ++d) force[3 * j + size_t(d)] -= 0.25 * p * s[d];
    }
  }
  // a hoop (tangential) force on top: no normal component, so no pressure
  for (size_t j = 0; j < nodes.size(); ++j) {
    const Real x = mesh.coords[3 * size_t(nodes[j])], z = mesh.coords[3 * size_t(nodes[j]) + 2];
    const Real r = std::hypot(x, z);
    force[3 * j] += tangential * z / r;
    force[3 * j + 2] -= tangential * x / r;
  }
  SolidInput in;
  in.monitorDt = 0;  // a row per sample() call, at its own time
  in.monitors = {{"top_arch", {0.0, 0.1, 4.6}}, {"haunch", {4.6, 0.1, 0.0}}, {"bottom_arch", {0.0, 0.1, -4.6}}};
  const auto dir = std::filesystem::temp_directory_path() / ("tq_wp_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "results.h5").string();
  {
    ResultsWriter w(path, in, solver);
    w.addWaterPressure(mesh, "inner", in.monitors, nodes, [&]() -> const std::vector<Real>& { return force; });
    w.sample(solver);
    w.sample(solver);
  }
  auto f = h5::openFile(path);
  for (const auto& mi : in.monitors) {
    const std::string g = "/monitors/" + mi.name;
    std::vector<hsize_t> dims;
    const auto rows = h5::readDoubles(f, g + "/water_pressure", &dims);
    ASSERT_EQ(dims.size(), 2u);
    ASSERT_EQ(dims[0], 2u);
    ASSERT_EQ(dims[1], 2u);
    EXPECT_NEAR(rows[1], p, 1e-9 * p) << mi.name;
    EXPECT_NEAR(rows[3], p, 1e-9 * p) << mi.name;
    auto gg = h5::openGroup(f, g);
    const Index node = Index(h5::readIntAttr(gg, "water_node"));
    // the wetted node nearest the monitor: on the inner radius, at the monitor's angle
    const Real x = mesh.coords[3 * size_t(node)], z = mesh.coords[3 * size_t(node) + 2];
    EXPECT_NEAR(std::hypot(x, z), 4.5, 1e-9);
    EXPECT_LT(std::hypot(x - mi.point[0], z - mi.point[2]), 0.2) << mi.name;
    // normal out of the lining into the water: towards the axis
    const Real nx = h5::readDoubleAttr(gg, "water_nx"), nz = h5::readDoubleAttr(gg, "water_nz");
    EXPECT_NEAR(nx * x + nz * z, -std::hypot(x, z), 1e-9);
    // tributary area: one element width along y times one hoop segment (chord) to the cosine of
    // the half angle between the two faces
    const Real chord = 2 * 4.5 * std::sin(M_PI / 24);
    EXPECT_NEAR(h5::readDoubleAttr(gg, "water_area"), 0.5 * spec.width * chord * std::cos(M_PI / 24), 1e-9);
  }
  std::filesystem::remove_all(dir);
}
