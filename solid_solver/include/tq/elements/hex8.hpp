/// @file hex8.hpp
/// @brief Trilinear hexahedron: natural coordinates, hourglass base vectors, and the per-element
///        geometry that the one-point element precomputes (small strain: the geometry is fixed).
#pragma once

#include "tq/core/types.hpp"

namespace tq::hex8 {

/// Natural coordinates (ξ, η, ζ) of the 8 nodes in VTK order.
inline constexpr Real kXi[8] = {-1, 1, 1, -1, -1, 1, 1, -1};
inline constexpr Real kEta[8] = {-1, -1, 1, 1, -1, -1, 1, 1};
inline constexpr Real kZeta[8] = {-1, -1, -1, -1, 1, 1, 1, 1};

/// Hourglass base vectors h_α = (ηζ, ζξ, ξη, ξηζ) at the nodes (Flanagan & Belytschko 1981).
inline constexpr Real kH[4][8] = {{1, 1, -1, -1, -1, -1, 1, 1},   // η ζ
                                  {1, -1, -1, 1, -1, 1, 1, -1},   // ζ ξ
                                  {1, -1, 1, -1, 1, -1, 1, -1},   // ξ η
                                  {-1, 1, -1, 1, 1, -1, 1, -1}};  // ξ η ζ

/// Local faces with outward normals (right-hand rule), VTK order.
inline constexpr int kFaces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                     {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

/// The 12 edges as local node pairs.
inline constexpr int kEdges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                      {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

/// Shortest and longest edge (m) of the element with nodes `nodes[8]` in the node-major
/// coordinate array `coords` [3N].
void edgeLengthRange(const Real* coords, const Index* nodes, Real& shortest, Real& longest);

/// Shape function derivatives dN[k][I] = ∂N_I/∂ξ_k at (ξ, η, ζ).
void shapeDerivatives(Real xi, Real eta, Real zeta, Real dN[3][8]);

/// Jacobian J[i][k] = ∂x_i/∂ξ_k at (ξ, η, ζ) for nodal coordinates x[i][I]; returns det J.
Real jacobian(const Real x[3][8], Real xi, Real eta, Real zeta, Real J[3][3]);

/// Smallest Jacobian determinant over the 8 corners and the centre, and where it occurs
/// (0-7 a corner node, 8 the centre).
Real minJacobian(const Real x[3][8], int* where = nullptr);

/// Geometry of one element for the one-point formulation.
struct Geometry {
  Real volume = 0;        ///< exact volume (m^3)
  Real b[3][8] = {};      ///< uniform (volume-averaged) gradient b_jI = (1/V)∫ ∂N_I/∂x_j dV (1/m)
  Real gamma[4][8] = {};  ///< hourglass projection γ_α = (h_α - Σ_j (h_α·x_j) b_j)/8
  Real rot[3][3] = {};    ///< local orthonormal frame: column k = local axis k (rotation of J0)
  Real invHalf[3] = {};   ///< 1/a_k, a_k = |∂x/∂ξ_k| at the centre (half edge lengths, m)
  Real charLength = 0;    ///< V / (largest face area) (m), for the stable step
};

/// Compute the geometry of one element (exact volume and uniform gradient by 2x2x2 Gauss).
Geometry computeGeometry(const Real x[3][8]);

/// Full 2x2x2 Gauss quadrature gradients (for the fully integrated reference element):
/// bg[g][j][I] = ∂N_I/∂x_j and wdet[g] = weight * det J at Gauss point g.
void gaussGradients(const Real x[3][8], Real bg[8][3][8], Real wdet[8]);

}  // namespace tq::hex8
