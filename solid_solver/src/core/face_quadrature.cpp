// The geometry of a face group: 2×2 Gauss points on its quads, axis-aligned planar faces
// (tq/core/face_quadrature.hpp).
#include "tq/core/face_quadrature.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

namespace tq {

namespace {

using face_quadrature::gaussQuad;

std::string mshort(const Mesh& m) { return "mesh " + m.source; }

}  // namespace

AxisFace axisFace(const Mesh& mesh, const std::string& group) {
  auto it = mesh.faces.find(group);
  if (it == mesh.faces.end()) {
    mesh.faceNodes(group);  // throws the standard "missing group" message
    throw InputError(mshort(mesh) + ": face group '" + group + "' is missing");
  }
  const auto& q = it->second;
  if (q.empty()) throw InputError(mshort(mesh) + ": face group '" + group + "' is empty");
  AxisFace f;
  f.name = group;
  f.quads = q;
  Real n[3] = {0, 0, 0};
  std::map<Index, Real> area;
  for (size_t k = 0; k < q.size() / 4; ++k)
    gaussQuad(mesh, &q[4 * k], [&](const Real N[4], const Real*, const Real ndA[3]) {
      const Real dA = std::sqrt(ndA[0] * ndA[0] + ndA[1] * ndA[1] + ndA[2] * ndA[2]);
      for (int i = 0; i < 3; ++i) n[i] += ndA[i];
      for (int c = 0; c < 4; ++c) area[q[4 * k + c]] += N[c] * dA;
    });
  const Real len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  f.axis = int(std::max_element(n, n + 3, [](Real a, Real b) { return std::abs(a) < std::abs(b); }) - n);
  f.sign = n[f.axis] > 0 ? 1 : -1;
  // Planar and axis-aligned: every node on the same coordinate plane.
  Real lo = 1e300, hi = -1e300, ext = 0;
  for (const auto& [node, a] : area) {
    const Real c = mesh.coords[dofIndex(node, f.axis)];
    lo = std::min(lo, c);
    hi = std::max(hi, c);
  }
  for (int i = 0; i < 3; ++i) {
    Real a = 1e300, b = -1e300;
    for (const auto& [node, ar] : area) {
      a = std::min(a, mesh.coords[dofIndex(node, i)]);
      b = std::max(b, mesh.coords[dofIndex(node, i)]);
    }
    ext = std::max(ext, b - a);
  }
  if (!(len > 0) || std::abs(n[f.axis]) < (1 - 1e-9) * len || hi - lo > 1e-9 * ext) {
    std::ostringstream os;
    os << mshort(mesh) << ": face group '" << group
       << "' must be a plane perpendicular to x, y or z for this boundary (its nodes span " << hi - lo << " m along "
       << "xyz"[f.axis] << "); use an axis-aligned block boundary";
    throw InputError(os.str());
  }
  for (const auto& [node, a] : area) {
    f.nodes.push_back(node);
    f.area.push_back(a);
  }
  return f;
}

}  // namespace tq
