// The water coupling of the solid on MPI ranks (tq/coupling/ranked_coupling.hpp): rank 0 runs the
// adapter and the carried laws on its whole-model mirror, gathering the wet nodes' state from their
// owners and sending their external force back to every copy.
#include "tq/coupling/ranked_coupling.hpp"

#include <chrono>
#include <stdexcept>

#ifdef TQ_SOLID_HAVE_MPI
#include <mpi.h>
#endif

namespace tq {

namespace {
// What a wet node's owner sends rank 0 each time: u, v, f_int, f_ext so far (3 each), the dashpot
// coefficients (3), the lumped mass: all the step's update of the node reads (WallPrediction).
constexpr int kPer = 16;
}  // namespace

struct RankedCoupling::Impl {
  explicit Impl(Solver& s) : local(s) {}
  int rank = 0, size = 1;
  Solver& local;
  Solver* view = nullptr;                  // rank 0: the mirror (one rank: the rank's own solver)
  std::shared_ptr<CarriedWater> water;     // rank 0
  std::shared_ptr<FluidCoupling> adapter;  // rank 0
  // This rank's wet nodes (their place k in the wetted face's list, their local index), and those it owns.
  std::vector<std::pair<size_t, Index>> held, owned;
  std::vector<int> counts, displs;  // rank 0: values from each rank in a gather
  std::vector<size_t> order;        // rank 0: the place k of each gathered node, in rank order
  std::vector<Real> mine, all, fe;

  /// Collective: the wet nodes' state, each from its owner, into the mirror's (rank 0).
  void gather(const NodalState& st, const std::vector<Index>& wet, double& seconds) {
    if (size == 1) return;
#ifdef TQ_SOLID_HAVE_MPI
    const auto t0 = std::chrono::steady_clock::now();
    mine.resize(kPer * owned.size());
    const Real *u = st.uData(), *v = st.vData(), *fi = st.fIntData(), *fx = st.fExtData(), *c = st.dashpotData();
    for (size_t q = 0; q < owned.size(); ++q) {
      const Index l = owned[q].second;
      Real* x = &mine[kPer * q];
      for (int d = 0; d < 3; ++d) {
        const size_t i = dofIndex(l, d);
        x[d] = u[i], x[3 + d] = v[i], x[6 + d] = fi[i], x[9 + d] = fx[i], x[12 + d] = c[i];
      }
      x[15] = st.mass(l);
    }
    MPI_Gatherv(mine.data(), int(mine.size()), MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0,
                MPI_COMM_WORLD);
    if (rank == 0) {
      NodalState& ms = view->state();
      Real *mu = ms.uData(), *mv = ms.vData(), *mfi = ms.fIntData(), *mfe = ms.fExtData();
      for (size_t q = 0; q < order.size(); ++q) {
        const Index n = wet[order[q]];
        const Real* x = &all[kPer * q];
        for (int d = 0; d < 3; ++d) {
          const size_t i = dofIndex(n, d);
          mu[i] = x[d], mv[i] = x[3 + d], mfi[i] = x[6 + d], mfe[i] = x[9 + d];
          if (ms.dashpot(n, d) != x[12 + d]) {  // set exactly: c + (−c) is 0, then 0 + x is x
            ms.addDashpot(n, d, -ms.dashpot(n, d));
            ms.addDashpot(n, d, x[12 + d]);
          }
        }
        if (ms.mass(n) != x[15]) {
          ms.addMass(n, -ms.mass(n));
          ms.addMass(n, x[15]);
        }
      }
      view->setTime(local.time());
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
#else
    (void)st, (void)wet, (void)seconds;
#endif
  }

  /// Rank 0 runs `part`; an error it meets is thrown on every rank alike (its type and message).
  template <class F>
  void onRoot(F&& part, double& seconds) {
    int code = 0;
    std::string why;
    if (rank == 0) {
      try {
        part();
      } catch (const CouplingError& e) {
        code = 4, why = e.what();
      } catch (const InstabilityError& e) {
        code = 3, why = e.what();
      } catch (const InputError& e) {
        code = 2, why = e.what();
      } catch (const std::exception& e) {
        code = 1, why = e.what();
      }
    }
#ifdef TQ_SOLID_HAVE_MPI
    if (size > 1) {
      const auto t0 = std::chrono::steady_clock::now();
      MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
      if (code) {
        unsigned long long n = why.size();
        MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
        why.resize(size_t(n));
        MPI_Bcast(why.data(), int(n), MPI_CHAR, 0, MPI_COMM_WORLD);
      }
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
#else
    (void)seconds;
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

  /// Collective: `n` values of rank 0 on every rank.
  void broadcast(Real* x, int n, double& seconds) {
#ifdef TQ_SOLID_HAVE_MPI
    if (size == 1) return;
    const auto t0 = std::chrono::steady_clock::now();
    MPI_Bcast(x, n, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
#else
    (void)x, (void)n, (void)seconds;
#endif
  }
};

RankedCoupling::RankedCoupling(const CouplingInput& in, const Mesh& global, const std::vector<Index>& localNode,
                               const std::vector<std::uint8_t>& owned, Solver& local, Solver* mirror)
    : impl_(std::make_unique<Impl>(local)) {
  Impl& I = *impl_;
#ifdef TQ_SOLID_HAVE_MPI
  int ready = 0;
  MPI_Initialized(&ready);
  if (ready) {
    MPI_Comm_rank(MPI_COMM_WORLD, &I.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &I.size);
  }
#endif
  I.view = I.size == 1 ? &local : mirror;
  wet_ = wallNodes(global, in.face);  // an InputError on every rank alike
  for (size_t k = 0; k < wet_.size(); ++k) {
    const Index l = I.size == 1 ? wet_[k] : localNode[size_t(wet_[k])];
    if (l < 0) continue;
    I.held.emplace_back(k, l);
    if (I.size == 1 || owned[size_t(l)]) I.owned.emplace_back(k, l);
  }
#ifdef TQ_SOLID_HAVE_MPI
  if (I.size > 1) {
    // Who sends which wet node, once: the counts and places, on rank 0 in rank order.
    const int n = int(I.owned.size());
    std::vector<int> nodeCounts(size_t(I.size), 0), nodeDispls(size_t(I.size), 0);
    MPI_Gather(&n, 1, MPI_INT, nodeCounts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<long long> ks, allKs;
    for (const auto& [k, l] : I.owned) ks.push_back((long long)k);
    if (I.rank == 0) {
      I.counts.assign(size_t(I.size), 0), I.displs.assign(size_t(I.size), 0);
      for (int r = 0; r < I.size; ++r) {
        if (r > 0) nodeDispls[size_t(r)] = nodeDispls[size_t(r) - 1] + nodeCounts[size_t(r) - 1];
        I.counts[size_t(r)] = kPer * nodeCounts[size_t(r)];
        I.displs[size_t(r)] = kPer * nodeDispls[size_t(r)];
      }
      allKs.resize(size_t(nodeDispls.back() + nodeCounts.back()));
      I.all.resize(kPer * allKs.size());
    }
    MPI_Gatherv(ks.data(), n, MPI_LONG_LONG, allKs.data(), nodeCounts.data(), nodeDispls.data(), MPI_LONG_LONG, 0,
                MPI_COMM_WORLD);
    if (I.rank == 0) {
      for (long long k : allKs) I.order.push_back(size_t(k));
      if (I.order.size() != wet_.size())  // every wet node has one owner (RankLayout)
        throw std::logic_error("the wet nodes' owners do not cover the wetted face");
    }
    // The wet nodes' supports as the ranks' solvers hold them (the staged analysis sets them) on
    // the mirror, which the prediction of the wall's motion reads.
    std::vector<Real> fixed, allFixed;
    for (const auto& [k, l] : I.owned)
      for (int d = 0; d < 3; ++d) fixed.push_back(local.isFixed(l, d) ? 1.0 : 0.0);
    std::vector<int> c3(size_t(I.size)), d3(size_t(I.size));
    for (int r = 0; r < I.size && I.rank == 0; ++r)
      c3[size_t(r)] = 3 * nodeCounts[size_t(r)], d3[size_t(r)] = 3 * nodeDispls[size_t(r)];
    if (I.rank == 0) allFixed.assign(3 * wet_.size(), 0.0);
    MPI_Gatherv(fixed.data(), int(fixed.size()), MPI_DOUBLE, allFixed.data(), c3.data(), d3.data(), MPI_DOUBLE, 0,
                MPI_COMM_WORLD);
    if (I.rank == 0)
      for (size_t q = 0; q < I.order.size(); ++q)
        for (int d = 0; d < 3; ++d) {
          const Index node = wet_[I.order[q]];
          if (allFixed[3 * q + size_t(d)] != 0)
            mirror->fix(node, d);
          else
            mirror->release(node, d);
        }
  }
#endif
  I.gather(local.state(), wet_, secondsComm_);
  Real info[4] = {0, 0, 0, 0};
  I.onRoot(
      [&] {
        if (I.size > 1) {
          if (I.view->massDampingCoefficient() != local.massDampingCoefficient())
            throw std::logic_error("the whole-model mirror's mass damping differs from the ranks' solvers'");
          I.view->setTimeStep(local.dt());
        }
        I.water = CarriedWater::fromCoupling(*I.view, in);
        I.adapter = std::make_shared<FluidCoupling>(*I.view, in, I.water.get());
        I.adapter->tellTimeBy(local);  // its messages say the ranks' time and step, not the mirror's
        info[0] = I.adapter->repeatsWindows() ? 1 : 0;
        info[1] = Real(I.adapter->windowSteps());
        info[2] = I.adapter->endTime();
        info[3] = Real(I.adapter->windowCount());
      },
      secondsComm_);
  I.broadcast(info, 4, secondsComm_);
  repeats_ = info[0] != 0;
  steps_ = Index(info[1]);
  endTime_ = info[2];
  windows_ = (long long)info[3];
  I.fe.assign(3 * wet_.size(), 0.0);
}

bool RankedCoupling::constrainLevels(std::vector<std::uint8_t>& level) const {
  std::vector<Index> nodes;
  for (const auto& h : impl_->held) nodes.push_back(h.second);
  return lowerToFinestLevel(level, nodes);
}

RankedCoupling::~RankedCoupling() = default;

void RankedCoupling::initialize() {
  impl_->onRoot([&] { impl_->adapter->initialize(); }, secondsComm_);
}

void RankedCoupling::finalize() {
  impl_->onRoot([&] { impl_->adapter->finalize(); }, secondsComm_);
}

void RankedCoupling::abort(const std::string& reason) noexcept {
  if (impl_->adapter) impl_->adapter->abort(reason);
}

FluidCoupling* RankedCoupling::adapter() { return impl_->adapter.get(); }
const CarriedWater* RankedCoupling::water() const { return impl_->water.get(); }

std::string RankedCoupling::name() const { return "water coupling on the ranks (rank 0 exchanges)"; }

// In the one-process order: the exchanged force, then the pressure the solid carries (their
// predictions read the f_ext the one before added), on rank 0's mirror; f_ext back to every copy.
void RankedCoupling::addForces(Real t, Real dt, NodalState& st) {
  Impl& I = *impl_;
  I.gather(st, wet_, secondsComm_);
  I.onRoot(
      [&] {
        NodalState& ms = I.size == 1 ? st : I.view->state();
        I.adapter->addForces(t, dt, ms);
        if (I.water) I.water->addForces(t, dt, ms);
        if (I.size > 1)
          for (size_t k = 0; k < wet_.size(); ++k)
            for (int d = 0; d < 3; ++d) I.fe[3 * k + size_t(d)] = ms.fExt(wet_[k], d);
      },
      secondsComm_);
  if (I.size == 1) return;
  I.broadcast(I.fe.data(), int(I.fe.size()), secondsComm_);
  Real* fx = st.fExtData();
  for (const auto& [k, l] : I.held)
    for (int d = 0; d < 3; ++d) fx[dofIndex(l, d)] = I.fe[3 * k + size_t(d)];
}

void RankedCoupling::checkpoint(StateArchive& a) {
  Impl& I = *impl_;
  if (!I.adapter) return;
  I.adapter->checkpoint(a);
  if (I.water) I.water->checkpoint(a);
}

void RankedCoupling::planWindow(const NodalState& st) {
  Impl& I = *impl_;
  I.gather(st, wet_, secondsComm_);
  I.onRoot([&] { I.adapter->planWindow(I.size == 1 ? st : I.view->state()); }, secondsComm_);
}

void RankedCoupling::planStep(Index j, Real dt) {
  impl_->onRoot([&] { impl_->adapter->planStep(j, dt); }, secondsComm_);
  open_ = true;
}

bool RankedCoupling::exchange(Real dt, const NodalState& st) {
  Impl& I = *impl_;
  I.gather(st, wet_, secondsComm_);
  Real accepted = 0;
  I.onRoot([&] { accepted = I.adapter->exchange(dt, I.size == 1 ? st : I.view->state()) ? 1 : 0; }, secondsComm_);
  I.broadcast(&accepted, 1, secondsComm_);
  open_ = false;
  return accepted != 0;
}

void RankedCoupling::acceptWindow() {
  impl_->onRoot([&] { impl_->adapter->acceptWindow(); }, secondsComm_);
  ++done_;
}

// Restart checkpoints: the windows done on every rank, the adapter's state across windows on rank 0.
void RankedCoupling::restartState(StateArchive& a) {
  a.io(done_);
  if (impl_->adapter) impl_->adapter->restartState(a);
}

void RankedCoupling::initializeResumed() {
  impl_->onRoot([&] { impl_->adapter->initializeResumed(); }, secondsComm_);
}

}  // namespace tq
