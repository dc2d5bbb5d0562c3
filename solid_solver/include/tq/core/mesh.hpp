/// @file mesh.hpp
/// @brief The solid mesh in memory (read from mesh.h5 by tq/io/mesh.hpp, or built here), and its checks.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "tq/core/types.hpp"

namespace tq {

/// Hexahedral mesh of rock and lining. Coordinates in m, z up, y along the tunnel axis.
/// Connectivity in VTK/gmsh hex8 order (nodes 0-3 the face ζ = -1 counter-clockwise seen from
/// +ζ, nodes 4-7 above them). Face quads are ordered counter-clockwise seen from outside.
struct Mesh {
  std::vector<Real> coords;                            ///< [3N] x, y, z of each node (m), node-major
  std::vector<Index> connectivity;                     ///< [8E] hex8 node indices, element-major
  std::vector<Index> region;                           ///< [E] index into regionNames
  std::vector<std::string> regionNames;                ///< physical group names of regions
  std::map<std::string, std::vector<Index>> faces;     ///< name -> [4F] boundary quads
  std::map<std::string, std::vector<Index>> nodeSets;  ///< name -> node indices
  std::vector<Index> rockLiningPairs;                  ///< [2P] (rock node, lining node) coincident pairs
  bool slice = false;                                  ///< one-element-thick plane-strain slice along y
  /// [N], or empty: an estimate of each node's subcycling level (setOrderLevels in
  /// tq/core/element_block.hpp), which the element blocks' order follows so that a chunk's elements
  /// step at one level; empty: the order depends on the mesh alone.
  std::vector<std::uint8_t> orderLevel;
  std::string source = "<memory>";  ///< where the mesh came from, for messages

  Index numNodes() const { return static_cast<Index>(coords.size() / 3); }
  Index numElems() const { return static_cast<Index>(connectivity.size() / 8); }
  /// Sorted, unique node indices of a face group (throws InputError naming the group if absent).
  std::vector<Index> faceNodes(const std::string& group) const;
  /// Index of a region by name, or -1.
  Index regionIndex(const std::string& name) const;
};

/// The tunnel's face groups the mesher writes (docs/formats.md "mesh.h5"): the lining's inner face
/// (the water's wall), the lining's outer face and the rock's face of the hole (the two sides of the
/// rock-lining interface).
namespace face_group {
inline constexpr const char* kLiningInner = "lining_inner";
inline constexpr const char* kLiningOuter = "lining_outer";
inline constexpr const char* kRockHole = "rock_hole";
}  // namespace face_group

/// True when no node appears twice in `nodes` (contributors whose nodes are distinct may compute
/// them on the solver's threads, each writing only its own nodes' forces).
bool nodesDistinct(std::vector<Index> nodes);

/// The height z of the tunnel's axis: the middle of the lining's inner face in z, else of the rock's
/// hole; NaN when the mesh has neither face group.
Real tunnelAxisZ(const Mesh& mesh);

/// The area vector of a face quad (its four mesh node indices, in order): ½ d1 × d2 of its diagonals
/// d1 = x2 − x0, d2 = x3 − x1, exact for a planar quad; outward for nodes counter-clockwise seen from
/// outside.
void quadAreaVector(const Mesh& mesh, const Index* quad, Real s[3]);

/// What checkMesh requires beyond well-formed arrays.
struct MeshRequirements {
  std::vector<std::string> faceGroups;  ///< face groups that must be present (e.g. "bottom")
};

/// Validate sizes, index ranges and every element's Jacobian (at the 8 corners and the centre).
/// Throws InputError with the element index and its node coordinates for an inverted or
/// degenerate element, and with the group name and the fix for a missing face group.
void checkMesh(const Mesh& mesh, const MeshRequirements& req = {});

/// Structured box of nx*ny*nz hex8 elements of one region. Faces: bottom (z min), top, xmin,
/// xmax, ymin, ymax.
struct BoxSpec {
  Index nx = 1, ny = 1, nz = 1;
  Real x0 = 0, y0 = 0, z0 = 0;  ///< lower corner (m)
  Real lx = 1, ly = 1, lz = 1;  ///< edge lengths (m)
  std::string region = "rock";
};
Mesh makeBoxMesh(const BoxSpec& spec);

/// Plane-strain ring slice in the x-z plane (centre at the origin), one element thick along y.
/// Faces: inner, outer, ymin, ymax. Elements: ξ along the hoop, η radial outwards, ζ along y.
struct RingSpec {
  Real rInner = 5.25, rOuter = 6.0;  ///< radii (m)
  Index nRadial = 3, nAround = 48;   ///< elements through the thickness and around
  Real width = 0.25;                 ///< slice thickness along y (m); a tube's length
  std::string region = "lining";
  Index nAxial = 1;  ///< elements along y (1: a plane-strain slice; more: a tube)
};
Mesh makeRingSliceMesh(const RingSpec& spec);

}  // namespace tq
