// The water coupling of the solid on MPI ranks (tq/coupling/ranked_coupling.hpp): each rank exchanges
// its own part of the wetted face with the water; the sums over the wet nodes are taken in the
// one-process order on every rank, from every node's terms gathered in one collective.
#include "tq/coupling/ranked_coupling.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#ifdef TQ_SOLID_HAVE_MPI
#include <mpi.h>
#endif

namespace tq {

namespace {
#ifdef TQ_SOLID_HAVE_MPI
constexpr int kFrontierTag = 0x7F02;  // this file's messages among the ranks
#endif
}  // namespace

struct RankedCoupling::Impl {
  explicit Impl(Solver& s) : local(s) {}
  int rank = 0, size = 1;
  Solver& local;
  WetPart part;                            // this rank's part of the face (its owned wet nodes)
  std::shared_ptr<CarriedWater> water;     // on this rank's part
  std::shared_ptr<FluidCoupling> adapter;  // on this rank's part
  std::vector<Index> partNodes;            // the part's nodes (this solver's indices), in place order
  std::vector<Index> heldNodes;            // every wet node this rank holds, owned or a frontier copy
  // The frontier's wet nodes: the local nodes whose f_ext this rank sends each other holder (it owns
  // them) or receives from their owner, per rank, in place order.
  std::vector<std::pair<int, std::vector<Index>>> sendTo, recvFrom;
  std::vector<std::vector<Real>> sendBuf, recvBuf;
  // Every rank's node count and the places of its nodes, in rank order (allPlaces: rank 0's nodes,
  // then rank 1's, ...), on every rank.
  std::vector<int> nodeCounts;
  std::vector<long long> allPlaces;
  // Results (rank 0): the gather's counts and offsets (4 values a node), the face's force last added.
  std::vector<int> counts, displs;
  std::vector<Real> mine, gathered, wholeForce;
  // WetPart::gather's counts and offsets for its width, and its values in rank order.
  std::vector<int> gatherCounts, gatherDispls;
  std::vector<Real> byRank;
  double *seconds = nullptr, *sumSeconds = nullptr;  // the messages' time, and the gathers' of it
  long long* sums = nullptr;                         // the gathers

  /// WetPart::gather: one MPI_Allgatherv of every rank's `width` values a node, then put in the face's
  /// order (allPlaces).
  void gather(const std::vector<Real>& mineTerms, size_t width, std::vector<Real>& whole) {
#ifdef TQ_SOLID_HAVE_MPI
    const auto t0 = std::chrono::steady_clock::now();
    gatherCounts.resize(size_t(size)), gatherDispls.resize(size_t(size));
    int at = 0;
    for (int r = 0; r < size; ++r) {
      gatherCounts[size_t(r)] = int(width) * nodeCounts[size_t(r)];
      gatherDispls[size_t(r)] = at;
      at += gatherCounts[size_t(r)];
    }
    byRank.resize(size_t(at));
    MPI_Allgatherv(mineTerms.data(), gatherCounts[size_t(rank)], MPI_DOUBLE, byRank.data(), gatherCounts.data(),
                   gatherDispls.data(), MPI_DOUBLE, MPI_COMM_WORLD);
    whole.resize(size_t(at));
    for (size_t i = 0; i < allPlaces.size(); ++i)
      std::copy_n(byRank.data() + width * i, width, whole.data() + width * size_t(allPlaces[i]));
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    *seconds += s, *sumSeconds += s, ++*sums;
#else
    (void)mineTerms, (void)width, (void)whole;
#endif
  }

  /// Collective: `part` on every rank; an error any rank meets is thrown on every rank alike (the
  /// worst kind, the lowest such rank's message).
  template <class F>
  void together(F&& step) {
    int code = 0;
    std::string why;
    try {
      step();
    } catch (const CouplingError& e) {
      code = 4, why = e.what();
    } catch (const InstabilityError& e) {
      code = 3, why = e.what();
    } catch (const InputError& e) {
      code = 2, why = e.what();
    } catch (const std::exception& e) {
      code = 1, why = e.what();
    }
#ifdef TQ_SOLID_HAVE_MPI
    if (size > 1) {
      const auto t0 = std::chrono::steady_clock::now();
      struct {
        int code, rank;
      } in{code, rank}, out{0, 0};
      MPI_Allreduce(&in, &out, 1, MPI_2INT, MPI_MAXLOC, MPI_COMM_WORLD);
      if (out.code) {
        unsigned long long n = why.size();
        MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, out.rank, MPI_COMM_WORLD);
        why.resize(size_t(n));
        MPI_Bcast(why.data(), int(n), MPI_CHAR, out.rank, MPI_COMM_WORLD);
        code = out.code;
      }
      *seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
#endif
    switch (code) {
      case 0:
        return;
      case 4:
        throw CouplingError(why);
      case 3:
        throw InstabilityError(why);
      case 2:
        throw InputError(why);
      default:
        throw std::runtime_error(why);
    }
  }

  /// The steps' works booked, the carried laws' and the adapter's in one gather.
  void flushWork() {
    if (size == 1) return;  // one process books each step's own
    if (water)
      flushWetWork(part, {water->workBook(), adapter->workBook()});
    else
      flushWetWork(part, {adapter->workBook()});
  }

  /// The frontier's wet nodes: each owner's f_ext to the other ranks that hold the node.
  void sendFrontier(NodalState& st) {
#ifdef TQ_SOLID_HAVE_MPI
    if (sendTo.empty() && recvFrom.empty()) return;
    const auto t0 = std::chrono::steady_clock::now();
    Real* fx = st.fExtData();
    std::vector<MPI_Request> req;
    for (size_t i = 0; i < recvFrom.size(); ++i) {
      recvBuf[i].resize(3 * recvFrom[i].second.size());
      req.emplace_back();
      MPI_Irecv(recvBuf[i].data(), int(recvBuf[i].size()), MPI_DOUBLE, recvFrom[i].first, kFrontierTag, MPI_COMM_WORLD,
                &req.back());
    }
    for (size_t i = 0; i < sendTo.size(); ++i) {
      sendBuf[i].clear();
      for (Index l : sendTo[i].second)
        for (int d = 0; d < 3; ++d) sendBuf[i].push_back(fx[dofIndex(l, d)]);
      req.emplace_back();
      MPI_Isend(sendBuf[i].data(), int(sendBuf[i].size()), MPI_DOUBLE, sendTo[i].first, kFrontierTag, MPI_COMM_WORLD,
                &req.back());
    }
    MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE);
    for (size_t i = 0; i < recvFrom.size(); ++i)
      for (size_t q = 0; q < recvFrom[i].second.size(); ++q)
        for (int d = 0; d < 3; ++d) fx[dofIndex(recvFrom[i].second[q], d)] = recvBuf[i][3 * q + size_t(d)];
    *seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
#else
    (void)st;
#endif
  }
};

RankedCoupling::RankedCoupling(const CouplingInput& in, const Mesh& global, const RankLayout& L, Solver& local)
    : impl_(std::make_unique<Impl>(local)) {
  Impl& I = *impl_;
  I.seconds = &secondsComm_;
  I.sumSeconds = &secondsSums_;
  I.sums = &sums_;
#ifdef TQ_SOLID_HAVE_MPI
  int ready = 0;
  MPI_Initialized(&ready);
  if (ready) {
    MPI_Comm_rank(MPI_COMM_WORLD, &I.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &I.size);
  }
#endif
  wet_ = wallNodes(global, in.face);  // an InputError on every rank alike
  if (I.size == 1) {                  // the one-process run
    I.heldNodes = wet_;
    I.together([&] {
      I.water = CarriedWater::fromCoupling(local, in);
      I.adapter = std::make_shared<FluidCoupling>(local, in, I.water.get());
    });
  } else {
#ifdef TQ_SOLID_HAVE_MPI
    // This rank's part: the wet nodes it owns, in the face's order; the frontier's other holders and
    // this rank's copies of wet nodes other ranks own.
    std::vector<std::pair<int, std::vector<Index>>> sendTo, recvFrom;
    auto listFor = [](std::vector<std::pair<int, std::vector<Index>>>& lists, int r) -> std::vector<Index>& {
      for (auto& [who, nodes] : lists)
        if (who == r) return nodes;
      lists.emplace_back(r, std::vector<Index>{});
      return lists.back().second;
    };
    std::vector<std::int64_t> ids;
    for (size_t k = 0; k < wet_.size(); ++k) {
      const Index l = L.localNode[size_t(wet_[k])];
      if (l < 0) continue;
      I.heldNodes.push_back(l);
      if (L.owned[size_t(l)]) {
        I.part.places.push_back(k);
        I.partNodes.push_back(l);
        ids.push_back(std::int64_t(wet_[k]));
      } else {
        I.part.copies.emplace_back(l, k);
      }
      const auto f = std::lower_bound(L.frontier.begin(), L.frontier.end(), l);
      if (f == L.frontier.end() || *f != l) continue;
      const size_t fi = size_t(f - L.frontier.begin());
      const int* holders = &L.frontierRanks[size_t(L.frontierStart[fi])];
      const size_t nh = size_t(L.frontierStart[fi + 1] - L.frontierStart[fi]);
      const int owner = *std::min_element(holders, holders + nh);
      for (size_t h = 0; h < nh; ++h)
        if (holders[h] != I.rank && owner == I.rank)
          listFor(sendTo, holders[h]).push_back(l);
        else if (holders[h] == owner && owner != I.rank)
          listFor(recvFrom, owner).push_back(l);
    }
    std::sort(sendTo.begin(), sendTo.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::sort(recvFrom.begin(), recvFrom.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    I.sendTo = std::move(sendTo), I.recvFrom = std::move(recvFrom);
    I.sendBuf.resize(I.sendTo.size()), I.recvBuf.resize(I.recvFrom.size());
    // Every rank's nodes, on every rank: the gathers of the sums put each node's terms in its place.
    const int mineCount = int(I.part.places.size());
    I.nodeCounts.assign(size_t(I.size), 0);
    MPI_Allgather(&mineCount, 1, MPI_INT, I.nodeCounts.data(), 1, MPI_INT, MPI_COMM_WORLD);
    std::vector<int> placeDispls(size_t(I.size), 0);
    for (int r = 1; r < I.size; ++r) placeDispls[size_t(r)] = placeDispls[size_t(r) - 1] + I.nodeCounts[size_t(r) - 1];
    const size_t total = size_t(placeDispls.back() + I.nodeCounts.back());
    if (total != wet_.size()) throw std::logic_error("the wet nodes' owners do not cover the wetted face once each");
    std::vector<long long> places(I.part.places.begin(), I.part.places.end());
    I.allPlaces.resize(total);
    MPI_Allgatherv(places.data(), mineCount, MPI_LONG_LONG, I.allPlaces.data(), I.nodeCounts.data(), placeDispls.data(),
                   MPI_LONG_LONG, MPI_COMM_WORLD);
    std::vector<std::uint8_t> seen(wet_.size(), 0);
    for (long long k : I.allPlaces)
      if (k < 0 || size_t(k) >= wet_.size() || seen[size_t(k)]++)
        throw std::logic_error("the wet nodes' owners do not cover the wetted face once each");
    int copiesHere = I.part.copies.empty() ? 0 : 1, copiesAnywhere = 0;
    MPI_Allreduce(&copiesHere, &copiesAnywhere, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    I.part.copiesAnywhere = copiesAnywhere != 0;
    I.part.wholeCount = wet_.size();
    I.part.part = I.rank;
    I.part.parts = I.size;
    I.part.gather = [&I](const std::vector<Real>& m, size_t width, std::vector<Real>& whole) {
      I.gather(m, width, whole);
    };
    // Results: rank 0 gathers each rank's nodes' force and mass (4 values a node).
    if (I.rank == 0) {
      I.counts.resize(size_t(I.size)), I.displs.resize(size_t(I.size));
      for (int r = 0; r < I.size; ++r)
        I.counts[size_t(r)] = 4 * I.nodeCounts[size_t(r)], I.displs[size_t(r)] = 4 * placeDispls[size_t(r)];
      I.gathered.resize(4 * wet_.size());
      I.wholeForce.assign(3 * wet_.size(), 0.0);
    }
    I.together([&] {
      if (in.volumeLaw != "none") I.water = std::make_shared<CarriedWater>(local, in, global, I.part, I.partNodes);
      I.adapter = std::make_shared<FluidCoupling>(local, in, I.water.get(), I.part, I.partNodes, std::move(ids));
    });
#endif
  }
  repeats_ = I.adapter->repeatsWindows();
  steps_ = I.adapter->windowSteps();
  endTime_ = I.adapter->endTime();
  windows_ = I.adapter->windowCount();
}

bool RankedCoupling::constrainLevels(std::vector<std::uint8_t>& level) const {
  return lowerToFinestLevel(level, impl_->heldNodes);
}

RankedCoupling::~RankedCoupling() = default;

void RankedCoupling::initialize() {
  impl_->together([&] { impl_->adapter->initialize(); });
}

void RankedCoupling::finalize() {
  impl_->together([&] {
    impl_->flushWork();
    impl_->adapter->finalize();
  });
}

void RankedCoupling::abort(const std::string& reason) noexcept {
  if (impl_->adapter) impl_->adapter->abort(reason);
}

FluidCoupling* RankedCoupling::adapter() { return impl_->adapter.get(); }
const CarriedWater* RankedCoupling::water() const { return impl_->water.get(); }
Index RankedCoupling::partNodes() const { return Index(impl_->adapter->nodes().size()); }
std::vector<Index> RankedCoupling::partCounts() const {
  std::vector<Index> n;
  if (impl_->size == 1) return {wetNodes()};
  for (int c : impl_->counts) n.push_back(Index(c / 4));
  return n;
}

void RankedCoupling::observe(Solver* view) {
  Impl& I = *impl_;
  if (I.size == 1) return;
  I.flushWork();
#ifdef TQ_SOLID_HAVE_MPI
  const auto t0 = std::chrono::steady_clock::now();
  // each wet node's force (3) and its mass as this rank sums it (the one-process sum), from its owner
  const std::vector<Real>& f = I.adapter->force();
  I.mine.clear();
  for (size_t q = 0; q < I.partNodes.size(); ++q) {
    I.mine.insert(I.mine.end(), f.begin() + long(3 * q), f.begin() + long(3 * q + 3));
    I.mine.push_back(I.local.state().mass(I.partNodes[q]));
  }
  MPI_Gatherv(I.mine.data(), int(I.mine.size()), MPI_DOUBLE, I.gathered.data(), I.counts.data(), I.displs.data(),
              MPI_DOUBLE, 0, MPI_COMM_WORLD);
  if (I.rank == 0 && view) {
    NodalState& ms = view->state();
    for (size_t q = 0; q < I.allPlaces.size(); ++q) {
      const size_t k = size_t(I.allPlaces[q]);
      for (size_t d = 0; d < 3; ++d) I.wholeForce[3 * k + d] = I.gathered[4 * q + d];
      const Index n = wet_[k];
      if (ms.mass(n) != I.gathered[4 * q + 3]) {  // set exactly: m + (−m) is 0, then 0 + x is x
        ms.addMass(n, -ms.mass(n));
        ms.addMass(n, I.gathered[4 * q + 3]);
      }
    }
  }
  secondsComm_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
#else
  (void)view;
#endif
}

const std::vector<Real>& RankedCoupling::wetForce() const {
  return impl_->size == 1 ? impl_->adapter->force() : impl_->wholeForce;
}

std::string RankedCoupling::name() const { return "water coupling on the ranks (each rank its part)"; }

// In the one-process order: the exchanged force, then the pressure the solid carries (its prediction
// reads the f_ext the exchanged force added), on this rank's part; the frontier's f_ext to its copies:
// with the carried laws it travels with their sums' terms (CarriedWater sets the copies), else in a
// message of its own from each owner.
// Neither meets an error one rank alone would (a step outside the protocol is one on every rank): no
// agreement is needed.
void RankedCoupling::addForces(Real t, Real dt, NodalState& st) {
  Impl& I = *impl_;
  I.adapter->addForces(t, dt, st);
  if (I.water) I.water->addForces(t, dt, st);
  if (!I.water) I.sendFrontier(st);  // with the carried laws the copies' f_ext came with their sums
}

void RankedCoupling::checkpoint(StateArchive& a) {
  Impl& I = *impl_;
  I.adapter->checkpoint(a);
  if (I.water) I.water->checkpoint(a);
}

void RankedCoupling::planWindow(const NodalState& st) {
  impl_->together([&] { impl_->adapter->planWindow(st); });
}

void RankedCoupling::planStep(Index j, Real dt) {
  impl_->adapter->planStep(j, dt);  // inside the window: no exchange, an error alike on every rank
  open_ = true;
}

bool RankedCoupling::exchange(Real dt, const NodalState& st) {
  bool accepted = false;
  impl_->together([&] { accepted = impl_->adapter->exchange(dt, st); });
  open_ = false;
  return accepted;  // the water's flag, the same on every part
}

void RankedCoupling::acceptWindow() {
  impl_->together([&] {
    impl_->flushWork();  // the energy guard reads the works
    impl_->adapter->acceptWindow();
  });
  ++done_;
}

// Restart checkpoints: the windows done, and each rank's adapter's state across windows (its part of
// the coupler's solid participant among it). At a window's end the works are booked (acceptWindow
// folded them), so no step's term is pending.
void RankedCoupling::restartState(StateArchive& a) {
  a.io(done_);
  impl_->adapter->restartState(a);
}

// Every rank's part connects to the water and carries on from its saved state; an error one part
// meets is thrown on every rank.
void RankedCoupling::initializeResumed() {
  impl_->together([&] { impl_->adapter->initializeResumed(); });
}

}  // namespace tq
