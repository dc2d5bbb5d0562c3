#include "tq/parallel/partition.hpp"

#include <algorithm>
#include <numeric>

namespace tq {

Real materialCostWeight(const std::string& model) {
  if (model == "elastic") return 1.0;
  if (model == "kelvin_voigt") return 1.2;
  if (model == "mohr_coulomb_damage") return 2.0;
  if (model == "reinforced_concrete") return 2.0;
  return 1.5;
}

std::vector<Real> elementCosts(const Mesh& mesh, const SolidInput& in) {
  std::vector<Real> byRegion(mesh.regionNames.size(), 1.0);
  for (const auto& [region, values] : in.materials) {
    const Index r = mesh.regionIndex(region);
    if (r >= 0) byRegion[size_t(r)] = materialCostWeight(values.model);
  }
  std::vector<Real> w(size_t(mesh.numElems()));
  for (Index e = 0; e < mesh.numElems(); ++e) w[size_t(e)] = byRegion[size_t(mesh.region[size_t(e)])];
  return w;
}

namespace {
void bisect(const std::vector<Real>& centre, const std::vector<Real>& weight, std::vector<Index>::iterator first,
            std::vector<Index>::iterator last, int part0, int parts, std::vector<int>& part) {
  if (parts == 1) {
    for (auto it = first; it != last; ++it) part[size_t(*it)] = part0;
    return;
  }
  // The axis of the largest extent of the centroids.
  Real lo[3], hi[3];
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = centre[3 * size_t(*first) + d];
  for (auto it = first; it != last; ++it)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], centre[3 * size_t(*it) + d]);
      hi[d] = std::max(hi[d], centre[3 * size_t(*it) + d]);
    }
  int axis = 0;
  for (int d = 1; d < 3; ++d)
    if (hi[d] - lo[d] > hi[axis] - lo[axis]) axis = d;
  std::sort(first, last, [&](Index a, Index b) {
    const Real ca = centre[3 * size_t(a) + axis], cb = centre[3 * size_t(b) + axis];
    return ca < cb || (ca == cb && a < b);
  });
  const int left = parts / 2;
  Real total = 0;
  for (auto it = first; it != last; ++it) total += weight[size_t(*it)];
  const Real target = total * Real(left) / Real(parts);
  const auto n = last - first;
  // The cut: the first position where the running weight reaches the target, kept so that each
  // side has at least as many elements as parts.
  Real run = 0;
  std::ptrdiff_t cut = 0;
  while (cut < n && run + 0.5 * weight[size_t(first[cut])] < target) run += weight[size_t(first[cut++])];
  cut = std::clamp<std::ptrdiff_t>(cut, left, n - (parts - left));
  bisect(centre, weight, first, first + cut, part0, left, part);
  bisect(centre, weight, first + cut, last, part0 + left, parts - left, part);
}
}  // namespace

std::vector<int> partitionRcb(const Mesh& mesh, const std::vector<Real>& weight, int parts) {
  const Index E = mesh.numElems();
  if (parts < 1) throw InputError("ranks = " + std::to_string(parts) + ": give at least 1");
  if (parts > E)
    throw InputError(std::to_string(parts) + " ranks for a mesh of " + std::to_string(E) +
                     " elements: give at most one rank per element (fewer ranks)");
  if (weight.size() != size_t(E)) throw InputError("partition: one cost weight per element expected");
  std::vector<Real> centre(3 * size_t(E), 0.0);
  for (Index e = 0; e < E; ++e)
    for (int k = 0; k < 8; ++k)
      for (int d = 0; d < 3; ++d)
        centre[3 * size_t(e) + d] += 0.125 * mesh.coords[dofIndex(mesh.connectivity[8 * size_t(e) + k], d)];
  std::vector<Index> order(static_cast<size_t>(E));
  std::iota(order.begin(), order.end(), 0);
  std::vector<int> part(size_t(E), 0);
  bisect(centre, weight, order.begin(), order.end(), 0, parts, part);
  return part;
}

std::vector<Real> partWeights(const std::vector<int>& part, const std::vector<Real>& weight, int parts) {
  std::vector<Real> w(size_t(parts), 0.0);
  for (size_t e = 0; e < part.size(); ++e) w[size_t(part[e])] += weight[e];
  return w;
}

}  // namespace tq
