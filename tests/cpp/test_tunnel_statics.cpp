// Static stages around the tunnel (tests/verification/solid_kirsch,
// solid_lined_tunnel), through the stage driver exactly as tq-solid runs them.
//
//  - Kirsch (Brady & Brown, Rock Mechanics for Underground Mining, ch. 7; VERIFICATION.md): a
//    circular hole of radius b excavated under a uniform far-field stress σv = p, σh = k p
//    (gravity off): wall hoop stress p[(1+k) + 2(1−k) cos 2θ] (compression positive; θ from the
//    horizontal): sidewall p(3 − k), crown p(3k − 1).
//  - Lining a ≤ r ≤ b installed stress-free after the excavation, bonded to the rock, then an
//    internal pressure p_i (VERIFICATION.md; tunnelquake.references.lined_tunnel_internal_pressure):
//    contact pressure, inner and outer hoop stress of the lining.
//  - The hydrostatic load p = p_axis − γw (z − z_axis) on the lining's inner face: its resultant is
//    the weight of the water, γw × (enclosed area) × width, downwards (divergence theorem).
//
// Meshes: a quarter of the plane-strain plate (symmetry planes x = 0 and z = 0 on rollers), one
// element thick, rays from the hole to the square outer boundary at L = 20 b (rollers), radial
// sizes growing geometrically so the elements stay square (r Δθ by Δr).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "tunnel_cases.hpp"

using namespace tq;

using namespace tqcases;

// Excavation under k = 0.5 (sidewall 2.5 p, crown 0.5 p): within 3 % on the refined mesh (32 per
// quarter = 128 around), and the error falls at second order with refinement (one-point
// elements: centroid stresses, the linear extrapolation to the wall and the polygonal hole are all
// O(h²)). The rollers at L = 80 b leave an O((b/L)²) floor (about 0.05 %; 0.4 % at L = 20 b), and
// 8 per quarter is not yet asymptotic for the crown, so the order is asserted (> 1.5) on the finer
// step 16 -> 32; measured 1.74 (sidewall), 1.69 (crown); 1.70 and 1.46 on 8 -> 16.
TEST(Kirsch, WallHoopStressConvergesAtSecondOrder) {
  const Real p = 10e6, k = 0.5, L = 80;
  const KirschResult r8 = kirsch(8, p, k, L), r16 = kirsch(16, p, k, L), r32 = kirsch(32, p, k, L);
  EXPECT_LT(std::abs(r32.errSide), 0.03);
  EXPECT_LT(std::abs(r32.errCrown), 0.03);
  const Real side1 = std::log2(std::abs(r8.errSide / r16.errSide));
  const Real side2 = std::log2(std::abs(r16.errSide / r32.errSide));
  const Real crown1 = std::log2(std::abs(r8.errCrown / r16.errCrown));
  const Real crown2 = std::log2(std::abs(r16.errCrown / r32.errCrown));
  std::printf("Kirsch observed orders (8->16, 16->32): sidewall %.2f, %.2f; crown %.2f, %.2f\n", side1, side2, crown1,
              crown2);
  EXPECT_GT(side2, 1.5);
  EXPECT_GT(crown2, 1.5);
  EXPECT_GT(side1, 1.2);  // falling clearly already on the coarse step
  EXPECT_GT(crown1, 1.2);
}

// The paper's lining (3 elements through 0.75 m, 48 around) and rock, 1.207 MPa (123 m of water):
// contact pressure and inner/outer hoop within 3 % of the closed form, with the rock prestressed
// (p0 = 5 MPa, kx 1.1) before the lining goes in.
TEST(LinedTunnel, InternalPressureMatchesClosedForm) {
  const Real pi = kLinedPi, p0 = 5e6;
  const LinedReference ref = linedReference(pi);
  const Real pcRef = ref.pc, hinRef = ref.hoopIn, houtRef = ref.hoopOut;
  for (Index n : {12, 24}) {
    const LinedResult r = linedTunnel(n, n / 4, pi, p0);
    std::printf(
        "lined tunnel, %d around the quarter, %d through: contact pressure %+.2f %% (interface forces "
        "%+.2f %%), inner hoop %+.2f %%, outer hoop %+.2f %% (reference p_c %.4g, hoop %.4g / %.4g MPa)\n",
        n, n / 4, 100 * (r.pc / pcRef - 1), 100 * (r.pcTie / pcRef - 1), 100 * (r.hoopIn / hinRef - 1),
        100 * (r.hoopOut / houtRef - 1), pcRef / 1e6, hinRef / 1e6, houtRef / 1e6);
    if (n == 12) {  // the paper's mesh
      EXPECT_NEAR(r.pc / pcRef, 1, 0.03);
      EXPECT_NEAR(r.pcTie / pcRef, 1, 0.03);
      EXPECT_NEAR(r.hoopIn / hinRef, 1, 0.03);
      EXPECT_NEAR(r.hoopOut / houtRef, 1, 0.03);
    }
  }
}

// The hydrostatic load's consistent nodal forces: resultant = −γw × enclosed area × width in z
// (the water's weight), 0 in x, for p varying linearly with height (exact with 2×2 Gauss).
TEST(Hydrostatic, ResultantIsTheWeightOfTheWater) {
  RingSpec rs;
  rs.rInner = 4.5;
  rs.rOuter = 5.25;
  rs.nRadial = 3;
  rs.nAround = 48;
  rs.width = 1.0;
  const Mesh m = makeRingSliceMesh(rs);
  const Real gw = 9810, pAxis = 1.207e6, zAxis = 0;
  const auto f = pressureNodalForces(m, "inner", [&](const Real x[3]) { return pAxis - gw * (x[2] - zAxis); });
  Real fx = 0, fz = 0;
  for (Index n = 0; n < m.numNodes(); ++n) {
    fx += f[3 * size_t(n)];
    fz += f[3 * size_t(n) + 2];
  }
  const Real area = 0.5 * rs.nAround * rs.rInner * rs.rInner * std::sin(2 * M_PI / rs.nAround);  // the polygon
  std::printf("hydrostatic resultant: Fz / (−γ A w) − 1 = %.2e, Fx / (γ A w) = %.2e\n", fz / (-gw * area) - 1,
              fx / (gw * area));
  EXPECT_NEAR(fz / (-gw * area), 1, 1e-12);
  EXPECT_NEAR(fx / (gw * area), 0, 1e-12);
}
