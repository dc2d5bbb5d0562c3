#include "tq/core/mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "tq/elements/hex8.hpp"

namespace tq {

std::vector<Index> Mesh::faceNodes(const std::string& group) const {
  auto it = faces.find(group);
  if (it == faces.end())
    throw InputError("mesh " + source + ": face group '" + group +
                     "' is missing; name that boundary with a physical group '" + group +
                     "' in the geometry (tunnelquake mesh writes it to /faces/" + group + ")");
  std::vector<Index> n(it->second);
  std::sort(n.begin(), n.end());
  n.erase(std::unique(n.begin(), n.end()), n.end());
  return n;
}

bool nodesDistinct(std::vector<Index> nodes) {
  std::sort(nodes.begin(), nodes.end());
  return std::adjacent_find(nodes.begin(), nodes.end()) == nodes.end();
}

Real tunnelAxisZ(const Mesh& mesh) {
  for (const char* g : {face_group::kLiningInner, face_group::kRockHole})
    if (mesh.faces.count(g)) {
      Real lo = 1e300, hi = -1e300;
      for (Index n : mesh.faceNodes(g)) {
        lo = std::min(lo, mesh.coords[dofIndex(n, 2)]);
        hi = std::max(hi, mesh.coords[dofIndex(n, 2)]);
      }
      if (const Real z = 0.5 * (lo + hi); std::isfinite(z)) return z;
    }
  return std::numeric_limits<Real>::quiet_NaN();
}

void quadAreaVector(const Mesh& mesh, const Index* quad, Real s[3]) {
  Real d1[3], d2[3];
  for (int d = 0; d < 3; ++d) {
    d1[d] = mesh.coords[dofIndex(quad[2], d)] - mesh.coords[dofIndex(quad[0], d)];
    d2[d] = mesh.coords[dofIndex(quad[3], d)] - mesh.coords[dofIndex(quad[1], d)];
  }
  s[0] = 0.5 * (d1[1] * d2[2] - d1[2] * d2[1]);
  s[1] = 0.5 * (d1[2] * d2[0] - d1[0] * d2[2]);
  s[2] = 0.5 * (d1[0] * d2[1] - d1[1] * d2[0]);
}

Index Mesh::regionIndex(const std::string& name) const {
  for (size_t r = 0; r < regionNames.size(); ++r)
    if (regionNames[r] == name) return static_cast<Index>(r);
  return -1;
}

void checkMesh(const Mesh& mesh, const MeshRequirements& req) {
  const std::string where = "mesh " + mesh.source;
  if (mesh.coords.size() % 3 != 0 || mesh.coords.empty())
    throw InputError(where + ": /nodes/coordinates must be a non-empty [N, 3] array");
  if (mesh.connectivity.size() % 8 != 0 || mesh.connectivity.empty())
    throw InputError(where + ": /elements/connectivity must be a non-empty [E, 8] array");
  const Index N = mesh.numNodes(), E = mesh.numElems();
  for (Real c : mesh.coords)
    if (!std::isfinite(c)) throw InputError(where + ": a node coordinate is not finite");
  if (static_cast<Index>(mesh.region.size()) != E)
    throw InputError(where + ": /elements/region has " + std::to_string(mesh.region.size()) + " entries for " +
                     std::to_string(E) + " elements");
  for (Index e = 0; e < E; ++e) {
    const Index r = mesh.region[e];
    if (r < 0 || r >= static_cast<Index>(mesh.regionNames.size()))
      throw InputError(where + ": element " + std::to_string(e) + " has region index " + std::to_string(r) +
                       " but only " + std::to_string(mesh.regionNames.size()) +
                       " region names are given (attribute /elements regions)");
    for (int k = 0; k < 8; ++k) {
      const Index n = mesh.connectivity[8 * e + k];
      if (n < 0 || n >= N)
        throw InputError(where + ": element " + std::to_string(e) + " refers to node " + std::to_string(n) +
                         ", outside 0.." + std::to_string(N - 1));
    }
    Real x[3][8];
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) x[i][k] = mesh.coords[3 * mesh.connectivity[8 * e + k] + i];
    int at = 0;
    const Real dmin = hex8::minJacobian(x, &at);
    Real J[3][3];
    const Real d0 = hex8::jacobian(x, 0, 0, 0, J);
    if (!(dmin > 1e-12 * std::abs(d0))) {
      std::ostringstream os;
      os.precision(9);
      os << where << ": element " << e << " (region '" << mesh.regionNames[mesh.region[e]] << "') is "
         << (d0 <= 0 ? "inverted" : "degenerate") << ": Jacobian determinant " << dmin << " at "
         << (at == 8 ? std::string("its centre") : "corner " + std::to_string(at)) << ". Its nodes (index: x y z):";
      for (int k = 0; k < 8; ++k)
        os << "\n  " << mesh.connectivity[8 * e + k] << ": " << x[0][k] << ' ' << x[1][k] << ' ' << x[2][k];
      os << "\nExpected VTK hex8 order: nodes 0-3 counter-clockwise seen from above the face they "
            "span, nodes 4-7 above them; a mirrored order (e.g. 0 3 2 1 4 7 6 5) inverts the "
            "element. Fix the node order or the geometry.";
      throw InputError(os.str());
    }
  }
  for (const auto& [name, quads] : mesh.faces) {
    if (quads.size() % 4 != 0) throw InputError(where + ": /faces/" + name + " must be an [F, 4] array");
    for (Index n : quads)
      if (n < 0 || n >= N)
        throw InputError(where + ": /faces/" + name + " refers to node " + std::to_string(n) + ", outside 0.." +
                         std::to_string(N - 1));
  }
  for (const auto& [name, nodes] : mesh.nodeSets)
    for (Index n : nodes)
      if (n < 0 || n >= N)
        throw InputError(where + ": /node_sets/" + name + " refers to node " + std::to_string(n) + ", outside 0.." +
                         std::to_string(N - 1));
  for (Index n : mesh.rockLiningPairs)
    if (n < 0 || n >= N)
      throw InputError(where + ": /interfaces/rock_lining refers to node " + std::to_string(n) + ", outside 0.." +
                       std::to_string(N - 1));
  for (const auto& g : req.faceGroups) mesh.faceNodes(g);  // throws with the fix if absent
}

namespace {
void addFace(Mesh& m, const std::string& name, const Index* elemNodes, int localFace) {
  auto& v = m.faces[name];
  for (int k = 0; k < 4; ++k) v.push_back(elemNodes[hex8::kFaces[localFace][k]]);
}
}  // namespace

/// The 8 corners of the structured hexahedron (a, b, c) of a grid numbered by nid(a, b, c), in the
/// hex8 order: the face c first, counter-clockwise about +c, then the face c + 1.
template <class Nid>
std::array<Index, 8> structuredHex(const Nid& nid, Index a, Index b, Index c) {
  return {nid(a, b, c),     nid(a + 1, b, c),     nid(a + 1, b + 1, c),     nid(a, b + 1, c),
          nid(a, b, c + 1), nid(a + 1, b, c + 1), nid(a + 1, b + 1, c + 1), nid(a, b + 1, c + 1)};
}

Mesh makeBoxMesh(const BoxSpec& s) {
  Mesh m;
  m.source = "<box " + std::to_string(s.nx) + "x" + std::to_string(s.ny) + "x" + std::to_string(s.nz) + ">";
  const Index NX = s.nx + 1, NY = s.ny + 1, NZ = s.nz + 1;
  auto nid = [&](Index i, Index j, Index k) { return i + NX * (j + NY * k); };
  m.coords.resize(3 * size_t(NX) * NY * NZ);
  for (Index k = 0; k < NZ; ++k)
    for (Index j = 0; j < NY; ++j)
      for (Index i = 0; i < NX; ++i) {
        const Index n = nid(i, j, k);
        m.coords[3 * n + 0] = s.x0 + s.lx * i / s.nx;
        m.coords[3 * n + 1] = s.y0 + s.ly * j / s.ny;
        m.coords[3 * n + 2] = s.z0 + s.lz * k / s.nz;
      }
  m.regionNames = {s.region};
  for (Index k = 0; k < s.nz; ++k)
    for (Index j = 0; j < s.ny; ++j)
      for (Index i = 0; i < s.nx; ++i) {
        const auto c = structuredHex(nid, i, j, k);
        m.connectivity.insert(m.connectivity.end(), c.begin(), c.end());
        m.region.push_back(0);
        if (k == 0) addFace(m, "bottom", c.data(), 0);
        if (k == s.nz - 1) addFace(m, "top", c.data(), 1);
        if (j == 0) addFace(m, "ymin", c.data(), 2);
        if (i == s.nx - 1) addFace(m, "xmax", c.data(), 3);
        if (j == s.ny - 1) addFace(m, "ymax", c.data(), 4);
        if (i == 0) addFace(m, "xmin", c.data(), 5);
      }
  return m;
}

Mesh makeRingSliceMesh(const RingSpec& s) {
  Mesh m;
  m.source = "<ring " + std::to_string(s.nRadial) + "x" + std::to_string(s.nAround) +
             (s.nAxial > 1 ? "x" + std::to_string(s.nAxial) : "") + ">";
  m.slice = s.nAxial == 1;
  const Index NR = s.nRadial + 1, NT = s.nAround, NY = s.nAxial + 1;  // the hoop direction closes on itself
  auto nid = [&](Index t, Index r, Index y) { return (t % NT) + NT * (r + NR * y); };
  m.coords.resize(3 * size_t(NT) * NR * NY);
  const Real pi = std::acos(-1.0);
  for (Index y = 0; y < NY; ++y)
    for (Index r = 0; r < NR; ++r)
      for (Index t = 0; t < NT; ++t) {
        const Real rad = s.rInner + (s.rOuter - s.rInner) * r / s.nRadial;
        const Real th = 2 * pi * t / s.nAround;
        const Index n = nid(t, r, y);
        m.coords[3 * n + 0] = rad * std::cos(th);
        m.coords[3 * n + 1] = s.width * y / s.nAxial;
        m.coords[3 * n + 2] = rad * std::sin(th);
      }
  m.regionNames = {s.region};
  // ξ along the hoop (θ increasing), η radially outwards, ζ along +y: (e_θ, e_r, e_y) is
  // right-handed in the x-z plane with θ measured from +x towards +z.
  for (Index y = 0; y < s.nAxial; ++y)
    for (Index r = 0; r < s.nRadial; ++r)
      for (Index t = 0; t < NT; ++t) {
        const auto c = structuredHex(nid, t, r, y);
        m.connectivity.insert(m.connectivity.end(), c.begin(), c.end());
        m.region.push_back(0);
        if (r == 0) addFace(m, "inner", c.data(), 2);
        if (r == s.nRadial - 1) addFace(m, "outer", c.data(), 4);
        if (y == 0) addFace(m, "ymin", c.data(), 0);
        if (y == s.nAxial - 1) addFace(m, "ymax", c.data(), 1);
      }
  return m;
}

}  // namespace tq
