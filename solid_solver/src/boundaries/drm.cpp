// The domain reduction method's effective forces (tq/boundaries/drm.hpp; docs/solid_solver.md
// "Domain reduction").
#include "tq/boundaries/drm.hpp"

#include <algorithm>
#include <cmath>
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
      b->elementForces(e, uProbe.data(), f0);
      const size_t base = coupling_.size();
      coupling_.resize(base + 24 * 24, 0.0);
      for (int kj = 0; kj < 8; ++kj)
        for (int j = 0; j < 3; ++j) {
          Real& probe = uProbe[3 * size_t(b->node(e, kj)) + size_t(j)];
          probe = 1;
          b->elementForces(e, uProbe.data(), f1);
          probe = 0;
          const bool colInner = field_.internal[size_t(s[kj])] != 0;
          for (int ki = 0; ki < 8; ++ki) {
            const bool rowInner = field_.internal[size_t(s[ki])] != 0;
            if (rowInner == colInner) continue;
            const Real sign = rowInner ? -1.0 : 1.0;  // P_b = −K_be w_e, P_e = +K_eb w_b
            for (int i = 0; i < 3; ++i)
              coupling_[base + size_t(3 * ki + i) * 24 + size_t(3 * kj + j)] = sign * (f1[3 * ki + i] - f0[3 * ki + i]);
          }
        }
      for (int k = 0; k < 8; ++k) elemNodes_.push_back(s[k]);
    }
  if (elemNodes_.empty())
    throw InputError("/drm: no element has all eight nodes among the " + std::to_string(N) +
                     " DRM nodes with both inner and outer ones; the nodes must be the two boundaries of a "
                     "one-element layer");
  w_.assign(3 * N, 0.0);
  uS_.assign(3 * N, 0.0);
  vS_.assign(3 * N, 0.0);
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
  sample(t, uS_, vS_);
  for (size_t i = 0; i < w_.size(); ++i) w_[i] = uS_[i] + beta_ * vS_[i];
  Real* fe = state.fExtData();
  const size_t L = elemNodes_.size() / 8;
  for (size_t l = 0; l < L; ++l) {
    const Index* s = &elemNodes_[8 * l];
    Real wl[24], f[24];
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) wl[3 * k + i] = w_[3 * size_t(s[k]) + size_t(i)];
    const Real* C = &coupling_[l * 24 * 24];
    for (int r = 0; r < 24; ++r) {
      Real acc = 0;
      for (int c = 0; c < 24; ++c) acc += C[24 * r + c] * wl[c];
      f[r] = acc;
    }
    for (int k = 0; k < 8; ++k) {
      const size_t n = size_t(field_.nodes[size_t(s[k])]);
      for (int i = 0; i < 3; ++i) fe[3 * n + size_t(i)] += f[3 * k + i];
    }
  }
}

}  // namespace tq
