// Helpers for the Mohr–Coulomb damage and contact tests: a material point driven without a mesh,
// the paper's Table 1 parameters, principal stresses, and rock–lining meshes with paired nodes.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <vector>

#include <functional>
#include "tq/core/solver.hpp"
#include "tq/materials/material_mc.hpp"

namespace tqtest {

using tq::Index;
using tq::Real;

/// Mohr–Coulomb damage parameters: elastic (E, ν, ρ), cohesion c, friction angle φ (degrees),
/// tensile strength σt and damage constant R.
inline tq::MohrCoulombDamageParams mohrCoulomb(tq::ElasticParams elastic, Real c, Real phi, Real st, Real R) {
  tq::MohrCoulombDamageParams p;
  p.elastic = elastic;
  p.cohesion = c;
  p.frictionAngle = phi;
  p.tensileStrength = st;
  p.damageConstant = R;
  return p;
}

/// Paper Table 1, rock: E 8 GPa, ν 0.27, c 0.55 MPa, φ 37°, ρ 2700, σt 1.20 MPa.
inline tq::MohrCoulombDamageParams paperRock(Real R = 100) {
  return mohrCoulomb({8e9, 0.27, 2700}, 0.55e6, 37, 1.20e6, R);
}

/// Paper Table 1, lining (C25): E 28 GPa, ν 0.17, c 1.80 MPa, φ 40°, ρ 2500, σt 1.27 MPa.
inline tq::MohrCoulombDamageParams paperLining(Real R = 100) {
  return mohrCoulomb({28e9, 0.17, 2500}, 1.80e6, 40, 1.27e6, R);
}

/// The rock mesh `r` with the lining mesh `l` appended (its nodes numbered from r.numNodes(), its
/// elements in region 1, "lining") and no face groups: the caller names the faces and the pairs.
inline tq::Mesh withLining(const tq::Mesh& r, const tq::Mesh& l) {
  tq::Mesh m = r;
  const Index off = r.numNodes();
  m.coords.insert(m.coords.end(), l.coords.begin(), l.coords.end());
  for (Index c : l.connectivity) m.connectivity.push_back(c + off);
  m.regionNames = {"rock", "lining"};
  for (Index e = 0; e < l.numElems(); ++e) m.region.push_back(1);
  m.faces.clear();
  return m;
}

/// Pairs each rock node (numbered below `rockNodes`) at radius `radius` from the y axis with the
/// lining node (numbered from `rockNodes`) at the same place: the rock–lining pairs of a lined ring.
inline void pairRockWithLiningAt(tq::Mesh& m, Index rockNodes, Real radius) {
  for (Index n = 0; n < rockNodes; ++n) {
    const Real* x = &m.coords[3 * size_t(n)];
    if (std::abs(std::hypot(x[0], x[2]) - radius) > 1e-9) continue;
    for (Index q = rockNodes; q < m.numNodes(); ++q) {
      const Real* y = &m.coords[3 * size_t(q)];
      if (std::abs(x[0] - y[0]) + std::abs(x[1] - y[1]) + std::abs(x[2] - y[2]) < 1e-9) {
        m.rockLiningPairs.push_back(n);
        m.rockLiningPairs.push_back(q);
      }
    }
  }
}

/// A lining box (z in [0, hl], nzl elements high) on a rock box (z in [−hr, 0], nzr elements high),
/// nx × ny columns of side w, the nodes at z = 0 doubled (rock node, lining node) and listed as
/// pairs. Faces: bottom (the rock's), top (the lining's), lining_outer (the lining's bottom,
/// outward normal −z, towards the rock) and, with `rockHole`, rock_hole (the rock's top).
inline tq::Mesh pairedStack(Index nx, Index ny, Index nzr, Index nzl, Real hr, Real hl, Real w, bool rockHole) {
  const tq::Mesh r = tq::makeBoxMesh({nx, ny, nzr, 0, 0, -hr, nx * w, ny * w, hr, "rock"});
  const tq::Mesh l = tq::makeBoxMesh({nx, ny, nzl, 0, 0, 0, nx * w, ny * w, hl, "lining"});
  const Index off = r.numNodes();
  tq::Mesh m = withLining(r, l);
  m.faces["bottom"] = r.faces.at("bottom");
  for (Index q : l.faces.at("top")) m.faces["top"].push_back(q + off);
  for (Index q : l.faces.at("bottom")) m.faces["lining_outer"].push_back(q + off);
  if (rockHole) m.faces["rock_hole"] = r.faces.at("top");
  // Pairs: rock top-layer node with the coincident lining bottom-layer node.
  const Index perLayer = (nx + 1) * (ny + 1);
  for (Index k = 0; k < perLayer; ++k) {
    m.rockLiningPairs.push_back(nzr * perLayer + k);
    m.rockLiningPairs.push_back(off + k);
  }
  tq::checkMesh(m);
  return m;
}

/// The cross product of quad k's diagonals in face list q (twice its area vector, along its
/// outward normal).
inline void quadDiagonalCross(const tq::Mesh& m, const std::vector<Index>& q, size_t k, Real c[3]) {
  const Real* x[4];
  for (int i = 0; i < 4; ++i) x[i] = &m.coords[3 * size_t(q[4 * k + size_t(i)])];
  Real d1[3], d2[3];
  for (int i = 0; i < 3; ++i) {
    d1[i] = x[2][i] - x[0][i];
    d2[i] = x[3][i] - x[1][i];
  }
  c[0] = d1[1] * d2[2] - d1[2] * d2[1];
  c[1] = d1[2] * d2[0] - d1[0] * d2[2];
  c[2] = d1[0] * d2[1] - d1[1] * d2[0];
}

inline Real nPhi(Real phiDeg) {
  const Real s = std::sin(phiDeg * M_PI / 180);
  return (1 + s) / (1 - s);
}

/// Principal stresses ascending (σ1 most compressive).
inline void principal(const Real s[6], Real p[3]) {
  Eigen::Matrix3d m;
  m << s[tq::XX], s[tq::XY], s[tq::ZX], s[tq::XY], s[tq::YY], s[tq::YZ], s[tq::ZX], s[tq::YZ], s[tq::ZZ];
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m, Eigen::EigenvaluesOnly);
  for (int i = 0; i < 3; ++i) p[i] = es.eigenvalues()(i);
}

/// One material point: stress, history, and strain-driven updates through the chunk interface.
struct MaterialPoint {
  std::shared_ptr<const tq::Material> mat;
  Real stress[6] = {0, 0, 0, 0, 0, 0};
  Real strain[6] = {0, 0, 0, 0, 0, 0};
  std::vector<Real> hist;
  explicit MaterialPoint(std::shared_ptr<const tq::Material> m) : mat(std::move(m)) {
    hist.assign(mat->historyNames().size(), 0.0);
  }
  Real h(int i) const { return hist[size_t(i)]; }
  /// Apply a strain increment (engineering shear).
  void apply(const Real de[6]) {
    Real d[6], s[6];
    Real* sp[6];
    std::vector<Real*> hp(hist.size());
    for (size_t i = 0; i < hist.size(); ++i) hp[i] = &hist[i];
    tq::MaterialChunk c;
    c.count = 1;
    for (int k = 0; k < 6; ++k) {
      d[k] = de[k];
      s[k] = stress[k];
      c.dstrain[k] = &d[k];
      sp[k] = &s[k];
      c.stress[k] = sp[k];
    }
    c.history = hp.data();
    mat->updateStressForElems(c);
    for (int k = 0; k < 6; ++k) {
      stress[k] = s[k];
      strain[k] += de[k];
    }
  }
  /// Mixed control: strain increments on the components with controlled[k] = false; on the others
  /// the strain is found (quasi-Newton with the elastic compliance) so that σ_k = target[k].
  void applyMixed(const Real de[6], const bool controlled[6], const Real target[6]) {
    const auto m = mat->elasticModuli();
    const Real E = m.mu * (3 * m.lambda + 2 * m.mu) / (m.lambda + m.mu), nu = m.lambda / (2 * (m.lambda + m.mu));
    const Real s0[6] = {stress[0], stress[1], stress[2], stress[3], stress[4], stress[5]};
    const Real e0[6] = {strain[0], strain[1], strain[2], strain[3], strain[4], strain[5]};
    const std::vector<Real> h0 = hist;
    Real d[6];
    for (int k = 0; k < 6; ++k) d[k] = de[k];
    for (int it = 0; it < 200; ++it) {
      for (int k = 0; k < 6; ++k) {
        stress[k] = s0[k];
        strain[k] = e0[k];
      }
      hist = h0;
      apply(d);
      Real r[6] = {0, 0, 0, 0, 0, 0}, rmax = 0, scale = 1;
      for (int k = 0; k < 6; ++k) {
        scale = std::max(scale, std::abs(stress[k]));
        if (controlled[k]) {
          r[k] = stress[k] - target[k];
          rmax = std::max(rmax, std::abs(r[k]));
        }
      }
      if (rmax <= 1e-13 * scale) return;
      // Δε_k -= C⁻¹ r on the controlled components (isotropic compliance).
      for (int k = 0; k < 3; ++k)
        if (controlled[k]) d[k] -= (r[k] - nu * (r[(k + 1) % 3] + r[(k + 2) % 3])) / E;
      for (int k = 3; k < 6; ++k)
        if (controlled[k]) d[k] -= r[k] / m.mu;
    }
  }
};

/// Displacement control of some dofs through a force (a test actuator): each step it adds the force
/// that brings the dof to target(t + Δt) exactly under the central difference (undamped, as the
/// dynamic contact force does for a pair), and books that force's work by the solver's trapezoid
/// rule. Its work is the loop area ∮F du of a cyclic test.
class DisplacementActuator final : public tq::NodalForceContributor {
 public:
  DisplacementActuator(std::vector<Index> nodes, int dir, std::function<Real(Real)> target)
      : nodes_(std::move(nodes)),
        dir_(dir),
        target_(std::move(target)),
        fPrev_(nodes_.size(), 0.0),
        uPrev_(nodes_.size(), 0.0) {}
  std::string name() const override { return "test actuator"; }
  void addForces(Real t, Real dt, tq::NodalState& s) override {
    force_ = 0;
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const size_t i = 3 * size_t(nodes_[k]) + size_t(dir_);
      const Real m = s.mass(nodes_[k]);
      const Real f0 = s.fExtData()[i] - s.fIntData()[i];
      const Real uPred = s.uData()[i] + dt * (s.vData()[i] + dt * f0 / m);
      const Real F = m * (target_(t + dt) - uPred) / (dt * dt);
      work_ += 0.5 * (fPrev_[k] + F) * (s.uData()[i] - uPrev_[k]);
      fPrev_[k] = F;
      uPrev_[k] = s.uData()[i];
      s.fExt(nodes_[k], dir_) += F;
      force_ += F;
    }
  }
  Real work() const { return work_; }    ///< work of the actuator forces so far (J)
  Real force() const { return force_; }  ///< total actuator force of the last step (N)

 private:
  std::vector<Index> nodes_;
  int dir_;
  std::function<Real(Real)> target_;
  std::vector<Real> fPrev_, uPrev_;
  Real work_ = 0, force_ = 0;
};

}  // namespace tqtest
