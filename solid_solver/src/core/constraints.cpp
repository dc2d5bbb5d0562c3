// Tied node groups (tq/core/constraints.hpp).
#include "tq/core/constraints.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include "tq/core/face_quadrature.hpp"

namespace tq {

TiedNodeGroups::TiedNodeGroups(std::string name, std::vector<std::vector<Index>> groups) : name_(std::move(name)) {
  start_.push_back(0);
  for (const auto& g : groups) {
    if (g.size() < 2) throw InputError(name_ + ": a tied group needs at least two nodes");
    node_.insert(node_.end(), g.begin(), g.end());
    start_.push_back(Index(node_.size()));
  }
  force_.assign(3 * node_.size(), 0.0);
}

std::vector<std::vector<Index>> TiedNodeGroups::pairs(const std::vector<Index>& flat) {
  std::vector<std::vector<Index>> g;
  for (size_t i = 0; i + 1 < flat.size(); i += 2) g.push_back({flat[i], flat[i + 1]});
  return g;
}

std::vector<std::vector<Index>> TiedNodeGroups::periodicPairs(const Mesh& mesh, const std::string& from,
                                                              const std::string& to) {
  const AxisFace a = axisFace(mesh, from), b = axisFace(mesh, to);
  const std::string what = "periodic faces '" + from + "' and '" + to + "'";
  if (a.axis != b.axis || a.sign == b.sign)
    throw InputError(what +
                     " are not opposite faces of the block (their outward normals must be -e and +e of one "
                     "axis, e.g. ymin and ymax)");
  if (a.nodes.size() != b.nodes.size())
    throw InputError(what + " have " + std::to_string(a.nodes.size()) + " and " + std::to_string(b.nodes.size()) +
                     " nodes: a periodic model needs the same node layout on both (an extruded mesh)");
  const int i = (a.axis + 1) % 3, j = (a.axis + 2) % 3;
  auto at = [&](Index n, int d) { return mesh.coords[dofIndex(n, d)]; };
  Real ext = 0;
  for (int d = 0; d < 3; ++d) {
    Real lo = 1e300, hi = -1e300;
    for (Index n : a.nodes) lo = std::min(lo, at(n, d)), hi = std::max(hi, at(n, d));
    ext = std::max(ext, hi - lo);
  }
  const Real tol = 1e-6 * std::max(ext, Real(1e-12));
  std::vector<std::tuple<Real, Real, Index>> other;
  for (Index n : b.nodes) other.emplace_back(at(n, i), at(n, j), n);
  std::sort(other.begin(), other.end());
  std::vector<std::vector<Index>> g;
  std::vector<char> used(other.size(), 0);
  for (Index n : a.nodes) {
    const Real ci = at(n, i), cj = at(n, j);
    auto k = size_t(std::lower_bound(other.begin(), other.end(), std::make_tuple(ci - tol, -1e300, Index(-1))) -
                    other.begin());
    Index partner = -1;
    for (; k < other.size() && std::get<0>(other[k]) <= ci + tol; ++k)
      if (!used[k] && std::abs(std::get<1>(other[k]) - cj) <= tol) {
        partner = std::get<2>(other[k]);
        used[k] = 1;
        break;
      }
    if (partner < 0) {
      std::ostringstream os;
      os << what << ": node " << n << " of '" << from << "' at "
         << "xyz"[i] << " = " << ci << ", "
         << "xyz"[j] << " = " << cj << " m has no node of '" << to
         << "' opposite it; a periodic model needs the same node "
         << "layout on both faces (an extruded mesh)";
      throw InputError(os.str());
    }
    g.push_back({n, partner});
  }
  return g;
}

void TiedNodeGroups::checkUniformMembers(const NodalState& s) const {
  for (Index g = 0; g < numGroups(); ++g) {
    const Index n0 = *begin(g);
    for (const Index* n = begin(g) + 1; n != end(g); ++n) {
      bool same = std::abs(s.mass(*n) - s.mass(n0)) <= 1e-9 * std::max(s.mass(*n), s.mass(n0));
      for (int d = 0; d < 3 && same; ++d)
        same = std::abs(s.dashpot(*n, d) - s.dashpot(n0, d)) <=
               1e-9 * std::max(std::abs(s.dashpot(*n, d)), std::abs(s.dashpot(n0, d))) + 1e-300;
      if (!same) {
        std::ostringstream os;
        os << name_ << ": node " << *n << " and node " << n0 << " are tied but carry different masses (" << s.mass(*n)
           << ", " << s.mass(n0) << " kg) or boundary dashpots; the tie needs mirror-equal members "
           << "(an extruded mesh with the same boundaries on both faces)";
        throw InputError(os.str());
      }
    }
  }
}

void TiedNodeGroups::install(Solver& solver) {
  NodalState& s = solver.state();
  for (Index g = 0; g < numGroups(); ++g) {
    for (int d = 0; d < 3; ++d) {
      const bool fixed0 = solver.isFixed(*begin(g), d);
      for (const Index* n = begin(g); n != end(g); ++n)
        if (solver.isFixed(*n, d) != fixed0) {
          std::ostringstream os;
          os << name_ << ": node " << *n << " and node " << *begin(g) << " are tied but direction "
             << "xyz"[d] << " is fixed for one and free for the other; support both or neither";
          throw InputError(os.str());
        }
      Real m = 0, p = 0;
      for (const Index* n = begin(g); n != end(g); ++n) {
        m += s.mass(*n);
        p += s.mass(*n) * s.v(*n, d);
      }
      const Real v = m > 0 ? p / m : 0;
      for (const Index* n = begin(g); n != end(g); ++n) s.v(*n, d) = v;
    }
  }
}

void TiedNodeGroups::addForces(Real, Real, NodalState& state) {
  Real* fe = state.fExtData();
  const Real* fi = state.fIntData();
  const Index G = numGroups();
#pragma omp parallel for schedule(static) if (G >= 4096)
  for (Index g = 0; g < G; ++g) {
    const Index j0 = start_[size_t(g)], j1 = start_[size_t(g) + 1];
    Real M = 0, F[3] = {0, 0, 0};
    for (Index j = j0; j < j1; ++j) {
      const Index n = node_[size_t(j)];
      M += state.mass(n);
      for (int d = 0; d < 3; ++d) F[d] += fe[dofIndex(n, d)] - fi[dofIndex(n, d)];
    }
    for (Index j = j0; j < j1; ++j) {
      const Index n = node_[size_t(j)];
      const Real m = state.mass(n);
      for (int d = 0; d < 3; ++d) {
        // Massless members (an element set not active yet) stay at rest: no exchange.
        const Real fc = (M > 0 && m > 0) ? m * F[d] / M - (fe[dofIndex(n, d)] - fi[dofIndex(n, d)]) : 0.0;
        force_[dofIndex(j, d)] = fc;
        fe[dofIndex(n, d)] += fc;
      }
    }
  }
}

}  // namespace tq
