// Element-level verification of the one-point hex8 with assumed-strain hourglass control.
//  - Patch test (VERIFICATION.md "Patch test and a single element under uniform strain"):
//    a linear displacement field on a mesh of distorted hexahedra must give the exact
//    uniform stress σ = C:ε in every element and zero force at every interior node (MacNeal &
//    Harder 1985). Tolerance: round-off (1e-10 relative).
//  - Single element under uniform strain: σ = C:ε exactly and nodal forces = traction resultants.
//  - Hourglass stiffness: a pure bending field u_x = κ x z on one rectangular element must store
//    the plate bending energy ½ E/(1-ν²) κ² ∫ z² dV exactly (the design target of the
//    assumed-strain field), while full integration overestimates it (shear locking).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "test_helpers.hpp"
#include "tq/core/element_block.hpp"
#include "tq/elements/hex8.hpp"

using namespace tq;
using tqtest::elastic;

namespace {

// Uniform strain (engineering shear) used in the tests.
const Real kEps[6] = {1.0e-4, -2.0e-4, 3.0e-4, 4.0e-4, -5.0e-4, 6.0e-4};

// Displacement of a linear field u = G x (+ rigid translation), with G giving kEps.
void linearField(const Real x[3], Real u[3]) {
  const Real G[3][3] = {{kEps[XX], kEps[XY] / 2 + 1e-4, kEps[ZX] / 2},
                        {kEps[XY] / 2 - 1e-4, kEps[YY], kEps[YZ] / 2 + 2e-4},
                        {kEps[ZX] / 2, kEps[YZ] / 2 - 2e-4, kEps[ZZ]}};  // + small rotation
  for (int i = 0; i < 3; ++i) u[i] = 1e-3 * (i + 1) + G[i][0] * x[0] + G[i][1] * x[1] + G[i][2] * x[2];
}

void expectedStress(Real E, Real nu, Real s[6]) {
  const auto m = ElasticModuli::fromYoungPoisson(E, nu);
  const Real tr = kEps[0] + kEps[1] + kEps[2];
  for (int k = 0; k < 3; ++k) s[k] = m.lambda * tr + 2 * m.mu * kEps[k];
  for (int k = 3; k < 6; ++k) s[k] = m.mu * kEps[k];
}

// Every node of `m` displaced by the linear field, one step of `s` (its forces at u^0); `sx`: the
// field's exact stress for E, ν.
void stepUnderLinearField(Solver& s, const Mesh& m, Real E, Real nu, Real sx[6]) {
  for (Index n = 0; n < m.numNodes(); ++n) {
    Real x[3] = {m.coords[3 * n], m.coords[3 * n + 1], m.coords[3 * n + 2]}, u[3];
    linearField(x, u);
    for (int d = 0; d < 3; ++d) s.state().u(n, d) = u[d];
  }
  s.step();
  expectedStress(E, nu, sx);
}

}  // namespace

TEST(Hex8Geometry, UniformGradientReproducesLinearFieldsOnDistortedElements) {
  BoxSpec spec{3, 3, 3, 0, 0, 0, 2.0, 1.5, 1.0};
  Mesh m = makeBoxMesh(spec);
  tqtest::distortInterior(m, spec, 0.3);
  for (Index e = 0; e < m.numElems(); ++e) {
    Real x[3][8];
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) x[i][k] = m.coords[3 * m.connectivity[8 * e + k] + i];
    const auto g = hex8::computeGeometry(x);
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        Real s = 0;
        for (int k = 0; k < 8; ++k) s += g.b[j][k] * x[i][k];
        EXPECT_NEAR(s, i == j ? 1.0 : 0.0, 1e-12);  // Σ_I b_jI x_iI = δ_ij
      }
    for (int a = 0; a < 4; ++a)
      for (int i = 0; i < 3; ++i) {
        Real s = 0, s1 = 0;
        for (int k = 0; k < 8; ++k) {
          s += g.gamma[a][k] * x[i][k];
          s1 += g.gamma[a][k];
        }
        EXPECT_NEAR(s, 0.0, 1e-12);   // γ_α ⟂ linear fields
        EXPECT_NEAR(s1, 0.0, 1e-12);  // γ_α ⟂ constants
      }
  }
}

TEST(Hex8Element, PatchTestDistortedMeshExactStressAndZeroInteriorForces) {
  const Real E = 30e9, nu = 0.25;
  BoxSpec spec{4, 3, 3, 0, 0, 0, 2.0, 1.5, 1.5};
  Mesh m = makeBoxMesh(spec);
  tqtest::distortInterior(m, spec, 0.35);
  SolverOptions opt;
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(E, nu, 2500)}}), opt);
  // Prescribe the linear field on all nodes; one step computes forces at u^0.
  Real sx[6];
  stepUnderLinearField(s, m, E, nu, sx);
  const Real scale = std::abs(sx[2]);
  const auto& b = *s.blocks()[0];
  for (Index e = 0; e < b.numElems(); ++e)
    for (int c = 0; c < 6; ++c) ASSERT_NEAR(b.stress(e, c), sx[c], 1e-10 * scale) << "element " << e;
  // Interior nodes: zero resultant force. Reference force magnitude σ h².
  const Real fref = scale * 0.5 * 0.5;
  auto boundary = [&](Index n) {
    const Real* x = &m.coords[3 * n];
    return std::abs(x[0]) < 1e-9 || std::abs(x[0] - 2.0) < 1e-9 || std::abs(x[1]) < 1e-9 ||
           std::abs(x[1] - 1.5) < 1e-9 || std::abs(x[2]) < 1e-9 || std::abs(x[2] - 1.5) < 1e-9;
  };
  int interior = 0;
  for (Index n = 0; n < m.numNodes(); ++n) {
    if (boundary(n)) continue;
    ++interior;
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(s.state().fInt(n, d), 0.0, 1e-10 * fref) << "node " << n;
  }
  EXPECT_GT(interior, 10);
}

TEST(Hex8Element, SingleElementUniformStrainGivesTractionResultants) {
  const Real E = 8e9, nu = 0.27, a = 2.0, bw = 1.0, c = 0.5;  // a box a x b x c
  BoxSpec spec{1, 1, 1, 0, 0, 0, a, bw, c};
  Mesh m = makeBoxMesh(spec);
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(E, nu, 2700)}}), SolverOptions{});
  Real sx[6];
  stepUnderLinearField(s, m, E, nu, sx);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(s.blocks()[0]->stress(0, k), sx[k], 1e-12 * std::abs(sx[2]));
  // Node 6 (corner at x=a, y=b, z=c): internal force = quarter of each face's traction
  // resultant: f_i = σ_ix (b c/4) + σ_iy (a c/4) + σ_iz (a b/4).
  const Real Ax = bw * c / 4, Ay = a * c / 4, Az = a * bw / 4;
  const Real f[3] = {sx[XX] * Ax + sx[XY] * Ay + sx[ZX] * Az, sx[XY] * Ax + sx[YY] * Ay + sx[YZ] * Az,
                     sx[ZX] * Ax + sx[YZ] * Ay + sx[ZZ] * Az};
  const Index n6 = m.connectivity[6];
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(s.state().fInt(n6, d), f[d], 1e-12 * std::abs(sx[2]) * a * bw);
}

namespace {
// Strain energy of one a x b x c element under u_x = κ x z, u_z = -κ x²/2 (pure bending in x-z,
// curvature κ) evaluated by the element: internal energy after one step.
Real bendingEnergy(Hex8Formulation f, Real E, Real nu, Real a, Real b, Real c, Real kappa) {
  BoxSpec spec{1, 1, 1, -a / 2, -b / 2, -c / 2, a, b, c};
  Mesh m = makeBoxMesh(spec);
  Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(E, nu, 2500)}}, f), SolverOptions{});
  for (Index n = 0; n < m.numNodes(); ++n) {
    const Real x = m.coords[3 * n], z = m.coords[3 * n + 2];
    s.state().u(n, 0) = kappa * x * z;
    s.state().u(n, 2) = -0.5 * kappa * x * x;
  }
  s.step();
  return s.energy().internal;
}
}  // namespace

TEST(Hex8Element, AssumedStrainHourglassIsExactForPlaneStrainBending) {
  // Bending of fibres along x with curvature along z in a slice constrained in y (ε_yy = 0):
  // σ_xx = E' κ z, σ_zz = 0, E' = E/(1-ν²); energy ½ E' κ² ∫z² dV = ½ E' κ² a b c³/12.
  const Real E = 28e9, nu = 0.17, a = 0.4, b = 0.3, c = 0.25, kappa = 1e-3;
  const Real Ep = E / (1 - nu * nu);
  const Real exact = 0.5 * Ep * kappa * kappa * a * b * c * c * c / 12;
  const Real onePoint = bendingEnergy(Hex8Formulation::OnePointAssumedStrain, E, nu, a, b, c, kappa);
  EXPECT_NEAR(onePoint / exact, 1.0, 1e-12);
  // Without the transverse Poisson correction the modulus is λ + 2μ.
  const auto mod = ElasticModuli::fromYoungPoisson(E, nu);
  const Real noPois = bendingEnergy(Hex8Formulation::OnePointAssumedStrainNoPoisson, E, nu, a, b, c, kappa);
  EXPECT_NEAR(noPois / exact, mod.pModulus() / Ep, 1e-12);
  // Full integration adds the parasitic shear energy: ½ μ κ² (x² part) → ratio 1 + (μ/E')(a/c)²... > 1.
  const Real full = bendingEnergy(Hex8Formulation::FullIntegration, E, nu, a, b, c, kappa);
  EXPECT_GT(full / exact, 1.3);
}

namespace {
// A material that keeps more history values an element than the element step passes.
class ManyHistoryMaterial final : public Material {
 public:
  std::string typeName() const override { return "many_history"; }
  Real density() const override { return 2000; }
  ElasticModuli elasticModuli() const override { return ElasticModuli::fromYoungPoisson(1e9, 0.25); }
  std::vector<std::string> historyNames() const override {
    return std::vector<std::string>(ElementBlock::kMaxHistory + 1, "h");
  }
  void updateStressForElems(const MaterialChunk&) const override {}
};
}  // namespace

// A material with more history than the step's stack array is refused when its block is built,
// naming the block, the material and both counts, instead of having its extra values dropped.
TEST(ElementBlock, AMaterialWithTooMuchHistoryIsRefusedByName) {
  const Mesh m = makeBoxMesh(BoxSpec{1, 1, 1, 0, 0, 0, 1.0, 1.0, 1.0});
  try {
    ElementBlock b("rock", std::make_shared<ManyHistoryMaterial>(), Hex8Formulation::OnePointAssumedStrain, m, {0});
    FAIL() << "built a block whose material keeps 33 history values";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("block 'rock'"), std::string::npos) << what;
    EXPECT_NE(what.find("many_history"), std::string::npos) << what;
    EXPECT_NE(what.find("keeps 33"), std::string::npos) << what;
    EXPECT_NE(what.find("32"), std::string::npos) << what;
  }
}
