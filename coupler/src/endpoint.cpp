// Framed messages over a Channel, validated before use.
#include "tq/coupler/endpoint.hpp"

#include <sstream>

#include "tq/coupler/messages.hpp"

namespace tq::coupler {
namespace {

std::string secondsText(double s) {
  std::ostringstream o;
  o << s << " s";
  return o.str();
}

/// Re-throws the exception in flight as the same type with `prefix` in front of its message.
[[noreturn]] void rethrowWith(const std::string& prefix, const std::string& suffix = "") {
  try {
    throw;
  } catch (const TimeoutError& e) {
    throw TimeoutError(prefix + e.what() + suffix);
  } catch (const PartnerLostError& e) {
    throw PartnerLostError(prefix + e.what() + suffix);
  } catch (const TransportError& e) {
    throw TransportError(prefix + e.what() + suffix);
  } catch (const ProtocolError& e) {
    throw ProtocolError(e.fault(), prefix + e.what() + suffix);
  }
}

std::uint64_t limitFor(wire::MessageType t, std::uint64_t expectedData) {
  switch (t) {
    case wire::MessageType::Hello:
    case wire::MessageType::Welcome:
      return wire::kMaxHandshakePayload;
    case wire::MessageType::Ready:
      return 0;
    case wire::MessageType::Reject:
    case wire::MessageType::Abort:
    case wire::MessageType::Bye:
      return 8 + wire::kMaxString;
    case wire::MessageType::Data:
      return expectedData ? expectedData : wire::kMaxHandshakePayload;
  }
  return 0;
}

}  // namespace

Endpoint::Endpoint(std::unique_ptr<Channel> channel, std::string me, std::string partner)
    : channel_(std::move(channel)), me_(std::move(me)), partner_(std::move(partner)) {}

Endpoint::~Endpoint() { close(); }

void Endpoint::close() noexcept {
  if (channel_) channel_->close();
  channel_.reset();
}

void Endpoint::send(wire::MessageType type, const std::vector<std::uint8_t>& payload, Deadline d,
                    const std::string& context) {
  if (!channel_)
    throw TransportError("participant '" + me_ + "' cannot send " + wire::typeName(std::uint16_t(type)) + " (" +
                         context + "): the link to '" + partner_ + "' is closed");
  buffer_.resize(wire::kHeaderSize + payload.size());
  wire::encodeHeader(type, sendSeq_, payload.data(), payload.size(), buffer_.data());
  std::copy(payload.begin(), payload.end(), buffer_.begin() + wire::kHeaderSize);
  const auto t0 = Clock::now();
  try {
    channel_->send(buffer_.data(), buffer_.size(), d);
  } catch (const TransportError&) {
    seconds_ += std::chrono::duration<double>(Clock::now() - t0).count();
    rethrowWith("participant '" + me_ + "' sending " + wire::typeName(std::uint16_t(type)) + " (" + context + ") to '" +
                partner_ + "' over " + channel_->describe() + ": ");
  }
  seconds_ += std::chrono::duration<double>(Clock::now() - t0).count();
  bytesSent_ += buffer_.size();
  ++sendSeq_;
}

Message Endpoint::receive(Deadline d, const std::string& expecting) {
  const std::string who = "participant '" + me_ + "' waiting for " + expecting + " from '" + partner_ + "'";
  if (!channel_) throw TransportError(who + ": the link is closed");
  Message m;
  std::uint8_t h[wire::kHeaderSize];
  const auto t0 = Clock::now();
  struct Tally {
    Endpoint& e;
    Clock::time_point t0;
    ~Tally() { e.seconds_ += std::chrono::duration<double>(Clock::now() - t0).count(); }
  } tally{*this, t0};
  try {
    channel_->receive(h, sizeof h, d);
    // The header arrived: the time until now was spent waiting for the partner (a sender
    // writes header and payload in one call, so the payload follows at transfer speed).
    secondsWaiting_ += std::chrono::duration<double>(Clock::now() - t0).count();
    m.header = wire::decodeHeader(h);
    if (m.header.sequence != recvSeq_)
      throw ProtocolError(ProtocolFault::BadSequence, "sequence number " + std::to_string(m.header.sequence) +
                                                          " where " + std::to_string(recvSeq_) +
                                                          " was due (a message was lost, repeated or reordered)");
    const std::uint64_t limit = limitFor(m.header.type, expectedData_);
    const bool exact = m.header.type == wire::MessageType::Data && expectedData_ != 0;
    if (exact ? m.header.payloadLength != limit : m.header.payloadLength > limit)
      throw ProtocolError(ProtocolFault::BadLength, wire::typeName(std::uint16_t(m.header.type)) + " announces " +
                                                        std::to_string(m.header.payloadLength) + " payload bytes; " +
                                                        (exact ? "the handshake fixed exactly " : "the limit is ") +
                                                        std::to_string(limit) +
                                                        (exact ? " (interface sizes differ?)" : ""));
    m.payload.resize(m.header.payloadLength);
    channel_->receive(m.payload.data(), m.payload.size(), d);
    if (wire::crc32(m.payload.data(), m.payload.size()) != m.header.payloadCrc)
      throw ProtocolError(ProtocolFault::BadPayloadCrc, wire::typeName(std::uint16_t(m.header.type)) +
                                                            " payload corrupted (payload CRC-32 mismatch)");
  } catch (const TimeoutError&) {
    rethrowWith(who + ": ", " within the timeout of " + secondsText(d.seconds) +
                                ". The partner is hung or slower than the timeout allows "
                                "(raise coupling.timeout if it is only slow).");
  } catch (const PartnerLostError&) {
    rethrowWith(who + ": ", ". The partner process has probably stopped: see its log.");
  } catch (const TransportError&) {
    rethrowWith(who + ": ");
  } catch (const ProtocolError&) {
    rethrowWith(who + " over " + channel_->describe() + ": refused a message: ");
  }
  bytesReceived_ += wire::kHeaderSize + m.payload.size();
  ++recvSeq_;
  if (m.header.type == wire::MessageType::Abort) {
    const Reason r = decodeReason(m.payload.data(), m.payload.size());
    throw PartnerLostError("'" + partner_ + "' stopped on an error while '" + me_ + "' was waiting for " + expecting +
                           ": " + r.message);
  }
  return m;
}

}  // namespace tq::coupler
