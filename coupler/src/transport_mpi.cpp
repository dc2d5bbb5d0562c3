// MPI transport (MPMD under mpirun): the only file besides transport_tcp.cpp that includes
// MPI. splitWorld() splits MPI_COMM_WORLD by application (colour = FNV-1a hash of the
// participant name) and finds the partner's leader (its lowest
// world rank). The two leaders exchange the same framed byte stream as over TCP, on a duplicate
// of MPI_COMM_WORLD so that no solver message can be confused with a coupler message.
// MPI cannot tell that a partner died: a silent partner is detected by the receive timeout
// (Open MPI's mpirun also ends the whole job when one process dies: it sends SIGTERM to the
// others, which stopOnTerminationSignals() turns into a PartnerLostError of the blocked call).
#include <mpi.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <thread>
#include <vector>

#include "tq/coupler/errors.hpp"
#include "transport_detail.hpp"

namespace tq::coupler {
namespace {

constexpr int kTag = 0x7C01;

struct MpiState {
  bool split = false;
  MPI_Comm app = MPI_COMM_NULL;
  MPI_Comm link = MPI_COMM_NULL;
  int worldRank = -1, appRank = -1, partnerLeader = -1;
  std::string me, partner;
};
MpiState& state() {
  static MpiState s;
  return s;
}

/// The termination signal that arrived (0 none): written by the handler only.
volatile std::sig_atomic_t g_signal = 0;

void onTerminationSignal(int sig) { g_signal = sig; }

const char* signalName(int sig) {
  return sig == SIGTERM ? "SIGTERM" : sig == SIGINT ? "SIGINT" : "a termination signal";
}

/// Throws when a termination signal arrived: the job is being ended (under mpirun: another
/// process of it stopped), so no message of the partner will come.
void checkSignal(const char* doing) {
  const int sig = g_signal;
  if (sig == 0) return;
  throw PartnerLostError(std::string(signalName(sig)) + " arrived while " + doing +
                         ": mpirun is ending the job, because another process of it stopped "
                         "(most likely the partner died: mpirun's message names the process "
                         "and its exit) or the job was interrupted");
}

int colourOf(const std::string& name) {
  std::uint32_t h = 2166136261u;  // FNV-1a, 32 bit
  for (unsigned char c : name) {
    h ^= c;
    h *= 16777619u;
  }
  return int(h & 0x7FFFFFFFu);
}

class MpiChannel final : public Channel {
 public:
  MpiChannel(MPI_Comm comm, int peer) : comm_(comm), peer_(peer) {}

  void send(const std::uint8_t* p, std::size_t n, Deadline d) override {
    if (n > std::size_t(INT32_MAX)) throw TransportError("MPI message above 2 GiB");
    checkSignal("sending to the partner");
    MPI_Request req;
    if (MPI_Isend(p, int(n), MPI_BYTE, peer_, kTag, comm_, &req) != MPI_SUCCESS)
      throw TransportError("MPI_Isend to world rank " + std::to_string(peer_) + " failed");
    wait(req, d, "send stalled: the partner did not take the data before the timeout");
  }

  void receive(std::uint8_t* p, std::size_t n, Deadline d) override {
    std::size_t done = 0;
    while (done < n) {
      if (pos_ < buf_.size()) {
        const std::size_t k = std::min(n - done, buf_.size() - pos_);
        std::memcpy(p + done, buf_.data() + pos_, k);
        pos_ += k;
        done += k;
        continue;
      }
      // Next MPI message: probe with a short spin, then back off to 200 µs naps.
      int flag = 0, spins = 0;
      MPI_Status st;
      for (;;) {
        checkSignal("waiting for the partner");
        MPI_Iprobe(peer_, kTag, comm_, &flag, &st);
        if (flag) break;
        if (d.remaining() <= 0)
          throw TimeoutError("nothing arrived (" + std::to_string(done) + " of " + std::to_string(n) +
                             " expected bytes received)");
        if (++spins > 2000) std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      int count = 0;
      MPI_Get_count(&st, MPI_BYTE, &count);
      buf_.resize(std::size_t(count));
      pos_ = 0;
      MPI_Recv(buf_.data(), count, MPI_BYTE, peer_, kTag, comm_, MPI_STATUS_IGNORE);
    }
  }
  void close() noexcept override {}
  std::string describe() const override {
    return "mpi world rank " + std::to_string(state().worldRank) + " <-> world rank " + std::to_string(peer_);
  }

 private:
  void wait(MPI_Request& req, Deadline d, const char* timeoutText) {
    int flag = 0, spins = 0;
    for (;;) {
      MPI_Test(&req, &flag, MPI_STATUS_IGNORE);
      if (flag) return;
      checkSignal("sending to the partner");
      if (d.remaining() <= 0) throw TimeoutError(timeoutText);
      if (++spins > 2000) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  MPI_Comm comm_;
  int peer_;
  std::vector<std::uint8_t> buf_;
  std::size_t pos_ = 0;
};

class MpiListener final : public Listener {
 public:
  explicit MpiListener(int peer) : peer_(peer) {}
  std::unique_ptr<Channel> accept(Deadline) override {
    if (used_) throw TransportError("the MPI partner is fixed: no second connection");
    used_ = true;
    return std::make_unique<MpiChannel>(state().link, peer_);
  }
  std::string describe() const override {
    return "mpi leader of '" + state().partner + "' (world rank " + std::to_string(peer_) + ")";
  }
  bool canAcceptAgain() const override { return false; }

 private:
  int peer_;
  bool used_ = false;
};

void requireLeader(const std::string& me, const std::string& partner) {
  const auto& s = state();
  if (!s.split)
    throw ConfigError("participant '" + me +
                      "': MPI transport needs tq::coupler::mpi::"
                      "splitWorld() after MPI_Init, before initialize()");
  if (s.me != me || s.partner != partner)
    throw ConfigError("participant '" + me + "': splitWorld was called for '" + s.me + "' <-> '" + s.partner + "'");
  if (s.appRank != 0)
    throw ConfigError("participant '" + me +
                      "': only rank 0 of an application talks to "
                      "the partner (this is rank " +
                      std::to_string(s.appRank) + ")");
}

}  // namespace

bool haveMpi() { return true; }

namespace mpi {

namespace {
bool g_weInitialized = false;
}
void initialize(int* argc, char*** argv) {
  int init = 0;
  MPI_Initialized(&init);
  if (!init) {
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    g_weInitialized = true;
  }
}
void finalize() {
  int fin = 0;
  MPI_Finalized(&fin);
  if (g_weInitialized && !fin) MPI_Finalize();
}
void abortJob(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);  // MPI_Abort does not return; in case an MPI library lets it
}
void stopOnTerminationSignals() {
  struct sigaction sa {};
  sa.sa_handler = onTerminationSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND | SA_RESTART;  // a second signal kills as usual
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
}
int terminationSignal() { return g_signal; }

int splitWorld(const std::string& me, const std::string& partner) {
  int init = 0;
  MPI_Initialized(&init);
  if (!init) throw ConfigError("splitWorld: MPI_Init has not been called");
  auto& s = state();
  int size = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &s.worldRank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const int mine = colourOf(me), theirs = colourOf(partner);
  std::vector<int> colours(std::size_t(size), 0);
  MPI_Allgather(&mine, 1, MPI_INT, colours.data(), 1, MPI_INT, MPI_COMM_WORLD);
  MPI_Comm_split(MPI_COMM_WORLD, mine, s.worldRank, &s.app);
  MPI_Comm_rank(s.app, &s.appRank);
  MPI_Comm_dup(MPI_COMM_WORLD, &s.link);
  s.partnerLeader = -1;
  for (int r = 0; r < size; ++r)
    if (colours[std::size_t(r)] == theirs) {
      s.partnerLeader = r;
      break;
    }
  if (s.partnerLeader < 0)
    throw TransportError("participant '" + me + "': no process of '" + partner + "' among the " + std::to_string(size) +
                         " MPI processes: start both under one mpirun "
                         "(MPMD: mpirun -np 1 solid : -np N fluid)");
  s.me = me;
  s.partner = partner;
  s.split = true;
  return int(MPI_Comm_c2f(s.app));
}

int appRank() { return state().appRank; }
int appSize() {
  int n = 1;
  if (state().app != MPI_COMM_NULL) MPI_Comm_size(state().app, &n);
  return n;
}

}  // namespace mpi

namespace detail {

std::unique_ptr<Listener> makeMpiListener(const TransportOptions&, const std::string& me, const std::string& partner) {
  requireLeader(me, partner);
  return std::make_unique<MpiListener>(state().partnerLeader);
}

std::unique_ptr<Channel> connectMpi(const TransportOptions&, const std::string& me, const std::string& partner,
                                    Deadline) {
  requireLeader(me, partner);
  return std::make_unique<MpiChannel>(state().link, state().partnerLeader);
}

}  // namespace detail
}  // namespace tq::coupler
