#include "tq/parallel/rank_exchange.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#ifdef TQ_SOLID_HAVE_MPI
#include <mpi.h>
#endif

namespace tq {

#ifdef TQ_SOLID_HAVE_MPI

bool rankRunsAvailable() { return true; }

namespace {

class MpiRankExchange final : public RankExchange {
 public:
  MpiRankExchange(const RankLayout& L, size_t frontierBlocks)
      : frontierBlocks_(frontierBlocks), owned_(L.owned), ghosts_(L.ghosts), frontier_(L.frontier) {
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
  void beginForceSum(const Real* f) override { start(f, 3); }
  void finishForceSum(Real* f) override { finish(f, 3); }

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
  static constexpr int kTag = 4301;

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
  // Waits for them and writes each frontier node's total, summed in ascending rank order.
  void finish(Real* data, int comps) {
    const auto t0 = std::chrono::steady_clock::now();
    MPI_Waitall(int(requests_.size()), requests_.data(), MPI_STATUSES_IGNORE);
    wait_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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
  double wait_ = 0;  // s waiting in finish() and sumAll()
};

}  // namespace

std::unique_ptr<RankExchange> makeRankExchange(const RankLayout& layout, size_t frontierBlocks) {
  return std::make_unique<MpiRankExchange>(layout, frontierBlocks);
}

#else

bool rankRunsAvailable() { return false; }

std::unique_ptr<RankExchange> makeRankExchange(const RankLayout&, size_t) {
  throw InputError(
      "this tq-solid was built without MPI: it cannot run on ranks (install the MPI development files, "
      "e.g. libopenmpi-dev, and build again)");
}

#endif

}  // namespace tq
