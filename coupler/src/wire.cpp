// Wire format v1: CRC-32, header codec, bounds-checked payload reader/writer.
#include "tq/coupler/wire.hpp"

#include "tq/coupler/crc32.hpp"

#include <cmath>
#include <sstream>

namespace tq::coupler {

const char* faultName(ProtocolFault f) {
  switch (f) {
    case ProtocolFault::BadMagic:
      return "bad_magic";
    case ProtocolFault::BadVersion:
      return "bad_version";
    case ProtocolFault::BadHeaderCrc:
      return "bad_header_crc";
    case ProtocolFault::UnknownType:
      return "unknown_type";
    case ProtocolFault::BadLength:
      return "bad_length";
    case ProtocolFault::BadSequence:
      return "bad_sequence";
    case ProtocolFault::BadPayloadCrc:
      return "bad_payload_crc";
    case ProtocolFault::BadPayload:
      return "bad_payload";
    case ProtocolFault::UnexpectedType:
      return "unexpected_type";
  }
  return "unknown";
}

namespace wire {
namespace {

std::uint16_t le16(const std::uint8_t* p) { return std::uint16_t(p[0] | (p[1] << 8)); }
std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}
std::uint64_t le64(const std::uint8_t* p) { return std::uint64_t(le32(p)) | std::uint64_t(le32(p + 4)) << 32; }
void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = std::uint8_t(v);
  p[1] = std::uint8_t(v >> 8);
}
void put32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = std::uint8_t(v >> (8 * i));
}
void put64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = std::uint8_t(v >> (8 * i));
}

std::string printable(const std::uint8_t* p, std::size_t n) {
  std::ostringstream s;
  for (std::size_t i = 0; i < n; ++i) {
    if (p[i] >= 32 && p[i] < 127)
      s << char(p[i]);
    else {
      static const char* hex = "0123456789abcdef";
      s << "\\x" << hex[p[i] >> 4] << hex[p[i] & 15];
    }
  }
  return s.str();
}

constexpr bool kLittleEndianHost =
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__)
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
#else
    false;
#endif

}  // namespace

bool isKnownType(std::uint16_t t) {
  switch (MessageType(t)) {
    case MessageType::Hello:
    case MessageType::Welcome:
    case MessageType::Reject:
    case MessageType::Ready:
    case MessageType::Data:
    case MessageType::Bye:
    case MessageType::Abort:
      return true;
  }
  return false;
}

std::string typeName(std::uint16_t t) {
  switch (MessageType(t)) {
    case MessageType::Hello:
      return "HELLO";
    case MessageType::Welcome:
      return "WELCOME";
    case MessageType::Reject:
      return "REJECT";
    case MessageType::Ready:
      return "READY";
    case MessageType::Data:
      return "DATA";
    case MessageType::Bye:
      return "BYE";
    case MessageType::Abort:
      return "ABORT";
  }
  return "type " + std::to_string(t);
}

std::uint32_t crc32(const std::uint8_t* p, std::size_t n, std::uint32_t crc) {
  return ::tq::crc::crc32(p, n, crc);  // the one CRC-32 of the project (crc32.hpp)
}

void encodeHeader(MessageType type, std::uint64_t sequence, const std::uint8_t* payload, std::size_t n,
                  std::uint8_t* h) {
  for (int i = 0; i < 4; ++i) h[i] = kMagic[i];
  put16(h + 4, kProtocolVersion);
  put16(h + 6, std::uint16_t(type));
  put64(h + 8, sequence);
  put64(h + 16, n);
  put32(h + 24, crc32(payload, n));
  put32(h + 28, crc32(h, 28));
}

Header decodeHeader(const std::uint8_t* h) {
  if (h[0] != kMagic[0] || h[1] != kMagic[1] || h[2] != kMagic[2] || h[3] != kMagic[3])
    throw ProtocolError(ProtocolFault::BadMagic, "not a TunnelQuake coupler message: it starts with '" +
                                                     printable(h, 4) +
                                                     "' instead of 'TQCP' (a foreign program, or "
                                                     "a partner that lost track of the message boundaries)");
  Header r;
  r.version = le16(h + 4);
  if (r.version != kProtocolVersion)
    throw ProtocolError(ProtocolFault::BadVersion, "coupler protocol version " + std::to_string(r.version) +
                                                       " received, this build speaks version " +
                                                       std::to_string(kProtocolVersion) +
                                                       ": build both participants from the same TunnelQuake version");
  const std::uint32_t want = le32(h + 28), got = crc32(h, 28);
  if (want != got)
    throw ProtocolError(ProtocolFault::BadHeaderCrc, "message header corrupted (header CRC-32 mismatch)");
  const std::uint16_t t = le16(h + 6);
  if (!isKnownType(t))
    throw ProtocolError(ProtocolFault::UnknownType,
                        "unknown message type " + std::to_string(t) + " in a protocol-version-1 header");
  r.type = MessageType(t);
  r.sequence = le64(h + 8);
  r.payloadLength = le64(h + 16);
  r.payloadCrc = le32(h + 24);
  return r;
}

void Writer::str(const std::string& s) {
  if (s.size() > kMaxString)
    throw ConfigError("string of " + std::to_string(s.size()) + " bytes is too long for the coupler protocol (limit " +
                      std::to_string(kMaxString) + ")");
  u32(std::uint32_t(s.size()));
  out_.insert(out_.end(), s.begin(), s.end());
}

void Writer::f64s(const double* v, std::size_t n) {
  if (kLittleEndianHost) {
    const auto* b = reinterpret_cast<const std::uint8_t*>(v);
    out_.insert(out_.end(), b, b + 8 * n);
  } else {
    for (std::size_t i = 0; i < n; ++i) f64(v[i]);
  }
}
void Writer::i64s(const std::int64_t* v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) i64(v[i]);
}
void Writer::i32s(const std::int32_t* v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) i32(v[i]);
}

void Reader::fail(const std::string& why) const {
  throw ProtocolError(ProtocolFault::BadPayload, what_ + " payload does not decode at byte " + std::to_string(pos_) +
                                                     " of " + std::to_string(n_) + ": " + why);
}
void Reader::need(std::size_t k) {
  if (k > n_ - pos_)
    fail("needs " + std::to_string(k) + " more bytes, only " + std::to_string(n_ - pos_) + " left (truncated)");
}
std::uint8_t Reader::u8() {
  need(1);
  return p_[pos_++];
}
double Reader::f64() {
  const std::uint64_t b = u64();
  double v;
  std::memcpy(&v, &b, 8);
  return v;
}
std::string Reader::str() {
  const std::uint32_t len = u32();
  if (len > kMaxString) fail("string length " + std::to_string(len) + " above the limit");
  need(len);
  std::string s(reinterpret_cast<const char*>(p_ + pos_), len);
  pos_ += len;
  return s;
}
std::uint64_t Reader::count(std::size_t elementSize, const char* name) {
  const std::uint64_t c = u64();
  if (elementSize && c > (n_ - pos_) / elementSize)
    fail(std::string(name) + " count " + std::to_string(c) + " does not fit in the " + std::to_string(n_ - pos_) +
         " bytes left");
  return c;
}
void Reader::f64s(double* v, std::size_t n) {
  need(8 * n);
  if (kLittleEndianHost) {
    std::memcpy(v, p_ + pos_, 8 * n);
    pos_ += 8 * n;
  } else {
    for (std::size_t i = 0; i < n; ++i) v[i] = f64();
  }
}
void Reader::i64s(std::int64_t* v, std::size_t n) {
  need(8 * n);
  for (std::size_t i = 0; i < n; ++i) v[i] = i64();
}
void Reader::i32s(std::int32_t* v, std::size_t n) {
  need(4 * n);
  for (std::size_t i = 0; i < n; ++i) v[i] = i32();
}
void Reader::finish() {
  if (pos_ != n_) fail(std::to_string(n_ - pos_) + " unexpected trailing bytes");
}

}  // namespace wire
}  // namespace tq::coupler
