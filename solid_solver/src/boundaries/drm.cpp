// The domain reduction method's effective forces (tq/boundaries/drm.hpp; docs/solid_solver.md
// "Domain reduction").
#include "tq/boundaries/drm.hpp"

#include <algorithm>
#include <cmath>
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
          Real& probe = uProbe[3 * size_t(b->node(e, kj)) + size_t(j)];
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
      // Stored column by column (K_be's column ie is contiguous over ib, K_eb's column ib over ie), so
      // the products below run along contiguous rows without a reduction: they vectorise.
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
      auto [it, added] = distinct.emplace(std::move(key), Index(couplings_.size()));
      if (added) couplings_.push_back(std::move(c));
      elemCoupling_.push_back(it->second);
      for (int k = 0; k < 8; ++k) elemNodes_.push_back(s[k]);
    }
  if (elemNodes_.empty())
    throw InputError("/drm: no element has all eight nodes among the " + std::to_string(N) +
                     " DRM nodes with both inner and outer ones; the nodes must be the two boundaries of a "
                     "one-element layer");
  w_.assign(3 * N, 0.0);
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

void DomainReduction::addForces(Real t, Real /*dt*/, NodalState& state) {
  // w = u0 + β u̇0 at t, linear between the samples k and k + 1 (held outside them).
  const size_t M = w_.size(), T = field_.time.size();
  size_t k = 0;
  Real a = 0;
  if (t >= field_.time.back()) {
    k = T - 2, a = 1;
  } else if (t > field_.time.front()) {
    k = size_t(std::upper_bound(field_.time.begin(), field_.time.end(), t) - field_.time.begin()) - 1;
    a = (t - field_.time[k]) / (field_.time[k + 1] - field_.time[k]);
  }
  const Real* u0 = &field_.u[k * M];
  const Real* v0 = &field_.v[k * M];
  const Real c0 = 1 - a, b0 = beta_ * (1 - a), b1 = beta_ * a;
  if (beta_ == 0)
    for (size_t i = 0; i < M; ++i) w_[i] = c0 * u0[i] + a * u0[M + i];
  else
    for (size_t i = 0; i < M; ++i) w_[i] = c0 * u0[i] + a * u0[M + i] + b0 * v0[i] + b1 * v0[M + i];
  Real* fe = state.fExtData();
  const size_t L = elemNodes_.size() / 8;
  for (size_t l = 0; l < L; ++l) {
    const Coupling& c = couplings_[size_t(elemCoupling_[l])];
    const Index* s = &elemNodes_[8 * l];
    switch (c.nb) {  // every corner is b or e: ne = 8 − nb, fixed sizes for the compiler
      case 1:
        coupleElement<1>(c, s, fe);
        break;
      case 2:
        coupleElement<2>(c, s, fe);
        break;
      case 3:
        coupleElement<3>(c, s, fe);
        break;
      case 4:
        coupleElement<4>(c, s, fe);
        break;
      case 5:
        coupleElement<5>(c, s, fe);
        break;
      case 6:
        coupleElement<6>(c, s, fe);
        break;
      default:
        coupleElement<7>(c, s, fe);
        break;
    }
  }
}

template <int NB>
void DomainReduction::coupleElement(const Coupling& c, const Index* s, Real* fe) const {
  constexpr int mb = 3 * NB, me = 3 * (8 - NB);
  Real wb[mb], we[me], pb[mb], pe[me];
  for (int k = 0; k < NB; ++k)
    for (int i = 0; i < 3; ++i) wb[3 * k + i] = w_[3 * size_t(s[c.b[k]]) + size_t(i)];
  for (int k = 0; k < 8 - NB; ++k)
    for (int i = 0; i < 3; ++i) we[3 * k + i] = w_[3 * size_t(s[c.e[k]]) + size_t(i)];
  // P_b = −K_be w_e on the inner corners, P_e = +K_eb w_b on the outer ones.
  const Real* kbe = c.kbe.data();  // [me][mb]: column j of K_be
  for (int r = 0; r < mb; ++r) pb[r] = 0;
  for (int j = 0; j < me; ++j)
    for (int r = 0; r < mb; ++r) pb[r] += kbe[j * mb + r] * we[j];
  const Real* keb = c.keb.data();  // [mb][me]: column j of K_eb
  for (int r = 0; r < me; ++r) pe[r] = 0;
  for (int j = 0; j < mb; ++j)
    for (int r = 0; r < me; ++r) pe[r] += keb[j * me + r] * wb[j];
  const Index* nodes = field_.nodes.data();
  for (int k = 0; k < NB; ++k) {
    Real* f = fe + 3 * size_t(nodes[s[c.b[k]]]);
    for (int i = 0; i < 3; ++i) f[i] -= pb[3 * k + i];
  }
  for (int k = 0; k < 8 - NB; ++k) {
    Real* f = fe + 3 * size_t(nodes[s[c.e[k]]]);
    for (int i = 0; i < 3; ++i) f[i] += pe[3 * k + i];
  }
}

}  // namespace tq
