// Tied node groups (tq/constraints.hpp).
#include "tq/constraints.hpp"

#include <sstream>

namespace tq {

TiedNodeGroups::TiedNodeGroups(std::string name, std::vector<std::vector<Index>> groups)
    : name_(std::move(name)) {
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
      for (int d = 0; d < 3; ++d) F[d] += fe[3 * size_t(n) + d] - fi[3 * size_t(n) + d];
    }
    for (Index j = j0; j < j1; ++j) {
      const Index n = node_[size_t(j)];
      const Real m = state.mass(n);
      for (int d = 0; d < 3; ++d) {
        // Massless members (an element set not active yet) stay at rest: no exchange.
        const Real fc = (M > 0 && m > 0) ? m * F[d] / M - (fe[3 * size_t(n) + d] - fi[3 * size_t(n) + d]) : 0.0;
        force_[3 * size_t(j) + d] = fc;
        fe[3 * size_t(n) + d] += fc;
      }
    }
  }
}

}  // namespace tq
