#include "tq/core/element_block.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <immintrin.h>

#include "tq/elements/hex8.hpp"

// The kernel's 4-wide vector helpers are always inlined: the AVX ABI note does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

#include "simd_util.hpp"

namespace tq {

Hex8Formulation parseFormulation(const std::string& n) {
  if (n == "one_point_assumed_strain") return Hex8Formulation::OnePointAssumedStrain;
  if (n == "one_point_assumed_strain_no_poisson") return Hex8Formulation::OnePointAssumedStrainNoPoisson;
  if (n == "full_integration") return Hex8Formulation::FullIntegration;
  throw InputError("unknown element formulation '" + n +
                   "'; use one_point_assumed_strain (default), one_point_assumed_strain_no_poisson "
                   "or full_integration");
}

std::string formulationName(Hex8Formulation f) {
  switch (f) {
    case Hex8Formulation::OnePointAssumedStrain:
      return "one_point_assumed_strain";
    case Hex8Formulation::OnePointAssumedStrainNoPoisson:
      return "one_point_assumed_strain_no_poisson";
    case Hex8Formulation::FullIntegration:
      return "full_integration";
  }
  return "?";
}

namespace {
// Chunk-SoA geometry record of the one-point element: component `comp` of lane l of chunk c at
// geo_[(c * kGeo + comp) * kChunk + l].
constexpr int kGB = 0;     // uniform gradient b_jI at kGB + 8 j + I
constexpr int kGHx = 24;   // h_α · x_j at kGHx + 3 α + j (γ_α = (h_α − Σ_j (h_α·x_j) b_j) / 8)
constexpr int kGRot = 36;  // local frame R_ik at kGRot + 3 i + k
constexpr int kGIa = 45;   // inverse half edge lengths 1/a_k at kGIa + k
constexpr int kGVol = 48;  // volume
constexpr int kGeo = 49;
}  // namespace

namespace {

// Largest distance in the list between two elements sharing a node (the scatter's slab width).
Index scatterSpan(const Mesh& mesh, const std::vector<Index>& elems) {
  std::vector<Index> first(size_t(mesh.numNodes()), -1);
  Index span = 0;
  for (Index i = 0; i < Index(elems.size()); ++i)
    for (int k = 0; k < 8; ++k) {
      Index& f = first[size_t(mesh.connectivity[8 * size_t(elems[size_t(i)]) + k])];
      if (f < 0) f = i;
      span = std::max(span, i - f);
    }
  return span;
}

// Slabs of the deterministic parallel scatter over the chunks `chunks` (a block's connectivity
// conn, 8 nodes an element), as boundaries of positions in that list (size: slabs + 1). Slab s + 2
// starts past every position that a chunk of slab s shares a node with (reach looks both ways, so
// this holds in any order), so slabs of one parity share no node and scatter concurrently without
// a race. Each slab is as narrow as that allows (at least minChunks): where the order's local span
// is small (the rings next to the tunnel, numbered first) the slabs are narrow, so the work there
// is shared among the threads instead of landing in one wide slab.
std::vector<Index> slabsInOrder(const std::vector<Index>& conn, Index numElems, Index numNodes, Index chunk,
                                const std::vector<Index>& chunks, Index minChunks) {
  const Index n = Index(chunks.size());
  if (n == 0) return {0, 0};
  auto elems = [&](Index pos, Index& a, Index& b) {
    a = chunks[size_t(pos)] * chunk;
    b = std::min(numElems, a + chunk);
  };
  std::vector<Index> last(size_t(numNodes), -1);  // [node] last position of a chunk holding it
  for (Index pos = 0; pos < n; ++pos) {
    Index a, b;
    elems(pos, a, b);
    for (Index e = a; e < b; ++e)
      for (int k = 0; k < 8; ++k) last[size_t(conn[8 * size_t(e) + k])] = pos;
  }
  std::vector<Index> reach(size_t(n), 0);  // [position] last position holding a node neighbour
  for (Index pos = 0; pos < n; ++pos) {
    Index a, b;
    elems(pos, a, b);
    for (Index e = a; e < b; ++e)
      for (int k = 0; k < 8; ++k)
        reach[size_t(pos)] = std::max(reach[size_t(pos)], last[size_t(conn[8 * size_t(e) + k])]);
  }
  std::vector<Index> start{0, std::min(n, minChunks)};
  while (start.back() < n) {
    const Index a = start[start.size() - 2], b = start.back();
    Index far = 0;
    for (Index c = a; c < b; ++c) far = std::max(far, reach[size_t(c)]);
    start.push_back(std::min(n, std::max(b + minChunks, far + 1)));
  }
  return start;
}

// Slabs over the chunks due at a subcycled step (`chunks`, reordered in place; returns the slab
// boundaries as positions in it). The due chunks cluster near the tunnel, in one or two of the
// block's slabs (fronts of the element order: whole rings of the tunnel's length), so they get a
// partition of their own: in their index order or in the order of their centres along x, y or z,
// whichever gives the narrowest widest slab (along the tunnel's axis a ring's chunks follow one
// another with their neighbours close). Depends on the mesh only.
std::vector<Index> subsetSlabs(const std::vector<Index>& conn, Index numElems, Index numNodes, Index chunk,
                               const std::vector<Real>& centre, std::vector<Index>& chunks, Index minChunks) {
  auto widest = [](const std::vector<Index>& st) {
    Index w = 0;
    for (size_t t = 0; t + 1 < st.size(); ++t) w = std::max(w, st[t + 1] - st[t]);
    return w;
  };
  std::vector<Index> bestOrder = chunks, best = slabsInOrder(conn, numElems, numNodes, chunk, chunks, minChunks);
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<Index> order = chunks;
    std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) {
      return centre[3 * size_t(a) + size_t(axis)] < centre[3 * size_t(b) + size_t(axis)];
    });
    std::vector<Index> st = slabsInOrder(conn, numElems, numNodes, chunk, order, minChunks);
    if (widest(st) < widest(best)) {
      best.swap(st);
      bestOrder.swap(order);
    }
  }
  chunks.swap(bestOrder);
  return best;
}

// Breadth-first order of the elements through shared nodes, from the sources (list positions).
std::vector<Index> breadthFirst(const Mesh& mesh, const std::vector<Index>& elems, const std::vector<Index>& sources) {
  const size_t E = elems.size();
  std::vector<Index> head(size_t(mesh.numNodes()) + 1, 0), list(8 * E);
  for (size_t i = 0; i < E; ++i)
    for (int k = 0; k < 8; ++k) ++head[size_t(mesh.connectivity[8 * size_t(elems[i]) + k]) + 1];
  for (size_t n = 0; n + 1 < head.size(); ++n) head[n + 1] += head[n];
  std::vector<Index> fill(head.begin(), head.end() - 1);
  for (size_t i = 0; i < E; ++i)
    for (int k = 0; k < 8; ++k) list[size_t(fill[size_t(mesh.connectivity[8 * size_t(elems[i]) + k])]++)] = Index(i);
  std::vector<std::uint8_t> seen(E, 0);
  std::vector<Index> order;
  order.reserve(E);
  for (Index r : sources)
    if (!seen[size_t(r)]) {
      seen[size_t(r)] = 1;
      order.push_back(r);
    }
  for (size_t root = 0, q = 0; order.size() < E || q < order.size(); ++root) {  // then any part not reached
    if (q == order.size()) {
      const Index r = Index(root - 1);
      if (seen[size_t(r)]) continue;
      seen[size_t(r)] = 1;
      order.push_back(r);
    }
    for (; q < order.size(); ++q) {
      const Index i = order[q];
      for (int k = 0; k < 8; ++k) {
        const Index n = mesh.connectivity[8 * size_t(elems[size_t(i)]) + k];
        for (Index j = head[size_t(n)]; j < head[size_t(n) + 1]; ++j)
          if (!seen[size_t(list[size_t(j)])]) {
            seen[size_t(list[size_t(j)])] = 1;
            order.push_back(list[size_t(j)]);
          }
      }
    }
  }
  return order;
}

// The elements in order of their estimated level (the smallest of their nodes' mesh.orderLevel),
// each level's in the order given: the fronts of the breadth-first order follow the levels only
// roughly (on the 3D paper model 2,368 rock elements of coarser levels sat in chunks that step at the
// finest level with a face element), so the level decides first. Unchanged without mesh.orderLevel.
std::vector<Index> byOrderLevel(const Mesh& mesh, std::vector<Index> elems) {
  if (mesh.orderLevel.empty()) return elems;
  auto level = [&](Index e) {
    std::uint8_t lo = 255;
    for (int k = 0; k < 8; ++k) lo = std::min(lo, mesh.orderLevel[size_t(mesh.connectivity[8 * size_t(e) + k])]);
    return lo;
  };
  std::stable_sort(elems.begin(), elems.end(), [&](Index a, Index b) { return level(a) < level(b); });
  return elems;
}

// The block's element order. A mesh numbered so that elements sharing a node lie far apart
// (gmsh numbers the paper mesh's rock so: span 47,081 of 58,080) leaves the scatter two slabs, so
// one thread: a block is renumbered breadth first when that at least halves the span, from its
// smallest elements (shortest edge within 1.5 × the block's shortest) and its elements on the
// tunnel's faces (whose nodes, the interface's and the water's, step at the finest level whatever
// the elements' size); a set that holds most of the block says nothing (a slice's thickness as
// every element's shortest edge, the lining on its faces), and with neither it starts from the
// element reached last from the first smallest one. In a graded mesh the fronts are then layers
// of one subcycling level, and a chunk steps at the finest level of its elements: in mesh order
// every chunk of the slice's rock near the tunnel held an element of the finest level (its
// subcycled conditions 0.555 of single-rate's element evaluations, 0.37 renumbered; span 1,070 →
// 161). Depends on the mesh only.
std::vector<Index> scatterOrder(const Mesh& mesh, std::vector<Index> elems) {
  if (elems.size() < 2) return elems;
  const Index span = scatterSpan(mesh, elems);
  if (span < Index(elems.size()) / 16) return byOrderLevel(mesh, std::move(elems));
  std::vector<Real> edge(elems.size());
  for (size_t i = 0; i < elems.size(); ++i) {
    Real longest = 0;
    hex8::edgeLengthRange(mesh.coords.data(), &mesh.connectivity[8 * size_t(elems[i])], edge[i], longest);
  }
  const Real hMin = *std::min_element(edge.begin(), edge.end());
  std::vector<Index> sources;
  for (size_t i = 0; i < elems.size(); ++i)
    if (edge[i] <= 1.5 * hMin) sources.push_back(Index(i));
  const bool uniform = sources.size() > elems.size() / 8;  // about uniform size (a slice's thickness)
  // The elements on the tunnel's faces: their nodes (the interface's and the water's) step at the
  // finest level whatever the elements' size.
  std::vector<char> onFace(size_t(mesh.numNodes()), 0);
  for (const char* g : {face_group::kLiningInner, face_group::kLiningOuter, face_group::kRockHole})
    if (const auto it = mesh.faces.find(g); it != mesh.faces.end())
      for (Index n : it->second) onFace[size_t(n)] = 1;
  std::vector<Index> wall;
  for (size_t i = 0; i < elems.size(); ++i)
    for (int k = 0; k < 8; ++k)
      if (onFace[size_t(mesh.connectivity[8 * size_t(elems[i]) + k])]) {
        wall.push_back(Index(i));
        break;
      }
  if (wall.size() > elems.size() / 8) wall.clear();  // most of the block (the lining)
  const Index smallest = sources.front();
  if (uniform) sources.clear();
  sources.insert(sources.end(), wall.begin(), wall.end());
  std::sort(sources.begin(), sources.end());
  sources.erase(std::unique(sources.begin(), sources.end()), sources.end());
  if (sources.empty())  // about uniform (the lining): from a far end instead
    sources = {breadthFirst(mesh, elems, {smallest}).back()};
  const std::vector<Index> order = breadthFirst(mesh, elems, sources);
  std::vector<Index> renumbered(elems.size());
  for (size_t i = 0; i < elems.size(); ++i) renumbered[i] = elems[size_t(order[i])];
  return byOrderLevel(mesh, scatterSpan(mesh, renumbered) * 2 <= span ? std::move(renumbered) : std::move(elems));
}

}  // namespace

ElementBlock::ElementBlock(std::string name, std::shared_ptr<const Material> material, Hex8Formulation formulation,
                           const Mesh& mesh, std::vector<Index> meshElems, Real hourglassScale)
    : name_(std::move(name)),
      material_(std::move(material)),
      formulation_(formulation),
      nElems_(static_cast<Index>(meshElems.size())),
      meshElems_(scatterOrder(mesh, std::move(meshElems))),
      hgScale_(hourglassScale),
      simd_(defaultSimd()) {
  if (formulation_ == Hex8Formulation::FullIntegration && !material_->isLinearElastic())
    throw InputError("block '" + name_ +
                     "': full_integration is a linear elastic reference "
                     "formulation; material '" +
                     material_->typeName() + "' needs one_point_assumed_strain");
  mod_ = material_->elasticModuli();
  nuBar_ = formulation_ == Hex8Formulation::OnePointAssumedStrain ? mod_.lambda / mod_.pModulus() : 0.0;
  const size_t E = size_t(nElems_);
  const size_t nChunks = (E + kChunk - 1) / kChunk;
  conn_.resize(8 * E);
  active_.assign(nChunks * kChunk, 0);  // padding lanes of the last chunk stay inactive
  std::fill(active_.begin(), active_.begin() + E, 1);
  vol_.resize(E);
  charLen_.resize(E);
  const bool full = formulation_ == Hex8Formulation::FullIntegration;
  if (full) {
    bg_.resize(8 * 24 * E);
    wdet_.resize(8 * E);
  } else {
    geo_.assign(nChunks * kGeo * kChunk, 0.0);  // padding lanes: zero geometry
  }
  total_ = !full && material_->isLinearElastic();
  for (auto& s : stress_) s.assign(nChunks * kChunk, 0.0);  // padded to whole chunks
  for (auto& s : total_ ? offset_ : strain_) s.assign(nChunks * kChunk, 0.0);
  const size_t nHistory = material_->historyNames().size();
  if (nHistory > kMaxHistory)
    throw InputError("block '" + name_ + "': material '" + material_->typeName() + "' keeps " +
                     std::to_string(nHistory) + " history values an element, more than the " +
                     std::to_string(kMaxHistory) + " the element step passes (ElementBlock::kMaxHistory)");
  for (size_t h = 0; h < nHistory; ++h) history_.emplace_back(E, 0.0);
  for (auto& h : history_) historyPtr_.push_back(h.data());
  hgHistory_ = full ? -1 : material_->hourglassScaleHistory();
  for (size_t e = 0; e < E; ++e) {
    const Index me = meshElems_[e];
    Real x[3][8];
    for (int k = 0; k < 8; ++k) {
      conn_[8 * e + k] = mesh.connectivity[8 * size_t(me) + k];
      for (int i = 0; i < 3; ++i) x[i][k] = mesh.coords[dofIndex(conn_[8 * e + k], i)];
    }
    const hex8::Geometry g = hex8::computeGeometry(x);
    vol_[e] = g.volume;
    charLen_[e] = g.charLength;
    if (full) {
      Real bg[8][3][8], wd[8];
      hex8::gaussGradients(x, bg, wd);
      std::copy(&bg[0][0][0], &bg[0][0][0] + 192, &bg_[192 * e]);
      std::copy(wd, wd + 8, &wdet_[8 * e]);
    } else {
      Real* G = &geo_[(e / kChunk) * kGeo * kChunk + e % kChunk];
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 8; ++k) G[(kGB + 8 * j + k) * kChunk] = g.b[j][k];
      for (int a = 0; a < 4; ++a)
        for (int j = 0; j < 3; ++j) {
          Real hx = 0;
          for (int k = 0; k < 8; ++k) hx += hex8::kH[a][k] * x[j][k];
          G[(kGHx + 3 * a + j) * kChunk] = hx;
        }
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) G[(kGRot + 3 * i + k) * kChunk] = g.rot[i][k];
      for (int k = 0; k < 3; ++k) G[(kGIa + k) * kChunk] = g.invHalf[k];
      G[kGVol * kChunk] = g.volume;
    }
  }
  initElementHistory(mesh);
  chunkEnergy_.resize(nChunks);
  chunkCentre_.assign(3 * nChunks, 0.0);  // mean of its elements' nodes (subcycling's slabs)
  for (size_t c = 0; c < nChunks; ++c) {
    const size_t a = c * kChunk, b = std::min(E, a + kChunk);
    for (size_t e = a; e < b; ++e)
      for (int k = 0; k < 8; ++k)
        for (int d = 0; d < 3; ++d)
          chunkCentre_[3 * c + size_t(d)] += mesh.coords[dofIndex(conn_[8 * e + k], d)] / Real(8 * (b - a));
  }
  // Slabs for the scatter over all chunks in order (depends on the mesh only)
  std::vector<Index> all(nChunks);
  for (size_t c = 0; c < nChunks; ++c) all[c] = Index(c);
  slabStart_ = slabsInOrder(conn_, nElems_, mesh.numNodes(), kChunk, all, 4);
}

void ElementBlock::nodeSumOrder(const Mesh& mesh, std::vector<Index> meshElems, std::vector<Index>& lumped,
                                std::vector<Index>& scattered) {
  lumped = scatterOrder(mesh, std::move(meshElems));
  const Index E = Index(lumped.size());
  const Index nChunks = (E + kChunk - 1) / kChunk;
  std::vector<Index> conn(8 * size_t(E)), all(static_cast<size_t>(nChunks));
  for (Index e = 0; e < E; ++e)
    for (int k = 0; k < 8; ++k) conn[8 * size_t(e) + size_t(k)] = mesh.connectivity[8 * size_t(lumped[size_t(e)]) + k];
  for (Index c = 0; c < nChunks; ++c) all[size_t(c)] = c;
  const std::vector<Index> slab = slabsInOrder(conn, E, mesh.numNodes(), kChunk, all, 4);  // as the constructor's
  const Index nSlabs = Index(slab.size()) - 1;
  scattered.clear();
  scattered.reserve(size_t(E));
  for (Index parity = 0; parity < 2; ++parity)  // as computeForcesForElems
    for (Index s = parity; s < nSlabs; s += 2)
      for (Index c = slab[size_t(s)]; c < slab[size_t(s) + 1]; ++c)
        for (Index e = c * kChunk; e < std::min(E, (c + 1) * kChunk); ++e) scattered.push_back(lumped[size_t(e)]);
}

void ElementBlock::initElementHistory(const Mesh& mesh) {
  if (history_.empty()) return;
  for (auto& c : elemCentre_) c.assign(size_t(nElems_), 0.0);  // element centres for the material
  for (size_t e = 0; e < size_t(nElems_); ++e)
    for (int k = 0; k < 8; ++k)
      for (int d = 0; d < 3; ++d) elemCentre_[d][e] += mesh.coords[dofIndex(conn_[8 * e + k], d)] / 8;
  const Real* centre[3] = {elemCentre_[0].data(), elemCentre_[1].data(), elemCentre_[2].data()};
  material_->initHistory(nElems_, centre, historyPtr_.data());
}

Real ElementBlock::geo(Index e, int comp) const {
  return geo_[(size_t(e) / kChunk * kGeo + comp) * kChunk + size_t(e) % kChunk];
}

namespace {
// Complementary energy density ½ σ:C⁻¹:σ of an isotropic material (Voigt stress, J/m³).
template <class T>
inline __attribute__((always_inline)) T complementaryEnergy(const T s[6], Real lam, Real mu) {
  const Real kc = lam / (3 * lam + 2 * mu);
  const T tr = s[0] + s[1] + s[2];
  return (0.25 / mu) * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] - kc * tr * tr) +
         (0.5 / mu) * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
}
}  // namespace

void ElementBlock::setStress(Index e, int comp, Real value) {
  if (total_) {  // σ_off moves with the stress; the energy stays continuous (no work is done)
    Real sig[6];
    for (int k = 0; k < 6; ++k) sig[k] = stress_[k][e];
    const Real w0 = complementaryEnergy(sig, mod_.lambda, mod_.mu);
    sig[comp] = value;
    if (active_[e]) energyShift_ -= vol_[e] * (complementaryEnergy(sig, mod_.lambda, mod_.mu) - w0);
    offset_[comp][e] += value - stress_[comp][e];
    hasOffset_ = true;
  }
  stress_[comp][e] = value;
}

Real ElementBlock::strain(Index e, int comp) const {
  if (!total_) return strain_[comp][e];
  // ε = C⁻¹:(σ − σ_off) of the last evaluation (engineering shear).
  const Real lam = mod_.lambda, mu = mod_.mu;
  Real d[6];
  for (int k = 0; k < 6; ++k) d[k] = stress_[k][e] - offset_[k][e];
  if (comp >= 3) return d[comp] / mu;
  const Real tr = d[0] + d[1] + d[2];
  return (d[comp] - lam / (3 * lam + 2 * mu) * tr) / (2 * mu);
}

void ElementBlock::setActive(Index e, bool on, const NodalState& state) {
  if (total_ && active_[e]) {  // its energy leaves the block's sum; keep the total continuous
    Real sig[6];
    for (int k = 0; k < 6; ++k) sig[k] = stress_[k][e];
    energyShift_ += vol_[e] * complementaryEnergy(sig, mod_.lambda, mod_.mu);
  }
  active_[e] = on ? 1 : 0;
  for (int c = 0; c < 6; ++c) stress_[c][e] = 0;
  for (auto& h : history_) h[e] = 0;
  if (!history_.empty()) {  // the material's per-element data from the element's centre
    const Real* centre[3] = {&elemCentre_[0][size_t(e)], &elemCentre_[1][size_t(e)], &elemCentre_[2][size_t(e)]};
    Real* hp[kMaxHistory];
    for (size_t h = 0; h < history_.size(); ++h) hp[h] = history_[h].data() + e;
    material_->initHistory(1, centre, hp);
  }
  // Restart strain-free from the current displacement (the next strain increment is measured
  // from here, so an element installed into a deformed mesh carries no stress).
  strainFromDisplacement(e, state);
}

void ElementBlock::rebaseStrain(const NodalState& state) {
  for (Index e = 0; e < nElems_; ++e) strainFromDisplacement(e, state);
}

void ElementBlock::strainFromDisplacement(Index e, const NodalState& state) {
  if (geo_.empty()) return;
  Real L[3][3] = {};
  for (int k = 0; k < 8; ++k) {
    const Index n = conn_[8 * size_t(e) + k];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) L[i][j] += state.u(n, i) * geo(e, kGB + 8 * j + k);
  }
  const Real eps[6] = {L[0][0], L[1][1], L[2][2], L[0][1] + L[1][0], L[1][2] + L[2][1], L[2][0] + L[0][2]};
  if (total_) {  // σ(u now) = the current stress: σ_off = σ − C:ε(u)
    const Real lam = mod_.lambda, mu = mod_.mu, tr = eps[0] + eps[1] + eps[2];
    for (int k = 0; k < 6; ++k) offset_[k][e] = stress_[k][e] - (k < 3 ? lam * tr + 2 * mu * eps[k] : mu * eps[k]);
    hasOffset_ = true;
    return;
  }
  for (int k = 0; k < 6; ++k) strain_[k][e] = eps[k];
}

void ElementBlock::lumpMassInto(NodalState& state) const {
  const Real rho = material_->density();
  for (Index e = 0; e < nElems_; ++e) {
    if (!active_[e]) continue;
    const Real m = rho * vol_[e] / 8;
    for (int k = 0; k < 8; ++k) state.addMass(conn_[8 * size_t(e) + k], m);
  }
}

Real ElementBlock::dissipatedEnergy() const {
  const int h = material_->dissipationHistory();
  if (h < 0 || size_t(h) >= history_.size()) return 0;
  Real sum = 0;  // serial, fixed order: the same for any thread count
  for (Index e = 0; e < nElems_; ++e) sum += vol_[e] * history_[size_t(h)][e];
  return sum;
}

Real ElementBlock::maxFrequency(Index* where) const {
  Real wmax = 0;
  Index at = -1;
  for (Index e = 0; e < nElems_; ++e) {
    if (!active_[e]) continue;
    const Real w = frequency(e);
    if (w > wmax) {
      wmax = w;
      at = e;
    }
  }
  if (where) *where = at;
  return wmax;
}

Real ElementBlock::frequency(Index e) const {
  return 2 * std::sqrt(mod_.pModulus() / material_->density()) / charLen_[e];
}

void ElementBlock::setChunkLevels(const std::vector<std::uint8_t>& nodeLevel, const std::vector<std::uint8_t>* given) {
  chunkLevel_.clear();
  levelChunks_.clear();
  levelSlabStart_.clear();
  if (nodeLevel.empty()) return;
  const Index nChunks = numChunks();
  if (given) {
    if (Index(given->size()) != nChunks) throw std::logic_error("setChunkLevels: one level per chunk");
    chunkLevel_ = *given;
  } else {
    chunkLevel_.assign(size_t(nChunks), 255);
    for (Index e = 0; e < nElems_; ++e) {
      if (!active_[e]) continue;
      std::uint8_t& l = chunkLevel_[size_t(e / kChunk)];
      for (int k = 0; k < 8; ++k) l = std::min(l, nodeLevel[size_t(conn_[8 * size_t(e) + k])]);
    }
  }
  // For each level L up to the coarsest one: the chunks due at a step of level L and their slabs
  int top = -1;
  for (std::uint8_t l : chunkLevel_)
    if (l != 255) top = std::max(top, int(l));
  // (the coarsest level's steps evaluate every chunk: they use the block's slabs)
  levelChunks_.assign(size_t(std::max(top, 0)), {});
  levelSlabStart_.assign(size_t(std::max(top, 0)), {});
  for (int L = 0; L < top; ++L) {
    for (Index c = 0; c < nChunks; ++c)
      if (chunkLevel_[size_t(c)] <= L) levelChunks_[size_t(L)].push_back(c);
    levelSlabStart_[size_t(L)] =
        subsetSlabs(conn_, nElems_, Index(nodeLevel.size()), kChunk, chunkCentre_, levelChunks_[size_t(L)], 2);
  }
}

std::vector<std::vector<Index>> ElementBlock::levelSumOrders(const Mesh& mesh, const std::vector<Index>& lumped,
                                                             const std::vector<std::uint8_t>& chunkLevel,
                                                             int maxLevel) {
  // The block's connectivity, chunk centres and slabs as its constructor and setChunkLevels make
  // them (the one-process block has the whole mesh's nodes).
  const Index E = Index(lumped.size()), nChunks = (E + kChunk - 1) / kChunk;
  std::vector<Index> conn(8 * size_t(E)), all(static_cast<size_t>(nChunks));
  for (Index e = 0; e < E; ++e)
    for (int k = 0; k < 8; ++k) conn[8 * size_t(e) + size_t(k)] = mesh.connectivity[8 * size_t(lumped[size_t(e)]) + k];
  std::vector<Real> centre(3 * size_t(nChunks), 0.0);
  for (Index c = 0; c < nChunks; ++c) {
    const Index a = c * kChunk, b = std::min(E, a + kChunk);
    for (Index e = a; e < b; ++e)
      for (int k = 0; k < 8; ++k)
        for (int d = 0; d < 3; ++d)
          centre[3 * size_t(c) + size_t(d)] +=
              mesh.coords[dofIndex(conn[8 * size_t(e) + size_t(k)], d)] / Real(8 * (b - a));
  }
  for (Index c = 0; c < nChunks; ++c) all[size_t(c)] = c;
  const std::vector<Index> slab = slabsInOrder(conn, E, mesh.numNodes(), kChunk, all, 4);
  int top = -1;
  for (std::uint8_t l : chunkLevel)
    if (l != 255) top = std::max(top, int(l));
  std::vector<std::vector<Index>> orders(size_t(maxLevel) + 1);
  auto add = [&](std::vector<Index>& out, Index c) {
    for (Index e = c * kChunk; e < std::min(E, (c + 1) * kChunk); ++e) out.push_back(lumped[size_t(e)]);
  };
  for (int L = 0; L <= maxLevel; ++L) {
    std::vector<Index>& out = orders[size_t(L)];
    if (L < top) {  // as computeForcesForElems at a step below the coarsest level
      std::vector<Index> cs;
      for (Index c = 0; c < nChunks; ++c)
        if (chunkLevel[size_t(c)] <= L) cs.push_back(c);
      const std::vector<Index> st = subsetSlabs(conn, E, mesh.numNodes(), kChunk, centre, cs, 2);
      const Index nS = Index(st.size()) - 1;
      for (Index parity = 0; parity < 2; ++parity)
        for (Index s = parity; s < nS; s += 2)
          for (Index k = st[size_t(s)]; k < st[size_t(s) + 1]; ++k) add(out, cs[size_t(k)]);
    } else {  // the block's slabs, the chunks not due left out
      const Index nS = Index(slab.size()) - 1;
      for (Index parity = 0; parity < 2; ++parity)
        for (Index s = parity; s < nS; s += 2)
          for (Index c = slab[size_t(s)]; c < slab[size_t(s) + 1]; ++c)
            if (chunkLevel[size_t(c)] <= L) add(out, c);
    }
  }
  return orders;
}

Index ElementBlock::findBadStress(Real limit) const {
  for (Index e = 0; e < nElems_; ++e)
    for (int c = 0; c < 6; ++c)
      if (!(std::abs(stress_[c][e]) <= limit)) return e;
  return -1;
}

namespace {

// The one-point kernel is written on short vectors of elements (GCC vector extensions): 2 lanes
// (SSE2) for the generic x86-64 build, 4 lanes for the AVX2 path, 8 for the AVX-512 one, chosen at
// run time by what the CPU has (ElementBlock::defaultSimd; TQ_SOLID_SIMD narrows it). Every lane is
// one element and runs the same operations whatever the width, so AVX2 and AVX-512 give the same
// bits; the chunk's energy terms are summed over its elements in lane order after the loops.
// V2, V4, V8, loadv, storev: simd_util.hpp.

/// Block constants of the assumed-strain hourglass stiffness.
struct HourglassModuli {
  Real lam, mu, lp2m, nuBar, scale;
};

// Assumed-strain hourglass stiffness in the element's local frame (derivation in
// docs/solid_solver.md). qh[k][α]: local component k of hourglass mode α (H_0 = ηζ, H_1 = ζξ,
// H_2 = ξη, H_3 = ξηζ); Qh: generalised hourglass forces, U = ½ Σ Qh·qh.
template <class V>
inline __attribute__((always_inline)) void hourglassStiffness(const HourglassModuli& hm, V vol, const V ia[3],
                                                              const V qh[3][4], V Qh[3][4]) {
  const Real lam = hm.lam, mu = hm.mu, lp2m = hm.lp2m, nuBar = hm.nuBar;
  const V V3 = hm.scale * vol / 3, V9 = hm.scale * vol / 9;
  // Twist/warping modes (component k of mode k): shear strains 2ε_12 ∝ ξ0, 2ε_20 ∝ ξ1, 2ε_01 ∝ ξ2.
  const V t0 = qh[1][1] * ia[2] + qh[2][2] * ia[1];
  const V t1 = qh[2][2] * ia[0] + qh[0][0] * ia[2];
  const V t2 = qh[0][0] * ia[1] + qh[1][1] * ia[0];
  Qh[0][0] = mu * V3 * (t1 * ia[2] + t2 * ia[1]);
  Qh[1][1] = mu * V3 * (t0 * ia[2] + t2 * ia[0]);
  Qh[2][2] = mu * V3 * (t0 * ia[1] + t1 * ia[0]);
  // Bending modes: component k ≠ α of mode α is fibre k bending with curvature along
  // m = 3 - α - k; its normal strain ε_kk = s ξ_m with s = qh[k][α]/a_k. For each m the two
  // bending strains (k ≠ m) share the transverse strain ε_mm = -ν̄ Σ s.
#pragma GCC unroll 3
  for (int m = 0; m < 3; ++m) {
    const int k1 = (m + 1) % 3, k2 = (m + 2) % 3;
    const int a1 = 3 - m - k1, a2 = 3 - m - k2;  // modes: α = third index of (k, m)
    const V s1 = qh[k1][a1] * ia[k1], s2 = qh[k2][a2] * ia[k2];
    const V em = -nuBar * (s1 + s2);
    const V tr = s1 + s2 + em;
    const V sg1 = lam * tr + 2 * mu * s1, sg2 = lam * tr + 2 * mu * s2, sgm = lam * tr + 2 * mu * em;
    Qh[k1][a1] = V3 * ia[k1] * (sg1 - nuBar * sgm);
    Qh[k2][a2] = V3 * ia[k2] * (sg2 - nuBar * sgm);
  }
  // ξηζ mode: compatible bilinear strains (orthogonal to everything else).
  const V s0 = ia[0] * ia[0], s1 = ia[1] * ia[1], s2 = ia[2] * ia[2];
  Qh[0][3] = V9 * (lp2m * s0 + mu * (s1 + s2)) * qh[0][3];
  Qh[1][3] = V9 * (lp2m * s1 + mu * (s2 + s0)) * qh[1][3];
  Qh[2][3] = V9 * (lp2m * s2 + mu * (s0 + s1)) * qh[2][3];
}

/// Qh × the material's per-element factor on the hourglass stiffness.
template <class V>
inline __attribute__((always_inline)) void scaleHourglass(V factor, V Qh[3][4]) {
#pragma GCC unroll 3
  for (int k = 0; k < 3; ++k)
#pragma GCC unroll 4
    for (int a = 0; a < 4; ++a) Qh[k][a] *= factor;
}

/// Load component `comp` of the lanes l..l+3 of a chunk-SoA array (kChunk values per component).
template <class V>
inline __attribute__((always_inline)) V geov(const Real* G, int comp, Index l) {
  return loadv<V>(G + comp * ElementBlock::kChunk + l);
}

/// L_ij = Σ_I b_jI g_iI for gathered nodal values g[i][I][lane] (displacement or velocity).
template <class V>
inline __attribute__((always_inline)) void gradient(const Real (*g)[8][ElementBlock::kChunk], const Real* G, Index l,
                                                    V L[3][3]) {
#pragma GCC unroll 3
  for (int j = 0; j < 3; ++j)
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      V s = loadv<V>(&g[i][0][l]) * geov<V>(G, kGB + 8 * j, l);
#pragma GCC unroll 8
      for (int k = 1; k < 8; ++k) s += loadv<V>(&g[i][k][l]) * geov<V>(G, kGB + 8 * j + k, l);
      L[i][j] = s;
    }
}

/// Generalised hourglass displacements in the element frame, q̂_kα = Σ_i R_ik q_iα with
/// q_iα = γ_α·g_i = (h_α·g_i − Σ_j (h_α·x_j) L_ij) / 8 (Flanagan & Belytschko's form of
/// γ_α = (h_α − Σ_j (h_α·x_j) b_j) / 8: γ is not stored).
template <class V>
inline __attribute__((always_inline)) void hourglassModes(const Real (*g)[8][ElementBlock::kChunk], const Real* G,
                                                          Index l, const V L[3][3], V qh[3][4]) {
  V q[3][4];
#pragma GCC unroll 4
  for (int a = 0; a < 4; ++a)
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      V hu = hex8::kH[a][0] * loadv<V>(&g[i][0][l]);
#pragma GCC unroll 8
      for (int k = 1; k < 8; ++k) hu += hex8::kH[a][k] * loadv<V>(&g[i][k][l]);
      const V hl = geov<V>(G, kGHx + 3 * a, l) * L[i][0] + geov<V>(G, kGHx + 3 * a + 1, l) * L[i][1] +
                   geov<V>(G, kGHx + 3 * a + 2, l) * L[i][2];
      q[i][a] = 0.125 * (hu - hl);
    }
#pragma GCC unroll 3
  for (int k = 0; k < 3; ++k)
#pragma GCC unroll 4
    for (int a = 0; a < 4; ++a)
      qh[k][a] = geov<V>(G, kGRot + k, l) * q[0][a] + geov<V>(G, kGRot + 3 + k, l) * q[1][a] +
                 geov<V>(G, kGRot + 6 + k, l) * q[2][a];
}

/// Generalised hourglass forces in the global frame, Q_iα = Σ_k R_ik Q̂_kα.
template <class V>
inline __attribute__((always_inline)) void hourglassToGlobal(const Real* G, Index l, const V Qh[3][4], V Q[3][4]) {
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i)
#pragma GCC unroll 4
    for (int a = 0; a < 4; ++a)
      Q[i][a] = geov<V>(G, kGRot + 3 * i, l) * Qh[0][a] + geov<V>(G, kGRot + 3 * i + 1, l) * Qh[1][a] +
                geov<V>(G, kGRot + 3 * i + 2, l) * Qh[2][a];
}

/// Nodal forces f_iI = Σ_j b_jI P_ij + Σ_α Q_iα h_αI / 8 with P = V σ − Σ_α Q_α (h_α·x)ᵀ / 8 (stress
/// divergence and hourglass forces Q_iα γ_αI in one pass); F[3 I + i].
template <class V>
inline __attribute__((always_inline)) void cornerForces(const Real* G, Index l, V vol, const V s[6], const V Q[3][4],
                                                        V F[24]) {
  const V sij[3][3] = {{s[XX], s[XY], s[ZX]}, {s[XY], s[YY], s[YZ]}, {s[ZX], s[YZ], s[ZZ]}};
  V P[3][3];
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j)
      P[i][j] =
          vol * sij[i][j] - 0.125 * (Q[i][0] * geov<V>(G, kGHx + j, l) + Q[i][1] * geov<V>(G, kGHx + 3 + j, l) +
                                     Q[i][2] * geov<V>(G, kGHx + 6 + j, l) + Q[i][3] * geov<V>(G, kGHx + 9 + j, l));
#pragma GCC unroll 8
  for (int k = 0; k < 8; ++k) {
    const V bx = geov<V>(G, kGB + k, l), by = geov<V>(G, kGB + 8 + k, l), bz = geov<V>(G, kGB + 16 + k, l);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      const V hg = 0.125 * (hex8::kH[0][k] * Q[i][0] + hex8::kH[1][k] * Q[i][1] + hex8::kH[2][k] * Q[i][2] +
                            hex8::kH[3][k] * Q[i][3]);
      F[3 * k + i] = bx * P[i][0] + by * P[i][1] + bz * P[i][2] + hg;
    }
  }
}

}  // namespace

/// Raw view of one chunk for the kernel (pointers at the chunk's first element).
struct ElementBlock::ChunkView {
  const Real* G;            // geometry [kGeo][kChunk]
  const Index* conn;        // [8 n]
  const std::uint8_t* act;  // [kChunk] (padding lanes inactive)
  Real* strain[6];          // [kChunk] each (stored form)
  Real* stress[6];
  const Real* offset[6];  // total form: σ_off, or null when the block has none
  bool allActive;         // no inactive element in the chunk
  Real* const* history;   // [count] per history variable
  const Material* material;
  Index n;  // elements in the chunk
  HourglassModuli hm;
  const Real* hgFactor;  // [n] the material's factor on each element's hourglass stiffness, or null
  Real beta, dt, dtLast;
  // The next chunk's streams, prefetched into L2 while this one computes (null for the last):
  // geometry, strain and stress, connectivity.
  const Real* nextG;
  const Real* nextStrain[6];  // stored form: strain; total form: σ_off (null when none)
  const Real* nextStress[6];
  const Index* nextConn;
  Real* cornerOut;          // on ranks: the corner forces' store (null: none)
  const Index* cornerSlot;  // on ranks: [n] each element's slot in it, or -1
};

namespace {

/// The corners' values x[3 node + i] of a chunk's elements into g[i][corner][lane], four elements at
/// a time: a node's (x, y) in one 16-byte load and its z in one 8-byte load, the four elements'
/// values transposed in registers into one 32-byte row of x, y and z a corner (three stores where
/// the scalar loop makes twelve; the same values, so the same bits). The lanes from n to nv (a
/// multiple of 4) are set to 0. No load reaches past a node's own three values.
__attribute__((target("avx2,fma"))) void gatherCornersAvx2(const Real* __restrict x, const Index* __restrict cn,
                                                           Index n, Index nv, Real (*g)[8][ElementBlock::kChunk]) {
  const Index full = n / 4 * 4;
  for (Index l = 0; l < full; l += 4) {
    const Index* c0 = cn + 8 * size_t(l);
#pragma GCC unroll 8
    for (int k = 0; k < 8; ++k) {
      const Real* p0 = x + 3 * size_t(c0[k]);
      const Real* p1 = x + 3 * size_t(c0[8 + k]);
      const Real* p2 = x + 3 * size_t(c0[16 + k]);
      const Real* p3 = x + 3 * size_t(c0[24 + k]);
      const __m256d a = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p0)), _mm_loadu_pd(p2), 1);
      const __m256d b = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p1)), _mm_loadu_pd(p3), 1);
      const __m128d z01 = _mm_loadh_pd(_mm_load_sd(p0 + 2), p1 + 2);
      const __m128d z23 = _mm_loadh_pd(_mm_load_sd(p2 + 2), p3 + 2);
      _mm256_store_pd(&g[0][k][l], _mm256_unpacklo_pd(a, b));
      _mm256_store_pd(&g[1][k][l], _mm256_unpackhi_pd(a, b));
      _mm256_store_pd(&g[2][k][l], _mm256_insertf128_pd(_mm256_castpd128_pd256(z01), z23, 1));
    }
  }
  for (Index l = full; l < nv; ++l)
    for (int k = 0; k < 8; ++k) {
      const Real* p = l < n ? x + 3 * size_t(cn[8 * size_t(l) + k]) : nullptr;
      for (int i = 0; i < 3; ++i) g[i][k][l] = p ? p[i] : 0;
    }
}

// The kernel body for one chunk; instantiated for the generic and the AVX2 target.
// kTotal: linear elastic total form σ = C:ε(u) + σ_off (no strain record, no material call).
template <bool kDamp, bool kTotal, class V>
inline __attribute__((always_inline)) void onePointBody(const ElementBlock::ChunkView& cv, const Real* __restrict u,
                                                        const Real* __restrict v, Real* __restrict f, BlockEnergy& en) {
  constexpr Index W = ElementBlock::kChunk, kLanes = sizeof(V) / sizeof(Real);
  // The next chunk's geometry in cache lines of 8 values: its first half prefetched over the strain
  // loop, the rest over the force loop.
  constexpr Index kGeoLines = kGeo * W / 8, kGeoHalf = kGeo * W / 16;
  using M = decltype(V{} != V{});
  const Real* __restrict G = cv.G;
  const Index* __restrict cn = cv.conn;
  const Index n = cv.n, nv = (n + kLanes - 1) / kLanes * kLanes;
  // 1. Gather the corners' displacements (and velocities) into [component][corner][lane].
  alignas(64) Real ug[3][8][W];
  alignas(64) Real vg[kDamp ? 3 : 1][8][W];
  if constexpr (kLanes >= 4) {
    gatherCornersAvx2(u, cn, n, nv, ug);
    if constexpr (kDamp) gatherCornersAvx2(v, cn, n, nv, vg);
  } else {
    for (Index l = 0; l < n; ++l)
      for (int k = 0; k < 8; ++k) {
        const Real* un = u + 3 * size_t(cn[8 * l + k]);
        ug[0][k][l] = un[0];
        ug[1][k][l] = un[1];
        ug[2][k][l] = un[2];
        if constexpr (kDamp) {
          const Real* vn = v + 3 * size_t(cn[8 * l + k]);
          vg[0][k][l] = vn[0];
          vg[1][k][l] = vn[1];
          vg[2][k][l] = vn[2];
        }
      }
    for (Index l = n; l < nv; ++l)  // padding lanes: at rest (their results are not used)
      for (int k = 0; k < 8; ++k)
        for (int i = 0; i < 3; ++i) {
          ug[i][k][l] = 0;
          if constexpr (kDamp) vg[i][k][l] = 0;
        }
  }
  // 2. Total strain and its increment, hourglass forces (generalised, global frame: Qg).
  alignas(64) Real de[6][W];
  alignas(64) Real Qg[12][W];
  alignas(64) Real ws[W], eh[W], wd[W];
  const HourglassModuli& hm = cv.hm;
  alignas(64) Real hf[W];
  if (cv.hgFactor) {
    for (Index l = 0; l < n; ++l) hf[l] = cv.hgFactor[l];
    for (Index l = n; l < nv; ++l) hf[l] = 1;
  }
  for (Index l = 0; l < nv; l += kLanes) {
    V actv;
    for (Index i = 0; i < kLanes; ++i) actv[i] = Real(cv.act[l + i]);
    const M on = actv != 0.0;
    const V zero = V{};
    if (cv.nextG)  // the first half of the next chunk's geometry, spread over this loop
      for (Index j = l * kGeoHalf / W; j < (l + kLanes) * kGeoHalf / W; ++j) __builtin_prefetch(cv.nextG + 8 * j, 0, 2);
    V L[3][3];
    gradient(ug, G, l, L);
    const V eps[6] = {L[0][0], L[1][1], L[2][2], L[0][1] + L[1][0], L[1][2] + L[2][1], L[2][0] + L[0][2]};
    const V vol = geov<V>(G, kGVol, l);
    V wel = zero;  // total form: complementary energy of the new stress (J)
    if constexpr (kTotal) {
      const V tr = eps[XX] + eps[YY] + eps[ZZ];
      V sg[6] = {hm.lam * tr + 2 * hm.mu * eps[XX],
                 hm.lam * tr + 2 * hm.mu * eps[YY],
                 hm.lam * tr + 2 * hm.mu * eps[ZZ],
                 hm.mu * eps[XY],
                 hm.mu * eps[YZ],
                 hm.mu * eps[ZX]};
      if (cv.offset[0])
#pragma GCC unroll 6
        for (int k = 0; k < 6; ++k) sg[k] += loadv<V>(cv.offset[k] + l);
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k)  // an inactive element keeps its stress
        storev(cv.stress[k] + l, cv.allActive ? sg[k] : on ? sg[k] : loadv<V>(cv.stress[k] + l));
      wel = vol * complementaryEnergy(sg, hm.lam, hm.mu);
    } else {
      V w = zero;
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k) {
        const V old = loadv<V>(cv.strain[k] + l);
        const V d = on ? eps[k] - old : zero;
        storev(de[k] + l, d);
        storev(cv.strain[k] + l, on ? eps[k] : old);
        w += loadv<V>(cv.stress[k] + l) * d;
      }
      storev(ws + l, w);  // σ^n : Δε for now
    }
    V qh[3][4], Qh[3][4];
    hourglassModes(ug, G, l, L, qh);
    const V ia[3] = {geov<V>(G, kGIa, l), geov<V>(G, kGIa + 1, l), geov<V>(G, kGIa + 2, l)};
    hourglassStiffness(hm, vol, ia, qh, Qh);
    if (cv.hgFactor) scaleHourglass(loadv<V>(hf + l), Qh);
    V ehg = zero;
#pragma GCC unroll 3
    for (int k = 0; k < 3; ++k)
#pragma GCC unroll 4
      for (int a = 0; a < 4; ++a) ehg += qh[k][a] * Qh[k][a];
    storev(eh + l, on ? 0.5 * ehg + wel : zero);
    if constexpr (kDamp) {
      // Stiffness-proportional damping on the hourglass modes: β K_hg q̇ with the lagged
      // velocity v^{n-1/2}.
      V Lv[3][3], qdh[3][4], Qdh[3][4];
      gradient(vg, G, l, Lv);
      if constexpr (kTotal) {  // the total form has no Δε: the lagged strain rate sym ∇v^{n-1/2}
        const V er[6] = {Lv[0][0], Lv[1][1], Lv[2][2], Lv[0][1] + Lv[1][0], Lv[1][2] + Lv[2][1], Lv[2][0] + Lv[0][2]};
#pragma GCC unroll 6
        for (int k = 0; k < 6; ++k) storev(de[k] + l, on ? er[k] : zero);
      }
      hourglassModes(vg, G, l, Lv, qdh);
      hourglassStiffness(hm, vol, ia, qdh, Qdh);
      if (cv.hgFactor) scaleHourglass(loadv<V>(hf + l), Qdh);
      V pd = zero;
#pragma GCC unroll 3
      for (int k = 0; k < 3; ++k)
#pragma GCC unroll 4
        for (int a = 0; a < 4; ++a) {
          pd += qdh[k][a] * Qdh[k][a];
          Qh[k][a] += cv.beta * Qdh[k][a];
        }
      storev(wd + l, on ? cv.beta * pd * cv.dt : zero);
    }
    V Q[3][4];
    hourglassToGlobal(G, l, Qh, Q);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i)
#pragma GCC unroll 4
      for (int a = 0; a < 4; ++a) storev(Qg[4 * i + a] + l, Q[i][a]);
  }
  // 3. Material update of the whole chunk (stored form).
  if constexpr (!kTotal) {
    MaterialChunk mc;
    mc.count = n;
    mc.lanes = int(kLanes);
    mc.dt = cv.dtLast;
    for (int k = 0; k < 6; ++k) {
      mc.dstrain[k] = de[k];
      mc.stress[k] = cv.stress[k];
    }
    mc.history = cv.history;
    cv.material->updateStressForElems(mc);
  }
  // 4. Nodal forces of the stress σ + σ_d and the hourglass forces (cornerForces).
  const Real lam = hm.lam, mu = hm.mu;
  // Damping stress rate factor and work factor: stored form de = Δε (rate β/Δt_last, work
  // × Δt/Δt_last), total form de = ε̇ (rate β, work × Δt); none on the first step (Δt_last = 0).
  const Real rate = (kDamp && cv.dtLast > 0) ? (kTotal ? cv.beta : cv.beta / cv.dtLast) : 0;
  const Real dtRatio = cv.dtLast > 0 ? (kTotal ? cv.dt : cv.dt / cv.dtLast) : 0;
  alignas(64) Real F[24][W];
  for (Index l = 0; l < nv; l += kLanes) {
    V actv;
    for (Index i = 0; i < kLanes; ++i) actv[i] = Real(cv.act[l + i]);
    const M on = actv != 0.0;
    const V zero = V{};
    if (cv.nextG) {  // the rest of the next chunk's geometry; its strain or σ_off, stress (one line per 8
                     // lanes), connectivity
      constexpr Index rest = kGeoLines - kGeoHalf;
      for (Index j = kGeoHalf + l * rest / W; j < kGeoHalf + (l + kLanes) * rest / W; ++j)
        __builtin_prefetch(cv.nextG + 8 * j, 0, 2);
      if (l % 8 == 0)
        for (int k = 0; k < 6; ++k) {
          if (cv.nextStrain[k]) __builtin_prefetch(cv.nextStrain[k] + l, 0, 2);
          if constexpr (kTotal)
            __builtin_prefetch(cv.nextStress[k] + l, 1, 2);  // written only
          else
            __builtin_prefetch(cv.nextStress[k] + l, 0, 2);
        }
      __builtin_prefetch(cv.nextConn + 8 * l, 0, 2);
      __builtin_prefetch(cv.nextConn + 8 * l + 16, 0, 2);
    }
    V s[6];
    const V vol = geov<V>(G, kGVol, l);
    if constexpr (kTotal) {
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k) s[k] = loadv<V>(cv.stress[k] + l);
    } else {
      V w2 = zero;
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k) {
        s[k] = loadv<V>(cv.stress[k] + l);
        w2 += s[k] * loadv<V>(de[k] + l);
      }
      storev(ws + l, on ? 0.5 * (loadv<V>(ws + l) + w2) * vol : zero);
    }
    if constexpr (kDamp) {
      // σ_d = β C : ε̇ with ε̇ = Δε/Δt_last = sym ∇v^{n-1/2} (lagged velocity).
      V d[6];
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k) d[k] = loadv<V>(de[k] + l);
      const V tr = d[XX] + d[YY] + d[ZZ];
      V sd[6];
      sd[XX] = rate * (lam * tr + 2 * mu * d[XX]);
      sd[YY] = rate * (lam * tr + 2 * mu * d[YY]);
      sd[ZZ] = rate * (lam * tr + 2 * mu * d[ZZ]);
      sd[XY] = rate * mu * d[XY];
      sd[YZ] = rate * mu * d[YZ];
      sd[ZX] = rate * mu * d[ZX];
      V pd = zero;
#pragma GCC unroll 6
      for (int k = 0; k < 6; ++k) {
        pd += sd[k] * d[k];
        s[k] += sd[k];
      }
      storev(wd + l, loadv<V>(wd + l) + (on ? pd * vol * dtRatio : zero));
    }
    V Q[3][4];
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i)
#pragma GCC unroll 4
      for (int a = 0; a < 4; ++a) Q[i][a] = loadv<V>(Qg[4 * i + a] + l);
    V Fk[24];
    cornerForces(G, l, vol, s, Q, Fk);
#pragma GCC unroll 24
    for (int k = 0; k < 24; ++k) storev(F[k] + l, on ? Fk[k] : zero);
  }
  // 5. Scatter into the nodes in element order (the slab scheme keeps this race-free); on ranks,
  //    some elements' corner forces also stored (the exchange sums their nodes in the one-process
  //    order).
  if (Real* const out = cv.cornerOut)
    for (Index l = 0; l < n; ++l)
      if (const Index slot = cv.cornerSlot[l]; slot >= 0)
        for (int k = 0; k < 24; ++k) out[24 * size_t(slot) + size_t(k)] = F[k][l];
  for (Index l = 0; l < n; ++l) {
    if (!cv.act[l]) continue;
    for (int k = 0; k < 8; ++k) {
      Real* fn = f + 3 * size_t(cn[8 * l + k]);
      fn[0] += F[3 * k][l];
      fn[1] += F[3 * k + 1][l];
      fn[2] += F[3 * k + 2][l];
    }
  }
  Real wStress = 0, eHg = 0, wDamp = 0;  // lane order: independent of the vector width
  for (Index l = 0; l < n; ++l) {
    if constexpr (!kTotal) wStress += ws[l];
    eHg += eh[l];
    if constexpr (kDamp) wDamp += wd[l];
  }
  en.stressWork = wStress;
  en.storedEnergy = eHg;
  en.dampingWork = wDamp;
}

template <bool kDamp, bool kTotal>
void onePointGeneric(const ElementBlock::ChunkView& cv, const Real* u, const Real* v, Real* f, BlockEnergy& en) {
  onePointBody<kDamp, kTotal, V2>(cv, u, v, f, en);
}

template <bool kDamp, bool kTotal>
__attribute__((target("avx2,fma"))) void onePointAvx2(const ElementBlock::ChunkView& cv, const Real* u, const Real* v,
                                                      Real* f, BlockEnergy& en) {
  onePointBody<kDamp, kTotal, V4>(cv, u, v, f, en);
}

template <bool kDamp, bool kTotal>
__attribute__((target("avx512f,avx512dq,avx512vl,avx2,fma"))) void onePointAvx512(const ElementBlock::ChunkView& cv,
                                                                                  const Real* u, const Real* v, Real* f,
                                                                                  BlockEnergy& en) {
  onePointBody<kDamp, kTotal, V8>(cv, u, v, f, en);
}

}  // namespace

ElementBlock::Simd ElementBlock::simdAvailable() {
  static const Simd widest = [] {
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return Simd::Generic;
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
      return Simd::Avx512;
    return Simd::Avx2;
  }();
  return widest;
}

ElementBlock::Simd ElementBlock::defaultSimd() {
  const char* env = std::getenv("TQ_SOLID_SIMD");
  const std::string asked = env ? env : "";
  if (asked == "generic") return Simd::Generic;
  if (asked == "avx2") return std::min(Simd::Avx2, simdAvailable());
  return simdAvailable();
}

template <bool kDamp, bool kTotal>
void ElementBlock::onePointChunk(Index c, Index next, const Real* __restrict u, const Real* __restrict v,
                                 const ElementStepParams& p, Real* __restrict f, BlockEnergy& en) {
  const Index e0 = c * kChunk;
  ChunkView cv;
  cv.G = &geo_[size_t(c) * kGeo * kChunk];
  cv.conn = &conn_[8 * size_t(e0)];
  cv.act = &active_[size_t(e0)];
  for (int k = 0; k < 6; ++k) {
    cv.strain[k] = kTotal ? nullptr : strain_[k].data() + e0;
    cv.stress[k] = stress_[k].data() + e0;
    cv.offset[k] = kTotal && hasOffset_ ? offset_[k].data() + e0 : nullptr;
  }
  cv.allActive = std::all_of(cv.act, cv.act + kChunk, [](std::uint8_t a) { return a != 0; });
  Real* hp[kMaxHistory];
  for (size_t h = 0; h < historyPtr_.size(); ++h) hp[h] = historyPtr_[h] + e0;
  cv.history = hp;
  cv.material = material_.get();
  cv.n = std::min(kChunk, nElems_ - e0);
  cv.hm = HourglassModuli{mod_.lambda, mod_.mu, mod_.pModulus(), nuBar_, hgScale_};
  cv.hgFactor = hgHistory_ >= 0 ? historyPtr_[size_t(hgHistory_)] + e0 : nullptr;
  cv.beta = p.beta;
  cv.dt = p.dt;
  cv.dtLast = p.dtLast;
  // Prefetch the next chunk this thread evaluates (`next`, -1: none) only for blocks whose streams
  // exceed the caches (> 16,384 elements: about 10 MB of element data): measured 15-25 % faster on
  // a 64,000-element box, but about 10 % slower on 4,096 elements, where the data come from L3
  // anyway. A subcycled step's due chunks are not consecutive: the next one is the slab's next due.
  const bool has = nElems_ > 16384 && next >= 0;
  const Index e1 = has ? next * kChunk : 0;
  cv.nextG = has ? &geo_[size_t(next) * kGeo * kChunk] : nullptr;
  cv.nextConn = has ? &conn_[8 * size_t(e1)] : nullptr;
  cv.cornerOut = cornerOut_;
  cv.cornerSlot = cornerOut_ ? cornerSlot_ + e0 : nullptr;
  for (int k = 0; k < 6; ++k) {
    cv.nextStrain[k] = !has         ? nullptr
                       : !kTotal    ? strain_[k].data() + e1
                       : hasOffset_ ? offset_[k].data() + e1
                                    : nullptr;
    cv.nextStress[k] = has ? stress_[k].data() + e1 : nullptr;
  }
  switch (simd_) {
    case Simd::Avx512:
      onePointAvx512<kDamp, kTotal>(cv, u, v, f, en);
      break;
    case Simd::Avx2:
      onePointAvx2<kDamp, kTotal>(cv, u, v, f, en);
      break;
    case Simd::Generic:
      onePointGeneric<kDamp, kTotal>(cv, u, v, f, en);
      break;
  }
}

void ElementBlock::fullIntegrationChunk(Index c, const Real* __restrict u, Real* __restrict f, BlockEnergy& en) {
  const Index e0 = c * kChunk, n = std::min(kChunk, nElems_ - e0);
  const Real lam = mod_.lambda, mu = mod_.mu;
  Real energy = 0;
  for (Index l = 0; l < n; ++l) {
    const size_t e = size_t(e0 + l);
    Real* const out = cornerOut_ && cornerSlot_[e] >= 0 ? cornerOut_ + 24 * size_t(cornerSlot_[e]) : nullptr;
    if (out) std::fill(out, out + 24, 0.0);
    if (!active_[e]) continue;
    Real fe[24] = {};
    Real ue[3][8];
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) ue[i][k] = u[dofIndex(conn_[8 * e + k], i)];
    Real savg[6] = {}, eavg[6] = {};
    for (int gp = 0; gp < 8; ++gp) {
      const Real* bg = &bg_[192 * e + 24 * gp];
      const Real w = wdet_[8 * e + gp];
      Real L[3][3] = {};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 8; ++k) L[i][j] += ue[i][k] * bg[8 * j + k];
      const Real eps[6] = {L[0][0], L[1][1], L[2][2], L[0][1] + L[1][0], L[1][2] + L[2][1], L[2][0] + L[0][2]};
      const Real tr = eps[0] + eps[1] + eps[2];
      const Real s[6] = {lam * tr + 2 * mu * eps[0],
                         lam * tr + 2 * mu * eps[1],
                         lam * tr + 2 * mu * eps[2],
                         mu * eps[3],
                         mu * eps[4],
                         mu * eps[5]};
      for (int k = 0; k < 6; ++k) {
        savg[k] += s[k] * w;
        eavg[k] += eps[k] * w;
        energy += 0.5 * s[k] * eps[k] * w;
      }
      for (int k = 0; k < 8; ++k) {
        const Real bx = bg[k] * w, by = bg[8 + k] * w, bz = bg[16 + k] * w;
        fe[3 * k + 0] += bx * s[XX] + by * s[XY] + bz * s[ZX];
        fe[3 * k + 1] += bx * s[XY] + by * s[YY] + bz * s[YZ];
        fe[3 * k + 2] += bx * s[ZX] + by * s[YZ] + bz * s[ZZ];
      }
    }
    for (int k = 0; k < 6; ++k) {
      stress_[k][e] = savg[k] / vol_[e];
      strain_[k][e] = eavg[k] / vol_[e];
    }
    if (out) std::copy(fe, fe + 24, out);
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) f[dofIndex(conn_[8 * e + k], i)] += fe[3 * k + i];
  }
  en.stressWork = 0;
  en.storedEnergy = energy;
  en.dampingWork = 0;
}

void ElementBlock::beginForces(const ElementStepParams& p) {
  const bool full = formulation_ == Hex8Formulation::FullIntegration;
  if (full && p.beta > 0)
    throw InputError("block '" + name_ + "': full_integration does not support stiffness-proportional damping");
  if (!full && !total_ && !history_.empty() && material_->hasBlockPass()) {
    const Real* centre[3] = {elemCentre_[0].data(), elemCentre_[1].data(), elemCentre_[2].data()};
    material_->blockPass(nElems_, centre, historyPtr_.data());
  }
}

// Even slabs first, then odd ones: slabs of one parity share no node, so each scatters into f
// directly; a node's contributions arrive in an order fixed by the mesh (its elements in slab
// order within each parity), whatever the thread count and whatever the order of the parity's
// slabs. Subcycling, a step of a level L below the coarsest: the chunks due at it, in their own
// slabs (built for each level by setChunkLevels: the due chunks cluster near the tunnel, where this
// block's slabs are wide). The sums are as fixed as the block's slabs: at a level-L step, a node's
// contributions arrive in the order of that level's slabs.
bool ElementBlock::levelStep(const ElementStepParams& p) const {
  return !chunkLevel_.empty() && size_t(p.activeLevel) < levelChunks_.size();
}

Index ElementBlock::numSlabs(const ElementStepParams& p) const {
  const std::vector<Index>& st = levelStep(p) ? levelSlabStart_[size_t(p.activeLevel)] : slabStart_;
  return Index(st.size()) - 1;
}

Index ElementBlock::slabWidth(const ElementStepParams& p, Index s) const {
  const std::vector<Index>& st = levelStep(p) ? levelSlabStart_[size_t(p.activeLevel)] : slabStart_;
  return st[size_t(s) + 1] - st[size_t(s)];
}

void ElementBlock::runSlab(const NodalState& state, const ElementStepParams& p, Index s, Real* f) {
  const Real* u = state.uData();
  const Real* v = state.vData();
  const bool full = formulation_ == Hex8Formulation::FullIntegration, damp = p.beta > 0;
  // c: the chunk to evaluate; next: the one this slab evaluates after it (-1: none), prefetched.
  auto chunk = [&](Index c, Index next) {
    if (repass_ && repassSkip_[size_t(c)]) return;  // as the window's first pass left it
    BlockEnergy& en = chunkEnergy_[size_t(c)];
    if (full)
      fullIntegrationChunk(c, u, f, en);
    else if (total_)
      damp ? onePointChunk<true, true>(c, next, u, v, p, f, en) : onePointChunk<false, true>(c, next, u, v, p, f, en);
    else
      damp ? onePointChunk<true, false>(c, next, u, v, p, f, en) : onePointChunk<false, false>(c, next, u, v, p, f, en);
  };
  if (levelStep(p)) {
    const std::vector<Index>& cs = levelChunks_[size_t(p.activeLevel)];
    const std::vector<Index>& st = levelSlabStart_[size_t(p.activeLevel)];
    const Index end = st[size_t(s) + 1];
    for (Index k = st[size_t(s)]; k < end; ++k) chunk(cs[size_t(k)], k + 1 < end ? cs[size_t(k) + 1] : -1);
  } else {
    const Index end = slabStart_[size_t(s) + 1];
    auto nextDue = [&](Index c) {  // the first due chunk from c on (a chunk not due has no active element)
      while (c < end && !chunkLevel_.empty() && chunkLevel_[size_t(c)] > p.activeLevel) ++c;
      return c;
    };
    for (Index c = nextDue(slabStart_[size_t(s)]); c < end;) {
      const Index next = nextDue(c + 1);
      chunk(c, next < end ? next : -1);
      c = next;
    }
  }
}

BlockEnergy ElementBlock::endForces(const ElementStepParams& p) const {
  BlockEnergy total;  // fixed summation order: independent of the thread count
  total.storedEnergy = energyShift_;
  const Index nChunks = numChunks();
  for (Index c = 0; c < nChunks; ++c) {
    const BlockEnergy& en = chunkEnergy_[size_t(c)];
    total.storedEnergy += en.storedEnergy;
    if (!chunkLevel_.empty() && chunkLevel_[size_t(c)] > p.activeLevel) continue;  // booked when evaluated
    total.stressWork += en.stressWork;
    total.dampingWork += en.dampingWork;
  }
  return total;
}

BlockEnergy ElementBlock::computeForcesForElems(const NodalState& state, const ElementStepParams& p, Real* f) {
  beginForces(p);
  // Small blocks run serially: a parallel region costs more than a few chunks of work, and
  // oversubscribed machines make its barrier expensive. Slabs differ in width (narrow where the
  // element order's span is small): handed out one at a time.
  const Index nS = numSlabs(p);
  const bool wide = levelStep(p) || numChunks() >= 8;
  for (Index parity = 0; parity < 2; ++parity) {
#pragma omp parallel for schedule(dynamic, 1) if (wide && nS >= 2 + parity)
    for (Index s = parity; s < nS; s += 2) runSlab(state, p, s, f);
  }
  return endForces(p);
}

void ElementBlock::elementForces(Index e, const Real* u, Real f[24]) const {
  std::fill(f, f + 24, 0.0);
  if (formulation_ == Hex8Formulation::FullIntegration)
    throw InputError("block '" + name_ + "': element forces need the one-point element");
  if (!active_[size_t(e)]) return;
  // The kernel's helpers on a pair of lanes of the element's chunk (V2), element e in one of them.
  const Index le = e % kChunk, l = le & ~Index(1), lane = le - l;
  const Real* G = &geo_[size_t(e / kChunk) * kGeo * kChunk];
  alignas(64) Real ug[3][8][kChunk];
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 8; ++k) {
      ug[i][k][l] = ug[i][k][l + 1] = 0;
      ug[i][k][le] = u[dofIndex(conn_[8 * size_t(e) + k], i)];
    }
  V2 L[3][3];
  gradient(ug, G, l, L);
  const Real eps[6] = {L[0][0][lane],
                       L[1][1][lane],
                       L[2][2][lane],
                       L[0][1][lane] + L[1][0][lane],
                       L[1][2][lane] + L[2][1][lane],
                       L[2][0][lane] + L[0][2][lane]};
  // σ(u): total form C:ε(u) + σ_off; stored form the last stress plus the elastic increment C:(ε(u) − ε).
  Real d[6];
  for (int k = 0; k < 6; ++k) d[k] = total_ ? eps[k] : eps[k] - strain_[k][size_t(e)];
  const Real lam = mod_.lambda, mu = mod_.mu, tr = d[XX] + d[YY] + d[ZZ];
  V2 s[6];
  for (int k = 0; k < 6; ++k) {
    const Real base = total_ ? (hasOffset_ ? offset_[k][size_t(e)] : 0.0) : stress_[k][size_t(e)];
    s[k] = V2{} + (base + (k < 3 ? lam * tr + 2 * mu * d[k] : mu * d[k]));
  }
  V2 qh[3][4], Qh[3][4], Q[3][4], F[24];
  hourglassModes(ug, G, l, L, qh);
  const V2 ia[3] = {geov<V2>(G, kGIa, l), geov<V2>(G, kGIa + 1, l), geov<V2>(G, kGIa + 2, l)};
  const V2 vol = geov<V2>(G, kGVol, l);
  hourglassStiffness(HourglassModuli{lam, mu, mod_.pModulus(), nuBar_, hgScale_}, vol, ia, qh, Qh);
  if (hgHistory_ >= 0) scaleHourglass(V2{} + history_[size_t(hgHistory_)][size_t(e)], Qh);
  hourglassToGlobal(G, l, Qh, Q);
  cornerForces(G, l, vol, s, Q, F);
  for (int k = 0; k < 24; ++k) f[k] = F[k][lane];
}

void ElementBlock::gatheredState(Index e, Real* out) const {
  const size_t i = size_t(e);
  out[0] = active_[i];
  for (int c = 0; c < 6; ++c) out[1 + c] = stress_[c][i];
  for (int c = 0; c < 6; ++c)
    out[7 + c] = total_ ? (hasOffset_ ? offset_[c][i] : 0.0) : (strain_[c].empty() ? 0.0 : strain_[c][i]);
  for (size_t h = 0; h < history_.size(); ++h) out[13 + h] = history_[h][i];
}

void ElementBlock::setGatheredState(Index e, const Real* in) {
  const size_t i = size_t(e);
  active_[i] = in[0] != 0 ? 1 : 0;
  for (int c = 0; c < 6; ++c) stress_[c][i] = in[1 + c];
  for (int c = 0; c < 6; ++c) {
    if (total_) {
      if (in[7 + c] != 0) hasOffset_ = true;
      if (!offset_[c].empty()) offset_[c][i] = in[7 + c];
    } else if (!strain_[c].empty()) {
      strain_[c][i] = in[7 + c];
    }
  }
  for (size_t h = 0; h < history_.size(); ++h) history_[h][i] = in[13 + h];
}

void ElementBlock::checkpoint(StateArchive& a) {
  // a re-pass restores the chunks it steps again only, and the window's start saves only those
  // when its re-passes will be so; every chunk's energy terms come back (a skipped chunk's are
  // given back step by step by the solver)
  const bool ranges = a.windowStart() && (a.saving() ? repassSave_ : repass_);
  const auto* only = ranges ? &repassKeep_ : nullptr;
  for (auto& s : stress_) a.io(s, only);
  for (auto& s : strain_) a.io(s, only);
  for (auto& h : history_) a.io(h, only);  // same size back: historyPtr_ stays valid
  a.io(energyShift_);
  a.io(chunkEnergy_);
}

void ElementBlock::setRepassSkip(std::vector<std::uint8_t> skip) {
  repassKeep_.clear();
  repass_ = repassSave_ = false;
  if (std::find(skip.begin(), skip.end(), std::uint8_t(1)) == skip.end()) skip.clear();
  repassSkip_ = std::move(skip);
  if (repassSkip_.empty()) return;
  if (repassSkip_.size() != size_t(numChunks())) throw std::logic_error("setRepassSkip: one flag a chunk");
  for (Index c = 0; c < numChunks(); ++c) {
    if (repassSkip_[size_t(c)]) continue;
    const size_t e0 = size_t(c * kChunk), e1 = size_t(std::min(nElems_, (c + 1) * kChunk));
    if (!repassKeep_.empty() && repassKeep_.back().second == e0)
      repassKeep_.back().second = e1;
    else
      repassKeep_.push_back({e0, e1});
  }
}

void setOrderLevels(Mesh& mesh, const std::vector<Real>& regionWaveSpeed, int maxLevel) {
  const Index N = mesh.numNodes(), E = mesh.numElems();
  auto speed = [&](Index e) {
    const size_t r = size_t(mesh.region[size_t(e)]);
    return r < regionWaveSpeed.size() ? regionWaveSpeed[r] : 0.0;
  };
  std::vector<Real> omega(size_t(E), 0.0);
  Real omegaMax = 0;
  for (Index e = 0; e < E; ++e) {
    if (!(speed(e) > 0)) continue;
    Real x[3][8];
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) x[i][k] = mesh.coords[dofIndex(mesh.connectivity[8 * size_t(e) + k], i)];
    omega[size_t(e)] = 2 * speed(e) / hex8::computeGeometry(x).charLength;
    omegaMax = std::max(omegaMax, omega[size_t(e)]);
  }
  std::vector<std::uint8_t>& level = mesh.orderLevel;
  level.assign(size_t(N), std::uint8_t(std::max(maxLevel, 0)));
  for (Index e = 0; e < E; ++e) {
    if (!(omega[size_t(e)] > 0)) continue;
    int l = 0;
    while (l < maxLevel && omegaMax >= omega[size_t(e)] * Real(2u << l)) ++l;
    for (int k = 0; k < 8; ++k) {
      std::uint8_t& nl = level[size_t(mesh.connectivity[8 * size_t(e) + k])];
      nl = std::min(nl, std::uint8_t(l));
    }
  }
  for (const char* g : {face_group::kLiningInner, face_group::kLiningOuter, face_group::kRockHole})
    if (const auto it = mesh.faces.find(g); it != mesh.faces.end())
      for (Index n : it->second) level[size_t(n)] = 0;
  for (bool lowered = true; lowered;) {  // graded: no node above its element's finest plus one
    lowered = false;
    for (Index e = 0; e < E; ++e) {
      if (!(omega[size_t(e)] > 0)) continue;
      const Index* c = &mesh.connectivity[8 * size_t(e)];
      std::uint8_t lo = 255;
      for (int k = 0; k < 8; ++k) lo = std::min(lo, level[size_t(c[k])]);
      for (int k = 0; k < 8; ++k)
        if (level[size_t(c[k])] > lo + 1) {
          level[size_t(c[k])] = std::uint8_t(lo + 1);
          lowered = true;
        }
    }
  }
}

}  // namespace tq
