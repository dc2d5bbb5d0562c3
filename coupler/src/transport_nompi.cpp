// Stand-ins when the library is built without MPI: every MPI request is a clear error.
#include <cstdlib>

#include "tq/coupler/errors.hpp"
#include "transport_detail.hpp"

namespace tq::coupler {
namespace {
[[noreturn]] void noMpi() {
  throw ConfigError(
      "this TunnelQuake coupler was built without MPI: use the TCP transport, "
      "or install an MPI library and rebuild");
}
}  // namespace
bool haveMpi() { return false; }
namespace mpi {
void initialize(int*, char***) { noMpi(); }
void finalize() {}
int splitWorld(const std::string&, const std::string&) { noMpi(); }
void abortJob(int code) { std::_Exit(code); }
void stopOnTerminationSignals() {}
int terminationSignal() { return 0; }
int appRank() { return 0; }
int appSize() { return 1; }
}  // namespace mpi
namespace detail {
std::unique_ptr<Listener> makeMpiListener(const TransportOptions&, const std::string&, const std::string&) { noMpi(); }
std::unique_ptr<Channel> connectMpi(const TransportOptions&, const std::string&, const std::string&, Deadline) {
  noMpi();
}
}  // namespace detail
}  // namespace tq::coupler
