// mesh.h5 input (docs/formats.md) and its checks (bad input stops with a clear
// message). Meshes are built in memory, written with writeMeshH5 and read back.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cstdio>
#include <filesystem>

#include "tq/io/mesh.hpp"

using namespace tq;

namespace {
std::string tmpPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("tq_test_" + std::to_string(::getpid()) + "_" + name)).string();
}
}  // namespace

TEST(MeshIO, RoundTripKeepsEverything) {
  Mesh m = makeBoxMesh({3, 2, 2, -1, 0, -5, 3, 2, 2});
  m.nodeSets["corner"] = {0, 5};
  m.rockLiningPairs = {1, 2, 3, 4};
  const auto p = tmpPath("roundtrip.h5");
  writeMeshH5(m, p);
  const Mesh r = readMeshH5(p, {{"bottom"}});
  std::filesystem::remove(p);
  EXPECT_EQ(r.coords, m.coords);
  EXPECT_EQ(r.connectivity, m.connectivity);
  EXPECT_EQ(r.region, m.region);
  EXPECT_EQ(r.regionNames, m.regionNames);
  EXPECT_EQ(r.faces, m.faces);
  EXPECT_EQ(r.nodeSets, m.nodeSets);
  EXPECT_EQ(r.rockLiningPairs, m.rockLiningPairs);
}

TEST(MeshIO, InvertedElementIsRejectedWithIndexAndCoordinates) {
  Mesh m = makeBoxMesh({3, 1, 1, 0, 0, 0, 3, 1, 1});
  // Mirror element 2: bottom and top faces swapped -> negative Jacobian everywhere.
  Index* c = &m.connectivity[8 * 2];
  for (int k = 0; k < 4; ++k) std::swap(c[k], c[k + 4]);
  const auto p = tmpPath("inverted.h5");
  writeMeshH5(m, p);
  try {
    readMeshH5(p);
    FAIL() << "inverted element accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("element 2 (region 'rock') is inverted"), std::string::npos) << msg;
    EXPECT_NE(msg.find("Jacobian determinant -"), std::string::npos) << msg;
    EXPECT_NE(msg.find("3 0 1"), std::string::npos) << msg;  // a node's coordinates are listed
  }
  std::filesystem::remove(p);
}

TEST(MeshIO, MissingBottomGroupNamesTheGroupAndTheFix) {
  Mesh m = makeBoxMesh({2, 2, 2, 0, 0, 0, 1, 1, 1});
  m.faces.erase("bottom");
  const auto p = tmpPath("nobottom.h5");
  writeMeshH5(m, p);
  try {
    readMeshH5(p, {{"bottom"}});
    FAIL() << "mesh without bottom accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("face group 'bottom' is missing"), std::string::npos) << msg;
    EXPECT_NE(msg.find("physical group 'bottom'"), std::string::npos) << msg;
  }
  std::filesystem::remove(p);
}

TEST(MeshIO, WrongFormatAndMissingFileAreReported) {
  EXPECT_THROW(readMeshH5("/nonexistent/mesh.h5"), InputError);
  Mesh m = makeBoxMesh({1, 1, 1, 0, 0, 0, 1, 1, 1});
  m.connectivity[3] = 99;  // out of range
  EXPECT_THROW(checkMesh(m), InputError);
}
