// Lining section forces (docs/theory.md "Lining section forces"): the lining's element stresses
// integrated through the thickness at the mid-plane of each element column of a ring.
#include "tq/io/ring_forces.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

namespace tq {

namespace {
constexpr Real kAngleTol = 1e-6;  // rad: nodes of one radial line (mesh generators place them exactly)
}

RingForces::RingForces(const Mesh& mesh, const ElementBlock& lining, const std::vector<Real>& axial)
    : mesh_(mesh), lining_(&lining) {
  if (lining.formulation() == Hex8Formulation::FullIntegration) {
    note_ = "no ring forces: the lining's formulation is full_integration (ring forces need the one-point element)";
    return;
  }
  const Index E = lining.numElems();
  if (E == 0) {
    note_ = "no ring forces: the lining region has no elements";
    return;
  }
  auto X = [&](Index n, int d) { return mesh.coords[dofIndex(n, d)]; };
  // Axial element layers by the elements' smallest y.
  std::vector<Real> ylo(static_cast<size_t>(E)), yhi(static_cast<size_t>(E));
  Real span = 0;
  for (Index e = 0; e < E; ++e) {
    Real lo = 1e300, hi = -1e300;
    for (int k = 0; k < 8; ++k) {
      lo = std::min(lo, X(lining.node(e, k), 1));
      hi = std::max(hi, X(lining.node(e, k), 1));
    }
    ylo[size_t(e)] = lo;
    yhi[size_t(e)] = hi;
    span = std::max(span, hi - lo);
  }
  const Real ytol = 1e-6 * span;
  std::vector<Real> layers(ylo);
  std::sort(layers.begin(), layers.end());
  layers.erase(std::unique(layers.begin(), layers.end(), [&](Real a, Real b) { return b - a < ytol; }), layers.end());
  auto layerOf = [&](Real y) {  // the layer whose extent contains y, else the nearest
    size_t best = 0;
    Real bd = 1e300;
    for (size_t k = 0; k < layers.size(); ++k) {
      const Real lo = layers[k], hi = k + 1 < layers.size() ? layers[k + 1] : lo + span;
      const Real d = y < lo - ytol ? lo - y : y > hi + ytol ? y - hi : 0.0;
      if (d < bd) {
        bd = d;
        best = k;
      }
    }
    return best;
  };
  std::set<size_t> chosen;
  for (Real y : axial) chosen.insert(layerOf(y));
  if (chosen.empty()) chosen.insert(layers.size() / 2);

  std::ostringstream why;
  for (size_t layer : chosen) {
    LiningRing R;
    std::vector<Index> elems;
    for (Index e = 0; e < E; ++e)
      if (std::abs(ylo[size_t(e)] - layers[layer]) < ytol) elems.push_back(e);
    std::vector<Index> nodes;
    for (Index e : elems)
      for (int k = 0; k < 8; ++k) nodes.push_back(lining.node(e, k));
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    R.yMin = layers[layer];
    R.yMax = -1e300;
    for (Index e : elems) R.yMax = std::max(R.yMax, yhi[size_t(e)]);
    // Centre: algebraic circle fit x² + z² = 2 a x + 2 b z + c over the layer's nodes on the face
    // group lining_inner (exact for nodes on one circle), or over all its nodes without that group
    // (exact for nodes on concentric circles placed symmetrically around them: a whole ring).
    std::vector<Index> fitNodes;
    if (auto it = mesh.faces.find(face_group::kLiningInner); it != mesh.faces.end())
      for (Index n : it->second)
        if (std::binary_search(nodes.begin(), nodes.end(), n)) fitNodes.push_back(n);
    std::sort(fitNodes.begin(), fitNodes.end());
    fitNodes.erase(std::unique(fitNodes.begin(), fitNodes.end()), fitNodes.end());
    if (fitNodes.size() < 3) fitNodes = nodes;
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (Index n : fitNodes) {
      const Eigen::Vector3d row(2 * X(n, 0), 2 * X(n, 2), 1.0);
      A += row * row.transpose();
      rhs += row * (X(n, 0) * X(n, 0) + X(n, 2) * X(n, 2));
    }
    const Eigen::Vector3d sol = A.ldlt().solve(rhs);
    R.xc = sol(0);
    R.zc = sol(1);
    // Radial lines: the nodes' angles about the centre, clustered.
    std::vector<std::pair<Real, Index>> ang;
    for (Index n : nodes) ang.emplace_back(std::atan2(X(n, 2) - R.zc, X(n, 0) - R.xc), n);
    std::sort(ang.begin(), ang.end());
    std::vector<Real> lineAngle;
    std::map<Index, int> lineOf;
    for (size_t i = 0; i < ang.size(); ++i) {
      if (i == 0 || ang[i].first - ang[i - 1].first > kAngleTol) lineAngle.push_back(ang[i].first);
      lineOf[ang[i].second] = int(lineAngle.size()) - 1;
    }
    int S = int(lineAngle.size());
    if (S > 1 && lineAngle[0] + 2 * M_PI - lineAngle[size_t(S) - 1] < kAngleTol) {  // the line at ±π
      for (auto& [n, l] : lineOf)
        if (l == S - 1) l = 0;
      lineAngle.pop_back();
      --S;
    }
    // Each element lies between two neighbouring lines, four corners on each.
    std::vector<int> lowerLine(elems.size());
    std::vector<int> column(size_t(S), -1);  // section of the column above each line
    bool polar = S >= 3;
    for (size_t i = 0; i < elems.size() && polar; ++i) {
      int lines[8];
      for (int k = 0; k < 8; ++k) lines[k] = lineOf[lining.node(elems[i], k)];
      const int a = *std::min_element(lines, lines + 8), b = *std::max_element(lines, lines + 8);
      const int na = int(std::count(lines, lines + 8, a));
      int lo = -1;
      if (b == a + 1)
        lo = a;
      else if (a == 0 && b == S - 1)
        lo = S - 1;  // across ±π
      if (lo < 0 || na != 4) {
        polar = false;
        why << "element " << lining.meshElem(elems[i]) << " of the lining does not lie between two radial node lines";
        break;
      }
      lowerLine[i] = lo;
      column[size_t(lo)] = 0;
    }
    if (!polar) {
      if (why.str().empty()) why << "the lining layer at y = " << R.yMin << " m has fewer than 3 radial node lines";
      continue;
    }
    // Sections: the columns, in angle order (a column across ±π sorts first, at its mid-angle).
    std::vector<std::pair<Real, int>> cols;
    for (int l = 0; l < S; ++l)
      if (column[size_t(l)] == 0) {
        Real lo = lineAngle[size_t(l)], hi = lineAngle[size_t((l + 1) % S)];
        if (hi < lo) hi += 2 * M_PI;
        Real mid = 0.5 * (lo + hi);
        if (mid > M_PI) mid -= 2 * M_PI;
        cols.emplace_back(mid, l);
      }
    std::sort(cols.begin(), cols.end());
    for (size_t c = 0; c < cols.size(); ++c) {
      column[size_t(cols[c].second)] = int(c);
      R.angle.push_back(cols[c].first);
    }
    R.closed = int(cols.size()) == S;
    R.lineAngle = lineAngle;
    R.column.assign(cols.size(), {});
    R.ref.assign(cols.size(), {0.0, 0.0});
    for (size_t i = 0; i < elems.size(); ++i) {
      // The element's stress stands for its radial extent [r_min, r_max] on the section (the
      // mean of its corners lies inside the arc, at ½(r_min + r_max) cos(Δθ/2)).
      Real rmin = 1e300, rmax = 0;
      std::uint8_t upper = 0;
      for (int k = 0; k < 8; ++k) {
        const Index n = lining.node(elems[i], k);
        const Real rn = std::hypot(X(n, 0) - R.xc, X(n, 2) - R.zc);
        rmin = std::min(rmin, rn);
        rmax = std::max(rmax, rn);
        if (lineOf[n] != lowerLine[i]) upper |= std::uint8_t(1u << k);
      }
      R.column[size_t(column[size_t(lowerLine[i])])].push_back({elems[i], 0.5 * (rmin + rmax), rmax - rmin, upper});
    }
    for (auto& col : R.column) {
      std::sort(col.begin(), col.end(), [](const auto& a, const auto& b) { return a.r < b.r; });
      if (col.size() < 2 && note_.empty())
        note_ = "one element through the lining's thickness: the moments M are NaN (they need two or more)";
    }
    // Radii and the inner-face nodes of each line.
    std::vector<std::vector<std::pair<Real, Index>>> onLine(static_cast<size_t>(S));
    for (Index n : nodes) onLine[size_t(lineOf[n])].emplace_back(std::hypot(X(n, 0) - R.xc, X(n, 2) - R.zc), n);
    Real ri = 0, ro = 0;
    for (auto& v : onLine) {
      std::sort(v.begin(), v.end());
      ri += v.front().first / Real(S);
      ro += v.back().first / Real(S);
    }
    R.rInner = ri;
    R.rOuter = ro;
    R.rMid = 0.5 * (ri + ro);
    std::vector<std::array<Real, 4>> faceMean;  // per line: mean x, z of its inner-face and outer-face nodes
    for (auto& v : onLine) {
      std::vector<Index> in;
      std::array<Real, 4> fm = {0, 0, 0, 0};
      int nin = 0, nout = 0;
      for (const auto& [r, n] : v) {
        if (r - v.front().first < 1e-6 * (ro - ri)) {
          in.push_back(n);
          fm[0] += X(n, 0);
          fm[1] += X(n, 2);
          ++nin;
        }
        if (v.back().first - r < 1e-6 * (ro - ri)) {
          fm[2] += X(n, 0);
          fm[3] += X(n, 2);
          ++nout;
        }
      }
      faceMean.push_back({fm[0] / nin, fm[1] / nin, fm[2] / nout, fm[3] / nout});
      R.inner.push_back(in);
    }
    // Moment reference of each section: the middle of the section's radial segment between the
    // straight inner and outer faces of its column (at ½(r_inner + r_outer) cos(Δθ/2) from the
    // centre on a polar grid), the mid-surface of the discrete ring.
    for (size_t c = 0; c < cols.size(); ++c) {
      const auto& lo = faceMean[size_t(cols[c].second)];
      const auto& hi = faceMean[size_t((cols[c].second + 1) % S)];
      const Real er[2] = {std::cos(R.angle[c]), std::sin(R.angle[c])};
      Real rho = 0;
      for (int f = 0; f < 2; ++f)
        rho += 0.5 * ((0.5 * (lo[2 * f] + hi[2 * f]) - R.xc) * er[0] +
                      (0.5 * (lo[2 * f + 1] + hi[2 * f + 1]) - R.zc) * er[1]);
      R.ref[c] = {R.xc + rho * er[0], R.zc + rho * er[1]};
    }
    // Diameters: pairs of node lines half a turn apart (whole rings).
    if (R.closed)
      for (int k = 0; k < S; ++k)
        for (int j = k + 1; j < S; ++j)
          if (std::abs(lineAngle[size_t(j)] - lineAngle[size_t(k)] - M_PI) < kAngleTol) {
            R.diameters.push_back({j, k});
            R.diameterAngle.push_back(lineAngle[size_t(j)] >= M_PI - kAngleTol ? 0.0 : lineAngle[size_t(j)]);
          }
    rings_.push_back(std::move(R));
  }
  if (rings_.empty())
    note_ = "no ring forces: " + why.str();
  else if (!why.str().empty())
    note_ += (note_.empty() ? "" : "; ") + ("some rings missing: " + why.str());
}

void RingForces::freeBodyForces(size_t r, const Real* u, Real* N, Real* M, Real* V) const {
  const LiningRing& R = rings_[r];
  const ElementBlock& b = *lining_;
  const Real L = R.yMax - R.yMin;
  Real f[24];
  for (size_t s = 0; s < R.angle.size(); ++s) {
    // T: the force of the column's θ+ corners on it, i.e. of the θ+ side on the θ− side; m: its
    // moment about the section's reference point (y component, + with tension at the inner face).
    Real Tx = 0, Tz = 0, m = 0;
    for (const auto& E : R.column[s]) {
      b.elementForces(E.elem, u, f);
      for (int k = 0; k < 8; ++k) {
        if (!(E.upper >> k & 1u)) continue;
        const Index n = b.node(E.elem, k);
        const Real fx = f[3 * k], fz = f[3 * k + 2];
        Tx += fx;
        Tz += fz;
        m += (mesh_.coords[dofIndex(n, 2)] - R.ref[s][1]) * fx - (mesh_.coords[3 * size_t(n)] - R.ref[s][0]) * fz;
      }
    }
    const Real c = std::cos(R.angle[s]), sn = std::sin(R.angle[s]);
    N[s] = (-sn * Tx + c * Tz) / L;
    V[s] = (c * Tx + sn * Tz) / L;
    M[s] = m / L;
  }
}

void RingForces::sectionForces(size_t r, Real* N, Real* M, Real* V) const {
  const LiningRing& R = rings_[r];
  const ElementBlock& b = *lining_;
  for (size_t s = 0; s < R.angle.size(); ++s) {
    const Real c = std::cos(R.angle[s]), sn = std::sin(R.angle[s]);
    // e_r = (c, s), e_θ = (−s, c) in the x–z plane.
    Real n = 0, v = 0, w = 0, wx = 0, wy = 0, wxx = 0, wxy = 0, ri = 1e300, ro = 0;
    for (const auto& L : R.column[s]) {
      if (!b.active(L.elem)) continue;
      const Real sxx = b.stress(L.elem, XX), szz = b.stress(L.elem, ZZ), sxz = b.stress(L.elem, ZX);
      const Real stt = sn * sn * sxx - 2 * sn * c * sxz + c * c * szz;
      const Real srt = (szz - sxx) * sn * c + sxz * (c * c - sn * sn);
      n += stt * L.h;
      v += srt * L.h;
      const Real x = L.r - R.rMid;
      w += L.h;
      wx += L.h * x;
      wy += L.h * stt;
      wxx += L.h * x * x;
      wxy += L.h * x * stt;
      ri = std::min(ri, L.r - 0.5 * L.h);
      ro = std::max(ro, L.r + 0.5 * L.h);
    }
    N[s] = n;
    V[s] = v;
    const Real det = w * wxx - wx * wx;
    if (det > 1e-12 * w * wxx) {
      // σθθ ≈ α + β (r − r_mid); M = ∫ (α + β (r − r_mid)) (r_mid − r) dr over the column.
      const Real beta = (w * wxy - wx * wy) / det, alpha = (wy - beta * wx) / w;
      const Real di = ri - R.rMid, dout = ro - R.rMid;
      M[s] = -alpha * 0.5 * (dout * dout - di * di) - beta * (dout * dout * dout - di * di * di) / 3;
    } else {
      M[s] = std::numeric_limits<Real>::quiet_NaN();
    }
  }
}

}  // namespace tq
