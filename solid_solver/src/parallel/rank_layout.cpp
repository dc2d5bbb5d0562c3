#include "tq/parallel/rank_layout.hpp"

#include <algorithm>

namespace tq {

RankLayout makeRankLayout(const Mesh& g, const std::vector<int>& part, int rank, int ranks,
                          const std::vector<std::vector<Index>>& together) {
  RankLayout L;
  L.rank = rank;
  L.ranks = ranks;
  const Index N = g.numNodes(), E = g.numElems();
  // For each global node, the ranks whose elements use it (ascending, unique): a node is held by
  // every rank that has one of its elements.
  std::vector<Index> start(size_t(N) + 1, 0);
  for (Index e = 0; e < E; ++e)
    for (int k = 0; k < 8; ++k) ++start[size_t(g.connectivity[8 * size_t(e) + k]) + 1];
  for (Index n = 0; n < N; ++n) start[size_t(n) + 1] += start[size_t(n)];
  std::vector<int> holder(static_cast<size_t>(start[size_t(N)]));
  {
    std::vector<Index> fill(start.begin(), start.end() - 1);
    for (Index e = 0; e < E; ++e)
      for (int k = 0; k < 8; ++k) {
        const Index n = g.connectivity[8 * size_t(e) + k];
        holder[size_t(fill[size_t(n)]++)] = part[size_t(e)];
      }
  }
  std::vector<Index> hStart(size_t(N) + 1, 0);
  std::vector<int> holders;
  holders.reserve(holder.size());
  for (Index n = 0; n < N; ++n) {
    auto b = holder.begin() + start[size_t(n)], e = holder.begin() + start[size_t(n) + 1];
    std::sort(b, e);
    e = std::unique(b, e);
    holders.insert(holders.end(), b, e);
    hStart[size_t(n) + 1] = Index(holders.size());
  }
  // Groups held together: every member is held by every rank that holds one of them (repeated
  // until no group grows, for groups that share a node).
  if (!together.empty()) {
    std::vector<std::vector<int>> of(static_cast<size_t>(N));
    for (Index n = 0; n < N; ++n)
      of[size_t(n)].assign(holders.begin() + hStart[size_t(n)], holders.begin() + hStart[size_t(n) + 1]);
    for (bool grown = true; grown;) {
      grown = false;
      for (const auto& grp : together) {
        std::vector<int> all;
        for (Index n : grp) all.insert(all.end(), of[size_t(n)].begin(), of[size_t(n)].end());
        std::sort(all.begin(), all.end());
        all.erase(std::unique(all.begin(), all.end()), all.end());
        for (Index n : grp)
          if (of[size_t(n)] != all) {
            of[size_t(n)] = all;
            grown = true;
          }
      }
    }
    holders.clear();
    for (Index n = 0; n < N; ++n) {
      holders.insert(holders.end(), of[size_t(n)].begin(), of[size_t(n)].end());
      hStart[size_t(n) + 1] = Index(holders.size());
    }
  }
  // This rank's elements and nodes, in the global order.
  L.localNode.assign(size_t(N), -1);
  for (Index n = 0; n < N; ++n)
    for (Index j = hStart[size_t(n)]; j < hStart[size_t(n) + 1]; ++j)
      if (holders[size_t(j)] == rank) {
        L.localNode[size_t(n)] = Index(L.globalNode.size());
        L.globalNode.push_back(n);
        break;
      }
  for (Index e = 0; e < E; ++e)
    if (part[size_t(e)] == rank) L.globalElem.push_back(e);
  Mesh& m = L.mesh;
  m.regionNames = g.regionNames;
  m.slice = g.slice;
  m.source = g.source + " (rank " + std::to_string(rank) + " of " + std::to_string(ranks) + ")";
  m.coords.reserve(3 * L.globalNode.size());
  for (Index n : L.globalNode)
    for (int d = 0; d < 3; ++d) m.coords.push_back(g.coords[dofIndex(n, d)]);
  m.connectivity.reserve(8 * L.globalElem.size());
  for (Index e : L.globalElem) {
    for (int k = 0; k < 8; ++k) m.connectivity.push_back(L.localNode[size_t(g.connectivity[8 * size_t(e) + k])]);
    m.region.push_back(g.region[size_t(e)]);
  }
  // Frontier, neighbours, ownership.
  const Index nl = Index(L.globalNode.size());
  L.owned.assign(size_t(nl), 1);
  std::vector<std::vector<Index>> shared(static_cast<size_t>(ranks));
  L.frontierStart.push_back(0);
  for (Index i = 0; i < nl; ++i) {
    const Index n = L.globalNode[size_t(i)];
    const Index h0 = hStart[size_t(n)], h1 = hStart[size_t(n) + 1];
    if (h1 - h0 < 2) continue;
    L.frontier.push_back(i);
    for (Index j = h0; j < h1; ++j) {
      const int r = holders[size_t(j)];
      L.frontierRanks.push_back(r);
      if (r != rank) shared[size_t(r)].push_back(i);
    }
    L.frontierStart.push_back(Index(L.frontierRanks.size()));
    if (holders[size_t(h0)] != rank) {
      L.owned[size_t(i)] = 0;
      L.ghosts.push_back(i);
    }
  }
  for (int r = 0; r < ranks; ++r)
    if (!shared[size_t(r)].empty()) L.neighbours.push_back({r, std::move(shared[size_t(r)])});
  std::vector<std::uint8_t> isFrontier(size_t(nl), 0);
  for (Index i : L.frontier) isFrontier[size_t(i)] = 1;
  L.frontierElem.assign(L.globalElem.size(), 0);
  for (size_t e = 0; e < L.globalElem.size(); ++e)
    for (int k = 0; k < 8; ++k)
      if (isFrontier[size_t(m.connectivity[8 * e + size_t(k)])]) L.frontierElem[e] = 1;
  return L;
}

}  // namespace tq
