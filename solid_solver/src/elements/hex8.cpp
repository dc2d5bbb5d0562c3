#include "tq/elements/hex8.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace tq::hex8 {

void shapeDerivatives(Real xi, Real eta, Real zeta, Real dN[3][8]) {
  for (int I = 0; I < 8; ++I) {
    const Real a = 1 + kXi[I] * xi, b = 1 + kEta[I] * eta, c = 1 + kZeta[I] * zeta;
    dN[0][I] = 0.125 * kXi[I] * b * c;
    dN[1][I] = 0.125 * kEta[I] * a * c;
    dN[2][I] = 0.125 * kZeta[I] * a * b;
  }
}

static Real det3(const Real J[3][3]) {
  return J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
         J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
}

Real jacobian(const Real x[3][8], Real xi, Real eta, Real zeta, Real J[3][3]) {
  Real dN[3][8];
  shapeDerivatives(xi, eta, zeta, dN);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      Real s = 0;
      for (int I = 0; I < 8; ++I) s += x[i][I] * dN[k][I];
      J[i][k] = s;
    }
  return det3(J);
}

void edgeLengthRange(const Real* coords, const Index* nodes, Real& shortest, Real& longest) {
  Real lo2 = std::numeric_limits<Real>::max(), hi2 = 0;
  for (const auto& ed : kEdges) {
    Real d2 = 0;
    for (int i = 0; i < 3; ++i) {
      const Real dx = coords[dofIndex(nodes[ed[0]], i)] - coords[dofIndex(nodes[ed[1]], i)];
      d2 += dx * dx;
    }
    lo2 = std::min(lo2, d2);
    hi2 = std::max(hi2, d2);
  }
  shortest = std::sqrt(lo2);
  longest = std::sqrt(hi2);
}

Real minJacobian(const Real x[3][8], int* where) {
  Real J[3][3];
  Real dmin = jacobian(x, 0, 0, 0, J);
  int at = 8;
  for (int I = 0; I < 8; ++I) {
    const Real d = jacobian(x, kXi[I], kEta[I], kZeta[I], J);
    if (d < dmin) {
      dmin = d;
      at = I;
    }
  }
  if (where) *where = at;
  return dmin;
}

static void inverse3(const Real J[3][3], Real det, Real inv[3][3]) {
  inv[0][0] = (J[1][1] * J[2][2] - J[1][2] * J[2][1]) / det;
  inv[0][1] = (J[0][2] * J[2][1] - J[0][1] * J[2][2]) / det;
  inv[0][2] = (J[0][1] * J[1][2] - J[0][2] * J[1][1]) / det;
  inv[1][0] = (J[1][2] * J[2][0] - J[1][0] * J[2][2]) / det;
  inv[1][1] = (J[0][0] * J[2][2] - J[0][2] * J[2][0]) / det;
  inv[1][2] = (J[0][2] * J[1][0] - J[0][0] * J[1][2]) / det;
  inv[2][0] = (J[1][0] * J[2][1] - J[1][1] * J[2][0]) / det;
  inv[2][1] = (J[0][1] * J[2][0] - J[0][0] * J[2][1]) / det;
  inv[2][2] = (J[0][0] * J[1][1] - J[0][1] * J[1][0]) / det;
}

void gaussGradients(const Real x[3][8], Real bg[8][3][8], Real wdet[8]) {
  const Real g = 1.0 / std::sqrt(3.0);
  for (int gp = 0; gp < 8; ++gp) {
    const Real xi = kXi[gp] * g, eta = kEta[gp] * g, zeta = kZeta[gp] * g;
    Real dN[3][8], J[3][3], Ji[3][3];
    shapeDerivatives(xi, eta, zeta, dN);
    const Real det = jacobian(x, xi, eta, zeta, J);
    inverse3(J, det, Ji);
    // ∂N/∂x_j = Σ_k ∂N/∂ξ_k ∂ξ_k/∂x_j, ∂ξ/∂x = J^{-1}
    for (int j = 0; j < 3; ++j)
      for (int I = 0; I < 8; ++I) bg[gp][j][I] = dN[0][I] * Ji[0][j] + dN[1][I] * Ji[1][j] + dN[2][I] * Ji[2][j];
    wdet[gp] = det;  // Gauss weights are 1 for the 2-point rule
  }
}

Geometry computeGeometry(const Real x[3][8]) {
  Geometry g;
  // Volume and uniform gradient: ∂N/∂x det J is at most quadratic per natural direction, so the
  // 2x2x2 rule integrates it exactly; b then satisfies Σ_I b_jI x_kI = δ_jk (patch test).
  Real bg[8][3][8], wdet[8];
  gaussGradients(x, bg, wdet);
  Real V = 0;
  for (int gp = 0; gp < 8; ++gp) V += wdet[gp];
  g.volume = V;
  for (int j = 0; j < 3; ++j)
    for (int I = 0; I < 8; ++I) {
      Real s = 0;
      for (int gp = 0; gp < 8; ++gp) s += bg[gp][j][I] * wdet[gp];
      g.b[j][I] = s / V;
    }
  // Hourglass projection vectors (Flanagan & Belytschko 1981): orthogonal to constants and to
  // the linear fields x_j, so a linear displacement field produces no hourglass force.
  for (int a = 0; a < 4; ++a) {
    Real hx[3] = {0, 0, 0};
    for (int j = 0; j < 3; ++j)
      for (int I = 0; I < 8; ++I) hx[j] += kH[a][I] * x[j][I];
    for (int I = 0; I < 8; ++I)
      g.gamma[a][I] = 0.125 * (kH[a][I] - hx[0] * g.b[0][I] - hx[1] * g.b[1][I] - hx[2] * g.b[2][I]);
  }
  // Local frame: rotation of the polar decomposition of the centre Jacobian J0 = R S.
  Real J0[3][3];
  jacobian(x, 0, 0, 0, J0);
  Eigen::Matrix3d J;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) J(i, k) = J0[i][k];
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(J, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) g.rot[i][k] = R(i, k);
  for (int k = 0; k < 3; ++k) g.invHalf[k] = 1.0 / J.col(k).norm();
  // Characteristic length V / A_max (the element's shortest "height" for a box).
  Real amax = 0;
  for (const auto& f : kFaces) {
    Real d1[3], d2[3];
    for (int i = 0; i < 3; ++i) {
      d1[i] = x[i][f[2]] - x[i][f[0]];
      d2[i] = x[i][f[3]] - x[i][f[1]];
    }
    const Real cx = d1[1] * d2[2] - d1[2] * d2[1], cy = d1[2] * d2[0] - d1[0] * d2[2],
               cz = d1[0] * d2[1] - d1[1] * d2[0];
    amax = std::max(amax, 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz));
  }
  g.charLength = V / amax;
  return g;
}

}  // namespace tq::hex8
