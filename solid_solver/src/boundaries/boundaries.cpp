// Constant nodal forces, surface pressure, viscoelastic base and free-field sides
// (tq/boundaries/boundaries.hpp; docs/solid_solver.md "Seismic boundaries").
#include "tq/boundaries/boundaries.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <unordered_map>

namespace tq {

namespace {

using face_quadrature::gaussQuad;

std::string mshort(const Mesh& m) { return "mesh " + m.source; }

}  // namespace

std::vector<Real> pressureNodalForces(const Mesh& mesh, const std::string& group,
                                      const std::function<Real(const Real x[3])>& pressure) {
  auto it = mesh.faces.find(group);
  if (it == mesh.faces.end()) {
    mesh.faceNodes(group);  // throws the standard "missing group" message
    throw InputError(mshort(mesh) + ": face group '" + group + "' is missing");
  }
  const auto& q = it->second;
  std::vector<Real> f(3 * size_t(mesh.numNodes()), 0.0);
  for (size_t k = 0; k < q.size() / 4; ++k)
    gaussQuad(mesh, &q[4 * k], [&](const Real N[4], const Real pos[3], const Real ndA[3]) {
      const Real p = pressure(pos);
      for (int c = 0; c < 4; ++c)
        for (int i = 0; i < 3; ++i) f[dofIndex(q[4 * k + c], i)] -= N[c] * p * ndA[i];
    });
  return f;
}

void ConstantNodalForces::addForces(Real, Real, NodalState& state) {
  Real* fe = state.fExtData();
  const size_t n = std::min(f_.size(), 3 * size_t(state.numNodes()));
  for (size_t i = 0; i < n; ++i) fe[i] += f_[i];
}

// ---- seismic boundaries ----------------------------------------------------------------------

namespace {

/// The mesh element that owns a boundary quad (all four nodes), or -1.
class QuadOwners {
 public:
  explicit QuadOwners(const Mesh& mesh) : mesh_(mesh) {
    const Index N = mesh.numNodes(), E = mesh.numElems();
    start_.assign(size_t(N) + 1, 0);
    for (Index e = 0; e < E; ++e)
      for (int k = 0; k < 8; ++k) ++start_[size_t(mesh.connectivity[8 * size_t(e) + k]) + 1];
    for (Index n = 0; n < N; ++n) start_[size_t(n) + 1] += start_[size_t(n)];
    list_.resize(size_t(start_.back()));
    std::vector<Index> fill(start_.begin(), start_.end() - 1);
    for (Index e = 0; e < E; ++e)
      for (int k = 0; k < 8; ++k) list_[size_t(fill[size_t(mesh.connectivity[8 * size_t(e) + k])]++)] = e;
  }
  Index find(const Index* q) const {
    for (Index j = start_[size_t(q[0])]; j < start_[size_t(q[0]) + 1]; ++j) {
      const Index e = list_[size_t(j)];
      int hits = 0;
      for (int c = 1; c < 4; ++c)
        for (int k = 0; k < 8; ++k)
          if (mesh_.connectivity[8 * size_t(e) + k] == q[c]) {
            ++hits;
            break;
          }
      if (hits == 3) return e;
    }
    return -1;
  }

 private:
  const Mesh& mesh_;
  std::vector<Index> start_;
  std::vector<Index> list_;
};

/// Each mesh element's material, from the blocks that hold them.
std::vector<const Material*> materialsOf(const Mesh& mesh, const std::vector<std::unique_ptr<ElementBlock>>& blocks) {
  std::vector<const Material*> m(size_t(mesh.numElems()), nullptr);
  for (const auto& b : blocks)
    for (Index e = 0; e < b->numElems(); ++e) m[size_t(b->meshElem(e))] = &b->material();
  return m;
}

/// The base dashpot per area in direction d (ρ cs across, ρ cp normal to the base).
Real baseDashpot(const BaseHalfSpace& hs, int d) { return hs.rho * (d == 2 ? hs.cp : hs.cs); }

}  // namespace

FreeFieldColumn SeismicBoundaries::buildColumn(const Mesh& mesh, const std::vector<const Material*>& elementMaterial,
                                               const std::string& group) const {
  const AxisFace f = axisFace(mesh, group);
  if (f.axis == 2)
    throw InputError(mshort(mesh) + ": face group '" + group +
                     "' is horizontal; a free-field column needs a vertical side face (xmin, xmax, ymin, ymax)");
  // Levels: the distinct heights of the face's nodes.
  std::vector<Real> z;
  Real zmin = 1e300, zmax = -1e300;
  for (Index n : f.nodes) {
    z.push_back(mesh.coords[dofIndex(n, 2)]);
    zmin = std::min(zmin, z.back());
    zmax = std::max(zmax, z.back());
  }
  const Real tol = 1e-9 * std::max(1.0, zmax - zmin);
  std::sort(z.begin(), z.end());
  std::vector<Real> levels;
  for (Real v : z)
    if (levels.empty() || v - levels.back() > tol) levels.push_back(v);
  if (levels.size() < 2) throw InputError(mshort(mesh) + ": face group '" + group + "' has no height");
  auto levelOf = [&](Real v) {
    const auto it = std::lower_bound(levels.begin(), levels.end(), v - tol);
    return Index(it - levels.begin());
  };
  // A face whose rows lean (a sloping ground surface changing along the face): where every vertical
  // line of its nodes holds as many nodes, the column's levels are the lines' mean heights, row by row,
  // and each quad lies in the layer of its centroid (the quads then take the column at their own
  // heights, as a shared column's do).
  bool leaning = [&] {
    for (size_t k = 0; k < f.quads.size() / 4; ++k) {
      Real lo = 1e300, hi = -1e300;
      for (int c = 0; c < 4; ++c) {
        lo = std::min(lo, mesh.coords[dofIndex(f.quads[4 * k + c], 2)]);
        hi = std::max(hi, mesh.coords[dofIndex(f.quads[4 * k + c], 2)]);
      }
      if (levelOf(hi) != levelOf(lo) + 1) return true;
    }
    return false;
  }();
  if (leaning) {
    const int along = f.axis == 0 ? 1 : 0;  // the face's horizontal direction
    std::map<long long, std::vector<Real>> lines;
    const Real htol = 1e-9 * std::max(1.0, zmax - zmin);
    for (Index n : f.nodes)
      lines[std::llround(mesh.coords[dofIndex(n, along)] / htol)].push_back(mesh.coords[dofIndex(n, 2)]);
    const size_t count = lines.begin()->second.size();
    bool same = count >= 2;
    for (auto& [key, zs] : lines) {
      (void)key;
      std::sort(zs.begin(), zs.end());
      same = same && zs.size() == count;
    }
    if (same) {
      levels.assign(count, 0.0);
      for (const auto& [key, zs] : lines) {
        (void)key;
        for (size_t r = 0; r < count; ++r) levels[r] += zs[r] / Real(lines.size());
      }
    } else {
      leaning = false;  // refused below: quads across several levels
    }
  }
  auto quadLayer = [&](Real zc) {
    const auto it = std::upper_bound(levels.begin(), levels.end(), zc);
    return std::clamp<Index>(Index(it - levels.begin()) - 1, 0, Index(levels.size()) - 2);
  };
  // One material per layer, from the elements that own the face's quads.
  std::vector<ColumnLayer> layers(levels.size() - 1);
  std::vector<bool> seen(layers.size(), false);
  const QuadOwners owners(mesh);
  for (size_t k = 0; k < f.quads.size() / 4; ++k) {
    const Index* q = &f.quads[4 * k];
    Real lo = 1e300, hi = -1e300, zc = 0;
    for (int c = 0; c < 4; ++c) {
      lo = std::min(lo, mesh.coords[dofIndex(q[c], 2)]);
      hi = std::max(hi, mesh.coords[dofIndex(q[c], 2)]);
      zc += 0.25 * mesh.coords[dofIndex(q[c], 2)];
    }
    const Index l0 = leaning ? quadLayer(zc) : levelOf(lo), l1 = leaning ? l0 + 1 : levelOf(hi);
    if (l1 != l0 + 1) {
      std::ostringstream os;
      os << mshort(mesh) << ": face group '" << group << "' is not horizontally layered: quad " << k
         << " spans z = " << lo << " .. " << hi
         << " m, across several node levels of that face; free-field columns need side faces whose "
            "quads are stacked in horizontal rows (use rollers there instead)";
      throw InputError(os.str());
    }
    const Index o = owners.find(q);
    if (o < 0 || !elementMaterial[size_t(o)])
      throw InputError(mshort(mesh) + ": quad " + std::to_string(k) + " of face group '" + group +
                       "' belongs to no element");
    const Material& mat = *elementMaterial[size_t(o)];
    const ElasticModuli em = mat.elasticModuli();
    ColumnLayer L{mat.density(), em.lambda, em.mu};
    ColumnLayer& have = layers[size_t(l0)];
    if (!seen[size_t(l0)]) {
      have = L;
      seen[size_t(l0)] = true;
    } else if (std::abs(have.rho - L.rho) > 1e-9 * have.rho || std::abs(have.mu - L.mu) > 1e-9 * have.mu ||
               std::abs(have.lambda - L.lambda) > 1e-9 * std::abs(have.mu)) {
      std::ostringstream os;
      os << mshort(mesh) << ": face group '" << group << "' has two materials in the layer z = " << levels[size_t(l0)]
         << " .. " << levels[size_t(l0) + 1] << " m (block '" << mesh.regionNames[size_t(mesh.region[size_t(o)])]
         << "' differs); a free-field column needs one material per horizontal layer (use rollers on that face)";
      throw InputError(os.str());
    }
  }
  for (size_t l = 0; l < layers.size(); ++l)
    if (!seen[l])
      throw InputError(mshort(mesh) + ": face group '" + group + "' has a gap between z = " +
                       std::to_string(levels[l]) + " and " + std::to_string(levels[l + 1]) + " m");
  BaseHalfSpace hs = spec_.halfSpace;
  if (!(hs.rho > 0)) {
    const ColumnLayer& b = layers.front();
    hs = {b.rho, std::sqrt((b.lambda + 2 * b.mu) / b.rho), std::sqrt(b.mu / b.rho)};
  }
  return FreeFieldColumn(levels, layers, hs, spec_.damping);
}

SeismicBoundaries::SeismicBoundaries(const Mesh& mesh, const std::vector<std::unique_ptr<ElementBlock>>& blocks,
                                     const SeismicBoundarySpec& spec, IncidentMotion motion, bool slice)
    : SeismicBoundaries(mesh, materialsOf(mesh, blocks), spec, std::move(motion), slice) {}

SeismicBoundaries::SeismicBoundaries(const Mesh& mesh, const std::vector<const Material*>& blocks,
                                     const SeismicBoundarySpec& spec, IncidentMotion motion, bool slice)
    : spec_(spec), motion_(std::move(motion)) {
  (void)slice;
  // Columns: one per free-field face, plus the base column if it is another face.
  for (const auto& face : spec_.freeFieldFaces) columns_.push_back(buildColumn(mesh, blocks, face));
  std::string colFace = spec_.columnFace;
  if (colFace.empty()) colFace = spec_.freeFieldFaces.empty() ? "xmin" : spec_.freeFieldFaces.front();
  baseColumn_ = -1;
  for (size_t i = 0; i < spec_.freeFieldFaces.size(); ++i)
    if (spec_.freeFieldFaces[i] == colFace) baseColumn_ = Index(i);
  if (spec_.bottom && baseColumn_ < 0) {
    columns_.push_back(buildColumn(mesh, blocks, colFace));
    baseColumn_ = Index(columns_.size()) - 1;
  }
  if (baseColumn_ < 0) baseColumn_ = 0;
  // Base.
  if (spec_.bottom) {
    base_ = axisFace(mesh, spec_.bottomFace);
    if (base_.axis != 2 || base_.sign != -1)
      throw InputError(mshort(mesh) + ": face group '" + spec_.bottomFace +
                       "' is not a horizontal base facing down (outward normal −z); the viscoelastic "
                       "boundary belongs on the bottom of the model");
    const FreeFieldColumn& col = columns_[size_t(baseColumn_)];
    if (std::abs(col.level(0) - mesh.coords[dofIndex(base_.nodes[0], 2)]) >
        1e-9 * std::max(1.0, col.level(col.numLevels() - 1) - col.level(0)))
      throw InputError(mshort(mesh) + ": the base column's bottom (face '" + colFace +
                       "') is not at the height of face group '" + spec_.bottomFace + "'");
    const BaseHalfSpace& hs = col.base();
    const Real G = hs.rho * hs.cs * hs.cs;
    if (!(spec_.distance > 0))
      throw InputError("viscoelastic base: distance R must be > 0 m (got " + std::to_string(spec_.distance) + ")");
    kArea_ = {spec_.alphaT * G / spec_.distance, spec_.alphaT * G / spec_.distance, spec_.alphaN * G / spec_.distance};
    cArea_ = {hs.rho * hs.cs, hs.rho * hs.cs, hs.rho * hs.cp};
    assignBaseColumns(mesh);
  }
  // Free-field sides: per node dashpots and column interpolation, per quad the traction loads. The
  // shared-column faces take the first face's column (their quads need not lie in its rows).
  if (!spec_.sharedColumnFaces.empty() && spec_.freeFieldFaces.empty())
    throw InputError(mshort(mesh) + ": shared-column faces need a free-field face whose column they share");
  std::vector<std::pair<std::string, bool>> sides;
  for (const auto& face : spec_.freeFieldFaces) sides.emplace_back(face, false);
  for (const auto& face : spec_.sharedColumnFaces) sides.emplace_back(face, true);
  std::unique_ptr<QuadOwners> owners;
  if (!spec_.sharedColumnFaces.empty()) owners = std::make_unique<QuadOwners>(mesh);
  for (size_t si = 0; si < sides.size(); ++si) {
    const auto& [faceName, shared] = sides[si];
    const size_t fi = shared ? 0 : si;
    const AxisFace f = axisFace(mesh, faceName);
    const FreeFieldColumn& col = columns_[fi];
    if (shared && f.axis == 2)
      throw InputError(mshort(mesh) + ": face group '" + faceName +
                       "' is horizontal; a free-field column needs a vertical side face");
    const Real zLo = col.level(0), zHi = col.level(col.numLevels() - 1), zTol = 1e-9 * std::max(1.0, zHi - zLo);
    std::map<Index, size_t> at;
    for (size_t k = 0; k < f.quads.size() / 4; ++k) {
      const Index* q = &f.quads[4 * k];
      Real zc = 0;
      for (int c = 0; c < 4; ++c) zc += 0.25 * mesh.coords[dofIndex(q[c], 2)];
      SideQuadLoad L;
      L.column = Index(fi);
      L.layer = col.layerAt(zc);
      if (shared) {  // within the column's height, of its layer's material
        for (int c = 0; c < 4; ++c) {
          const Real z = mesh.coords[dofIndex(q[c], 2)];
          if (z < zLo - zTol || z > zHi + zTol)
            throw InputError(mshort(mesh) + ": face group '" + faceName + "' has a node at z = " + std::to_string(z) +
                             " m, outside the column of '" + spec_.freeFieldFaces.front() + "' (" +
                             std::to_string(zLo) + " .. " + std::to_string(zHi) + " m)");
        }
        const Index o = owners->find(q);
        if (o < 0 || !blocks[size_t(o)])
          throw InputError(mshort(mesh) + ": quad " + std::to_string(k) + " of face group '" + faceName +
                           "' belongs to no element");
        const Material& mat = *blocks[size_t(o)];
        const ElasticModuli em = mat.elasticModuli();
        const ColumnLayer& have = col.layer(L.layer);
        if (std::abs(have.rho - mat.density()) > 1e-9 * have.rho || std::abs(have.mu - em.mu) > 1e-9 * have.mu ||
            std::abs(have.lambda - em.lambda) > 1e-9 * std::abs(have.mu)) {
          std::ostringstream os;
          os << mshort(mesh) << ": face group '" << faceName << "' quad " << k << " (z = " << zc << " m) is in block '"
             << mesh.regionNames[size_t(mesh.region[size_t(o)])]
             << "', not of the material of the column's layer there (face '" << spec_.freeFieldFaces.front()
             << "'); a shared column needs the face's ground layered as the column's: plug the tunnel's ends "
                "with ground (use rollers on that face otherwise)";
          throw InputError(os.str());
        }
      }
      L.axis = f.axis;
      L.sign = f.sign;
      for (int c = 0; c < 4; ++c) {
        L.node[c] = q[c];
        L.share[c] = 0;
      }
      gaussQuad(mesh, q, [&](const Real N[4], const Real*, const Real ndA[3]) {
        const Real dA = std::sqrt(ndA[0] * ndA[0] + ndA[1] * ndA[1] + ndA[2] * ndA[2]);
        for (int c = 0; c < 4; ++c) L.share[c] += N[c] * dA;
      });
      sideQuads_.push_back(L);
      const ColumnLayer& m = col.layer(L.layer);
      const Real cp = std::sqrt((m.lambda + 2 * m.mu) / m.rho), cs = std::sqrt(m.mu / m.rho);
      for (int c = 0; c < 4; ++c) {
        auto [it, fresh] = at.try_emplace(q[c], side_.size());
        if (fresh) {
          SideNode s;
          s.node = q[c];
          s.column = Index(fi);
          col.interpolation(mesh.coords[dofIndex(q[c], 2)], &s.level, &s.w);
          s.c[0] = s.c[1] = s.c[2] = 0;
          side_.push_back(s);
        }
        SideNode& s = side_[it->second];
        for (int d = 0; d < 3; ++d) s.c[d] += L.share[c] * m.rho * (d == f.axis ? cp : cs);
      }
    }
  }
}

void SeismicBoundaries::assignBaseColumns(const Mesh& mesh) {
  baseColumnOf_.assign(base_.nodes.size(), baseColumn_);
  const Real zBase = mesh.coords[dofIndex(base_.nodes[0], 2)];
  std::vector<std::array<Real, 4>> boxes;  // x lo, x hi, y lo, y hi of each candidate face
  std::vector<Index> candidates;
  for (size_t i = 0; i < spec_.freeFieldFaces.size(); ++i) {
    const FreeFieldColumn& c = columns_[i];
    if (std::abs(c.level(0) - zBase) > 1e-9 * std::max(1.0, c.level(c.numLevels() - 1) - c.level(0))) continue;
    const AxisFace f = axisFace(mesh, spec_.freeFieldFaces[i]);
    std::array<Real, 4> b{1e300, -1e300, 1e300, -1e300};
    for (Index n : f.nodes) {
      const Real x = mesh.coords[dofIndex(n, 0)], y = mesh.coords[dofIndex(n, 1)];
      b[0] = std::min(b[0], x);
      b[1] = std::max(b[1], x);
      b[2] = std::min(b[2], y);
      b[3] = std::max(b[3], y);
    }
    boxes.push_back(b);
    candidates.push_back(Index(i));
  }
  if (candidates.size() < 2) return;
  for (size_t k = 0; k < base_.nodes.size(); ++k) {
    const Real x = mesh.coords[dofIndex(base_.nodes[k], 0)], y = mesh.coords[dofIndex(base_.nodes[k], 1)];
    Real best = 1e300;
    for (size_t j = 0; j < boxes.size(); ++j) {
      const auto& b = boxes[j];
      const Real dx = std::max({b[0] - x, Real(0), x - b[1]}), dy = std::max({b[2] - y, Real(0), y - b[3]});
      const Real d2 = dx * dx + dy * dy;
      if (d2 < best) {  // the first of equally near faces
        best = d2;
        baseColumnOf_[k] = candidates[j];
      }
    }
  }
}

void SeismicBoundaries::restrictToNodes(const std::vector<Index>& localNode, const std::vector<std::uint8_t>& owned) {
  AxisFace base = base_;
  base.nodes.clear();
  base.area.clear();
  baseCounted_.clear();
  std::vector<Index> columnOf;
  for (size_t i = 0; i < base_.nodes.size(); ++i) {
    const Index n = localNode[size_t(base_.nodes[i])];
    if (n < 0) continue;
    base.nodes.push_back(n);
    base.area.push_back(base_.area[i]);
    baseCounted_.push_back(owned[size_t(n)]);
    if (!baseColumnOf_.empty()) columnOf.push_back(baseColumnOf_[i]);
  }
  baseColumnOf_ = std::move(columnOf);
  base.quads.clear();  // in the whole model's numbering: not used once built
  base_ = std::move(base);
  std::vector<SideNode> side;
  for (SideNode s : side_) {
    s.node = localNode[size_t(s.node)];
    if (s.node >= 0) side.push_back(s);
  }
  side_ = std::move(side);
  std::vector<SideQuadLoad> quads;
  for (SideQuadLoad q : sideQuads_) {
    bool any = false;
    for (int c = 0; c < 4; ++c) {
      q.node[c] = localNode[size_t(q.node[c])];
      any = any || q.node[c] >= 0;
    }
    if (any) quads.push_back(q);
  }
  sideQuads_ = std::move(quads);
  if (sidesOnThreads()) computeSidesOnThreads(true);  // in the rank's numbering
}

void SeismicBoundaries::install(NodalState& state) {
  for (const auto& s : side_)
    for (int d = 0; d < 3; ++d) state.addDashpot(s.node, d, s.c[d]);
  u0_.assign(3 * base_.nodes.size(), 0.0);
  for (size_t i = 0; i < base_.nodes.size(); ++i)
    for (int d = 0; d < 3; ++d) {
      state.addDashpot(base_.nodes[i], d, base_.area[i] * baseDashpot(baseColumnOf(i).base(), d));
      u0_[3 * i + d] = state.u(base_.nodes[i], d);
    }
  uPrev_ = u0_;
  fPrev_.assign(u0_.size(), 0.0);
  first_ = true;
  // Base nodes that are all distinct are independent within a step: computed on the threads.
  baseDistinct_ = nodesDistinct(base_.nodes);
  computeBaseOnThreads(base_.nodes.size() >= kThreadedBaseNodes);
  computeSidesOnThreads(side_.size() >= kThreadedSideNodes);
  springWork_ = 0;
}

void SeismicBoundaries::computeBaseOnThreads(bool on) { baseTerm_.assign(on && baseDistinct_ ? u0_.size() : 0, 0.0); }

void SeismicBoundaries::computeSidesOnThreads(bool on) {
  sideNodes_.clear();
  sideStart_.clear();
  sideTerms_.clear();
  quadTraction_.clear();
  if (!on) return;
  // Each node's terms in the order the one loop adds them: side_ in order, then the quads' corners.
  std::unordered_map<Index, size_t> slot;
  std::vector<std::vector<SideTerm>> terms;
  const auto add = [&](Index node, SideTerm t) {
    auto [it, fresh] = slot.try_emplace(node, sideNodes_.size());
    if (fresh) {
      sideNodes_.push_back(node);
      terms.emplace_back();
    }
    terms[it->second].push_back(t);
  };
  for (size_t k = 0; k < side_.size(); ++k) add(side_[k].node, {Index(k), -1});
  for (size_t k = 0; k < sideQuads_.size(); ++k)
    for (int c = 0; c < 4; ++c)
      if (sideQuads_[k].node[c] >= 0) add(sideQuads_[k].node[c], {Index(k), c});
  sideStart_.push_back(0);
  for (const auto& t : terms) {
    sideTerms_.insert(sideTerms_.end(), t.begin(), t.end());
    sideStart_.push_back(sideTerms_.size());
  }
  quadTraction_.assign(3 * sideQuads_.size(), 0.0);
}

void SeismicBoundaries::addForces(Real t, Real dt, NodalState& state) {
  for (auto& c : columns_) c.advance(t, dt, motion_);
  Real* fe = state.fExtData();
  // Base: spring to u_0, input A[K u_col + 2ρc v_in] (the dashpot is a nodal dashpot), u_col the base of
  // the node's column (assignBaseColumns).
  if (spec_.bottom) {
    Real vin[3];
    for (int d = 0; d < 3; ++d) vin[d] = motion_.velocity(d, t);
    const size_t B = base_.nodes.size();
    const bool counting = !first_;
    auto baseNode = [&](size_t i, Real* terms) {
      const Index n = base_.nodes[i];
      const Real A = base_.area[i];
      const FreeFieldColumn& own = baseColumnOf(i);
      const BaseHalfSpace& hs = own.base();
      const Real G = hs.rho * hs.cs * hs.cs;
      const Real k[3] = {spec_.alphaT * G / spec_.distance, spec_.alphaT * G / spec_.distance,
                         spec_.alphaN * G / spec_.distance};
      for (int d = 0; d < 3; ++d) {
        const size_t j = 3 * i + d;
        const Real u = state.u(n, d);
        const Real fs = -A * k[d] * (u - u0_[j]);
        fe[dofIndex(n, d)] += fs + A * (k[d] * own.u(0, d) + 2 * baseDashpot(hs, d) * vin[d]);
        terms[d] = 0.5 * (fs + fPrev_[j]) * (u - uPrev_[j]);
        fPrev_[j] = fs;
        uPrev_[j] = u;
      }
    };
    Real work = 0;
    const auto counts = [&](size_t i) { return counting && (baseCounted_.empty() || baseCounted_[i]); };
    if (baseTerm_.empty()) {
      for (size_t i = 0; i < B; ++i) {
        Real terms[3];
        baseNode(i, terms);
        if (counts(i))
          for (int d = 0; d < 3; ++d) work += terms[d];
      }
    } else {  // distinct nodes on the threads; their work summed after, in node order (the same bits)
      Real* terms = baseTerm_.data();
#pragma omp parallel for schedule(static)
      for (size_t i = 0; i < B; ++i) baseNode(i, terms + 3 * i);
      for (size_t i = 0; i < B; ++i)
        if (counts(i))
          for (int d = 0; d < 3; ++d) work += terms[3 * i + size_t(d)];
    }
    springWork_ += work;
    first_ = false;
  }
  // Sides: A C v̄_ff through the dashpots, and σ_ff · n over each quad.
  const auto dashpotTerm = [&](const SideNode& s, Real* f) {
    const FreeFieldColumn& col = columns_[size_t(s.column)];
    const Index k1 = std::min<Index>(s.level + 1, col.numLevels() - 1);
    for (int d = 0; d < 3; ++d) {
      const Real vff = (1 - s.w) * col.vMean(s.level, d) + s.w * col.vMean(k1, d);
      f[d] += s.c[d] * vff;
    }
  };
  static constexpr int kVoigt[3][3] = {{XX, XY, ZX}, {XY, YY, YZ}, {ZX, YZ, ZZ}};
  const auto traction = [&](const SideQuadLoad& L, Real* t3) {
    const Real* sig = columns_[size_t(L.column)].stress(L.layer);
    for (int i = 0; i < 3; ++i) t3[i] = L.sign * sig[kVoigt[i][L.axis]];
  };
  if (sideNodes_.empty()) {
    for (const auto& s : side_) dashpotTerm(s, fe + dofIndex(s.node, 0));
    for (const auto& L : sideQuads_) {
      Real t3[3];
      traction(L, t3);
      for (int c = 0; c < 4; ++c)
        if (L.node[c] >= 0)  // on ranks: a corner this rank does not hold
          for (int i = 0; i < 3; ++i) fe[dofIndex(L.node[c], i)] += L.share[c] * t3[i];
    }
    return;
  }
  // Node by node on the threads, each node's terms added in the one loop's order: the same bits.
  Real* tr = quadTraction_.data();
  const size_t Q = sideQuads_.size(), S = sideNodes_.size();
#pragma omp parallel
  {
#pragma omp for schedule(static)
    for (size_t k = 0; k < Q; ++k) traction(sideQuads_[k], tr + 3 * k);
#pragma omp for schedule(static)
    for (size_t j = 0; j < S; ++j) {
      Real* f = fe + dofIndex(sideNodes_[j], 0);
      for (size_t k = sideStart_[j]; k < sideStart_[j + 1]; ++k) {
        const SideTerm& t = sideTerms_[k];
        if (t.corner < 0) {
          dashpotTerm(side_[size_t(t.index)], f);
          continue;
        }
        const Real share = sideQuads_[size_t(t.index)].share[t.corner];
        for (int i = 0; i < 3; ++i) f[i] += share * tr[3 * size_t(t.index) + size_t(i)];
      }
    }
  }
}

}  // namespace tq
