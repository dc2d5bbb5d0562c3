// tq-solid on MPI ranks (docs/architecture.md "The solid on ranks"). Every rank reads the input
// and the global mesh and partitions it the same way (recursive coordinate bisection weighted by
// element cost); each then builds a solver of its own elements and their nodes. Every node's mass
// and internal force is summed from its elements' values in the one-process order, the frontier
// elements' values sent to the ranks that share their nodes (rank_exchange), so a run on ranks has
// the one-process run's bits; the step size, the energies and the norms are reduced over every
// rank. Rank 0 also holds the whole model as a mirror: at the sample and snapshot times the ranks'
// nodes and elements are gathered into it, and the serial results writer writes the one results
// file from it. Restart checkpoints: each rank saves its part's state, rank 0 gathers them into the
// one-process run's checkpoint files (coupled with the water: at the end of every K-th window, with
// the coupling's state, as one process).
#include "tq/app/ranked_run.hpp"

#include "tq/app/app.hpp"

#include <hdf5.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#ifdef TQ_SOLID_HAVE_MPI
#include <mpi.h>
#include <pthread.h>
#include <sys/resource.h>
#endif

#include "tq/app/stages.hpp"
#include "tq/contact/contact.hpp"
#include "tq/coupling/coupled_stepper.hpp"
#include "tq/coupling/coupling_results.hpp"
#include "tq/coupling/ranked_coupling.hpp"
#include "tq/io/input.hpp"
#include "tq/io/restart.hpp"
#include "tq/io/results.hpp"
#include "tq/materials/registry.hpp"
#include "tq/parallel/partition.hpp"
#include "tq/parallel/rank_exchange.hpp"
#include "tq/parallel/rank_layout.hpp"

namespace tq {

bool wantsRankedRun(const std::vector<std::string>& args) {
  return std::find(args.begin(), args.end(), "--distributed") != args.end();
}

namespace {

#ifdef TQ_SOLID_HAVE_MPI
/// A run on ranks ended from outside: mpirun ends every rank with SIGTERM when one of them dies
/// (killed, crashed) or when the run is stopped (Ctrl-C, `tunnelquake run` stopping). A thread of
/// each rank waits for it (the signals blocked in every other thread); rank 0 then writes the
/// results file's status, between two of its writes (the writer's lock), and every rank exits.
struct StopWatch {
  std::mutex mutex;                 // held by every use of the results writer
  ResultsWriter* writer = nullptr;  // rank 0's, while it is open
};
StopWatch gStop;

void waitForStop(sigset_t signals) {
  int sig = 0;
  if (sigwait(&signals, &sig) != 0) return;
  {
    std::lock_guard<std::mutex> lock(gStop.mutex);
    if (gStop.writer) {
      std::ostringstream os;
      os << "stopped: the run on ranks was ended by signal " << sig
         << (sig == SIGTERM ? " (SIGTERM: mpirun ends every rank when one of them is lost, or when the run is stopped)"
                            : "")
         << "; the results up to t = " << gStop.writer->lastSampleTime() << " s are kept";
      try {
        gStop.writer->setStatus(os.str());
        std::cerr << "tq-solid: " << os.str().substr(9) << "\n";
      } catch (const std::exception&) {
      }
    }
  }
  std::_Exit(128 + sig);
}
#endif

int parseRankCommandLine(const std::vector<std::string>& args, std::ostream& err, RunOptions& cl) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--distributed") {
    } else if (!takeRunOption(args, i, cl)) {
      err << "tq-solid: unknown argument '" << a << "' (on ranks: tq-solid solid_input.h5 --distributed [-o "
          << "results.h5] [--threads N] [--check] [--checkpoint-dir DIR [--resume [--resume-sequence N]]])\n";
      return 1;
    }
  }
  if (cl.input.empty()) {
    err << "tq-solid: no input file given (tq-solid solid_input.h5 --distributed)\n";
    return 1;
  }
  if (cl.resume && cl.checkpointDir.empty()) {
    err << "tq-solid: --resume needs --checkpoint-dir (where the checkpoints are)\n";
    return 1;
  }
  return -1;
}

#ifdef TQ_SOLID_HAVE_MPI

/// What the run on ranks does not support yet, or "" (the same answer on every rank: the input is
/// the same file).
std::string unsupportedOnRanks(const SolidInput& in, int ranks) {
  const std::string fix = "; run it without --ranks (one process, OpenMP threads), or leave that part out";
  // The reinforced lining's section share reads the element's face-row partners among its block's
  // elements: on several ranks a partner may sit on another rank (s = 0 there, not as one process).
  for (const auto& [region, v] : in.materials)
    if (ranks > 1 && v.model == "reinforced_concrete")
      return "the reinforced_concrete material (region '" + region +
             "': its section share needs the whole lining ring on one rank) does not run on ranks yet; use "
             "mohr_coulomb_damage or elastic there, or run it without --ranks (one process, OpenMP threads)";
  const StagedInput& S = in.staged;
  if (S.present) {
    if (S.drm.present()) return "the domain reduction layer (/drm, incident_wave) does not run on ranks yet" + fix;
    if (S.faultOffset.present) return "the fault offset (/fault_offset) does not run on ranks yet" + fix;
    if (S.periodic.present) return "periodic faces (/boundaries periodic) do not run on ranks yet" + fix;
  }
  if (in.options.integrator != Integrator::CentralDifference)
    return "the integrator " + integratorName(in.options.integrator) +
           " does not run on ranks (central_difference only)" + fix;
  return "";
}

/// The state rank 0 needs for the results: each rank's owned nodes (u, v, a) and its elements
/// (ElementBlock::gatheredState: active flag, stress, strain record, history), gathered into the
/// mirror (a solver of the whole model on rank 0).
class StateGather {
 public:
  StateGather(const RankLayout& L, const Solver& local, Solver* mirror) {
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    for (size_t i = 0; i < L.globalNode.size(); ++i)
      if (L.owned[i]) {
        ownedLocal_.push_back(Index(i));
        nodeIds_.push_back(L.globalNode[i]);
      }
    for (const auto& b : local.blocks()) {
      R_ = std::max(R_, size_t(b->gatheredSize()));
      for (Index e = 0; e < b->numElems(); ++e) {
        elems_.emplace_back(b.get(), e);
        elemIds_.push_back(L.globalElem[size_t(b->meshElem(e))]);
      }
    }
    unsigned long long r = R_;
    MPI_Allreduce(MPI_IN_PLACE, &r, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
    R_ = size_t(r);
    nodeCounts_ = gatherIds(nodeIds_, allNodes_, rank, size);
    elemCounts_ = gatherIds(elemIds_, allElems_, rank, size);
    if (mirror) {
      mirrorElem_.assign(size_t(mirror->mesh().numElems()), {nullptr, -1});
      for (auto& b : mirror->blocks())
        for (Index e = 0; e < b->numElems(); ++e) mirrorElem_[size_t(b->meshElem(e))] = {b.get(), e};
    }
  }

  void gather(const Solver& local, Solver* mirror) {
    const NodalState& st = local.state();
    std::vector<Real> nodes;
    nodes.reserve(9 * ownedLocal_.size());
    for (Index n : ownedLocal_) {
      for (int d = 0; d < 3; ++d) nodes.push_back(st.u(n, d));
      for (int d = 0; d < 3; ++d) nodes.push_back(st.v(n, d));
      for (int d = 0; d < 3; ++d) nodes.push_back(st.a(n, d));
    }
    const size_t R = R_;
    std::vector<Real> elems(R * elems_.size(), 0.0);
    for (size_t k = 0; k < elems_.size(); ++k) {
      const auto [b, e] = elems_[k];
      b->gatheredState(e, &elems[R * k]);
    }
    std::vector<Real> allN, allE;
    gatherValues(nodes, nodeCounts_, 9, allN);
    gatherValues(elems, elemCounts_, int(R), allE);
    if (!mirror) return;
    NodalState& ms = mirror->state();
    for (size_t k = 0; k < allNodes_.size(); ++k) {
      const Index n = allNodes_[k];
      for (int d = 0; d < 3; ++d) {
        ms.u(n, d) = allN[9 * k + size_t(d)];
        ms.v(n, d) = allN[9 * k + 3 + size_t(d)];
        ms.a(n, d) = allN[9 * k + 6 + size_t(d)];
      }
    }
    for (size_t k = 0; k < allElems_.size(); ++k) {
      const auto [b, e] = mirrorElem_[size_t(allElems_[k])];
      b->setGatheredState(e, &allE[R * k]);
    }
    mirror->setTime(local.time());
    mirror->setReportedEnergy(local.energy());
  }

  /// The dynamic contact's pairs: each rank's owned pairs into the mirror's contact (rank 0), with
  /// the dissipated energy summed over the ranks. Every rank calls it alike.
  void gatherContact(const DynamicContact& local, const std::vector<Index>& pairIndex,
                     const std::vector<std::uint8_t>& owned, DynamicContact* mirror, RankExchange& rx) {
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (pairCounts_.empty()) {
      std::vector<Index> ids;
      for (size_t k = 0; k < pairIndex.size(); ++k)
        if (owned[k]) {
          ownedPairs_.push_back(Index(k));
          ids.push_back(pairIndex[k]);
        }
      pairCounts_ = gatherIds(ids, allPairs_, rank, size);
    }
    constexpr int P = DynamicContact::kGatheredSize;
    std::vector<Real> mine(P * ownedPairs_.size()), all;
    for (size_t k = 0; k < ownedPairs_.size(); ++k) local.gatheredPair(ownedPairs_[k], &mine[P * k]);
    gatherValues(mine, pairCounts_, P, all);
    Real dissipated = local.dissipatedEnergy();
    rx.sumAll(&dissipated, 1);
    if (!mirror) return;
    for (size_t k = 0; k < allPairs_.size(); ++k) mirror->setGatheredPair(allPairs_[k], &all[P * k]);
    mirror->setDissipatedEnergy(dissipated);
  }

 private:
  // The ids of every rank, on rank 0 in rank order; returns the counts per rank.
  static std::vector<int> gatherIds(const std::vector<Index>& mine, std::vector<Index>& all, int rank, int size) {
    int n = int(mine.size());
    std::vector<int> counts(size_t(size), 0), displs(size_t(size), 0);
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rank == 0) {
      for (int r = 1; r < size; ++r) displs[size_t(r)] = displs[size_t(r) - 1] + counts[size_t(r) - 1];
      all.resize(size_t(displs.back() + counts.back()));
    }
    MPI_Gatherv(mine.data(), n, MPI_INT32_T, all.data(), counts.data(), displs.data(), MPI_INT32_T, 0, MPI_COMM_WORLD);
    return counts;
  }
  static void gatherValues(const std::vector<Real>& mine, const std::vector<int>& counts, int per,
                           std::vector<Real>& all) {
    std::vector<int> c(counts.size()), displs(counts.size(), 0);
    for (size_t r = 0; r < counts.size(); ++r) c[r] = counts[r] * per;
    for (size_t r = 1; r < counts.size(); ++r) displs[r] = displs[r - 1] + c[r - 1];
    all.resize(size_t(displs.back() + c.back()));
    MPI_Gatherv(mine.data(), int(mine.size()), MPI_DOUBLE, all.data(), c.data(), displs.data(), MPI_DOUBLE, 0,
                MPI_COMM_WORLD);
  }

  size_t R_ = 13;  // values per element (ElementBlock::gatheredSize, the largest of any block)
  std::vector<Index> ownedLocal_, nodeIds_, elemIds_, allNodes_, allElems_;
  std::vector<Index> ownedPairs_, allPairs_;
  std::vector<int> pairCounts_;
  std::vector<std::pair<const ElementBlock*, Index>> elems_;
  std::vector<int> nodeCounts_, elemCounts_;
  std::vector<std::pair<ElementBlock*, Index>> mirrorElem_;
};

/// A run on ranks that cannot start from its checkpoint folder (another tq-solid holds it, nothing
/// to resume, a checkpoint of another run or rank count): the code and the message, alike on every
/// rank.
class CheckpointRefusal : public std::runtime_error {
 public:
  CheckpointRefusal(int code, const std::string& why) : std::runtime_error(why), code(code) {}
  int code;
};

/// Rank 0's text, on every rank.
void broadcast(std::string& text) {
  unsigned long long n = text.size();
  MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
  text.resize(size_t(n));
  if (n) MPI_Bcast(text.data(), int(n), MPI_CHAR, 0, MPI_COMM_WORLD);
}

/// What a checkpoint of a run on ranks belongs to: the one-process run's hash (runInputHash), then
/// the rank count (rankRunFingerprint).
std::uint64_t runHash(const SolidInput& in, Real dt) { return runInputHash(in.path, in.meshPath, dt, in.tEnd); }
/// The fingerprint of the run on `ranks` ranks (0: the one-process run's own, to say so when a
/// resume meets one).
std::string rankRunFingerprint(std::uint64_t runHash, long long ranks) {
  return hex64(ranks > 0 ? fnv1a(&ranks, sizeof ranks, runHash) : runHash);
}

/// Restart checkpoints of a run on ranks, in the one-process run's folder and files (tq/io/restart.hpp:
/// the lock, the manifest written last, the CRC-32 checks, the two kept): each rank saves the state
/// of its own part (its solver with its elements, nodes and contributors; rank 0 also the results
/// writer's), rank 0 gathers the parts and writes them as the one state file, a header naming the
/// rank count first, then the bytes of rank 0, 1, ... A resume reads that file on rank 0 and hands
/// each rank its part. Resumable on the same rank count only: a part is its rank's elements and
/// nodes in that partition's numbering.
class RankCheckpoints {
 public:
  using State = std::function<void(StateArchive&)>;

  /// Collective. Rank 0 opens the folder (its lock) and with --resume checks the checkpoint to go
  /// on from; a refusal is thrown on every rank alike (CheckpointRefusal).
  RankCheckpoints(const RunOptions& cl, const SolidInput& in, Real dt, int rank, int size)
      : rank_(rank),
        size_(size),
        resume_(cl.resume),
        interval_(in.checkpointInterval),
        next_(in.checkpointInterval),
        inputs_(inputDigest(in.staged.inputFingerprint)) {
    std::string why;
    int code = 0;
    if (rank == 0) {
      const std::uint64_t hash = runHash(in, dt);
      fingerprint_ = rankRunFingerprint(hash, size);
      try {
        dir_ = std::make_unique<RestartCheckpoints>(cl.checkpointDir);
        dir_->setKeep(2);  // a resume falls back to the one before the last when the last is damaged
        if (resume_) {
          if (!dir_->last(from_, why, cl.resumeSequence)) {
            why = "cannot resume: " + why;
          } else if (from_.fingerprint != fingerprint_) {
            std::ostringstream os;
            os << "cannot resume from " << dir_->dir() << ": its checkpoint (t = " << from_.time << " s) ";
            long long other = 0;
            for (long long k = 1; k <= 4096 && !other; ++k)
              if (k != size && rankRunFingerprint(hash, k) == from_.fingerprint) other = k;
            if (other > 0)
              os << "was written by the run on " << other << " ranks; resume it on " << other << " ranks (--ranks "
                 << other << "): a checkpoint holds each rank's part of that partition";
            else if (rankRunFingerprint(hash, 0) == from_.fingerprint)
              os << "was written by the run as one process; resume it without --ranks";
            else
              os << "was written for another input (the case, its mesh or its motion changed since, or this is "
                    "another build of tq-solid: fingerprint "
                 << from_.fingerprint << ", this run " << fingerprint_ << "); run without --resume to start again";
            why = os.str();
          }
          if (!why.empty()) code = 2;
        }
      } catch (const InputError& e) {
        why = e.what(), code = 2;
      } catch (const OutputError& e) {
        why = e.what(), code = 5;
      }
    }
    MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
    broadcast(why);
    if (code) throw CheckpointRefusal(code, why);
  }

  bool resuming() const { return resume_; }
  const CheckpointManifest& from() const { return from_; }
  long long written() const { return written_; }
  double seconds() const { return seconds_; }

  /// The checkpoint's own counters, in every rank's state.
  void io(StateArchive& a) {
    a.io(next_);
    a.io(seq_);
  }

  /// A fresh start: the folder's earlier checkpoints removed (rank 0).
  void clear() const {
    if (dir_) dir_->clear();
  }
  /// The results are whole: nothing left to resume.
  void completed() const { clear(); }

  /// Due at the end of the step to `t` (every rank alike: the same t on all of them).
  bool due(Real t, Real dt, Real tEnd) const { return interval_ > 0 && t >= next_ - 1e-9 * dt && t < tEnd - 1e-9 * dt; }
  /// Coupled with the water: due at the end of every K-th window instead (/coupling checkpoint_windows,
  /// the water given the same K; 0: none), as one process: not inside a window, not after the last.
  void everyWindows(long long k) { windows_ = k; }
  bool due(const RankedCoupling& c) const {
    return windows_ > 0 && !c.windowOpen() && c.windowsDone() % windows_ == 0 && c.windowsDone() < c.windowCount();
  }

  /// Collective: every rank's state saved (`state`; rank 0's under `lock`, with the results file
  /// flushed first), gathered and written by rank 0 with a copy of the results file. `window`: the
  /// coupling windows completed (-1: not coupled), for the manifest.
  void write(Real t, Real dt, long long step, const State& state, ResultsWriter* writer, std::mutex& lock,
             long long window = -1) {
    const auto c0 = std::chrono::steady_clock::now();
    while (t >= next_ - 1e-9 * dt) next_ += interval_;
    ++seq_;
    std::string mine;
    long long samples = 0;
    {
      std::unique_lock<std::mutex> held(lock, std::defer_lock);
      if (rank_ == 0) held.lock();
      if (writer) {
        writer->flush();
        samples = writer->samples();
      }
      archive_.beginSave();
      state(archive_);
      archive_.end();
      std::ostringstream os;
      archive_.write(os);
      mine = os.str();
    }
    std::vector<std::vector<unsigned char>> parts = gatherParts(mine);
    if (rank_ == 0) {
      StateArchive all;
      all.beginSave();
      Header h;
      h.ranks = size_;
      all.io(h);
      for (auto& p : parts) all.io(p);
      all.end();
      parts.clear();
      CheckpointManifest m;
      m.sequence = seq_;
      m.time = t;
      m.step = step;
      m.samples = samples;
      m.window = window;
      m.fingerprint = fingerprint_;
      m.inputs = inputs_;
      std::lock_guard<std::mutex> held(lock);
      dir_->write(m, all, writer->path());
    }
    ++written_;
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
  }

  /// Collective, --resume: the checkpoint's state file read on rank 0, each rank's part restored
  /// into it by `state` (rank 0's under `lock`). A part that does not fit stops every rank alike.
  void restore(const State& state, std::mutex& lock) {
    std::string why;
    std::vector<std::vector<unsigned char>> parts;
    if (rank_ == 0) {
      try {
        StateArchive all;
        dir_->read(from_, all);
        all.beginRestore();
        Header h;
        all.io(h);
        if (std::string(h.tag, sizeof h.tag) != std::string(Header{}.tag, sizeof h.tag))
          throw InputError("it is not the state of a run on ranks");
        if (h.ranks != size_)
          throw InputError("it holds the parts of " + std::to_string(h.ranks) + " ranks; resume it on " +
                           std::to_string(h.ranks) + " ranks (--ranks " + std::to_string(h.ranks) + ")");
        parts.resize(size_t(size_));
        for (auto& p : parts) all.io(p);
        all.end();
      } catch (const std::exception& e) {
        why = e.what();
      }
    }
    broadcast(why);
    if (!why.empty()) throw CheckpointRefusal(2, "cannot resume from " + where() + ": " + why);
    const std::string mine = scatterParts(parts);
    int failed = 0;
    try {
      std::istringstream is(mine);
      if (!archive_.read(is)) throw InputError("its part of the state ends early");
      std::unique_lock<std::mutex> held(lock, std::defer_lock);
      if (rank_ == 0) held.lock();
      archive_.beginRestore();
      state(archive_);
      archive_.end();
    } catch (const std::exception& e) {
      why = e.what();
      failed = 1;
    }
    MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (failed)
      throw CheckpointRefusal(2, "cannot resume from " + where() + ": a rank's part does not fit this run" +
                                     (why.empty() ? "" : " (" + why + ")") + "; run without --resume to start again");
  }
  /// The results copy of the checkpoint resumed from (rank 0).
  std::string resultsCopy() const { return dir_ ? dir_->file(from_.results) : ""; }

 private:
  struct Header {
    char tag[8] = {'T', 'Q', 'R', 'A', 'N', 'K', 'S', '1'};
    long long ranks = 0;
  };
  std::string where() const { return dir_ ? dir_->file(from_.solid) : "the checkpoint"; }

  std::vector<std::vector<unsigned char>> gatherParts(const std::string& mine) const {
    if (mine.size() > size_t(INT_MAX))
      throw OutputError("the checkpoint state of rank " + std::to_string(rank_) +
                        " exceeds 2 GiB (one message); run on more ranks");
    int n = int(mine.size());
    std::vector<int> counts(size_t(size_), 0), displs(size_t(size_), 0);
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<unsigned char> all;
    if (rank_ == 0) {
      size_t total = 0;
      for (int r = 0; r < size_; ++r) total += size_t(counts[size_t(r)]);
      if (total > size_t(INT_MAX)) throw OutputError("the checkpoint state exceeds 2 GiB (one message)");
      for (int r = 1; r < size_; ++r) displs[size_t(r)] = displs[size_t(r) - 1] + counts[size_t(r) - 1];
      all.resize(total);
    }
    MPI_Gatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, 0, MPI_COMM_WORLD);
    std::vector<std::vector<unsigned char>> parts;
    if (rank_ == 0)
      for (int r = 0; r < size_; ++r)
        parts.emplace_back(all.begin() + displs[size_t(r)], all.begin() + displs[size_t(r)] + counts[size_t(r)]);
    return parts;
  }
  std::string scatterParts(const std::vector<std::vector<unsigned char>>& parts) const {
    std::vector<int> counts(size_t(size_), 0), displs(size_t(size_), 0);
    std::vector<unsigned char> all;
    if (rank_ == 0) {
      for (int r = 0; r < size_; ++r) {
        counts[size_t(r)] = int(parts[size_t(r)].size());
        if (r > 0) displs[size_t(r)] = displs[size_t(r) - 1] + counts[size_t(r) - 1];
        all.insert(all.end(), parts[size_t(r)].begin(), parts[size_t(r)].end());
      }
    }
    int n = 0;
    MPI_Scatter(counts.data(), 1, MPI_INT, &n, 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::string mine(size_t(n), '\0');
    MPI_Scatterv(all.data(), counts.data(), displs.data(), MPI_BYTE, mine.data(), n, MPI_BYTE, 0, MPI_COMM_WORLD);
    return mine;
  }

  int rank_, size_;
  bool resume_;
  Real interval_, next_;
  long long windows_ = 0;
  long long seq_ = 0, written_ = 0;
  double seconds_ = 0;
  std::string inputs_, fingerprint_;
  std::unique_ptr<RestartCheckpoints> dir_;  // rank 0
  CheckpointManifest from_;
  StateArchive archive_;
};

/// What a coupled run (/coupling, condition dynamic_water) on ranks cannot honour, or "" (alike on
/// every rank).
std::string coupledRunOnRanksRefusal(const SolidInput& in) {
  const CouplingInput& ci = in.staged.coupling;
  if (!in.staged.present || !ci.present) return "";
  if (ci.transport == "mpi")
    return "/coupling transport mpi: the solid on ranks couples over TCP only (its ranks are one MPI job of their "
           "own); set /coupling transport tcp (tunnelquake run does), or run tq-solid as one process";
  if (ci.map != "coincident")
    return "/coupling map " + ci.map +
           ": the solid on ranks exchanges each rank's part of the wetted face with the coincident map only; set "
           "/coupling map coincident (tunnelquake run does), or run tq-solid as one process";
  return "";
}

/// The water coupling on ranks (tq/coupling/ranked_coupling.hpp): the seismic step set from
/// /coupling (collective), each rank's adapter and carried laws made on its part and connected (`resuming`: not yet,
/// once their state is restored: RankedCoupling::initializeResumed), the coupling its ranks' solvers' Water
/// contributor, the run's end at whole windows, the coupling's histories in rank 0's results (`writer`, null
/// elsewhere).
std::shared_ptr<RankedCoupling> connectWaterOnRanks(SolidInput& in, const Mesh& global, const RankLayout& L, Solver& s,
                                                    Solver* view, ResultsWriter* writer, std::mutex& lock,
                                                    std::ostream& out, int rank, int size, bool resuming) {
  const CouplingInput& ci = in.staged.coupling;
  if (ci.windowSize > 0) s.setTimeStep(ci.windowSize / Real(ci.windowSteps));
  auto water = std::make_shared<RankedCoupling>(ci, global, L, s);
  if (rank == 0) out << "tq-solid: " << water->adapter()->describe() << "; waiting for the fluid" << std::endl;
  if (!resuming) water->initialize();
  s.addContributor(ForcePhase::Water, water);
  in.tEnd = water->endTime();  // whole windows
  if (writer) {
    std::lock_guard<std::mutex> held(lock);
    RankedCoupling* w = water.get();
    addCouplingSeries(*writer, *view, in, *water->adapter(), water->water(), &water->wetNodeList(),
                      [w]() -> const std::vector<Real>& { return w->wetForce(); });
  }
  if (rank == 0) {
    out << "tq-solid: coupled with the fluid; t_end = " << in.tEnd << " s (" << water->windowCount() << " windows)";
    if (size > 1) {
      out << "; each rank exchanges its own part of the wetted face's " << water->wetNodes()
          << " nodes with the water (the nodes it owns:";
      for (Index n : water->partCounts()) out << " " << n;
      out << ")";
    }
    out << std::endl;
  }
  return water;
}

/// The end of a coupled run on ranks: the fluid's last window (collective), the coupling's summary
/// and the time its messages between the ranks took (the largest over the ranks), a warning for
/// unconverged windows.
void finishWaterOnRanks(RankedCoupling& water, const SolidInput& in, ResultsWriter* writer, RankExchange* rx,
                        std::ostream& err) {
  water.finalize();
  const Real gather = rx ? rx->maxAll(water.secondsCommunicating()) : water.secondsCommunicating();
  const Real sums = rx ? rx->maxAll(water.secondsSumming()) : water.secondsSumming();
  if (!writer) return;
  writeCouplingSummary(*writer, in.staged.coupling, *water.adapter(), water.water());
  writer->writeAttrs("/coupling",
                     {{"ranks_messages_s", gather}, {"ranks_sums_s", sums}, {"wet_nodes", double(water.wetNodes())}},
                     {{"on_ranks",
                       "parts: each rank exchanges the wet nodes it owns with the water, the sums over "
                       "the wet nodes taken in the one-process order on every rank"}});
  // the count of the sums' gathers: this process's (a resumed run counts from its restart)
  writer->writeAttrs("/timings", {{"ranks_sums", double(water.sumsGathered())}}, {});
  const FluidCouplingStats cs = water.adapter()->stats();
  if (cs.unconvergedWindows > 0)
    err << "tq-solid: warning: " << cs.unconvergedWindows << " of " << cs.windows
        << " coupling windows ended at the pass limit (coupling.max_iterations = " << in.staged.coupling.maxIterations
        << ") with the interface residual above the tolerance " << in.staged.coupling.tolerance
        << "; /coupling unconverged_windows in the results counts them.\n";
}

/// A coupled run on ranks that stops on an error: rank 0 tells the fluid (unless the coupling itself
/// stopped) and writes the coupling's summary so far.
void stopWaterOnRanks(RankedCoupling* water, const CouplingInput& in, ResultsWriter* writer, bool couplingStopped,
                      const std::string& message) {
  if (!water || !water->adapter()) return;
  if (!couplingStopped) water->abort("the solid stopped: " + message);
  if (writer) {
    try {
      writeCouplingSummary(*writer, in, *water->adapter(), water->water());
    } catch (const std::exception&) {
    }
  }
}

/// The solver of one rank's part: a block per region of its frontier elements, then one per region
/// of the others (RankExchange::frontierBlocks), the supports and loads of the global mesh mapped
/// onto its nodes, the exchange set, the masses summed and the step reduced over every rank. With
/// subcycling, a block per region and per one-process chunk its elements belong to (each pass):
/// a chunk is evaluated at the steps of its level, so that each element is evaluated at the steps
/// one process evaluates it (RankExchange::subcycle gives each chunk that level).
std::unique_ptr<Solver> buildRankSolver(const SolidInput& in, const Mesh& global, const std::vector<int>& part,
                                        const RankLayout& L, std::unique_ptr<RankExchange>& exchange) {
  std::vector<std::string> names;
  for (const auto& m : in.materials) names.push_back(m.first);
  const std::vector<Index> regions = materialRegions(global, names);
  std::vector<std::pair<Index, std::shared_ptr<const Material>>> mats;
  for (size_t m = 0; m < in.materials.size(); ++m) mats.emplace_back(regions[m], makeMaterial(in.materials[m].second));
  // With subcycling: [global element] its chunk in one process (its region's block: 64 elements of
  // that block's order a chunk); else every element 0.
  std::vector<Index> chunkOf(size_t(global.numElems()), 0);
  if (in.options.subcyclingLevels > 0) {
    Index next = 0;
    for (const auto& [r, mat] : mats) {
      std::vector<Index> elems, lumped, scattered;
      for (Index e = 0; e < global.numElems(); ++e)
        if (global.region[size_t(e)] == r) elems.push_back(e);
      ElementBlock::nodeSumOrder(global, std::move(elems), lumped, scattered);
      for (size_t p = 0; p < lumped.size(); ++p) chunkOf[size_t(lumped[p])] = next + Index(p) / ElementBlock::kChunk;
      next += (Index(lumped.size()) + ElementBlock::kChunk - 1) / ElementBlock::kChunk;
    }
  }
  std::vector<std::unique_ptr<ElementBlock>> blocks;
  size_t frontierBlocks = 0;
  for (int pass = 0; pass < 2; ++pass) {  // frontier elements first
    for (const auto& [r, mat] : mats) {
      std::map<Index, std::vector<Index>> groups;  // by their one-process chunk, in its order
      for (Index e = 0; e < L.mesh.numElems(); ++e)
        if (L.mesh.region[size_t(e)] == r && L.frontierElem[size_t(e)] == (pass == 0 ? 1 : 0))
          groups[chunkOf[size_t(L.globalElem[size_t(e)])]].push_back(e);
      for (auto& [chunk, elems] : groups) {
        blocks.push_back(std::make_unique<ElementBlock>(global.regionNames[size_t(r)], mat, in.formulation, L.mesh,
                                                        std::move(elems)));
        if (pass == 0) ++frontierBlocks;
      }
    }
  }
  SolverOptions opt = in.options;
  opt.dt = 0;  // the step is set once the exchange is in (every rank the same)
  auto s = std::make_unique<Solver>(L.mesh, std::move(blocks), opt);
  exchange = makeRankExchange(L, frontierBlocks, global, part, regions, s->blocks());
  s->setRankExchange(exchange.get());
  s->rebuild();
  s->setTimeStep(in.options.dt);
  for (const auto& [group, dirs] : in.fixed) {
    const auto nodes = global.faceNodes(group);
    for (char c : dirs) {
      const int d = c == 'x' ? 0 : c == 'y' ? 1 : c == 'z' ? 2 : -1;
      if (d < 0)
        throw InputError("fixed directions '" + dirs + "' for face group '" + group +
                         "': use letters x, y, z (e.g. \"xyz\" or \"z\")");
      for (Index n : nodes)
        if (L.localNode[size_t(n)] >= 0) s->fix(L.localNode[size_t(n)], d);
    }
  }
  for (const auto& l : in.loads)
    for (const auto& [n, w] : loadShares(in, global, l))
      if (L.localNode[size_t(n)] >= 0) s->addLoad({{L.localNode[size_t(n)]}, l.direction, l.force * w, l.function});
  return s;
}

/// Test hook (docs/solid_solver.md "Restart checkpoints on ranks"): TQ_RANK_FAULT=<rank>:<step>
/// kills rank <rank> (SIGKILL, as a lost node) at the first final state once it has taken <step> steps of the
/// time loop (coupled: a window's end);
/// 0 (none) on every other rank or without it.
long long rankFaultStep(int rank) {
  const char* f = std::getenv("TQ_RANK_FAULT");
  if (!f) return 0;
  const std::string v = f;
  const size_t colon = v.find(':');
  if (colon == std::string::npos || v.substr(0, colon) != std::to_string(rank)) return 0;
  return std::atoll(v.c_str() + colon + 1);
}

std::string hms(double s) {
  std::ostringstream os;
  if (s >= 60) os << int(s / 60) << " min ";
  os << int(std::fmod(s, 60)) << " s";
  return os.str();
}

/// The run of one rank. Every rank reaches each collective call in the same order: the errors
/// that every rank meets alike (the input, the step, an instability, reduced over the ranks) end
/// them all through the same catch; one that only rank 0 can meet (its results file) aborts the job
/// once the file holds its status.
int runOnRank(const RunOptions& cl, int rank, int size, std::ostream& out, std::ostream& err) {
  std::unique_ptr<ResultsWriter> writer;
  std::shared_ptr<RankedCoupling> water;  // the water coupling (dynamic_water), after the writer: closed before it
  CouplingInput coupling;                 // its settings (the input is gone when an error is caught)
  struct Unwatched {                      // the watcher of stop signals lets go of the writer before it closes
    ~Unwatched() {
      std::lock_guard<std::mutex> lock(gStop.mutex);
      gStop.writer = nullptr;
    }
  } unwatched;
  // Every use of the writer under the watcher's lock.
  const auto withWriter = [&](const auto& fn) {
    std::lock_guard<std::mutex> lock(gStop.mutex);
    if (writer) fn(*writer);
  };
  const auto stopWith = [&](int code, const std::string& message, const char* label) {
    if (rank == 0) err << "tq-solid: " << label << message << "\n";
    withWriter([&](ResultsWriter& w) { w.setStatus("stopped: " + message); });
    return code;
  };
  try {
    try {
      SolidInput in = readSolidInput(cl.input);
      if (const std::string why = unsupportedOnRanks(in, size); !why.empty()) throw InputError(why);
      if (const std::string why = coupledRunOnRanksRefusal(in); !why.empty()) throw InputError(why);
      const Mesh global = readInputMesh(in);
      const std::vector<Real> cost = elementCosts(global, in);
      const std::vector<int> part = partitionRcb(global, cost, size);
      std::unique_ptr<RankExchange> exchange;
      std::unique_ptr<Solver> local, mirror;
      std::unique_ptr<StagedAnalysis> stages;
      RankLayout layout;
      // The materials of the whole model's regions (the seismic boundaries' columns read the
      // elements a rank does not hold).
      std::vector<std::shared_ptr<const Material>> regionMaterial(global.regionNames.size());
      for (const auto& [region, v] : in.materials)
        if (const Index r = global.regionIndex(region); r >= 0) regionMaterial[size_t(r)] = makeMaterial(v);
      RankPart rankPart;
      if (size == 1) {  // the whole model: the solver of a plain run, no frontier
        local = buildSolver(in, global);
        if (in.staged.present) stages = std::make_unique<StagedAnalysis>(in, global, *local);
      } else {
        // A rock-lining pair's two nodes are held together: its force needs both.
        std::vector<std::vector<Index>> together;
        if (in.staged.present)
          for (size_t p = 0; p + 1 < global.rockLiningPairs.size(); p += 2)
            together.push_back({global.rockLiningPairs[p], global.rockLiningPairs[p + 1]});
        layout = makeRankLayout(global, part, rank, size, together);
        local = buildRankSolver(in, global, part, layout, exchange);
        if (rank == 0) mirror = buildSolver(in, global);
        if (in.staged.present) {
          rankPart.rank = rank;
          rankPart.global = &global;
          rankPart.localNode = &layout.localNode;
          rankPart.owned = &layout.owned;
          rankPart.elementMaterial.resize(size_t(global.numElems()));
          for (Index e = 0; e < global.numElems(); ++e)
            rankPart.elementMaterial[size_t(e)] = regionMaterial[size_t(global.region[size_t(e)])].get();
          stages = std::make_unique<StagedAnalysis>(in, layout.mesh, *local, &rankPart);
        }
      }
      Solver& s = *local;
      s.checkSubcycling(in.options.subcyclingLevels);         // refused now, not after the static stages
      Solver* view = size == 1 ? local.get() : mirror.get();  // what the results are written from (rank 0)
      // The partition: weights per rank, frontier nodes.
      const std::vector<Real> w = partWeights(part, cost, size);
      const Real wmax = *std::max_element(w.begin(), w.end());
      Real wsum = 0;
      for (Real x : w) wsum += x;
      Real counts[2] = {Real(layout.frontier.size()), Real(layout.owned.size() - layout.ghosts.size())};
      if (exchange) exchange->sumAll(counts, 2);
      const Real imbalance = wmax / (wsum / size);
      const StableStep st = s.stableStep();
      if (rank == 0) {
        out << "tq-solid: " << global.numNodes() << " nodes, " << global.numElems() << " elements, "
            << integratorName(s.options().integrator) << ", on " << size << " rank(s) x " << omp_get_max_threads()
            << " thread(s)\n  partition: recursive coordinate bisection by element cost, largest part "
            << std::setprecision(4) << imbalance << " x the mean, " << std::llround(counts[0])
            << " frontier node copies\n  stable step " << st.dtCritical << " s, dt = " << s.dt() << " s, "
            << std::llround(std::ceil(in.tEnd / s.dt())) << " steps to t_end = " << in.tEnd << " s" << std::endl;
      }
      if (rank == 0 && stages) {
        out << "  stages:";
        for (const auto& n : in.staged.stages.sequence) out << " " << n;
        out << (in.staged.condition.empty() ? "" : " (condition " + in.staged.condition + ")") << "\n";
      }
      if (cl.check) {
        if (rank == 0) out << "tq-solid: input and mesh are valid (on " << size << " ranks)\n";
        return 0;
      }
      std::unique_ptr<StateGather> gather;
      if (size > 1) gather = std::make_unique<StateGather>(layout, s, mirror.get());
      // Restart checkpoints: the folder opened (and with --resume the checkpoint checked) before the
      // results file is started, so a refused resume leaves that file as it was.
      std::unique_ptr<RankCheckpoints> checkpoints;
      if (!cl.checkpointDir.empty()) checkpoints = std::make_unique<RankCheckpoints>(cl, in, s.dt(), rank, size);
      std::function<void()> gatherContact;
      const auto observe = [&] {
        if (gather) gather->gather(s, mirror.get());
        if (water) water->observe(mirror.get());  // the wet nodes' force and mass, for the results
        if (gatherContact) gatherContact();
      };
      if (rank == 0) {
        std::lock_guard<std::mutex> lock(gStop.mutex);
        writer = std::make_unique<ResultsWriter>(cl.output, in, *view);
        gStop.writer = writer.get();
      }
      if (stages) {
        // The static stages and the switch, on every rank alike (rank 0 says what they did).
        std::ostream none(nullptr);
        std::ostream& log = rank == 0 ? out : none;
        stages->runStatics(log, in.progressSeconds);
        if (stages->hasSeismic()) stages->switchToDynamics(log);
        // The dynamic contact in the results: a mirror of it on rank 0, filled at every gather.
        const auto* contact = dynamic_cast<const DynamicContact*>(stages->rockLiningInterface().get());
        if (contact && size > 1) {
          std::shared_ptr<DynamicContact> shown;
          if (mirror) {
            shown = std::make_shared<DynamicContact>(*mirror, rockLiningPairs(global), contact->params());
            mirror->addContributor(ForcePhase::Interface, shown);
          }
          gatherContact = [&, contact, shown] {
            gather->gatherContact(*contact, stages->contactPairIndex(), stages->contactPairOwned(), shown.get(),
                                  *exchange);
          };
        }
        observe();
        if (mirror) mirror->resetMotion();  // the seismic start's displacement, as the ranks' solvers hold it
        withWriter([&](ResultsWriter& w) {
          for (const auto& r : stages->reports())
            w.writeStage(r.name, r.steps, r.ratio, r.converged, r.wallSeconds, r.note);
        });
        if (!stages->hasSeismic()) {
          withWriter([&](ResultsWriter& w) {
            w.snapshot(*view);
            w.setStatus("completed");
            out << "tq-solid: completed the static stages (no seismic stage)\n  results: " << cl.output << "\n";
          });
          return 0;
        }
      }
      if (in.staged.present && in.staged.coupling.present) {
        coupling = in.staged.coupling;
        water = connectWaterOnRanks(in, global, layout, s, view, writer.get(), gStop.mutex, out, rank, size,
                                    checkpoints && checkpoints->resuming());
        if (checkpoints && in.checkpointInterval > 0)
          checkpoints->everyWindows(std::max<long long>(1, in.staged.coupling.checkpointWindows));
      }
      if (in.options.subcyclingLevels > 0) {  // after every contributor is in: they mark their fine nodes
        const SubcyclingInfo sc = s.enableSubcycling(in.options.subcyclingLevels);
        withWriter([&](ResultsWriter& w) { reportSubcycling(sc, out, w); });
      }
      // Everything a checkpoint holds of this rank, in this order (saved and restored alike).
      size_t nextSnap = 0;
      const auto rankState = [&](StateArchive& a) {
        s.checkpoint(a);
        if (writer) writer->checkpoint(a);
        a.io(nextSnap);
        checkpoints->io(a);
        if (water) water->restartState(a);
      };
      if (checkpoints && checkpoints->resuming()) {
        checkpoints->restore(rankState, gStop.mutex);
        withWriter([&](ResultsWriter& w) { w.resumeFrom(checkpoints->resultsCopy(), *view); });
        const CheckpointManifest& m = checkpoints->from();
        if (rank == 0)
          out << "tq-solid: resumed from checkpoint " << m.sequence << " at t = " << m.time << " s (step " << m.step
              << ", " << m.samples << " samples"
              << (m.window >= 0 ? ", coupling window " + std::to_string(m.window) : "") << ") on " << size << " rank(s)"
              << std::endl;
        if (water) water->initializeResumed();
      } else {
        if (checkpoints) checkpoints->clear();
        observe();
        withWriter([&](ResultsWriter& w) { w.sample(*view); });
      }
      // The next history time, from rank 0's writer, sent to every rank after each sample: the
      // ranks decide alike when to gather, without a message at the other steps.
      Real nextSample = writer ? writer->nextSampleTime() : 0;
      if (size > 1) MPI_Bcast(&nextSample, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
      const auto t0 = std::chrono::steady_clock::now();
      auto lastReport = t0, lastFlush = t0;
      const Index step0 = s.stepCount();
      Real tPrev = s.time();
      const long long faultStep = rankFaultStep(rank);
      CoupledStepper stepper(s, water.get());  // without the water: one step
      // The kinetic energy summed only for the final states the balance is read at, as a one-process
      // run decides it: from the next history time every rank holds, so every rank alike.
      const auto wantKinetic = [&] { stepper.askKineticEnergy(nextSample, in.tEnd); };
      // After each final state (every step; coupled: not inside an implicit window of several steps,
      // CoupledStepper): the samples, snapshots, checkpoints and progress.
      const auto onFinal = [&] {
        if (water && rank == 0)
          if (const std::string note = water->adapter()->takeNote(); !note.empty()) out << "tq-solid: " << note << "\n";
        if (faultStep > 0 && s.stepCount() - step0 >= faultStep)  // coupled: at the first window end past it
          std::raise(SIGKILL);
        const Real t = s.time(), gap = t - tPrev;
        tPrev = t;
        const bool due = t + gap >= nextSample - 1e-9 * gap;
        const bool snap = nextSnap < in.snapshotTimes.size() && t >= in.snapshotTimes[nextSnap] - 0.5 * s.dt();
        if (due || snap) observe();
        if (due) {
          withWriter([&](ResultsWriter& w) { w.sample(*view); });
          nextSample = writer ? writer->nextSampleTime() : 0;
          if (size > 1) MPI_Bcast(&nextSample, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
        }
        while (nextSnap < in.snapshotTimes.size() && t >= in.snapshotTimes[nextSnap] - 0.5 * s.dt()) {
          withWriter([&](ResultsWriter& w) { w.snapshot(*view); });
          ++nextSnap;
        }
        if (checkpoints && (water ? checkpoints->due(*water) : checkpoints->due(t, s.dt(), in.tEnd))) {
          checkpoints->write(t, s.dt(), s.stepCount(), rankState, writer.get(), gStop.mutex,
                             water ? water->windowsDone() : -1);
          lastFlush = std::chrono::steady_clock::now();
        }
        if (!writer) return;
        const auto now = std::chrono::steady_clock::now();
        if (std::chrono::duration<double>(now - lastFlush).count() > 2.0) {
          withWriter([](ResultsWriter& w) { w.flush(); });
          lastFlush = now;
        }
        if (std::chrono::duration<double>(now - lastReport).count() >= in.progressSeconds) {
          const double wall = std::chrono::duration<double>(now - t0).count();
          const double rate = double(s.stepCount() - step0) / wall;
          out << "  t = " << std::setprecision(5) << t << " s / " << in.tEnd << " s, step " << s.stepCount() << ", "
              << std::setprecision(4) << rate << " steps/s, energy error " << std::setprecision(2)
              << s.checkedEnergyError() << " (t = " << std::setprecision(5) << s.checkedEnergyTime() << " s), ETA "
              << hms((in.tEnd - t) / s.dt() / rate) << std::endl;
          lastReport = now;
        }
      };
      // after each final state, once its samples are taken (nextSample is then the next one)
      const auto onFinalThenWant = [&] {
        onFinal();
        wantKinetic();
      };
      wantKinetic();
      try {
        while (s.time() < in.tEnd - 1e-9 * s.dt() && (!water || water->ongoing())) stepper.advance(onFinalThenWant);
      } catch (const CouplingError&) {
        // The state the fluid was lost at is the last sample where it is final (every rank alike):
        // not inside an implicit window of several steps, which the water never accepted.
        if (!water || !water->repeatsWindows()) {
          observe();
          withWriter([&](ResultsWriter& w) { w.sample(*view); });
        }
        throw;
      }
      s.setKineticEnergyWanted(true);
      if (water) finishWaterOnRanks(*water, in, writer.get(), exchange.get(), err);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const long long steps = s.stepCount() - step0;
      // Every rank's copy of a frontier node holds the same displacement and velocity, bitwise
      // (the frontier sums run in rank order on every rank): checked once at the end.
      // The share of the stepping spent waiting for the other ranks, the largest over the ranks.
      const Real waitShare = exchange ? exchange->maxAll(wall > 0 ? exchange->waitSeconds() / wall : 0.0) : 0.0;
      Real mismatch = 0;
      if (exchange) {
        mismatch = exchange->frontierMismatch(s.state().uData(), 3);
        mismatch = std::max(mismatch, exchange->frontierMismatch(s.state().vData(), 3));
      }
      // Each rank's peak resident memory (MiB), on rank 0 in rank order.
      std::vector<double> peak(size_t(size), 0.0);
      {
        struct rusage ru {};
        getrusage(RUSAGE_SELF, &ru);
        double mine = double(ru.ru_maxrss) / 1024.0;  // kB on Linux
        MPI_Gather(&mine, 1, MPI_DOUBLE, peak.data(), 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
      }
      withWriter([&](ResultsWriter& w) {
        w.writeTimings(wall, steps, steps * global.numElems(), omp_get_max_threads());
        const double peakOthers = size > 1 ? *std::max_element(peak.begin() + 1, peak.end()) : 0.0;
        w.writeAttrs("/ranks",
                     {{"ranks", double(size)},
                      {"threads_per_rank", double(omp_get_max_threads())},
                      {"largest_part_over_mean", imbalance},
                      {"frontier_node_copies", counts[0]},
                      {"frontier_copies_max_difference", mismatch}},
                     {{"partition", "recursive coordinate bisection weighted by element cost"},
                      {"results", "gathered to rank 0 at every sample and snapshot, written by it"},
                      {"checkpoints",
                       "each rank's part of the state gathered by rank 0 into one file; resumable on "
                       "the same rank count"}});
        // What this run took of the machine (with the wall times: not results, tunnelquake compare
        // leaves them out).
        w.writeAttrs("/timings", {{"wait_fraction", waitShare},
                                  {"peak_memory_rank0_MiB", peak[0]},
                                  {"peak_memory_other_ranks_max_MiB", peakOthers}});
        if (checkpoints)
          w.writeAttrs("/timings", {{"checkpoints", double(checkpoints->written())},
                                    {"checkpoint_s", checkpoints->seconds()},
                                    {"checkpoint_interval", in.checkpointInterval}});
        w.setStatus("completed");
        if (checkpoints) checkpoints->completed();
        out << "tq-solid: completed " << steps << " steps in " << hms(wall) << " ("
            << (steps > 0 ? 1e6 * wall / (double(steps) * global.numElems()) : 0.0) << " µs per element-step), "
            << "energy error " << std::setprecision(3) << s.checkedEnergyError() << " (t = " << std::setprecision(6)
            << s.checkedEnergyTime() << " s), on " << size << " rank(s)\n  peak memory per rank (MiB):";
        for (int r = 0; r < size; ++r) out << " " << std::llround(peak[size_t(r)]);
        out << (size > 1 ? " (rank 0 also holds the whole model for the results)" : "") << "\n  results: " << cl.output
            << "\n";
      });
      return 0;
    } catch (const CheckpointRefusal& e) {
      return stopWith(e.code, e.what(), "");
    } catch (const CouplingError& e) {  // the fluid is lost, silent or refused: stop with its cause
      withWriter([&](ResultsWriter& w) { stopWaterOnRanks(water.get(), coupling, &w, true, e.what()); });
      return stopWith(4, e.what(), "");
    } catch (const InputError& e) {
      withWriter([&](ResultsWriter& w) { stopWaterOnRanks(water.get(), coupling, &w, false, e.what()); });
      return stopWith(2, e.what(), "input error: ");
    } catch (const InstabilityError& e) {
      withWriter([&](ResultsWriter& w) { stopWaterOnRanks(water.get(), coupling, &w, false, e.what()); });
      const std::string m = e.what();
      if (rank != 0 && m.find("another rank") == std::string::npos)
        err << "tq-solid: rank " << rank << ": " << m << "\n";
      return stopWith(3, m, "");
    }
  } catch (const OutputError& e) {  // rank 0's results file or checkpoint: the others cannot go on without it
    err << "tq-solid: " << e.what() << "\n";
    withWriter([&](ResultsWriter& w) {
      try {
        w.setStatus("stopped: " + std::string(e.what()));
      } catch (const std::exception&) {
      }
    });
    MPI_Abort(MPI_COMM_WORLD, 5);
    return 5;
  }
}

#endif

}  // namespace

int runSolidOnRanks(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  RunOptions cl;
  if (const int rc = parseRankCommandLine(args, err, cl); rc >= 0) return rc;
#ifdef TQ_SOLID_HAVE_MPI
  // The stop signals go to one thread of each rank (waitForStop): blocked here, before MPI and
  // OpenMP start theirs, so that every thread inherits the block.
  sigset_t stops;
  sigemptyset(&stops);
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&stops, sig);
  pthread_sigmask(SIG_BLOCK, &stops, nullptr);
  std::thread(waitForStop, stops).detach();
  int ready = 0;
  MPI_Initialized(&ready);
  if (!ready) {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  }
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int rc = 0;
  try {
    rc = runOnRank(cl, rank, size, out, err);
  } catch (const std::exception& e) {  // not met alike by every rank: end the whole job
    err << "tq-solid: rank " << rank << ": error: " << e.what() << "\n";
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  // every rank the same code: the errors above are met alike by all of them
  MPI_Finalize();
  return rc;
#else
  (void)out;
  err << "tq-solid: input error: this tq-solid was built without MPI and cannot run on ranks (--distributed); "
         "install the MPI development files (e.g. libopenmpi-dev) and build again, or run without --ranks\n";
  return 2;
#endif
}

}  // namespace tq
