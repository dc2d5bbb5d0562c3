// Transport factory and the address-file format (no socket or MPI code here).
#include <sstream>

#include "tq/coupler/errors.hpp"
#include "transport_detail.hpp"

namespace tq::coupler {

std::unique_ptr<Listener> makeListener(const TransportOptions& o, const std::string& me, const std::string& partner) {
  if (o.kind == TransportKind::Mpi) return detail::makeMpiListener(o, me, partner);
  return detail::makeTcpListener(o, me, partner);
}

std::unique_ptr<Channel> connectTo(const TransportOptions& o, const std::string& me, const std::string& partner,
                                   Deadline deadline) {
  if (o.kind == TransportKind::Mpi) return detail::connectMpi(o, me, partner, deadline);
  return detail::connectTcp(o, me, partner, deadline);
}

std::string tcpAddressLine(const std::string& host, int port) {
  return "tqcp 1 tcp " + host + " " + std::to_string(port) + "\n";
}

bool parseTcpAddressLine(const std::string& line, std::string& host, int& port) {
  if (line.empty() || line.back() != '\n') return false;  // not completely written
  std::istringstream s(line);
  std::string magic, version, kind, extra;
  if (!(s >> magic >> version >> kind >> host >> port)) return false;
  if (s >> extra) return false;
  return magic == "tqcp" && version == "1" && kind == "tcp" && port > 0 && port < 65536;
}

}  // namespace tq::coupler
