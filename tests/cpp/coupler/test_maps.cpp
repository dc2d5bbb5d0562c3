// Interface maps: k-d tree, coincident 1:1 pairs, nearest projection; consistent maps reproduce
// constant and linear motion exactly, the conservative (transposed) map keeps total force and
// work to round-off.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>

#include "ring_scenario.hpp"
#include "tq/coupler/errors.hpp"
#include "tq/coupler/maps.hpp"

using namespace tq::coupler;

namespace {

SurfaceView view(const std::vector<double>& xyz, const std::vector<std::int32_t>& tri = {},
                 const std::vector<std::int64_t>* ids = nullptr) {
  SurfaceView s;
  s.coordinates = xyz.data();
  s.nodes = xyz.size() / 3;
  s.triangles = tri.data();
  s.numTriangles = tri.size() / 3;
  s.ids = ids ? ids->data() : nullptr;
  return s;
}

/// A linear motion u(x) = a + B x (3 components), evaluated at points.
std::vector<double> linearField(const std::vector<double>& xyz) {
  const double a[3] = {0.01, -0.02, 0.005};
  const double B[3][3] = {{1e-3, 2e-3, -1e-3}, {-4e-4, 5e-4, 3e-3}, {2e-3, -1e-3, 7e-4}};
  std::vector<double> u(xyz.size());
  for (std::size_t n = 0; n < xyz.size() / 3; ++n)
    for (int i = 0; i < 3; ++i)
      u[3 * n + i] = a[i] + B[i][0] * xyz[3 * n] + B[i][1] * xyz[3 * n + 1] + B[i][2] * xyz[3 * n + 2];
  return u;
}

/// Random points on the faceted source surface (barycentric sampling of random triangles):
/// a non-matching target mesh lying on the source geometry.
std::vector<double> pointsOnFacets(const std::vector<double>& xyz, const std::vector<std::int32_t>& tri, int n,
                                   unsigned seed) {
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::uniform_int_distribution<std::size_t> T(0, tri.size() / 3 - 1);
  std::vector<double> p;
  for (int k = 0; k < n; ++k) {
    const std::size_t e = T(g);
    double r1 = U(g), r2 = U(g);
    if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
    const double w[3] = {1 - r1 - r2, r1, r2};
    for (int i = 0; i < 3; ++i) {
      double s = 0;
      for (int v = 0; v < 3; ++v) s += w[v] * xyz[3 * std::size_t(tri[3 * e + v]) + i];
      p.push_back(s);
    }
  }
  return p;
}

/// A ring's faceted wetted face (nTheta around, nLayers rings, `length` long) and n random points
/// on its facets (pointsOnFacets with `seed`): a source mesh and a non-matching target.
struct RingAndPoints {
  std::vector<double> s;          ///< the ring's nodes
  std::vector<std::int32_t> tri;  ///< its triangles
  std::vector<double> t;          ///< the points on them
};
RingAndPoints ringAndPoints(int nTheta, int nLayers, double length, int n, unsigned seed) {
  scenario::Ring r;
  r.nTheta = nTheta;
  r.nLayers = nLayers;
  r.length = length;
  RingAndPoints out{r.solidCoordinates(), r.solidTriangles(), {}};
  out.t = pointsOnFacets(out.s, out.tri, n, seed);
  return out;
}

double maxAbsDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

}  // namespace

TEST(KdTree, AgreesWithBruteForce) {
  std::mt19937 g(7);
  std::uniform_real_distribution<double> U(-5, 5);
  std::vector<double> p(3 * 2000);
  for (auto& x : p) x = U(g);
  KdTree t(p.data(), 2000);
  for (int q = 0; q < 200; ++q) {
    const double x[3] = {U(g), U(g), U(g)};
    std::size_t best = 0;
    double bd = 1e300;
    std::vector<std::size_t> ball;
    for (std::size_t i = 0; i < 2000; ++i) {
      const double d =
          std::pow(p[3 * i] - x[0], 2) + std::pow(p[3 * i + 1] - x[1], 2) + std::pow(p[3 * i + 2] - x[2], 2);
      if (d < bd) bd = d, best = i;
      if (d <= 1.0) ball.push_back(i);
    }
    double d2 = 0;
    EXPECT_EQ(t.nearest(x, &d2), best);
    EXPECT_DOUBLE_EQ(d2, bd);
    std::vector<std::size_t> got;
    t.within(x, 1.0, got);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, ball);
  }
}

TEST(CoincidentMap, FindsThePairsOfTheRingAndMapsExactly) {
  scenario::Ring r;
  const auto s = r.solidCoordinates(), f = r.fluidCoordinates();
  const auto ids = r.solidIds();
  const ConsistentMap m = CoincidentNodes(1e-6).build(view(s), view(f));
  EXPECT_TRUE(m.isPermutation());
  for (int k = 0; k < r.nodes(); ++k) {
    const auto& w = m.weights();
    EXPECT_EQ(w.col[w.rowStart[std::size_t(k)]], std::uint32_t(r.solidIndexOfFluid(k)));
  }
  // The prescribed velocity on the solid maps bit-exactly onto the fluid's nodes, and the
  // fluid's force maps back bit-exactly (a permutation has no arithmetic).
  EXPECT_EQ(m.apply(scenario::field(r, true, true, 0.3), 3), scenario::field(r, false, true, 0.3));
  EXPECT_EQ(m.transpose().apply(scenario::field(r, false, false, 0.3), 3), scenario::field(r, true, false, 0.3));
  (void)ids;
}

TEST(CoincidentMap, ListsUnmatchedNodesWithIdsAndDistances) {
  scenario::Ring r;
  auto s = r.solidCoordinates();
  auto f = r.fluidCoordinates();
  f[3 * 5] += 2e-3;  // two fluid nodes moved 2 mm
  f[3 * 9 + 2] -= 2e-3;
  const auto sid = r.solidIds(), fid = r.fluidIds();
  try {
    CoincidentNodes(1e-6).build(view(s, {}, &sid), view(f, {}, &fid));
    FAIL() << "unmatched nodes accepted";
  } catch (const MapError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("2 of 128 target nodes"), std::string::npos) << w;
    EXPECT_NE(w.find("(id " + std::to_string(fid[5]) + ")"), std::string::npos) << w;
    EXPECT_NE(w.find("(id " + std::to_string(fid[9]) + ")"), std::string::npos) << w;
    EXPECT_NE(w.find("0.002 m away"), std::string::npos) << w;
  }
  // Different counts: refused up front, pointing at the projection map.
  std::vector<double> fewer(f.begin(), f.end() - 3);
  EXPECT_THROW(CoincidentNodes(1e-6).build(view(s), view(fewer)), MapError);
}

TEST(ProjectionMap, ReproducesConstantAndLinearMotionExactlyOnNonMatchingMeshes) {
  // Source: the lining's wetted face, coarse (48 x 4); target: 3000 points of a different
  // distribution on the same faceted surface.
  const auto [s, tri, t] = ringAndPoints(48, 4, 3.0, 3000, 42);
  const ConsistentMap m = NearestProjection(1e-9).build(view(s, tri), view(t));
  EXPECT_EQ(m.targetSize(), 3000u);
  EXPECT_FALSE(m.isPermutation());

  std::vector<double> c(s.size());
  for (std::size_t i = 0; i < c.size(); i += 3) c[i] = 0.02, c[i + 1] = -0.01, c[i + 2] = 0.003;
  const auto mc = m.apply(c, 3);
  for (std::size_t i = 0; i < mc.size(); i += 3) {
    EXPECT_NEAR(mc[i], 0.02, 1e-16);
    EXPECT_NEAR(mc[i + 1], -0.01, 1e-16);
    EXPECT_NEAR(mc[i + 2], 0.003, 1e-16);
  }
  // Linear motion: exact at points on the source surface (barycentric interpolation is exact
  // for linear fields); round-off only: |u| ~ 0.03 m, error < 1e-15 m.
  EXPECT_LT(maxAbsDiff(m.apply(linearField(s), 3), linearField(t)), 1e-15);
}

TEST(ProjectionMap, LinearMotionOnTheTrueCylinderHasTheChordError) {
  // Targets on the exact cylinder (a finer ring): the error of a linear field is the field's
  // gradient times the distance to the facets, at most the sagitta R (1 − cos(π/nθ)).
  scenario::Ring coarse, fine;
  coarse.nTheta = 48;
  coarse.nLayers = 3;
  fine.nTheta = 301;
  fine.nLayers = 5;
  const auto s = coarse.solidCoordinates();
  const auto t = fine.solidCoordinates();
  const double sagitta = coarse.radius * (1 - std::cos(M_PI / coarse.nTheta));
  const ConsistentMap m = NearestProjection(1.01 * sagitta).build(view(s, coarse.solidTriangles()), view(t));
  const double gradMax = 3.2e-3 * std::sqrt(3.0);  // bound of |B| rows used in linearField
  EXPECT_LT(maxAbsDiff(m.apply(linearField(s), 3), linearField(t)), gradMax * sagitta);
  // ... and a tolerance below the sagitta refuses the points, listing them.
  try {
    NearestProjection(0.5 * sagitta).build(view(s, coarse.solidTriangles()), view(t));
    FAIL();
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("farther than"), std::string::npos) << e.what();
  }
}

TEST(ConservativeMap, PreservesTotalForceAndWorkToRoundOff) {
  const auto [s, tri, t] = ringAndPoints(40, 3, 2.0, 2500, 3);
  const ConsistentMap motion = NearestProjection(1e-9).build(view(s, tri), view(t));
  const ConservativeMap forces = motion.transpose();
  static_assert(ConservativeMap::kConstraint == MapConstraint::Conservative);
  static_assert(ConsistentMap::kConstraint == MapConstraint::Consistent);
  EXPECT_EQ(forces.inputSize(), t.size() / 3);
  EXPECT_EQ(forces.outputSize(), s.size() / 3);

  std::mt19937 g(11);
  std::normal_distribution<double> N(0, 1e4);  // N per water node
  std::vector<double> ft(t.size());
  for (auto& x : ft) x = N(g);
  const auto fs = forces.apply(ft, 3);
  for (int i = 0; i < 3; ++i) {
    double a = 0, b = 0, scale = 0;
    for (std::size_t n = 0; n < ft.size() / 3; ++n) a += ft[3 * n + i], scale += std::abs(ft[3 * n + i]);
    for (std::size_t n = 0; n < fs.size() / 3; ++n) b += fs[3 * n + i];
    EXPECT_LT(std::abs(a - b), 1e-14 * scale) << "component " << i;
  }
  // Work of the forces on the mapped motion equals the work of the mapped forces.
  const auto us = linearField(s);
  const auto ut = motion.apply(us, 3);
  const double wFluid = std::inner_product(ft.begin(), ft.end(), ut.begin(), 0.0);
  const double wSolid = std::inner_product(fs.begin(), fs.end(), us.begin(), 0.0);
  double scale = 0;
  for (std::size_t i = 0; i < ft.size(); ++i) scale += std::abs(ft[i] * ut[i]);
  EXPECT_LT(std::abs(wFluid - wSolid), 1e-14 * scale);
}

TEST(ProjectionMap, PlanarNonMatchingGridsAreExactForLinearFields) {
  // Source: 11 x 11 grid of 0.1 m quads on z = 0 split into triangles; target: a rotated,
  // finer grid inside it.
  std::vector<double> s;
  std::vector<std::int32_t> quads;
  for (int j = 0; j <= 10; ++j)
    for (int i = 0; i <= 10; ++i) s.insert(s.end(), {0.1 * i, 0.1 * j, 0.0});
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 10; ++i) {
      const int a = j * 11 + i;
      quads.insert(quads.end(), {a, a + 1, a + 12, a + 11});
    }
  const auto tri = trianglesFromQuads(quads.data(), quads.size() / 4);
  std::vector<double> t;
  const double c = std::cos(0.3), sn = std::sin(0.3);
  for (int j = 0; j < 17; ++j)
    for (int i = 0; i < 17; ++i) {
      const double x = 0.025 * i - 0.2, y = 0.025 * j - 0.2;
      t.insert(t.end(), {0.5 + c * x - sn * y, 0.5 + sn * x + c * y, 0.0});
    }
  const ConsistentMap m = NearestProjection(1e-12).build(view(s, tri), view(t));
  EXPECT_LT(maxAbsDiff(m.apply(linearField(s), 3), linearField(t)), 1e-16);
}
