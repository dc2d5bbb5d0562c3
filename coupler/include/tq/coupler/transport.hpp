#pragma once
/// @file transport.hpp
/// Byte transports: abstract Channel and Listener, variants TCP (transport_tcp.cpp) and MPI
/// (transport_mpi.cpp), made by makeTransport(). These two source files are the only ones in
/// the project that include socket or MPI headers.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

namespace tq::coupler {

using Clock = std::chrono::steady_clock;

/// A point in time after which a blocking call gives up with TimeoutError.
struct Deadline {
  Clock::time_point at;
  double seconds = 0.0;  ///< the timeout it was made from, for messages
  static Deadline in(double seconds) {
    return {Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds)),
            seconds};
  }
  /// Seconds left (may be negative).
  double remaining() const { return std::chrono::duration<double>(at - Clock::now()).count(); }
};

/// An established, ordered, reliable byte stream to the partner.
class Channel {
 public:
  virtual ~Channel() = default;
  /// Sends all n bytes. Throws TimeoutError, PartnerLostError or TransportError.
  virtual void send(const std::uint8_t* data, std::size_t n, Deadline deadline) = 0;
  /// Receives exactly n bytes. Throws TimeoutError (with the count received so far),
  /// PartnerLostError on end of stream or reset, TransportError otherwise.
  virtual void receive(std::uint8_t* data, std::size_t n, Deadline deadline) = 0;
  virtual void close() noexcept = 0;
  /// "tcp 127.0.0.1:41234 ↔ 127.0.0.1:50110", "mpi world rank 1"
  virtual std::string describe() const = 0;
};

/// Waits for partners. An acceptor may get several connections over time (a foreign process
/// that knocks on the port is refused and the listener keeps waiting).
class Listener {
 public:
  virtual ~Listener() = default;
  virtual std::unique_ptr<Channel> accept(Deadline deadline) = 0;
  virtual std::string describe() const = 0;
  /// False when no second connection can ever arrive (MPI: the partner is fixed).
  virtual bool canAcceptAgain() const = 0;
};

enum class TransportKind { Tcp, Mpi };
enum class ConnectRole { Auto, Listen, Connect };

/// How this side reaches its partner. Not compared in the handshake.
struct TransportOptions {
  TransportKind kind = TransportKind::Tcp;
  /// Auto: the configuration's first participant listens, the second connects.
  ConnectRole role = ConnectRole::Auto;
  /// TCP listener: address to bind. Loopback unless the user asks for a network address.
  std::string bindAddress = "127.0.0.1";
  /// TCP listener: port; 0 lets the operating system choose a free one (the default).
  int port = 0;
  /// TCP: file through which the listener publishes "tqcp 1 tcp <host> <port>" and the
  /// connector finds it. Written atomically; removed when the listener closes.
  std::string addressFile;
  /// TCP connector: explicit partner address (used instead of addressFile when port > 0).
  std::string connectHost = "127.0.0.1";
  int connectPort = 0;
  /// s: how long to wait for the partner to appear (connect, accept, handshake).
  double connectTimeout = 120.0;
  /// s: how long any single receive may wait for the partner during the run.
  double receiveTimeout = 120.0;
};

/// Listener factory (TCP: binds and publishes the address; MPI: the partner leader's rank).
std::unique_ptr<Listener> makeListener(const TransportOptions& o, const std::string& participant,
                                       const std::string& partner);
/// Connector factory: keeps retrying until connected or the deadline passes.
std::unique_ptr<Channel> connectTo(const TransportOptions& o, const std::string& participant,
                                   const std::string& partner, Deadline deadline);

/// TCP: the address line a listener writes into its address file.
std::string tcpAddressLine(const std::string& host, int port);
/// Parses an address line; false if it is not one.
bool parseTcpAddressLine(const std::string& line, std::string& host, int& port);

/// True when the library was built with MPI.
bool haveMpi();

namespace mpi {
/// MPI_Init (if not yet initialized) for programs that have no other MPI use. Asks for
/// MPI_THREAD_FUNNELED: the program may run threads (tq-solid's OpenMP), only the one that
/// called this makes MPI calls.
void initialize(int* argc, char*** argv);
/// MPI_Finalize if this library initialized MPI.
void finalize();
/// MPI_Abort(MPI_COMM_WORLD, code): ends every process of the job (for a partner that does not
/// answer and so would never reach MPI_Finalize). Does not return.
[[noreturn]] void abortJob(int code);
/// Makes SIGTERM and SIGINT end a blocked MPI send or receive of the coupler with a
/// PartnerLostError instead of killing the process at once: Open MPI's mpirun sends SIGTERM to
/// every process of the job when one of them dies (SIGKILL follows after
/// odls_base_sigkill_timeout, 1 s by default), so the solver can still say why and close its
/// results. The handler only records the signal (and is reset, so a second one kills); the
/// coupler's MPI channel looks at it. Call after initialize().
void stopOnTerminationSignals();
/// The signal that arrived (SIGTERM, SIGINT), or 0.
int terminationSignal();
/// Number of processes in this application's communicator (valid after splitWorld).
int appSize();
/// MPMD start-up under mpirun: every process of both applications calls this once, after
/// MPI_Init, with its participant name (a collective over MPI_COMM_WORLD). It splits the world
/// by application (colour = participant) and finds the partner's leader. Returns the Fortran
/// handle (MPI_Comm_c2f) of this application's own communicator, for the solver to use instead
/// of MPI_COMM_WORLD. Throws TransportError when the partner is not among the processes.
int splitWorld(const std::string& participant, const std::string& partner);
/// Rank of this process in its application communicator (valid after splitWorld).
int appRank();
}  // namespace mpi

}  // namespace tq::coupler
