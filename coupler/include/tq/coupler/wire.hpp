#pragma once
/// @file wire.hpp
/// The coupler's wire format, version 5 (docs/coupler.md is the normative description).
///
/// Every message is a fixed 32-byte header followed by a payload; all integers and floats are
/// little-endian, floats IEEE-754 binary64:
///
///     offset size field
///      0     4   magic "TQCP"
///      4     2   protocol version (u16) = 4
///      6     2   message type (u16), MessageType
///      8     8   sequence number (u64): per direction, 0 for the first message, +1 each
///     16     8   payload length in bytes (u64)
///     24     4   CRC-32 (IEEE 802.3, as zlib.crc32) of the payload
///     28     4   CRC-32 of header bytes 0..27
///
/// This header has no socket or MPI dependency: the same bytes travel over TCP and MPI.

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "tq/coupler/errors.hpp"

namespace tq::coupler::wire {

constexpr std::array<std::uint8_t, 4> kMagic{'T', 'Q', 'C', 'P'};
constexpr std::uint16_t kProtocolVersion = 5;
constexpr std::size_t kHeaderSize = 32;
/// Largest payload accepted before the handshake has fixed the exact sizes (HELLO carries the
/// interface coordinates: 1 GiB allows ~30 million nodes).
constexpr std::uint64_t kMaxHandshakePayload = std::uint64_t(1) << 30;
/// Largest string accepted inside a payload.
constexpr std::uint32_t kMaxString = 1u << 16;

enum class MessageType : std::uint16_t {
  Hello = 1,    ///< connector → acceptor: who I am and how I am configured
  Welcome = 2,  ///< acceptor → connector: the acceptor's own HELLO record (accepted)
  Reject = 3,   ///< either way during the handshake: refused, with a reason
  Ready = 4,    ///< connector → acceptor: the connector accepts the acceptor's record
  Data = 10,    ///< one exchange of interface fields
  Bye = 20,     ///< clean end of the coupling
  Abort = 21,   ///< the sender stops on an error; the reason travels with it
};

/// True for the message types defined in this protocol version.
bool isKnownType(std::uint16_t t);
/// Name of a message type ("HELLO", "DATA", ...), "type 77" for unknown ones.
std::string typeName(std::uint16_t t);

/// CRC-32 (polynomial 0xEDB88320, reflected, init and final xor 0xFFFFFFFF): zlib.crc32.
std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0);

struct Header {
  std::uint16_t version = kProtocolVersion;
  MessageType type = MessageType::Data;
  std::uint64_t sequence = 0;
  std::uint64_t payloadLength = 0;
  std::uint32_t payloadCrc = 0;
};

/// Writes the 32 header bytes for a payload (fills length and payload CRC).
void encodeHeader(MessageType type, std::uint64_t sequence, const std::uint8_t* payload, std::size_t n,
                  std::uint8_t* out32);

/// Validates and decodes 32 header bytes: magic, version, header CRC, known type, in that
/// order. Length, sequence and payload CRC are checked by the caller, who knows the limits.
Header decodeHeader(const std::uint8_t* in32);

/// Appends little-endian values to a byte buffer.
class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { put(v); }
  void u32(std::uint32_t v) { put(v); }
  void u64(std::uint64_t v) { put(v); }
  void i32(std::int32_t v) { put(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { put(static_cast<std::uint64_t>(v)); }
  void f64(double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, 8);
    put(b);
  }
  void str(const std::string& s);
  void f64s(const double* v, std::size_t n);
  void i64s(const std::int64_t* v, std::size_t n);
  void i32s(const std::int32_t* v, std::size_t n);

 private:
  template <class U>
  void put(U v) {
    for (std::size_t i = 0; i < sizeof(U); ++i) out_.push_back(std::uint8_t(v >> (8 * i)));
  }
  std::vector<std::uint8_t>& out_;
};

/// Bounds-checked little-endian reader over a payload; any overrun or bad value throws
/// ProtocolError(BadPayload) naming the message and the offset.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t n, std::string what) : p_(data), n_(n), what_(std::move(what)) {}
  std::uint8_t u8();
  std::uint16_t u16() { return get<std::uint16_t>(); }
  std::uint32_t u32() { return get<std::uint32_t>(); }
  std::uint64_t u64() { return get<std::uint64_t>(); }
  std::int32_t i32() { return static_cast<std::int32_t>(get<std::uint32_t>()); }
  std::int64_t i64() { return static_cast<std::int64_t>(get<std::uint64_t>()); }
  double f64();
  std::string str();
  /// Reads a count that is followed by `elementSize`-byte items and checks that they fit.
  std::uint64_t count(std::size_t elementSize, const char* name);
  void f64s(double* v, std::size_t n);
  void i64s(std::int64_t* v, std::size_t n);
  void i32s(std::int32_t* v, std::size_t n);
  std::size_t remaining() const { return n_ - pos_; }
  std::size_t offset() const { return pos_; }
  /// Throws if bytes are left over.
  void finish();
  [[noreturn]] void fail(const std::string& why) const;

 private:
  void need(std::size_t k);
  template <class U>
  U get() {
    need(sizeof(U));
    U v = 0;
    for (std::size_t i = 0; i < sizeof(U); ++i) v |= U(p_[pos_ + i]) << (8 * i);
    pos_ += sizeof(U);
    return v;
  }
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t pos_ = 0;
  std::string what_;
};

}  // namespace tq::coupler::wire
