#pragma once
// Internal: the transport variants behind makeListener()/connectTo().
#include <memory>
#include <string>

#include "tq/coupler/transport.hpp"

namespace tq::coupler::detail {

std::unique_ptr<Listener> makeTcpListener(const TransportOptions& o, const std::string& me, const std::string& partner);
std::unique_ptr<Channel> connectTcp(const TransportOptions& o, const std::string& me, const std::string& partner,
                                    Deadline deadline);
std::unique_ptr<Listener> makeMpiListener(const TransportOptions& o, const std::string& me, const std::string& partner);
std::unique_ptr<Channel> connectMpi(const TransportOptions& o, const std::string& me, const std::string& partner,
                                    Deadline deadline);

}  // namespace tq::coupler::detail
