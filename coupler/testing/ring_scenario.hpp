#pragma once
/// @file ring_scenario.hpp
/// The analytic scenario the fake participants replay (tq-coupler-dummy, and the Python fakes
/// of tunnelquake.coupling.fakes through the coupler's Python module): a cylindrical interface of
/// radius R (the lining's wetted face), nTheta nodes around and nLayers rings along y.
///
/// - solid node k: ring j = k / nTheta, i = k % nTheta, θ = 2π i / nTheta,
///   x = R cos θ, y = j·length/(nLayers − 1) (0 for one ring), z = R sin θ; id = 1000 + k.
/// - fluid nodes: the same points in reverse order, id = 500000 + (n − 1 − k); so a coincident
///   map must find the permutation by position.
/// - surface triangles: each quad (i, i+1) × (j, j+1) split along its diagonal.
/// - prescribed wall velocity (written by the solid) at time t, m/s:
///   v = (0.01 cos 2π·2t + 0.001 cos 2θ, 0, 0.005 sin 2π·2t)
/// - prescribed force (written by the fluid) at time t, N per node:
///   f = (1e3 cos θ sin 2π·3t, 0, 1e3 sin θ sin 2π·3t + 10)

#include <cmath>
#include <cstdint>
#include <vector>

namespace tq::coupler::scenario {

struct Ring {
  int nTheta = 64;
  int nLayers = 2;
  double radius = 4.5;
  double length = 1.0;

  int nodes() const { return nTheta * nLayers; }
  double theta(int k) const { return 2.0 * M_PI * double(k % nTheta) / double(nTheta); }

  std::vector<double> solidCoordinates() const {
    std::vector<double> c(3 * std::size_t(nodes()));
    for (int k = 0; k < nodes(); ++k) {
      const int j = k / nTheta;
      const double th = theta(k);
      c[3 * k] = radius * std::cos(th);
      c[3 * k + 1] = nLayers > 1 ? length * double(j) / double(nLayers - 1) : 0.0;
      c[3 * k + 2] = radius * std::sin(th);
    }
    return c;
  }
  std::vector<std::int64_t> solidIds() const {
    std::vector<std::int64_t> ids(static_cast<std::size_t>(nodes()));
    for (int k = 0; k < nodes(); ++k) ids[std::size_t(k)] = 1000 + k;
    return ids;
  }
  std::vector<std::int32_t> solidTriangles() const {
    std::vector<std::int32_t> t;
    for (int j = 0; j + 1 < nLayers; ++j)
      for (int i = 0; i < nTheta; ++i) {
        const int a = j * nTheta + i, b = j * nTheta + (i + 1) % nTheta;
        const int c = b + nTheta, d = a + nTheta;
        t.insert(t.end(), {a, b, c, a, c, d});
      }
    return t;
  }
  /// Fluid node k is solid node n − 1 − k.
  int solidIndexOfFluid(int k) const { return nodes() - 1 - k; }
  std::vector<double> fluidCoordinates() const {
    const auto s = solidCoordinates();
    std::vector<double> c(s.size());
    for (int k = 0; k < nodes(); ++k)
      for (int a = 0; a < 3; ++a) c[3 * k + a] = s[3 * std::size_t(solidIndexOfFluid(k)) + a];
    return c;
  }
  std::vector<std::int64_t> fluidIds() const {
    std::vector<std::int64_t> ids(static_cast<std::size_t>(nodes()));
    for (int k = 0; k < nodes(); ++k) ids[std::size_t(k)] = 500000 + solidIndexOfFluid(k);
    return ids;
  }
  std::vector<std::int32_t> fluidTriangles() const {
    auto t = solidTriangles();
    for (auto& v : t) v = solidIndexOfFluid(v);
    return t;
  }
};

/// Prescribed velocity at a node of angle θ, time t.
inline void velocity(double theta, double t, double v[3]) {
  v[0] = 0.01 * std::cos(2 * M_PI * 2 * t) + 0.001 * std::cos(2 * theta);
  v[1] = 0.0;
  v[2] = 0.005 * std::sin(2 * M_PI * 2 * t);
}
/// Prescribed force at a node of angle θ, time t.
inline void force(double theta, double t, double f[3]) {
  f[0] = 1e3 * std::cos(theta) * std::sin(2 * M_PI * 3 * t);
  f[1] = 0.0;
  f[2] = 1e3 * std::sin(theta) * std::sin(2 * M_PI * 3 * t) + 10.0;
}

/// Field values on the solid's nodes (solid = true) or on the fluid's nodes.
inline std::vector<double> field(const Ring& r, bool onSolid, bool isVelocity, double t) {
  std::vector<double> out(3 * std::size_t(r.nodes()));
  for (int k = 0; k < r.nodes(); ++k) {
    const int s = onSolid ? k : r.solidIndexOfFluid(k);
    const double th = r.theta(s);
    isVelocity ? velocity(th, t, &out[3 * std::size_t(k)]) : force(th, t, &out[3 * std::size_t(k)]);
  }
  return out;
}

}  // namespace tq::coupler::scenario
