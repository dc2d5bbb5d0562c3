#include "tq/parallel/rank_exchange.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#ifdef TQ_SOLID_HAVE_MPI
#include <mpi.h>
#endif

namespace tq {

#ifdef TQ_SOLID_HAVE_MPI

bool rankRunsAvailable() { return true; }

namespace {

// Each node's sum in the one-process order. One process adds an element's values to its nodes
// block by block in a fixed order (lumpMassInto: the block's element order; the force kernel: its
// even slabs, then its odd ones), a function of the whole mesh alone. A rank's blocks are other
// blocks, so a node's sum on a rank follows that order explicitly: every element stores its values
// (a unit: an element for the masses, an element's corner for the forces), the ranks send the
// units of their elements at the nodes they share, and each node adds its units in the position
// of their elements in the one-process order. Every copy of a node, and the one process, then add
// the same values in the same order: the same bits.
struct NodeSumPlan {
  int comps = 1;
  size_t localUnits = 0;                      // units this rank computes; received ones follow
  std::vector<Index> node;                    // the local nodes it sums
  std::vector<Index> start, unit;             // [row] node[row]'s units in [start[row], start[row + 1])
  std::vector<std::vector<Index>> sendUnits;  // [neighbour] the local units it is sent, in order
  std::vector<size_t> recvAt;                 // [neighbour] its first unit in the buffer
  std::vector<Real> values;                   // [(local + received units) * comps]

  // The sums into out[comps * i + d] for each of its nodes i (of the units in at[row] .. at[row + 1]
  // of `units`: by default its own).
  void sum(Real* out) const { sum(out, start, unit); }
  void sum(Real* out, const std::vector<Index>& at, const std::vector<Index>& units) const {
    const size_t c = size_t(comps);
    if (c == 3) {  // the forces: the three components in one pass, each its own sequence
      for (size_t r = 0; r < node.size(); ++r) {
        Real s0 = 0, s1 = 0, s2 = 0;
        for (Index t = at[r]; t < at[r + 1]; ++t) {
          const Real* v = &values[3 * size_t(units[size_t(t)])];
          s0 += v[0];
          s1 += v[1];
          s2 += v[2];
        }
        Real* o = out + 3 * size_t(node[r]);
        o[0] = s0, o[1] = s1, o[2] = s2;
      }
      return;
    }
    for (size_t r = 0; r < node.size(); ++r)
      for (size_t d = 0; d < c; ++d) {
        Real s = 0;
        for (Index t = at[r]; t < at[r + 1]; ++t) s += values[c * size_t(units[size_t(t)]) + d];
        out[c * size_t(node[r]) + d] = s;
      }
  }
};

// The plan of `comps` values per unit for the local nodes where `include` is 1 (every frontier node
// among them). seq[global element]: its position in the one-process order; unitOf(local element,
// corner): its local unit. incElem (when given): [incidence] its global element, in the plan's
// unit order.
template <class UnitOf>
NodeSumPlan makePlan(const RankLayout& L, const Mesh& global, const std::vector<int>& part,
                     const std::vector<Index>& seq, const std::vector<std::uint8_t>& include, int comps,
                     size_t localUnits, const UnitOf& unitOf, std::vector<Index>* incElem = nullptr) {
  NodeSumPlan P;
  P.comps = comps;
  P.localUnits = localUnits;
  const size_t nb = L.neighbours.size();
  std::vector<Index> row(L.globalNode.size(), -1);
  for (size_t i = 0; i < include.size(); ++i)
    if (include[i]) {
      row[i] = Index(P.node.size());
      P.node.push_back(Index(i));
    }
  const size_t nl = P.node.size();
  std::vector<Index> localElem(size_t(global.numElems()), -1);
  for (size_t e = 0; e < L.globalElem.size(); ++e) localElem[size_t(L.globalElem[e])] = Index(e);
  // Each local node's incidences: (position of the element, its rank, the element, the corner).
  struct Inc {
    Index seq;
    int rank;
    Index elem;
    int corner;
  };
  std::vector<Index> at(nl + 1, 0);  // node i's incidences inc[at[i] .. at[i + 1])
  for (Index e = 0; e < global.numElems(); ++e)
    for (int k = 0; k < 8; ++k)
      if (const Index l = L.localNode[size_t(global.connectivity[8 * size_t(e) + k])]; l >= 0 && row[size_t(l)] >= 0)
        ++at[size_t(row[size_t(l)]) + 1];
  for (size_t i = 0; i < nl; ++i) at[i + 1] += at[i];
  std::vector<Inc> inc(static_cast<size_t>(at[nl]));
  {
    std::vector<Index> fill(at.begin(), at.end() - 1);
    for (Index e = 0; e < global.numElems(); ++e)
      for (int k = 0; k < 8; ++k)
        if (const Index l = L.localNode[size_t(global.connectivity[8 * size_t(e) + k])]; l >= 0 && row[size_t(l)] >= 0)
          inc[size_t(fill[size_t(row[size_t(l)])]++)] = {seq[size_t(e)], part[size_t(e)], e, k};
  }
  for (size_t i = 0; i < nl; ++i)
    std::sort(inc.begin() + at[i], inc.begin() + at[i + 1], [](const Inc& a, const Inc& b) { return a.seq < b.seq; });
  // The messages: for each shared node (ascending, the same list on both sides), the sender's
  // units at it in the order; where[x]: the buffer unit of incidence x from another rank.
  std::vector<Index> where(inc.size(), -1);
  P.sendUnits.resize(nb);
  P.recvAt.resize(nb);
  size_t next = localUnits;
  for (size_t j = 0; j < nb; ++j) {
    P.recvAt[j] = next;
    for (Index n : L.neighbours[j].nodes)
      for (Index x = at[size_t(row[size_t(n)])]; x < at[size_t(row[size_t(n)]) + 1]; ++x) {
        const Inc& c = inc[size_t(x)];
        if (c.rank == L.rank) P.sendUnits[j].push_back(unitOf(localElem[size_t(c.elem)], c.corner));
        if (c.rank == L.neighbours[j].rank) where[size_t(x)] = Index(next++);
      }
  }
  P.start = std::move(at);
  P.unit.resize(inc.size());
  for (size_t x = 0; x < inc.size(); ++x) {
    const Inc& c = inc[x];
    const Index u = c.rank == L.rank ? unitOf(localElem[size_t(c.elem)], c.corner) : where[x];
    if (u < 0)
      throw std::logic_error("rank layout: an element of rank " + std::to_string(c.rank) + " at global node " +
                             std::to_string(global.connectivity[8 * size_t(c.elem) + size_t(c.corner)]) +
                             " that no neighbour sends");
    P.unit[x] = u;
  }
  if (incElem) {
    incElem->resize(inc.size());
    for (size_t x = 0; x < inc.size(); ++x) (*incElem)[x] = inc[x].elem;
  }
  P.values.assign(size_t(comps) * next, 0.0);
  return P;
}

class MpiRankExchange final : public RankExchange {
 public:
  MpiRankExchange(const RankLayout& L, size_t frontierBlocks, const Mesh& global, const std::vector<int>& part,
                  const std::vector<Index>& blockRegions, const std::vector<std::unique_ptr<ElementBlock>>& blocks)
      : frontierBlocks_(frontierBlocks),
        owned_(L.owned),
        ghosts_(L.ghosts),
        frontier_(L.frontier),
        global_(&global),
        part_(part) {
    layout_ = L;  // its lists (subcycle() makes the force plans again); the mesh is not needed
    layout_.mesh = Mesh();
    // The one-process order: its blocks (one per region, in blockRegions' order), each adding its
    // elements' masses in its element order and its forces in its scatter order.
    std::vector<Index> massSeq(size_t(global.numElems()), 0), forceSeq(size_t(global.numElems()), 0);
    {
      Index mPos = 0, fPos = 0;
      std::vector<Index> lumped, scattered;
      for (Index r : blockRegions) {
        std::vector<Index> elems;
        for (Index e = 0; e < global.numElems(); ++e)
          if (global.region[size_t(e)] == r) elems.push_back(e);
        ElementBlock::nodeSumOrder(global, std::move(elems), lumped, scattered);
        opLumped_.push_back(lumped);
        for (Index e : lumped) massSeq[size_t(e)] = mPos++;
        for (Index e : scattered) forceSeq[size_t(e)] = fPos++;
      }
    }
    // The masses: every node from its elements' shares (a unit an element, block by block).
    const size_t nl = L.globalNode.size(), ne = L.globalElem.size();
    std::vector<Index> elemUnit(ne, -1);
    size_t units = 0;
    for (const auto& b : blocks)
      for (Index e = 0; e < b->numElems(); ++e) elemUnit[size_t(b->meshElem(e))] = Index(units++);
    shares_ = makePlan(L, global, part, massSeq, std::vector<std::uint8_t>(nl, 1), 1, units,
                       [&](Index le, int) { return elemUnit[size_t(le)]; });
    // The forces. This rank's blocks scatter into the nodes as one process does, in their own
    // order (localSeq); where a node's elements all lie on this rank and that order is the
    // one-process order, the scatter is the one-process sum. The others, and every frontier node,
    // are summed from the corner forces (a unit a corner) of the elements at them, which the
    // blocks store besides.
    std::vector<Index> localSeq(ne, 0);
    {
      Index pos = 0;
      for (const auto& b : blocks) {
        const std::vector<Index>& st = b->slabStarts();
        const Index nS = Index(st.size()) - 1, nE = b->numElems();
        for (Index parity = 0; parity < 2; ++parity)  // as computeForcesForElems
          for (Index sl = parity; sl < nS; sl += 2)
            for (Index c = st[size_t(sl)]; c < st[size_t(sl) + 1]; ++c)
              for (Index e = c * ElementBlock::kChunk; e < std::min(nE, (c + 1) * ElementBlock::kChunk); ++e)
                localSeq[size_t(b->meshElem(e))] = pos++;
      }
    }
    std::vector<std::uint8_t> summed(nl, 0);
    for (Index i : L.frontier) summed[size_t(i)] = 1;
    {
      std::vector<Index> at(nl + 1, 0), elems(8 * ne);
      for (size_t e = 0; e < ne; ++e)
        for (int k = 0; k < 8; ++k) ++at[size_t(L.mesh.connectivity[8 * e + size_t(k)]) + 1];
      for (size_t i = 0; i < nl; ++i) at[i + 1] += at[i];
      std::vector<Index> fill(at.begin(), at.end() - 1);
      for (size_t e = 0; e < ne; ++e)
        for (int k = 0; k < 8; ++k) elems[size_t(fill[size_t(L.mesh.connectivity[8 * e + size_t(k)])]++)] = Index(e);
      for (size_t i = 0; i < nl; ++i) {
        auto b = elems.begin() + at[i], en = elems.begin() + at[i + 1];
        std::sort(b, en, [&](Index x, Index y) {
          return forceSeq[size_t(L.globalElem[size_t(x)])] < forceSeq[size_t(L.globalElem[size_t(y)])];
        });
        for (auto it = b; it + 1 < en && !summed[i]; ++it)
          if (localSeq[size_t(*it)] > localSeq[size_t(*(it + 1))]) summed[i] = 1;
      }
    }
    std::vector<Index> slot(ne, -1);
    size_t slots = 0;
    for (size_t e = 0; e < ne; ++e)
      for (int k = 0; k < 8 && slot[e] < 0; ++k)
        if (summed[size_t(L.mesh.connectivity[8 * e + size_t(k)])]) slot[e] = Index(slots++);
    forces_ = makePlan(L, global, part, forceSeq, summed, 3, 8 * slots,
                       [&](Index le, int k) { return 8 * slot[size_t(le)] + Index(k); });
    summedNodes_ = forces_.node.size();
    for (const auto& b : blocks) {
      blockSlots_.emplace_back();
      for (Index e = 0; e < b->numElems(); ++e) blockSlots_.back().push_back(slot[size_t(b->meshElem(e))]);
      b->setCornerForceOutput(forces_.values.data(), blockSlots_.back().data());
    }
    // The owned nodes of every rank, on rank 0 (sumInNodeOrder).
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    std::vector<int> ids;
    for (size_t i = 0; i < L.owned.size(); ++i)
      if (L.owned[i]) {
        ownedLocal_.push_back(Index(i));
        ids.push_back(int(L.globalNode[i]));
      }
    globalNodes_ = size_t(global.numNodes());
    int n = int(ids.size());
    ownedCounts_.assign(size_t(size_), 0);
    MPI_Gather(&n, 1, MPI_INT, ownedCounts_.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<int> displs(size_t(size_), 0);
    for (int r = 1; r < size_; ++r) displs[size_t(r)] = displs[size_t(r) - 1] + ownedCounts_[size_t(r) - 1];
    ownedIds_.resize(rank_ == 0 ? size_t(displs.back() + ownedCounts_.back()) : 0);
    MPI_Gatherv(ids.data(), n, MPI_INT, ownedIds_.data(), ownedCounts_.data(), displs.data(), MPI_INT, 0,
                MPI_COMM_WORLD);
    const size_t F = L.frontier.size();
    // Where each frontier node's partial values come from, in ascending rank order: this rank's
    // own (source -1) or neighbour j's buffer at position p.
    std::vector<Index> frontierOf(L.globalNode.size(), -1);
    for (size_t k = 0; k < F; ++k) frontierOf[size_t(L.frontier[k])] = Index(k);
    std::vector<std::vector<Term>> terms(F);
    for (size_t k = 0; k < F; ++k) terms[k].push_back({L.rank, -1, Index(k)});
    for (size_t j = 0; j < L.neighbours.size(); ++j) {
      const RankNeighbour& nb = L.neighbours[j];
      ranks_.push_back(nb.rank);
      nodes_.push_back(nb.nodes);
      for (size_t p = 0; p < nb.nodes.size(); ++p)
        terms[size_t(frontierOf[size_t(nb.nodes[p])])].push_back({nb.rank, int(j), Index(p)});
    }
    termStart_.push_back(0);
    for (auto& t : terms) {
      std::sort(t.begin(), t.end(), [](const Term& a, const Term& b) { return a.rank < b.rank; });
      terms_.insert(terms_.end(), t.begin(), t.end());
      termStart_.push_back(Index(terms_.size()));
    }
    send_.resize(ranks_.size());
    recv_.resize(ranks_.size());
    requests_.resize(2 * ranks_.size());
  }

  size_t frontierBlocks() const override { return frontierBlocks_; }
  const std::uint8_t* owned() const override { return owned_.data(); }
  const std::vector<Index>& ghosts() const override { return ghosts_; }

  void sumFrontier(Real* data, int comps) override {
    start(data, comps);
    finish(data, comps);
  }
  Real frontierMismatch(const Real* data, int comps) override {
    start(data, comps);
    MPI_Waitall(int(requests_.size()), requests_.data(), MPI_STATUSES_IGNORE);
    const size_t c = size_t(comps);
    Real worst = 0;
    for (size_t j = 0; j < ranks_.size(); ++j)
      for (size_t p = 0; p < nodes_[j].size(); ++p)
        for (size_t d = 0; d < c; ++d) {
          const Real mine = data[c * size_t(nodes_[j][p]) + d], theirs = recv_[j][c * p + d];
          worst = std::max(worst, mine == theirs ? Real(0) : std::abs(mine - theirs));
          if (!(mine == theirs) && !(std::abs(mine - theirs) > 0)) worst = std::numeric_limits<Real>::infinity();
        }
    return maxAll(worst);
  }
  // The blocks store their corner forces (setCornerForceOutput) instead of adding them to f: the
  // frontier elements' units are sent once their blocks are done, and every node's force is summed
  // from its units in the one-process order once the others are.
  void beginForceSum(const Real*) override { post(forces_, kForceTag, planRequests_); }
  void finishForceSum(Real* f, int activeLevel) override {
    const auto t0 = std::chrono::steady_clock::now();
    MPI_Waitall(int(planRequests_.size()), planRequests_.data(), MPI_STATUSES_IGNORE);
    wait_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (levelStart_.empty()) {
      forces_.sum(f);
    } else {  // subcycling: the elements due at this step's level, in that level's order
      const size_t L = std::min(size_t(activeLevel), levelStart_.size() - 1);
      forces_.sum(f, levelStart_[L], levelUnit_[L]);
    }
  }
  void minFrontier(Real* data, int comps) override {
    start(data, comps);
    waitAll();
    const size_t c = size_t(comps);
    for (size_t k = 0; k < frontier_.size(); ++k)
      for (size_t d = 0; d < c; ++d) {
        Real m = self_[c * k + d];
        for (Index t = termStart_[k]; t < termStart_[k + 1]; ++t) {
          const Term& T = terms_[size_t(t)];
          if (T.source >= 0) m = std::min(m, recv_[size_t(T.source)][c * size_t(T.pos) + d]);
        }
        data[c * size_t(frontier_[k]) + d] = m;
      }
  }
  std::vector<std::vector<std::uint8_t>> subcycle(const std::vector<std::uint8_t>& nodeLevel, int maxLevel,
                                                  const std::vector<std::unique_ptr<ElementBlock>>& blocks) override {
    const Mesh& global = *global_;
    // The one-process chunks: block by block (opLumped_), 64 elements of its order each.
    std::vector<Index> chunkOf(size_t(global.numElems()), -1), chunkStart{0};
    for (const auto& lumped : opLumped_) {
      for (size_t p = 0; p < lumped.size(); ++p)
        chunkOf[size_t(lumped[p])] = chunkStart.back() + Index(p) / ElementBlock::kChunk;
      chunkStart.push_back(chunkStart.back() +
                           (Index(lumped.size()) + ElementBlock::kChunk - 1) / ElementBlock::kChunk);
    }
    // Their levels: min over their active elements' nodes, over every rank (255: none active).
    std::vector<Real> level(size_t(chunkStart.back()), 255.0);
    for (const auto& b : blocks)
      for (Index e = 0; e < b->numElems(); ++e) {
        if (!b->active(e)) continue;
        Real& l = level[size_t(chunkOf[size_t(layout_.globalElem[size_t(b->meshElem(e))])])];
        for (int k = 0; k < 8; ++k) l = std::min(l, Real(nodeLevel[size_t(b->node(e, k))]));
      }
    MPI_Allreduce(MPI_IN_PLACE, level.data(), int(level.size()), MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    // This rank's chunks: each lies in one of them.
    std::vector<std::vector<std::uint8_t>> mine;
    for (const auto& b : blocks) {
      mine.emplace_back(size_t(b->numChunks()), 255);
      for (Index e = 0; e < b->numElems(); ++e) {
        const Index c = chunkOf[size_t(layout_.globalElem[size_t(b->meshElem(e))])];
        const Index first =
            chunkOf[size_t(layout_.globalElem[size_t(b->meshElem(e / ElementBlock::kChunk * ElementBlock::kChunk))])];
        if (c != first)
          throw std::logic_error("subcycling on ranks: a chunk of block '" + b->name() +
                                 "' holds elements of two one-process chunks");
        mine.back()[size_t(e / ElementBlock::kChunk)] = std::uint8_t(level[size_t(c)]);
      }
    }
    // Each level's order of the elements' forces at the nodes: the one-process blocks' in turn.
    const size_t nL = size_t(maxLevel) + 1;
    std::vector<std::vector<Index>> seq(nL, std::vector<Index>(size_t(global.numElems()), -1));
    {
      std::vector<Index> pos(nL, 0);
      for (size_t ob = 0; ob < opLumped_.size(); ++ob) {
        std::vector<std::uint8_t> cl;
        for (Index c = chunkStart[ob]; c < chunkStart[ob + 1]; ++c) cl.push_back(std::uint8_t(level[size_t(c)]));
        const auto orders = ElementBlock::levelSumOrders(global, opLumped_[ob], cl, maxLevel);
        for (size_t L = 0; L < nL; ++L)
          for (Index e : orders[L]) seq[L][size_t(e)] = pos[L]++;
      }
    }
    // Every node summed from its elements' corner forces (a slot an element): the plan of all
    // of them (the messages), then each level's units, in that level's order.
    const size_t nl = layout_.globalNode.size(), ne = layout_.globalElem.size();
    // (the plan's order a key for every element, the same on both sides of a message: the elements
    // of no level after the others, by index)
    std::vector<Index> key(seq.back());
    for (size_t e = 0; e < key.size(); ++e)
      if (key[e] < 0) key[e] = global.numElems() + Index(e);
    std::vector<Index> incElem;
    forces_ = makePlan(
        layout_, global, part_, key, std::vector<std::uint8_t>(nl, 1), 3, 8 * ne,
        [](Index le, int k) { return 8 * le + Index(k); }, &incElem);
    summedNodes_ = forces_.node.size();
    levelStart_.assign(nL, {});
    levelUnit_.assign(nL, {});
    for (size_t L = 0; L < nL; ++L) {
      std::vector<Index>& at = levelStart_[L];
      std::vector<Index>& unit = levelUnit_[L];
      at.push_back(0);
      std::vector<std::pair<Index, Index>> row;
      for (size_t r = 0; r < forces_.node.size(); ++r) {
        row.clear();
        for (Index x = forces_.start[r]; x < forces_.start[r + 1]; ++x)
          if (const Index q = seq[L][size_t(incElem[size_t(x)])]; q >= 0) row.emplace_back(q, forces_.unit[size_t(x)]);
        std::sort(row.begin(), row.end());
        for (const auto& [q, u] : row) unit.push_back(u);
        at.push_back(Index(unit.size()));
      }
    }
    blockSlots_.clear();
    for (const auto& b : blocks) {
      blockSlots_.emplace_back();
      for (Index e = 0; e < b->numElems(); ++e) blockSlots_.back().push_back(b->meshElem(e));
      b->setCornerForceOutput(forces_.values.data(), blockSlots_.back().data());
    }
    return mine;
  }
  void sumElementShares(const std::vector<std::vector<Real>>& perBlock, Real* nodal) override {
    size_t u = 0;
    for (const auto& v : perBlock)
      for (Real x : v) shares_.values[u++] = x;
    if (u != shares_.localUnits) throw std::logic_error("sumElementShares: one value per element of each block");
    std::vector<MPI_Request> req;
    post(shares_, kShareTag, req);
    MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE);
    shares_.sum(nodal);
  }

  // Every rank's values gathered and summed in rank order on every rank: the same bits on all of
  // them (a reduction's order is the MPI library's choice, and a convergence test or a stop that
  // one rank decides from other bits than the others would leave them waiting for each other).
  void sumAll(Real* v, int n) override {
    const auto t0 = std::chrono::steady_clock::now();
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    all_.resize(size_t(n) * size_t(size));
    MPI_Allgather(v, n, MPI_DOUBLE, all_.data(), n, MPI_DOUBLE, MPI_COMM_WORLD);
    for (int i = 0; i < n; ++i) {
      Real sum = 0;
      for (int r = 0; r < size; ++r) sum += all_[size_t(r) * size_t(n) + size_t(i)];
      v[i] = sum;
    }
    wait_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  // The owners' terms gathered on rank 0, summed there node by node in the global numbering, the
  // sums sent to every rank: one process's sequential loop, in O(nodes) values a call.
  void sumInNodeOrder(const Real* terms, int nSums, int per, Real* sums) override {
    const auto t0 = std::chrono::steady_clock::now();
    const size_t k = size_t(nSums) * size_t(per);
    std::vector<Real> mine;
    mine.reserve(k * ownedLocal_.size());
    for (Index i : ownedLocal_) mine.insert(mine.end(), terms + k * size_t(i), terms + k * size_t(i) + k);
    std::vector<int> counts(static_cast<size_t>(size_)), displs(size_t(size_), 0);
    for (int r = 0; r < size_; ++r) counts[size_t(r)] = int(k) * ownedCounts_[size_t(r)];
    for (int r = 1; r < size_; ++r) displs[size_t(r)] = displs[size_t(r) - 1] + counts[size_t(r) - 1];
    std::vector<Real> all(rank_ == 0 ? k * ownedIds_.size() : 0);
    MPI_Gatherv(mine.data(), int(mine.size()), MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0,
                MPI_COMM_WORLD);
    if (rank_ == 0) {
      std::vector<Real> byNode(k * globalNodes_, 0.0);  // a node no element uses: terms 0, as one process's
      for (size_t p = 0; p < ownedIds_.size(); ++p)
        std::copy(&all[k * p], &all[k * p] + k, &byNode[k * size_t(ownedIds_[p])]);
      for (int s = 0; s < nSums; ++s) {
        Real sum = 0;
        for (size_t n = 0; n < globalNodes_; ++n)
          for (int j = 0; j < per; ++j) sum += byNode[k * n + size_t(s) * size_t(per) + size_t(j)];
        sums[s] = sum;
      }
    }
    MPI_Bcast(sums, nSums, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    wait_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  double waitSeconds() const override { return wait_; }
  Real maxAll(Real v) override {
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return v;
  }
  Real minAll(Real v) override {
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    return v;
  }

 private:
  struct Term {
    int rank;    // the rank whose partial value it is
    int source;  // -1 this rank, else the neighbour's index
    Index pos;   // position in that source's list
  };
  static constexpr int kTag = 4301, kForceTag = 4302, kShareTag = 4303;

  // Posts the receives of a plan's units from the neighbours and the sends of this rank's.
  void post(NodeSumPlan& P, int tag, std::vector<MPI_Request>& req) {
    const size_t c = size_t(P.comps), nb = ranks_.size();
    req.resize(2 * nb);
    planSend_.resize(nb);
    for (size_t j = 0; j < nb; ++j) {
      const size_t end = j + 1 < nb ? P.recvAt[j + 1] : P.values.size() / c;
      MPI_Irecv(&P.values[c * P.recvAt[j]], int(c * (end - P.recvAt[j])), MPI_DOUBLE, ranks_[j], tag, MPI_COMM_WORLD,
                &req[j]);
    }
    for (size_t j = 0; j < nb; ++j) {
      std::vector<Real>& out = planSend_[j];
      out.resize(c * P.sendUnits[j].size());
      for (size_t p = 0; p < P.sendUnits[j].size(); ++p)
        for (size_t d = 0; d < c; ++d) out[c * p + d] = P.values[c * size_t(P.sendUnits[j][p]) + d];
      MPI_Isend(out.data(), int(out.size()), MPI_DOUBLE, ranks_[j], tag, MPI_COMM_WORLD, &req[nb + j]);
    }
  }

  // Posts the receives and sends of the frontier values of `data` (comps per node) and keeps this
  // rank's own partial values.
  void start(const Real* data, int comps) {
    const size_t c = size_t(comps);
    self_.resize(c * frontier_.size());
    for (size_t k = 0; k < frontier_.size(); ++k)
      for (size_t d = 0; d < c; ++d) self_[c * k + d] = data[c * size_t(frontier_[k]) + d];
    for (size_t j = 0; j < ranks_.size(); ++j) {
      recv_[j].resize(c * nodes_[j].size());
      MPI_Irecv(recv_[j].data(), int(recv_[j].size()), MPI_DOUBLE, ranks_[j], kTag, MPI_COMM_WORLD, &requests_[j]);
    }
    for (size_t j = 0; j < ranks_.size(); ++j) {
      send_[j].resize(c * nodes_[j].size());
      for (size_t p = 0; p < nodes_[j].size(); ++p)
        for (size_t d = 0; d < c; ++d) send_[j][c * p + d] = data[c * size_t(nodes_[j][p]) + d];
      MPI_Isend(send_[j].data(), int(send_[j].size()), MPI_DOUBLE, ranks_[j], kTag, MPI_COMM_WORLD,
                &requests_[ranks_.size() + j]);
    }
  }
  // Waits for the frontier messages in flight, the wait counted in wait_.
  void waitAll() {
    const auto t0 = std::chrono::steady_clock::now();
    MPI_Waitall(int(requests_.size()), requests_.data(), MPI_STATUSES_IGNORE);
    wait_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  // Waits for them and writes each frontier node's total, summed in ascending rank order.
  void finish(Real* data, int comps) {
    waitAll();
    const size_t c = size_t(comps);
    for (size_t k = 0; k < frontier_.size(); ++k)
      for (size_t d = 0; d < c; ++d) {
        Real sum = 0;
        for (Index t = termStart_[k]; t < termStart_[k + 1]; ++t) {
          const Term& T = terms_[size_t(t)];
          sum += T.source < 0 ? self_[c * size_t(T.pos) + d] : recv_[size_t(T.source)][c * size_t(T.pos) + d];
        }
        data[c * size_t(frontier_[k]) + d] = sum;
      }
  }

  size_t frontierBlocks_;
  std::vector<std::uint8_t> owned_;
  std::vector<Index> ghosts_, frontier_;
  std::vector<int> ranks_;
  std::vector<std::vector<Index>> nodes_;
  std::vector<Term> terms_;
  std::vector<Index> termStart_;
  std::vector<Real> self_;
  std::vector<std::vector<Real>> send_, recv_;
  std::vector<Real> all_;  // sumAll's gathered values
  std::vector<MPI_Request> requests_;
  NodeSumPlan shares_, forces_;                 // the masses' and the forces' sums in the one-process order
  std::vector<std::vector<Index>> blockSlots_;  // [block][element] its corner forces' slot, or -1
  size_t summedNodes_ = 0;                      // nodes whose force is summed from corner forces
  int rank_ = 0, size_ = 1;
  std::vector<Index> ownedLocal_;            // this rank's owned nodes
  std::vector<int> ownedCounts_, ownedIds_;  // rank 0: every rank's owned nodes (global indices)
  size_t globalNodes_ = 0;
  const Mesh* global_;                                      // the whole mesh (subcycle())
  std::vector<int> part_;                                   // the partition
  RankLayout layout_;                                       // this rank's lists (its mesh left out)
  std::vector<std::vector<Index>> opLumped_;                // [one-process block] its element order
  std::vector<std::vector<Index>> levelStart_, levelUnit_;  // subcycling: [level] each node's units
  std::vector<std::vector<Real>> planSend_;
  std::vector<MPI_Request> planRequests_;
  double wait_ = 0;  // s waiting in finish() and sumAll()
};

}  // namespace

std::unique_ptr<RankExchange> makeRankExchange(const RankLayout& layout, size_t frontierBlocks, const Mesh& global,
                                               const std::vector<int>& part, const std::vector<Index>& blockRegions,
                                               const std::vector<std::unique_ptr<ElementBlock>>& blocks) {
  return std::make_unique<MpiRankExchange>(layout, frontierBlocks, global, part, blockRegions, blocks);
}

#else

bool rankRunsAvailable() { return false; }

std::unique_ptr<RankExchange> makeRankExchange(const RankLayout&, size_t, const Mesh&, const std::vector<int>&,
                                               const std::vector<Index>&,
                                               const std::vector<std::unique_ptr<ElementBlock>>&) {
  throw InputError(
      "this tq-solid was built without MPI: it cannot run on ranks (install the MPI development files, "
      "e.g. libopenmpi-dev, and build again)");
}

#endif

}  // namespace tq
