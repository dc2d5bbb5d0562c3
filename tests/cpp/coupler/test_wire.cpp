// Wire format: CRC, header validation, payload codecs, and the committed test vectors
// (tests/data/coupler/vectors_v5.txt) that pin the bytes: the well-formed messages must encode
// to them exactly and every malformed one must be refused with its fault. After a change of the
// protocol, write a new file with `TQ_COUPLER_WRITE_VECTORS=<dir> tq_coupler_tests`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "tq/coupler/messages.hpp"

using namespace tq::coupler;

namespace {

std::vector<std::uint8_t> fromHex(const std::string& h) {
  std::vector<std::uint8_t> b(h.size() / 2);
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = std::uint8_t(std::stoi(h.substr(2 * i, 2), nullptr, 16));
  return b;
}

struct Vector {
  std::string name, expect;
  std::vector<std::uint8_t> bytes;
};

std::vector<Vector> readVectors() {
  std::ifstream f(TQ_COUPLER_VECTORS);
  EXPECT_TRUE(f.good()) << "missing test vectors " << TQ_COUPLER_VECTORS;
  std::vector<Vector> out;
  std::string line;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    Vector v;
    std::string hex;
    s >> v.name >> v.expect >> hex;
    v.bytes = fromHex(hex);
    out.push_back(v);
  }
  return out;
}

CouplingConfig sampleConfig() {
  CouplingConfig c;
  c.first = "solid";
  c.second = "fluid";
  c.windowSize = 1e-4;
  c.maxWindows = 1000;
  c.scheme = SchemeKind::Implicit;
  c.maxIterations = 20;
  c.tolerance = 1e-4;
  c.acceleration = AccelerationKind::IqnIls;
  c.initialRelaxation = 0.5;
  c.predictor = PredictorKind::Linear;
  c.reuse = 8;
  c.meshes.push_back({"wall", MapKind::Coincident, "solid", 1e-6});
  c.fields.push_back({"wall", "velocity", 3, "solid", MapConstraint::Consistent, 1e-9});
  c.fields.push_back({"wall", "force", 3, "fluid", MapConstraint::Conservative, 0.25});
  return c;
}

using Bytes = std::vector<std::uint8_t>;
using Named = std::vector<std::pair<std::string, Bytes>>;

/// The well-formed messages of the vectors, in file order.
Named sampleMessageList() {
  const std::vector<double> xyz = {4.5, 0, 0, 0, 0, 4.5, -4.5, 0, 0};
  const std::vector<double> rev = {-4.5, 0, 0, 0, 0, 4.5, 4.5, 0, 0};
  Hello hello{"run-7f3a", "solid", "fluid", sampleConfig(), {{"wall", {1000, 1001, 1002}, xyz, {0, 1, 2}}}};
  Hello welcome{"run-7f3a", "fluid", "solid", sampleConfig(), {{"wall", {500002, 500001, 500000}, rev, {}}}};
  DataMessage d;
  d.window = 12;
  d.iteration = 1;
  d.flags = flags::kConverged;
  d.time = 0.0013;
  d.residual = 2.5e-5;
  d.fields.push_back({0, 3, {0.1, -0.2, 0.3, 1e-300, -0.0, 12345.678, -1.5e10, std::ldexp(1.0, -20), 7.0}});
  using T = wire::MessageType;
  return Named{
      {"hello", frame(T::Hello, 0, encodeHello(hello))},
      {"welcome", frame(T::Welcome, 0, encodeHello(welcome))},
      {"ready", frame(T::Ready, 1, {})},
      {"reject", frame(T::Reject, 0, encodeReason({ReasonCode::WrongToken, "wrong token"}))},
      {"data", frame(T::Data, 5, encodeData(d))},
      {"bye", frame(T::Bye, 7, encodeReason({ReasonCode::SolverError, ""}))},
      {"abort", frame(T::Abort, 9, encodeReason({ReasonCode::SolverError, "solid stopped: diverged \xc3\xbc"}))},
  };
}

std::map<std::string, Bytes> sampleMessages() {
  const auto list = sampleMessageList();
  return {list.begin(), list.end()};
}

/// The message with header fields changed and the header CRC made valid again.
Bytes reheader(Bytes m, int version, int type) {
  if (version >= 0) m[4] = std::uint8_t(version), m[5] = std::uint8_t(version >> 8);
  if (type >= 0) m[6] = std::uint8_t(type), m[7] = std::uint8_t(type >> 8);
  const std::uint32_t crc = wire::crc32(m.data(), 28);
  for (int i = 0; i < 4; ++i) m[std::size_t(28 + i)] = std::uint8_t(crc >> (8 * i));
  return m;
}

/// The message with another payload and a consistent header (length, CRCs).
Bytes repayload(const Bytes& m, const Bytes& payload) {
  const auto h = wire::decodeHeader(m.data());
  return frame(h.type, h.sequence, payload);
}

struct Malformed {
  std::string name, fault;
  Bytes bytes;
};

/// Messages every receiver must refuse, each with its fault.
std::vector<Malformed> malformedMessages() {
  const auto good = sampleMessages();
  const Bytes& data = good.at("data");
  const Bytes payload(data.begin() + 32, data.end());
  const std::string http = "GET / HTTP/1.1\r\nHost: localhost\r\n\r\n";
  Bytes badMagic = data;
  badMagic[3] = 'X';
  Bytes flippedSeq = data, flippedPayload = data;
  flippedSeq[9] ^= 0x01;
  flippedPayload[40] ^= 0x80;
  Bytes trailing = payload;
  trailing.insert(trailing.end(), 4, 0);
  // the data block's field index, component count and a value count far beyond the payload
  Bytes huge(payload.begin(), payload.begin() + 36);
  wire::Writer w(huge);
  w.u32(0);
  w.u32(3);
  w.u64(std::uint64_t(1) << 60);
  // HELLO with scheme code 7 (after token, participant, partner, units, first, second)
  Bytes hello(good.at("hello").begin() + 32, good.at("hello").end());
  wire::Reader r(hello.data(), hello.size(), "HELLO");
  for (int i = 0; i < 6; ++i) r.str();
  hello[r.offset()] = 7;
  return {
      {"foreign_http", "bad_magic", Bytes(http.begin(), http.end())},
      {"bad_magic", "bad_magic", badMagic},
      {"bad_version", "bad_version", reheader(data, wire::kProtocolVersion + 1, -1)},
      {"bad_header_crc", "bad_header_crc", flippedSeq},
      {"unknown_type", "unknown_type", reheader(data, -1, 99)},
      {"truncated", "bad_length", Bytes(data.begin(), data.end() - 8)},
      {"short_header", "bad_length", Bytes(data.begin(), data.begin() + 20)},
      {"bad_payload_crc", "bad_payload_crc", flippedPayload},
      {"truncated_payload", "bad_payload", repayload(data, Bytes(payload.begin(), payload.end() - 8))},
      {"trailing_bytes", "bad_payload", repayload(data, trailing)},
      {"huge_count", "bad_payload", repayload(data, huge)},
      {"bad_enum", "bad_payload", repayload(good.at("hello"), hello)},
      {"ready_with_payload", "bad_payload", frame(wire::MessageType::Ready, 1, {'x'})},
  };
}

std::string hex(const Bytes& b) {
  std::ostringstream s;
  for (auto c : b) s << std::hex << std::setw(2) << std::setfill('0') << int(c);
  return s.str();
}

/// The text of the vectors file.
std::string vectorFileText() {
  std::ostringstream s;
  s << "# TunnelQuake coupler protocol v" << wire::kProtocolVersion
    << " test vectors: name, expected outcome (ok or the fault), message hex.\n"
       "# Written by tests/cpp/coupler/test_wire.cpp (TQ_COUPLER_WRITE_VECTORS=<dir> "
       "tq_coupler_tests), which\n"
       "# checks the coupler against it: ok rows encoded byte for byte, the others refused.\n";
  for (const auto& [name, bytes] : sampleMessageList()) s << name << " ok " << hex(bytes) << "\n";
  for (const auto& m : malformedMessages()) s << m.name << " " << m.fault << " " << hex(m.bytes) << "\n";
  return s.str();
}

/// Unframes and decodes by type, as a receiver does; throws ProtocolError.
void decodeAny(const std::vector<std::uint8_t>& m) {
  std::vector<std::uint8_t> p;
  const auto h = unframe(m.data(), m.size(), p);
  switch (h.type) {
    case wire::MessageType::Hello:
    case wire::MessageType::Welcome:
      decodeHello(p.data(), p.size());
      break;
    case wire::MessageType::Reject:
    case wire::MessageType::Abort:
    case wire::MessageType::Bye:
      decodeReason(p.data(), p.size());
      break;
    case wire::MessageType::Ready:
      if (!p.empty()) throw ProtocolError(ProtocolFault::BadPayload, "READY payload must be empty");
      break;
    case wire::MessageType::Data:
      decodeData(p.data(), p.size());
      break;
  }
}

}  // namespace

TEST(Wire, Crc32MatchesTheStandardCheckValue) {
  const std::string s = "123456789";  // CRC-32/ISO-HDLC check value 0xCBF43926
  EXPECT_EQ(wire::crc32(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()), 0xCBF43926u);
  // Slice-by-8 and byte-wise paths agree on every length and alignment.
  std::vector<std::uint8_t> b(300);
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = std::uint8_t(i * 37 + 11);
  for (std::size_t n : {0u, 1u, 7u, 8u, 9u, 63u, 64u, 299u}) {
    std::uint32_t slow = 0xFFFFFFFFu;
    for (std::size_t i = 0; i < n; ++i) {
      slow ^= b[i];
      for (int k = 0; k < 8; ++k) slow = (slow & 1u) ? 0xEDB88320u ^ (slow >> 1) : slow >> 1;
    }
    EXPECT_EQ(wire::crc32(b.data(), n), ~slow) << n;
  }
}

TEST(Wire, HeaderRoundTripAndLayout) {
  const std::vector<std::uint8_t> payload = {1, 2, 3, 4, 5};
  const auto m = frame(wire::MessageType::Data, 0x0102030405060708ull, payload);
  ASSERT_EQ(m.size(), 37u);
  EXPECT_EQ(std::string(m.begin(), m.begin() + 4), "TQCP");
  EXPECT_EQ(m[4], 5);   // version, little-endian
  EXPECT_EQ(m[6], 10);  // DATA
  EXPECT_EQ(m[8], 0x08);
  EXPECT_EQ(m[15], 0x01);  // sequence little-endian
  EXPECT_EQ(m[16], 5);     // payload length
  const auto h = wire::decodeHeader(m.data());
  EXPECT_EQ(h.sequence, 0x0102030405060708ull);
  EXPECT_EQ(h.payloadLength, 5u);
  EXPECT_EQ(h.type, wire::MessageType::Data);
}

TEST(Wire, CodecsRoundTrip) {
  const auto msgs = sampleMessages();
  std::vector<std::uint8_t> p;
  unframe(msgs.at("hello").data(), msgs.at("hello").size(), p);
  const Hello h = decodeHello(p.data(), p.size());
  EXPECT_EQ(h.token, "run-7f3a");
  EXPECT_EQ(h.config.fields.at(1).constraint, MapConstraint::Conservative);
  EXPECT_EQ(h.config.fields.at(1).absoluteTolerance, 0.25);
  EXPECT_EQ(describeDifferences(h.config, sampleConfig(), "x"), "");
  EXPECT_EQ(h.meshes.at(0).ids, (std::vector<std::int64_t>{1000, 1001, 1002}));
  EXPECT_EQ(h.meshes.at(0).triangles, (std::vector<std::int32_t>{0, 1, 2}));
  unframe(msgs.at("data").data(), msgs.at("data").size(), p);
  const DataMessage d = decodeData(p.data(), p.size());
  EXPECT_EQ(d.window, 12u);
  EXPECT_EQ(d.iteration, 1u);
  ASSERT_EQ(d.fields.size(), 1u);
  EXPECT_EQ(d.fields[0].values[3], 1e-300);          // bit-exact
  EXPECT_TRUE(std::signbit(d.fields[0].values[4]));  // -0.0 kept
  EXPECT_EQ(p.size(), dataPayloadSize({9}));
}

// The predictor's code in the hello record: 0 constant, 1 linear, 2 damped round-trip and their
// names parse back; code 3 is refused naming the field; an unknown name lists the three.
TEST(Wire, EveryPredictorRoundTripsAndAnUndefinedCodeIsRefused) {
  const std::vector<double> xyz = {4.5, 0, 0, 0, 0, 4.5, -4.5, 0, 0};
  for (auto k : {PredictorKind::Constant, PredictorKind::Linear, PredictorKind::Damped}) {
    Hello h{"run-7f3a", "solid", "fluid", sampleConfig(), {{"wall", {1000, 1001, 1002}, xyz, {0, 1, 2}}}};
    h.config.predictor = k;
    const auto bytes = encodeHello(h);
    EXPECT_EQ(decodeHello(bytes.data(), bytes.size()).config.predictor, k) << predictorName(k);
    EXPECT_EQ(parsePredictor(predictorName(k)), k);
  }
  Hello bad{"run-7f3a", "solid", "fluid", sampleConfig(), {{"wall", {1000, 1001, 1002}, xyz, {0, 1, 2}}}};
  bad.config.predictor = PredictorKind(3);
  const auto bytes = encodeHello(bad);
  try {
    decodeHello(bytes.data(), bytes.size());
    ADD_FAILURE() << "predictor code 3 decoded";
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("predictor code 3 is not defined"), std::string::npos) << e.what();
  }
  try {
    parsePredictor("quadratic");
    ADD_FAILURE() << "predictor 'quadratic' parsed";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("use constant, linear or damped"), std::string::npos) << e.what();
  }
}

// Every configuration name the case files and the hello record's peers use parses back to its value,
// and an unknown one is refused naming the key and every name it could have been, in order.
TEST(Wire, EveryConfigurationNameParsesBackAndAnUnknownOneListsThemAll) {
  auto refused = [](auto parse, const std::string& bad) {
    try {
      parse(bad);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("parsed");
  };
  for (auto k : {SchemeKind::Explicit, SchemeKind::Paper, SchemeKind::Implicit})
    EXPECT_EQ(parseScheme(schemeName(k)), k) << schemeName(k);
  for (auto k :
       {AccelerationKind::None, AccelerationKind::Constant, AccelerationKind::Aitken, AccelerationKind::IqnIls})
    EXPECT_EQ(parseAcceleration(accelerationName(k)), k) << accelerationName(k);
  for (auto k : {ResidualScale::Current, ResidualScale::Largest})
    EXPECT_EQ(parseResidualScale(residualScaleName(k)), k) << residualScaleName(k);
  for (auto k : {MapKind::Coincident, MapKind::Projection})
    EXPECT_EQ(parseMapKind(mapKindName(k)), k) << mapKindName(k);
  EXPECT_EQ(refused(parseScheme, "staggered"), "unknown coupling scheme 'staggered': use explicit, paper or implicit");
  EXPECT_EQ(refused(parseAcceleration, "anderson"),
            "unknown acceleration 'anderson': use none, constant, aitken or iqn-ils");
  EXPECT_EQ(refused(parsePredictor, "Linear"), "unknown predictor 'Linear': use constant, linear or damped");
  EXPECT_EQ(refused(parseResidualScale, "peak"), "unknown residual scale 'peak': use current or largest");
  EXPECT_EQ(refused(parseMapKind, "nearest"), "unknown interface map 'nearest': use coincident or projection");
}

TEST(Wire, SharedTestVectorsDecodeAndEncodeIdentically) {
  const auto vectors = readVectors();
  const auto mine = sampleMessages();
  std::size_t ok = 0, bad = 0;
  for (const auto& v : vectors) {
    if (v.expect == "ok") {
      ASSERT_TRUE(mine.count(v.name)) << "unknown ok vector " << v.name;
      EXPECT_NO_THROW(decodeAny(v.bytes)) << v.name;
      EXPECT_EQ(mine.at(v.name), v.bytes) << v.name << ": the encoding differs from the committed bytes";
      ++ok;
    } else {
      try {
        decodeAny(v.bytes);
        ADD_FAILURE() << v.name << ": malformed message accepted";
      } catch (const ProtocolError& e) {
        EXPECT_EQ(faultName(e.fault()), v.expect) << v.name << ": " << e.what();
        EXPECT_GT(std::string(e.what()).size(), 20u);
      }
      ++bad;
    }
  }
  EXPECT_EQ(ok, mine.size());
  EXPECT_GE(bad, 10u);
}

TEST(Wire, VectorFileIsWhatTheGeneratorWrites) {
  // The malformed rows are derived from the well-formed ones; a protocol change writes a new
  // file (TQ_COUPLER_WRITE_VECTORS=<dir>) under a new version's name.
  if (const char* dir = std::getenv("TQ_COUPLER_WRITE_VECTORS")) {
    const std::string name = "/vectors_v" + std::to_string(wire::kProtocolVersion) + ".txt";
    std::ofstream(std::string(dir) + name) << vectorFileText();
  }
  std::ifstream f(TQ_COUPLER_VECTORS);
  std::stringstream committed;
  committed << f.rdbuf();
  EXPECT_EQ(committed.str(), vectorFileText());
}

TEST(Wire, ForeignBytesAreNamedInTheError) {
  const std::string http = "GET / HTTP/1.1\r\nHost: localhost\r\n\r\n";  // >= 32 bytes
  try {
    wire::decodeHeader(reinterpret_cast<const std::uint8_t*>(http.data()));
    FAIL();
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.fault(), ProtocolFault::BadMagic);
    EXPECT_NE(std::string(e.what()).find("'GET '"), std::string::npos) << e.what();
  }
}

TEST(Wire, ReaderNeverReadsPastTheEnd) {
  // Every truncation of a valid HELLO payload is refused as bad_payload, none crashes.
  const auto m = sampleMessages().at("hello");
  std::vector<std::uint8_t> p(m.begin() + 32, m.end());
  for (std::size_t n = 0; n < p.size(); ++n) {
    try {
      decodeHello(p.data(), n);
      ADD_FAILURE() << "truncated HELLO of " << n << " bytes accepted";
    } catch (const ProtocolError& e) {
      EXPECT_EQ(e.fault(), ProtocolFault::BadPayload);
    }
  }
}
