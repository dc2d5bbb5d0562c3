#pragma once
/// @file endpoint.hpp
/// Framed, validated messages over a Channel: sequence numbers, size limits, CRCs, and errors
/// that name both participants and what was expected.

#include <memory>
#include <string>
#include <vector>

#include "tq/coupler/errors.hpp"
#include "tq/coupler/transport.hpp"
#include "tq/coupler/wire.hpp"

namespace tq::coupler {

struct Message {
  wire::Header header;
  std::vector<std::uint8_t> payload;
};

class Endpoint {
 public:
  Endpoint(std::unique_ptr<Channel> channel, std::string me, std::string partner);
  ~Endpoint();

  /// Frames and sends one message.
  void send(wire::MessageType type, const std::vector<std::uint8_t>& payload, Deadline d, const std::string& context);
  /// Receives one message and validates it completely before returning it: header (magic,
  /// version, CRC, type), sequence number, length limit for its type, payload CRC. ABORT from
  /// the partner is turned into PartnerLostError carrying the partner's reason. `expecting`
  /// describes what the protocol waits for ("DATA of window 12, iteration 0").
  Message receive(Deadline d, const std::string& expecting);
  /// Exact DATA payload size this side expects to receive (0: not known yet).
  void setExpectedDataSize(std::uint64_t bytes) { expectedData_ = bytes; }
  void close() noexcept;
  bool open() const { return channel_ != nullptr; }
  const std::string& me() const { return me_; }
  const std::string& partner() const { return partner_; }
  void setPartner(std::string p) { partner_ = std::move(p); }
  std::string describe() const { return channel_ ? channel_->describe() : "closed"; }
  /// Seconds spent inside send() and receive() (including waiting for the partner).
  double secondsInTransport() const { return seconds_; }
  /// Of secondsInTransport: seconds a receive() waited until the message's header had arrived,
  /// i.e. blocked on the partner (its compute, or the network) rather than moving data.
  double secondsWaiting() const { return secondsWaiting_; }
  std::uint64_t bytesSent() const { return bytesSent_; }
  std::uint64_t bytesReceived() const { return bytesReceived_; }

 private:
  std::unique_ptr<Channel> channel_;
  std::string me_, partner_;
  std::uint64_t sendSeq_ = 0, recvSeq_ = 0;
  std::uint64_t expectedData_ = 0;
  double seconds_ = 0.0;
  double secondsWaiting_ = 0.0;
  std::uint64_t bytesSent_ = 0, bytesReceived_ = 0;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace tq::coupler
