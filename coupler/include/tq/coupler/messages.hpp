#pragma once
/// @file messages.hpp
/// Payloads of the protocol messages (layouts in docs/coupler.md) and their codecs.

#include <cstdint>
#include <string>
#include <vector>

#include "tq/coupler/config.hpp"
#include "tq/coupler/wire.hpp"

namespace tq::coupler {

/// A participant's own vertices of one interface mesh.
struct MeshVertices {
  std::string name;
  std::vector<std::int64_t> ids;        ///< one per node, unique (e.g. solid node numbers)
  std::vector<double> coordinates;      ///< 3 per node, m
  std::vector<std::int32_t> triangles;  ///< 3 node indices per surface triangle (may be empty)
  std::size_t size() const { return ids.size(); }
};

/// The HELLO / WELCOME record. The token is always the first item of the payload, in every
/// protocol version, so that an acceptor can tell a foreign run from a misconfigured partner.
struct Hello {
  std::string token;
  std::string participant;  ///< sender
  std::string partner;      ///< whom the sender expects at the other end
  CouplingConfig config;
  std::vector<MeshVertices> meshes;
  /// The sender's part of its participant (Participant::setPart): `part` of `parts`, each a
  /// connection of its own carrying its own vertices; 0 of 1 for a participant in one piece.
  std::uint32_t part = 0, parts = 1;
};

/// Reason codes of REJECT and ABORT.
enum class ReasonCode : std::uint32_t {
  WrongToken = 1,
  WrongVersion = 2,
  ConfigMismatch = 3,
  MeshMismatch = 4,
  ProtocolViolation = 5,
  SolverError = 6,
  Timeout = 7,
  Diverged = 8,
};

struct Reason {
  ReasonCode code = ReasonCode::SolverError;
  std::string message;
};

/// DATA flags.
namespace flags {
constexpr std::uint32_t kConverged = 1u;   ///< second → first: the window is complete
constexpr std::uint32_t kLastWindow = 2u;  ///< this is the final window's final exchange
}  // namespace flags

/// One field block of a DATA message: values node-major (n0c0 n0c1 n0c2 n1c0 ...).
struct FieldBlock {
  std::uint32_t field = 0;  ///< index into the configuration's field list
  std::uint32_t components = 0;
  std::vector<double> values;
};

struct DataMessage {
  std::uint64_t window = 0;
  std::uint32_t iteration = 0;
  std::uint32_t flags = 0;
  double time = 0.0;      ///< s, end of the window
  double residual = 0.0;  ///< relative residual measured by the second participant (or NaN)
  std::vector<FieldBlock> fields;
};

std::vector<std::uint8_t> encodeHello(const Hello& h);
Hello decodeHello(const std::uint8_t* p, std::size_t n);
std::vector<std::uint8_t> encodeReason(const Reason& r);
Reason decodeReason(const std::uint8_t* p, std::size_t n);
std::vector<std::uint8_t> encodeData(const DataMessage& d);
DataMessage decodeData(const std::uint8_t* p, std::size_t n);
/// Exact payload size of a DATA message with blocks of the given value counts.
std::uint64_t dataPayloadSize(const std::vector<std::uint64_t>& valuesPerBlock);

/// A complete framed message (header + payload), as it travels.
std::vector<std::uint8_t> frame(wire::MessageType type, std::uint64_t sequence,
                                const std::vector<std::uint8_t>& payload);

/// Decodes one complete framed message, checking everything a receiver checks (used by the
/// test vectors): header, length == bytes present, payload CRC. Returns the header.
wire::Header unframe(const std::uint8_t* p, std::size_t n, std::vector<std::uint8_t>& payload);

}  // namespace tq::coupler
