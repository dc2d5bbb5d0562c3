// The domain reduction method's effective forces (tq/boundaries/drm.hpp; docs/solid_solver.md
// "Domain reduction").
#include "tq/boundaries/drm.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <sstream>

namespace tq {

void checkDrmFreeField(const DrmFreeField& f, Index numNodes) {
  const size_t N = f.nodes.size(), T = f.time.size();
  auto fail = [](const std::string& s) { throw InputError("/drm: " + s); };
  if (N == 0) fail("no DRM layer nodes; give the layer's nodes in /drm/nodes or remove /drm");
  if (f.internal.size() != N)
    fail("internal has " + std::to_string(f.internal.size()) + " entries for " + std::to_string(N) + " nodes");
  if (T < 2) fail("the free field needs at least two time samples (got " + std::to_string(T) + ")");
  for (size_t k = 1; k < T; ++k)
    if (!(f.time[k] > f.time[k - 1]))
      fail("time must increase strictly (sample " + std::to_string(k) + " is not after sample " +
           std::to_string(k - 1) + ")");
  for (const auto* arr : {&f.u, &f.v, &f.a})
    if (arr->size() != 3 * N * T)
      fail("displacement, velocity and acceleration must each be [" + std::to_string(T) + ", " + std::to_string(N) +
           ", 3]");
  std::vector<std::uint8_t> seen(size_t(std::max<Index>(numNodes, 0)), 0);
  size_t inner = 0;
  for (size_t i = 0; i < N; ++i) {
    const Index n = f.nodes[i];
    if (n < 0 || n >= numNodes)
      fail("node " + std::to_string(n) + " (entry " + std::to_string(i) + ") is not a mesh node (0 … " +
           std::to_string(numNodes - 1) + ")");
    if (seen[size_t(n)]) fail("node " + std::to_string(n) + " is listed twice");
    seen[size_t(n)] = 1;
    if (f.internal[i] > 1) fail("internal must be 0 (outer node e) or 1 (inner node b)");
    inner += f.internal[i];
  }
  if (inner == 0 || inner == N)
    fail("the layer needs inner (internal = 1) and outer (internal = 0) nodes; got " + std::to_string(inner) +
         " inner of " + std::to_string(N));
  for (const auto* arr : {&f.u, &f.v, &f.a})
    for (Real x : *arr)
      if (!std::isfinite(x)) fail("the free field holds a value that is not finite");
}

DomainReduction::DomainReduction(const Mesh& mesh, const std::vector<std::unique_ptr<ElementBlock>>& blocks,
                                 DrmFreeField field, Real beta)
    : field_(std::move(field)), beta_(beta) {
  checkDrmFreeField(field_, mesh.numNodes());
  const size_t N = field_.nodes.size();
  std::vector<Index> slot(size_t(mesh.numNodes()), -1);
  for (size_t i = 0; i < N; ++i) {
    slot[size_t(field_.nodes[i])] = Index(i);
    (field_.internal[i] ? nInner_ : nOuter_) += 1;
  }
  std::vector<Real> uProbe(3 * size_t(mesh.numNodes()), 0.0);
  Real f0[24], f1[24];
  std::map<std::vector<long long>, Index> distinct;
  // One element's b–e coupling: its inner and outer corners (local numbers) and the blocks K_be
  // (3 nb × 3 ne) and K_eb (3 ne × 3 nb), each stored column by column.
  struct Coupling {
    int nb = 0, ne = 0;
    int b[8] = {}, e[8] = {};
    std::vector<Real> kbe, keb;
  };
  std::vector<Coupling> couplings;
  std::vector<Index> elemNodes;     // [8 L] slots of each layer element's corners
  std::vector<Index> elemCoupling;  // [L] index into couplings
  for (const auto& b : blocks)
    for (Index e = 0; e < b->numElems(); ++e) {
      Index s[8];
      int inner = 0, outer = 0;
      for (int k = 0; k < 8; ++k) {
        s[k] = slot[size_t(b->node(e, k))];
        if (s[k] < 0) break;
        (field_.internal[size_t(s[k])] ? inner : outer) += 1;
      }
      if (inner + outer < 8 || inner == 0 || outer == 0 || !b->active(e)) continue;
      if (!b->material().isLinearElastic() || b->formulation() == Hex8Formulation::FullIntegration) {
        std::ostringstream os;
        os << "/drm: element " << b->meshElem(e) << " of the DRM layer is in block '" << b->name() << "' ("
           << b->material().typeName() << ", " << formulationName(b->formulation())
           << "); the layer and everything outside it must be linear elastic one-point elements: give that "
              "region an elastic material or move the DRM layer outside the nonlinear zone";
        throw InputError(os.str());
      }
      // K column by column: f(u) − f(0) is exact for the linear elastic element.
      Real K[24][24];
      b->elementForces(e, uProbe.data(), f0);
      for (int kj = 0; kj < 8; ++kj)
        for (int j = 0; j < 3; ++j) {
          Real& probe = uProbe[dofIndex(b->node(e, kj), j)];
          probe = 1;
          b->elementForces(e, uProbe.data(), f1);
          probe = 0;
          for (int r = 0; r < 24; ++r) K[r][3 * kj + j] = f1[r] - f0[r];
        }
      Coupling c;
      for (int k = 0; k < 8; ++k) {
        if (field_.internal[size_t(s[k])])
          c.b[c.nb++] = k;
        else
          c.e[c.ne++] = k;
      }
      for (int ie = 0; ie < 3 * c.ne; ++ie)
        for (int ib = 0; ib < 3 * c.nb; ++ib) {
          const int rb = 3 * c.b[ib / 3] + ib % 3, re = 3 * c.e[ie / 3] + ie % 3;
          c.kbe.push_back(K[rb][re]);
        }
      for (int ib = 0; ib < 3 * c.nb; ++ib)
        for (int ie = 0; ie < 3 * c.ne; ++ie) {
          const int rb = 3 * c.b[ib / 3] + ib % 3, re = 3 * c.e[ie / 3] + ie % 3;
          c.keb.push_back(K[re][rb]);
        }
      // Share equal couplings: the key is the split and the entries in units of 2⁻³⁰ of the largest.
      Real big = 0;
      for (Real x : c.kbe) big = std::max(big, std::abs(x));
      for (Real x : c.keb) big = std::max(big, std::abs(x));
      const Real q = big > 0 ? std::ldexp(1.0, std::ilogb(big) - 30) : 1.0;
      std::vector<long long> key = {c.nb};
      for (int k = 0; k < c.nb; ++k) key.push_back(c.b[k]);
      for (Real x : c.kbe) key.push_back(std::llround(x / q));
      for (Real x : c.keb) key.push_back(std::llround(x / q));
      auto [it, added] = distinct.emplace(std::move(key), Index(couplings.size()));
      if (added) couplings.push_back(std::move(c));
      elemCoupling.push_back(it->second);
      for (int k = 0; k < 8; ++k) elemNodes.push_back(s[k]);
    }
  if (elemNodes.empty())
    throw InputError("/drm: no element has all eight nodes among the " + std::to_string(N) +
                     " DRM nodes with both inner and outer ones; the nodes must be the two boundaries of a "
                     "one-element layer");
  nCouplings_ = Index(couplings.size());
  nLayerElems_ = Index(elemCoupling.size());
  // Assembly node by node, the elements in their order: row slot r, column slot q, the block
  // −K_be (r inner, q outer) or +K_eb (r outer, q inner), row-major 3 × 3.
  std::vector<std::map<Index, std::array<Real, 9>>> rows(N);
  for (size_t l = 0; l < size_t(nLayerElems_); ++l) {
    const Coupling& c = couplings[size_t(elemCoupling[l])];
    const Index* sl = &elemNodes[8 * l];
    const int mb = 3 * c.nb, me = 3 * c.ne;
    for (int kb = 0; kb < c.nb; ++kb)
      for (int ke = 0; ke < c.ne; ++ke) {
        auto& toE = rows[size_t(sl[c.b[kb]])][sl[c.e[ke]]];  // row b, column e: −K_be
        auto& toB = rows[size_t(sl[c.e[ke]])][sl[c.b[kb]]];  // row e, column b: +K_eb
        for (int i = 0; i < 3; ++i)
          for (int d = 0; d < 3; ++d) {
            toE[size_t(3 * i + d)] -= c.kbe[size_t((3 * ke + d) * mb + 3 * kb + i)];
            toB[size_t(3 * i + d)] += c.keb[size_t((3 * kb + d) * me + 3 * ke + i)];
          }
      }
  }
  // Equal blocks (bit for bit) are stored once.
  std::map<std::array<std::uint64_t, 9>, Index> blockIds;
  rowStart_.assign(N + 1, 0);
  for (size_t r = 0; r < N; ++r) {
    for (const auto& [q, blk] : rows[r]) {
      std::array<std::uint64_t, 9> bits;
      std::memcpy(bits.data(), blk.data(), sizeof bits);
      auto [it, added] = blockIds.emplace(bits, Index(blocks_.size() / 12));
      if (added)  // column by column, each column padded to four: one vector a column
        for (int d = 0; d < 3; ++d)
          for (int i = 0; i < 4; ++i) blocks_.push_back(i < 3 ? blk[size_t(3 * i + d)] : 0.0);
      rowEntries_.push_back(3 * q);
      rowEntries_.push_back(12 * it->second);
    }
    rowStart_[r + 1] = Index(rowEntries_.size() / 2);
  }
  w_.assign(3 * N, 0.0);
  avx2_ = ElementBlock::defaultUseAvx2();
}

void DomainReduction::sample(Real t, std::vector<Real>& u, std::vector<Real>& v) const {
  const size_t M = 3 * field_.nodes.size(), T = field_.time.size();
  u.resize(M);
  v.resize(M);
  size_t k = 0;
  Real w = 0;
  if (t <= field_.time.front()) {
    k = 0;
  } else if (t >= field_.time.back()) {
    k = T - 1;
  } else {
    k = size_t(std::upper_bound(field_.time.begin(), field_.time.end(), t) - field_.time.begin()) - 1;
    w = (t - field_.time[k]) / (field_.time[k + 1] - field_.time[k]);
  }
  const Real* u0 = &field_.u[k * M];
  const Real* v0 = &field_.v[k * M];
  if (w == 0) {
    std::copy(u0, u0 + M, u.begin());
    std::copy(v0, v0 + M, v.begin());
    return;
  }
  const Real* u1 = u0 + M;
  const Real* v1 = v0 + M;
  for (size_t i = 0; i < M; ++i) {
    u[i] = (1 - w) * u0[i] + w * u1[i];
    v[i] = (1 - w) * v0[i] + w * v1[i];
  }
}

namespace {

/// The rows [r0, r1) of the layer's product, each row's entries in order (tq/boundaries/drm.hpp):
/// into out at the rows' mesh nodes (added) where nodes is given, else at the rows (assigned).
struct RowProduct {
  const Index *start, *entries, *nodes;  // entries: [3 column slot, 12 block] each
  const Real *blocks, *w;
  Real* out;
};

typedef Real V4 __attribute__((vector_size(32)));

inline __attribute__((always_inline)) void rowsBody(const RowProduct& q, size_t r0, size_t r1) {
  for (size_t r = r0; r < r1; ++r) {
    // Two partial sums (even and odd entries) shorten the chain of additions; the order is fixed.
    V4 acc0 = {0, 0, 0, 0}, acc1 = {0, 0, 0, 0};
    const Index pEnd = q.start[r + 1];
    Index p = q.start[r];
    auto term = [&](Index e) {
      const Real* x = q.w + q.entries[2 * e];
      const Real* b = q.blocks + q.entries[2 * e + 1];
      V4 c0, c1, c2;
      std::memcpy(&c0, b, sizeof c0);
      std::memcpy(&c1, b + 4, sizeof c1);
      std::memcpy(&c2, b + 8, sizeof c2);
      return c0 * x[0] + c1 * x[1] + c2 * x[2];
    };
    for (; p + 1 < pEnd; p += 2) {
      acc0 += term(p);
      acc1 += term(p + 1);
    }
    if (p < pEnd) acc0 += term(p);
    const V4 acc = acc0 + acc1;
    if (q.nodes) {
      Real* f = q.out + 3 * size_t(q.nodes[r]);
      f[0] += acc[0];
      f[1] += acc[1];
      f[2] += acc[2];
    } else {
      Real* f = q.out + 3 * r;
      f[0] = acc[0];
      f[1] = acc[1];
      f[2] = acc[2];
    }
  }
}

__attribute__((target("avx2,fma"))) void rowsAvx2(const RowProduct& q, size_t r0, size_t r1) { rowsBody(q, r0, r1); }
void rowsGeneric(const RowProduct& q, size_t r0, size_t r1) { rowsBody(q, r0, r1); }

/// Layers of fewer nodes run on one thread (the parallel region costs more than the work).
constexpr size_t kThreadedNodes = 512;

}  // namespace

void DomainReduction::product(Real* out, bool atNodes) const {
  const size_t N = field_.nodes.size();
  const RowProduct q{rowStart_.data(), rowEntries_.data(), atNodes ? field_.nodes.data() : nullptr,
                     blocks_.data(),   w_.data(),          out};
  const bool avx2 = avx2_;
  constexpr size_t kRows = 64;  // rows a work item
  const size_t nItems = (N + kRows - 1) / kRows;
#pragma omp parallel for schedule(static) if (N >= kThreadedNodes)
  for (size_t it = 0; it < nItems; ++it) {
    const size_t r0 = it * kRows, r1 = std::min(N, r0 + kRows);
    if (avx2)
      rowsAvx2(q, r0, r1);
    else
      rowsGeneric(q, r0, r1);
  }
}

const Real* DomainReduction::forcesAt(Index k) {
  for (int s = 0; s < 2; ++s)
    if (kept_[s].sample == k) {
      lastUsed_ = s;
      return kept_[s].f.data();
    }
  // w = u0 + β u̇0 at sample k, then its forces in the field's order, into the slot used less recently.
  const size_t M = w_.size();
  const Real* __restrict u0 = &field_.u[size_t(k) * M];
  const Real* __restrict v0 = &field_.v[size_t(k) * M];
  Real* __restrict w = w_.data();
  const Real beta = beta_;
#pragma omp parallel for schedule(static) if (M >= 3 * kThreadedNodes)
  for (size_t i = 0; i < M; ++i) w[i] = u0[i] + beta * v0[i];
  const int s = 1 - lastUsed_;
  kept_[s].f.resize(M);
  product(kept_[s].f.data(), false);
  ++products_;
  kept_[s].sample = k;
  lastUsed_ = s;
  return kept_[s].f.data();
}

void DomainReduction::addForces(Real t, Real dt, NodalState& state) {
  // The field at t is (1 − a) × sample k + a × sample k + 1 (held outside the samples), and so are
  // its forces.
  const size_t M = w_.size(), T = field_.time.size(), N = M / 3;
  size_t k = 0;
  Real a = 0;
  if (t >= field_.time.back()) {
    k = T - 2, a = 1;
  } else if (t > field_.time.front()) {
    k = size_t(std::upper_bound(field_.time.begin(), field_.time.end(), t) - field_.time.begin()) - 1;
    a = (t - field_.time[k]) / (field_.time[k + 1] - field_.time[k]);
  }
  Real* __restrict fe = state.fExtData();
  const Index k0 = Index(k), k1 = Index(k + 1);
  const bool need0 = a != 1, need1 = a != 0;
  if (need0 && need1 && field_.time[k + 1] - field_.time[k] < dt) {
    // Samples finer than the step: one product of the interpolated field (each step would need two
    // new samples' products). The choice depends on t and dt alone, not on what was kept.
    const Real* __restrict u0 = &field_.u[k * M];
    const Real* __restrict v0 = &field_.v[k * M];
    const Real c0 = 1 - a, b0 = beta_ * (1 - a), b1 = beta_ * a;
    Real* __restrict w = w_.data();
#pragma omp parallel for schedule(static) if (M >= 3 * kThreadedNodes)
    for (size_t i = 0; i < M; ++i) w[i] = c0 * u0[i] + a * u0[M + i] + b0 * v0[i] + b1 * v0[M + i];
    product(fe, true);
    ++products_;
    return;
  }
  const Real* __restrict f0 = need0 ? forcesAt(k0) : nullptr;
  const Real* __restrict f1 = need1 ? forcesAt(k1) : nullptr;
  const Index* __restrict nodes = field_.nodes.data();
  const Real c0 = 1 - a;
#pragma omp parallel for schedule(static) if (N >= kThreadedNodes)
  for (size_t r = 0; r < N; ++r) {
    Real* f = fe + 3 * size_t(nodes[r]);
    for (size_t d = 0; d < 3; ++d) {
      const size_t i = 3 * r + d;
      f[d] += f0 && f1 ? c0 * f0[i] + a * f1[i] : f0 ? f0[i] : f1[i];
    }
  }
}

}  // namespace tq
