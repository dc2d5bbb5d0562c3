#pragma once
/// @file errors.hpp
/// Typed errors of the coupler. Every error says which participant, which partner and what was
/// expected, so that a solver can catch one, close its results file and stop cleanly.

#include <stdexcept>
#include <string>

namespace tq::coupler {

/// Base of every coupler error.
class CouplerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Inconsistent or invalid configuration on this side (bad option, unknown mesh or field name,
/// time step larger than the coupling window, ...).
class ConfigError : public CouplerError {
 public:
  using CouplerError::CouplerError;
};

/// Why a received byte sequence was refused. The values are part of the test vectors.
enum class ProtocolFault {
  BadMagic = 1,        ///< not a TunnelQuake coupler message at all (foreign peer)
  BadVersion = 2,      ///< a coupler message of another protocol version
  BadHeaderCrc = 3,    ///< header corrupted
  UnknownType = 4,     ///< message type not defined in this version
  BadLength = 5,       ///< payload length above the limit or different from the expected size
  BadSequence = 6,     ///< message lost, repeated or reordered
  BadPayloadCrc = 7,   ///< payload corrupted
  BadPayload = 8,      ///< payload does not decode (truncated, trailing bytes, bad value)
  UnexpectedType = 9,  ///< a valid message, but not the one the protocol state expects
};

/// Short stable name of a fault ("bad_magic", ...), as used in the test-vector file.
const char* faultName(ProtocolFault f);

/// A malformed, corrupted, foreign or out-of-order message. Never silently ignored.
class ProtocolError : public CouplerError {
 public:
  ProtocolError(ProtocolFault fault, const std::string& what) : CouplerError(what), fault_(fault) {}
  ProtocolFault fault() const { return fault_; }

 private:
  ProtocolFault fault_;
};

/// The partner is not the expected one or is configured differently (token, version, names,
/// units, scheme, meshes, fields). The message lists every difference found.
class HandshakeError : public CouplerError {
 public:
  using CouplerError::CouplerError;
};

/// A failure of the byte transport (socket or MPI call failed).
class TransportError : public CouplerError {
 public:
  using CouplerError::CouplerError;
};

/// Nothing (or not enough) arrived from the partner within the configured timeout.
class TimeoutError : public TransportError {
 public:
  using TransportError::TransportError;
};

/// The partner went away: end of stream, connection reset, or it sent ABORT.
class PartnerLostError : public TransportError {
 public:
  using TransportError::TransportError;
};

/// An interface map could not be built (unmatched nodes, points too far from the surface).
class MapError : public CouplerError {
 public:
  using CouplerError::CouplerError;
};

/// The coupled iteration diverged or produced non-finite values.
class DivergenceError : public CouplerError {
 public:
  using CouplerError::CouplerError;
};

}  // namespace tq::coupler
