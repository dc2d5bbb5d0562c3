/// @file face_quadrature.hpp
/// @brief The geometry of a face group of the mesh: 2×2 Gauss points on its bilinear quads, and a
///        planar face whose outward normal is a coordinate axis (the block's sides, base and
///        periodic faces) with each node's tributary area.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "tq/core/mesh.hpp"

namespace tq {

/// The nodes of a planar face group whose outward normal is a coordinate axis, each with its
/// tributary area ∫N_I dA (exact for bilinear quads, 2×2 Gauss).
struct AxisFace {
  std::string name;
  int axis = 0;  ///< 0 x, 1 y, 2 z: the normal's direction
  int sign = 1;  ///< +1 or −1: outward normal = sign · e_axis
  std::vector<Index> nodes;
  std::vector<Real> area;    ///< m², per node
  std::vector<Index> quads;  ///< [4F] the face's quads (for per-face loads)
};
/// Throws InputError naming the group if it is missing or not planar and axis-aligned.
AxisFace axisFace(const Mesh& mesh, const std::string& group);

namespace face_quadrature {

inline constexpr Real kXi4[4] = {-1, 1, 1, -1}, kEta4[4] = {-1, -1, 1, 1};

/// Bilinear quad at (ξ, η): shape functions N and the tangents ∂x/∂ξ, ∂x/∂η.
inline void quadAt(const Real x[4][3], Real xi, Real eta, Real N[4], Real* pos, Real axi[3], Real aeta[3]) {
  for (int k = 0; k < 4; ++k) N[k] = 0.25 * (1 + kXi4[k] * xi) * (1 + kEta4[k] * eta);
  for (int i = 0; i < 3; ++i) {
    axi[i] = aeta[i] = 0;
    if (pos) pos[i] = 0;
    for (int k = 0; k < 4; ++k) {
      axi[i] += 0.25 * kXi4[k] * (1 + kEta4[k] * eta) * x[k][i];
      aeta[i] += 0.25 * kEta4[k] * (1 + kXi4[k] * xi) * x[k][i];
      if (pos) pos[i] += N[k] * x[k][i];
    }
  }
}

inline void cross(const Real a[3], const Real b[3], Real c[3]) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

/// 2×2 Gauss loop over one quad: fn(N, position, n dA) with the oriented area element.
template <class Fn>
void gaussQuad(const Mesh& mesh, const Index* q, Fn fn) {
  Real x[4][3];
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i) x[k][i] = mesh.coords[dofIndex(q[k], i)];
  const Real g = 1 / std::sqrt(3.0);
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      Real N[4], pos[3], axi[3], aeta[3], ndA[3];
      quadAt(x, a ? g : -g, b ? g : -g, N, pos, axi, aeta);
      cross(axi, aeta, ndA);  // weight 1 per Gauss point
      fn(N, pos, ndA);
    }
}

}  // namespace face_quadrature

}  // namespace tq
