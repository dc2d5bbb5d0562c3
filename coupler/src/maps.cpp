// Interface maps: k-d tree, coincident 1:1 pairs, nearest projection on triangles.
#include "tq/coupler/maps.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "tq/coupler/errors.hpp"

namespace tq::coupler {

// ---------------------------------------------------------------- k-d tree
namespace {
constexpr std::uint32_t kLeafSize = 8;
double dist2(const double* a, const double* b) {
  const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
  return x * x + y * y + z * z;
}
}  // namespace

KdTree::KdTree(const double* points, std::size_t n) : p_(points), n_(n), order_(n) {
  std::iota(order_.begin(), order_.end(), 0u);
  if (n) build(0, std::uint32_t(n), 0);
}

std::int32_t KdTree::build(std::uint32_t lo, std::uint32_t hi, int depth) {
  const auto id = std::int32_t(nodes_.size());
  nodes_.push_back({lo, hi, -1, 0.0, -1, -1});
  if (hi - lo <= kLeafSize) return id;
  // Split along the widest extent at the median.
  double mn[3] = {1e300, 1e300, 1e300}, mx[3] = {-1e300, -1e300, -1e300};
  for (std::uint32_t i = lo; i < hi; ++i)
    for (int a = 0; a < 3; ++a) {
      mn[a] = std::min(mn[a], p_[3 * order_[i] + a]);
      mx[a] = std::max(mx[a], p_[3 * order_[i] + a]);
    }
  int axis = 0;
  for (int a = 1; a < 3; ++a)
    if (mx[a] - mn[a] > mx[axis] - mn[axis]) axis = a;
  (void)depth;
  const std::uint32_t mid = lo + (hi - lo) / 2;
  std::nth_element(order_.begin() + lo, order_.begin() + mid, order_.begin() + hi,
                   [&](std::uint32_t a, std::uint32_t b) { return p_[3 * a + axis] < p_[3 * b + axis]; });
  const double split = p_[3 * order_[mid] + axis];
  const std::int32_t l = build(lo, mid, depth + 1);
  const std::int32_t r = build(mid, hi, depth + 1);
  nodes_[std::size_t(id)].axis = axis;
  nodes_[std::size_t(id)].split = split;
  nodes_[std::size_t(id)].left = l;
  nodes_[std::size_t(id)].right = r;
  return id;
}

void KdTree::nearestRec(std::int32_t ni, const double q[3], std::size_t& best, double& bestD2) const {
  const Node& nd = nodes_[std::size_t(ni)];
  if (nd.axis < 0) {
    for (std::uint32_t i = nd.lo; i < nd.hi; ++i) {
      const double d = dist2(q, p_ + 3 * order_[i]);
      if (d < bestD2 || (d == bestD2 && order_[i] < best)) {
        bestD2 = d;
        best = order_[i];
      }
    }
    return;
  }
  const double delta = q[nd.axis] - nd.split;
  const std::int32_t nearSide = delta < 0 ? nd.left : nd.right;
  const std::int32_t farSide = delta < 0 ? nd.right : nd.left;
  nearestRec(nearSide, q, best, bestD2);
  if (delta * delta <= bestD2) nearestRec(farSide, q, best, bestD2);
}

std::size_t KdTree::nearest(const double q[3], double* distance2) const {
  if (!n_) throw MapError("nearest point requested from an empty point set");
  std::size_t best = 0;
  double d2 = std::numeric_limits<double>::infinity();
  nearestRec(0, q, best, d2);
  if (distance2) *distance2 = d2;
  return best;
}

void KdTree::withinRec(std::int32_t ni, const double q[3], double r2, std::vector<std::size_t>& out) const {
  const Node& nd = nodes_[std::size_t(ni)];
  if (nd.axis < 0) {
    for (std::uint32_t i = nd.lo; i < nd.hi; ++i)
      if (dist2(q, p_ + 3 * order_[i]) <= r2) out.push_back(order_[i]);
    return;
  }
  const double delta = q[nd.axis] - nd.split;
  if (delta <= 0 || delta * delta <= r2) withinRec(nd.left, q, r2, out);
  if (delta >= 0 || delta * delta <= r2) withinRec(nd.right, q, r2, out);
}

void KdTree::within(const double q[3], double r, std::vector<std::size_t>& out) const {
  if (n_) withinRec(0, q, r * r, out);
}

// ---------------------------------------------------------------- maps
namespace {
void checkRows(const SparseWeights& w) {
  if (w.rowStart.size() != w.rows + 1 || w.col.size() != w.value.size() || w.rowStart.back() != w.col.size())
    throw MapError("map weights: inconsistent compressed-row arrays");
  for (std::size_t r = 0; r < w.rows; ++r) {
    double s = 0.0;
    for (std::size_t k = w.rowStart[r]; k < w.rowStart[r + 1]; ++k) {
      if (w.col[k] >= w.cols) throw MapError("map weights: column index out of range");
      s += w.value[k];
    }
    if (std::abs(s - 1.0) > 1e-12)
      throw MapError("consistent map: weights of target node " + std::to_string(r) + " sum to " + std::to_string(s) +
                     ", not 1");
  }
}
}  // namespace

ConsistentMap::ConsistentMap(SparseWeights w) : w_(std::move(w)) { checkRows(w_); }

void ConsistentMap::apply(const double* src, int c, double* dst) const {
  for (std::size_t r = 0; r < w_.rows; ++r) {
    double acc[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (std::size_t k = w_.rowStart[r]; k < w_.rowStart[r + 1]; ++k) {
      const double* s = src + std::size_t(c) * w_.col[k];
      for (int i = 0; i < c; ++i) acc[i] += w_.value[k] * s[i];
    }
    for (int i = 0; i < c; ++i) dst[std::size_t(c) * r + std::size_t(i)] = acc[i];
  }
}

std::vector<double> ConsistentMap::apply(const std::vector<double>& src, int c) const {
  if (src.size() != w_.cols * std::size_t(c))
    throw MapError("consistent map: input has " + std::to_string(src.size()) + " values, expected " +
                   std::to_string(w_.cols * std::size_t(c)));
  std::vector<double> out(w_.rows * std::size_t(c));
  apply(src.data(), c, out.data());
  return out;
}

ConservativeMap ConsistentMap::transpose() const { return ConservativeMap(w_); }

bool ConsistentMap::isPermutation() const {
  if (w_.rows != w_.cols) return false;
  std::vector<char> seen(w_.cols, 0);
  for (std::size_t r = 0; r < w_.rows; ++r) {
    if (w_.rowStart[r + 1] - w_.rowStart[r] != 1) return false;
    const auto c = w_.col[w_.rowStart[r]];
    if (seen[c] || w_.value[w_.rowStart[r]] != 1.0) return false;
    seen[c] = 1;
  }
  return true;
}

void ConservativeMap::apply(const double* in, int c, double* out) const {
  std::fill(out, out + w_.cols * std::size_t(c), 0.0);
  for (std::size_t r = 0; r < w_.rows; ++r) {
    const double* x = in + std::size_t(c) * r;
    for (std::size_t k = w_.rowStart[r]; k < w_.rowStart[r + 1]; ++k) {
      double* y = out + std::size_t(c) * w_.col[k];
      for (int i = 0; i < c; ++i) y[i] += w_.value[k] * x[i];
    }
  }
}

std::vector<double> ConservativeMap::apply(const std::vector<double>& in, int c) const {
  if (in.size() != w_.rows * std::size_t(c))
    throw MapError("conservative map: input has " + std::to_string(in.size()) + " values, expected " +
                   std::to_string(w_.rows * std::size_t(c)));
  std::vector<double> out(w_.cols * std::size_t(c));
  apply(in.data(), c, out.data());
  return out;
}

// ---------------------------------------------------------------- builders
namespace {

std::string nodeText(const SurfaceView& s, std::size_t i) {
  std::ostringstream o;
  o.precision(9);
  o << "#" << i;
  if (s.ids) o << " (id " << s.ids[i] << ")";
  o << " at (" << s.coordinates[3 * i] << ", " << s.coordinates[3 * i + 1] << ", " << s.coordinates[3 * i + 2] << ")";
  return o.str();
}

constexpr std::size_t kListed = 10;

}  // namespace

ConsistentMap CoincidentNodes::build(const SurfaceView& src, const SurfaceView& tgt) const {
  if (src.nodes != tgt.nodes)
    throw MapError(
        "coincident (1:1) map needs the same number of nodes on both sides: "
        "source has " +
        std::to_string(src.nodes) + ", target " + std::to_string(tgt.nodes) +
        " (use the projection map for non-matching meshes)");
  KdTree tree(src.coordinates, src.nodes);
  SparseWeights w;
  w.rows = tgt.nodes;
  w.cols = src.nodes;
  w.rowStart.assign(1, 0);
  std::vector<std::size_t> owner(src.nodes, std::size_t(-1));
  std::ostringstream unmatched, doubled;
  std::size_t nUnmatched = 0, nDoubled = 0;
  for (std::size_t t = 0; t < tgt.nodes; ++t) {
    double d2 = 0;
    const std::size_t s = tree.nearest(tgt.coordinates + 3 * t, &d2);
    if (std::sqrt(d2) > tol_) {
      if (nUnmatched++ < kListed)
        unmatched << "\n  target " << nodeText(tgt, t) << ": nearest source node " << nodeText(src, s) << " is "
                  << std::sqrt(d2) << " m away";
      w.col.push_back(0);
    } else {
      if (owner[s] != std::size_t(-1) && nDoubled++ < kListed)
        doubled << "\n  source " << nodeText(src, s) << " is within the tolerance of "
                << "targets #" << owner[s] << " and #" << t;
      owner[s] = t;
      w.col.push_back(std::uint32_t(s));
    }
    w.value.push_back(1.0);
    w.rowStart.push_back(w.col.size());
  }
  if (nUnmatched || nDoubled) {
    std::ostringstream m;
    m << "coincident (1:1) map with tolerance " << tol_ << " m failed:";
    if (nUnmatched)
      m << " " << nUnmatched << " of " << tgt.nodes << " target nodes have no source node within the tolerance"
        << unmatched.str() << (nUnmatched > kListed ? "\n  ..." : "");
    if (nDoubled)
      m << (nUnmatched ? "\n" : " ") << nDoubled
        << " source nodes pair with more than one target (tolerance too large or "
           "duplicated nodes)"
        << doubled.str() << (nDoubled > kListed ? "\n  ..." : "");
    throw MapError(m.str());
  }
  return ConsistentMap(std::move(w));
}

namespace {

/// Closest point to p on triangle (a, b, c): barycentric weights (Ericson, Real-Time
/// Collision Detection, §5.1.5) — exact on the interior, clamped to edges and vertices.
void closestOnTriangle(const double* p, const double* a, const double* b, const double* c, double w[3]) {
  double ab[3], ac[3], ap[3];
  for (int i = 0; i < 3; ++i) {
    ab[i] = b[i] - a[i];
    ac[i] = c[i] - a[i];
    ap[i] = p[i] - a[i];
  }
  auto dot = [](const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) {
    w[0] = 1;
    w[1] = 0;
    w[2] = 0;
    return;
  }
  double bp[3], cp[3];
  for (int i = 0; i < 3; ++i) {
    bp[i] = p[i] - b[i];
    cp[i] = p[i] - c[i];
  }
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) {
    w[0] = 0;
    w[1] = 1;
    w[2] = 0;
    return;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    w[0] = 1 - v;
    w[1] = v;
    w[2] = 0;
    return;
  }
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) {
    w[0] = 0;
    w[1] = 0;
    w[2] = 1;
    return;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double t = d2 / (d2 - d6);
    w[0] = 1 - t;
    w[1] = 0;
    w[2] = t;
    return;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w[0] = 0;
    w[1] = 1 - t;
    w[2] = t;
    return;
  }
  const double den = 1.0 / (va + vb + vc);
  const double v = vb * den, u = vc * den;
  w[0] = 1.0 - v - u;
  w[1] = v;
  w[2] = u;
}

}  // namespace

ConsistentMap NearestProjection::build(const SurfaceView& src, const SurfaceView& tgt) const {
  if (!src.numTriangles)
    throw MapError(
        "projection map needs the source surface triangles, and the source has "
        "none");
  const std::size_t nt = src.numTriangles;
  const std::int32_t* T = src.triangles;
  std::vector<double> centroid(3 * nt);
  double rmax = 0.0;
  for (std::size_t e = 0; e < nt; ++e) {
    for (int k = 0; k < 3; ++k) {
      const auto v = T[3 * e + k];
      if (v < 0 || std::size_t(v) >= src.nodes)
        throw MapError("projection map: triangle " + std::to_string(e) + " refers to node " + std::to_string(v) +
                       " of " + std::to_string(src.nodes));
    }
    for (int i = 0; i < 3; ++i) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += src.coordinates[3 * T[3 * e + k] + i];
      centroid[3 * e + i] = s / 3.0;
    }
    for (int k = 0; k < 3; ++k)
      rmax = std::max(rmax, std::sqrt(dist2(&centroid[3 * e], src.coordinates + 3 * T[3 * e + k])));
  }
  KdTree tree(centroid.data(), nt);
  SparseWeights w;
  w.rows = tgt.nodes;
  w.cols = src.nodes;
  std::vector<std::size_t> cand;
  std::ostringstream far;
  std::size_t nFar = 0;
  for (std::size_t t = 0; t < tgt.nodes; ++t) {
    const double* p = tgt.coordinates + 3 * t;
    // Every triangle whose closest point is nearer than that of the triangle with the
    // nearest centroid has its centroid within d0 + rmax: search exactly that ball.
    double c2 = 0;
    tree.nearest(p, &c2);
    cand.clear();
    tree.within(p, std::sqrt(c2) + rmax, cand);
    std::sort(cand.begin(), cand.end());  // deterministic ties
    double best = std::numeric_limits<double>::infinity(), bw[3] = {1, 0, 0};
    std::size_t be = 0;
    for (std::size_t e : cand) {
      double lw[3];
      const double *a = src.coordinates + 3 * T[3 * e], *b = src.coordinates + 3 * T[3 * e + 1],
                   *c = src.coordinates + 3 * T[3 * e + 2];
      closestOnTriangle(p, a, b, c, lw);
      double q[3];
      for (int i = 0; i < 3; ++i) q[i] = lw[0] * a[i] + lw[1] * b[i] + lw[2] * c[i];
      const double d = dist2(p, q);
      if (d < best) {
        best = d;
        be = e;
        std::copy(lw, lw + 3, bw);
      }
    }
    if (std::sqrt(best) > maxDist_ && nFar++ < kListed)
      far << "\n  target " << nodeText(tgt, t) << " is " << std::sqrt(best) << " m from the source surface";
    for (int k = 0; k < 3; ++k)
      if (bw[k] != 0.0) {
        w.col.push_back(std::uint32_t(T[3 * be + k]));
        w.value.push_back(bw[k]);
      }
    w.rowStart.push_back(w.col.size());
  }
  if (nFar) {
    std::ostringstream m;
    m << "projection map: " << nFar << " of " << tgt.nodes << " target points lie farther than " << maxDist_
      << " m from the source surface (meshes of different geometry, or units differ?)" << far.str()
      << (nFar > kListed ? "\n  ..." : "");
    throw MapError(m.str());
  }
  return ConsistentMap(std::move(w));
}

std::unique_ptr<MapBuilder> makeMapBuilder(MapKind kind, double tolerance) {
  switch (kind) {
    case MapKind::Coincident:
      return std::make_unique<CoincidentNodes>(tolerance);
    case MapKind::Projection:
      return std::make_unique<NearestProjection>(tolerance);
  }
  throw MapError("unknown map kind");
}

std::vector<std::int32_t> trianglesFromQuads(const std::int32_t* q, std::size_t n) {
  std::vector<std::int32_t> t;
  t.reserve(6 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t* v = q + 4 * i;
    t.insert(t.end(), {v[0], v[1], v[2], v[0], v[2], v[3]});
  }
  return t;
}

}  // namespace tq::coupler
