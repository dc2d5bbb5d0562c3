// Payload codecs of HELLO/WELCOME, REJECT/ABORT and DATA (layouts in docs/coupler.md).
#include "tq/coupler/messages.hpp"

#include <string>

namespace tq::coupler {

using wire::Reader;
using wire::Writer;

namespace {

void encodeConfig(Writer& w, const CouplingConfig& c) {
  w.str(c.units);
  w.str(c.first);
  w.str(c.second);
  w.u8(std::uint8_t(c.scheme));
  w.f64(c.windowSize);
  w.u64(c.maxWindows);
  w.u32(std::uint32_t(c.maxIterations));
  w.f64(c.tolerance);
  w.u8(std::uint8_t(c.acceleration));
  w.f64(c.initialRelaxation);
  w.u8(std::uint8_t(c.predictor));
  w.u8(std::uint8_t(c.residualScale));
  w.u32(std::uint32_t(c.reuse));
  w.u32(std::uint32_t(c.meshes.size()));
  for (const auto& m : c.meshes) {
    w.str(m.name);
    w.u8(std::uint8_t(m.mapping));
    w.str(m.mappingSide);
    w.f64(m.tolerance);
  }
  w.u32(std::uint32_t(c.fields.size()));
  for (const auto& f : c.fields) {
    w.str(f.mesh);
    w.str(f.name);
    w.u32(std::uint32_t(f.components));
    w.str(f.writer);
    w.u8(std::uint8_t(f.constraint));
    w.f64(f.absoluteTolerance);
  }
}

std::uint8_t enumValue(Reader& r, std::uint8_t max, const char* what) {
  const std::uint8_t v = r.u8();
  if (v > max) r.fail(std::string(what) + " code " + std::to_string(v) + " is not defined");
  return v;
}

CouplingConfig decodeConfig(Reader& r) {
  CouplingConfig c;
  c.units = r.str();
  c.first = r.str();
  c.second = r.str();
  c.scheme = SchemeKind(enumValue(r, 2, "scheme"));
  c.windowSize = r.f64();
  c.maxWindows = r.u64();
  c.maxIterations = int(r.u32());
  c.tolerance = r.f64();
  c.acceleration = AccelerationKind(enumValue(r, 3, "acceleration"));
  c.initialRelaxation = r.f64();
  c.predictor = PredictorKind(enumValue(r, 2, "predictor"));
  c.residualScale = ResidualScale(enumValue(r, 1, "residual scale"));
  const std::uint32_t reuse = r.u32();
  if (reuse > 1000) r.fail("reuse " + std::to_string(reuse) + " above the limit 1000");
  c.reuse = int(reuse);
  const std::uint32_t nm = r.u32();
  if (nm > 1024) r.fail("mesh count " + std::to_string(nm) + " above the limit 1024");
  for (std::uint32_t i = 0; i < nm; ++i) {
    MeshSpec m;
    m.name = r.str();
    m.mapping = MapKind(enumValue(r, 1, "map kind"));
    m.mappingSide = r.str();
    m.tolerance = r.f64();
    c.meshes.push_back(std::move(m));
  }
  const std::uint32_t nf = r.u32();
  if (nf > 4096) r.fail("field count " + std::to_string(nf) + " above the limit 4096");
  for (std::uint32_t i = 0; i < nf; ++i) {
    FieldSpec f;
    f.mesh = r.str();
    f.name = r.str();
    f.components = int(r.u32());
    f.writer = r.str();
    f.constraint = MapConstraint(enumValue(r, 1, "map constraint"));
    f.absoluteTolerance = r.f64();
    c.fields.push_back(std::move(f));
  }
  return c;
}

}  // namespace

std::vector<std::uint8_t> encodeHello(const Hello& h) {
  std::vector<std::uint8_t> out;
  Writer w(out);
  w.str(h.token);
  w.str(h.participant);
  w.str(h.partner);
  encodeConfig(w, h.config);
  w.u32(std::uint32_t(h.meshes.size()));
  for (const auto& m : h.meshes) {
    if (m.coordinates.size() != 3 * m.ids.size() || m.triangles.size() % 3)
      throw ConfigError("mesh '" + m.name +
                        "': coordinates must be 3 per id and "
                        "triangles 3 indices each");
    w.str(m.name);
    w.u64(m.ids.size());
    w.i64s(m.ids.data(), m.ids.size());
    w.f64s(m.coordinates.data(), m.coordinates.size());
    w.u64(m.triangles.size() / 3);
    w.i32s(m.triangles.data(), m.triangles.size());
  }
  w.u32(h.part);
  w.u32(h.parts);
  return out;
}

Hello decodeHello(const std::uint8_t* p, std::size_t n) {
  Reader r(p, n, "HELLO");
  Hello h;
  h.token = r.str();
  h.participant = r.str();
  h.partner = r.str();
  h.config = decodeConfig(r);
  const std::uint32_t nm = r.u32();
  if (nm > 1024) r.fail("mesh count above the limit 1024");
  for (std::uint32_t i = 0; i < nm; ++i) {
    MeshVertices m;
    m.name = r.str();
    const std::uint64_t nn = r.count(32, "node");
    m.ids.resize(nn);
    m.coordinates.resize(3 * nn);
    r.i64s(m.ids.data(), nn);
    r.f64s(m.coordinates.data(), 3 * nn);
    const std::uint64_t nt = r.count(12, "triangle");
    m.triangles.resize(3 * nt);
    r.i32s(m.triangles.data(), 3 * nt);
    for (auto t : m.triangles)
      if (t < 0 || std::uint64_t(t) >= nn)
        r.fail("mesh '" + m.name + "': triangle node index " + std::to_string(t) + " outside 0.." + std::to_string(nn) +
               "-1");
    h.meshes.push_back(std::move(m));
  }
  h.part = r.u32();
  h.parts = r.u32();
  if (h.parts < 1 || h.parts > 65536 || h.part >= h.parts)
    r.fail("part " + std::to_string(h.part) + " of " + std::to_string(h.parts) +
           " is not a part (0 <= part < parts <= 65536)");
  r.finish();
  return h;
}

std::vector<std::uint8_t> encodeReason(const Reason& x) {
  std::vector<std::uint8_t> out;
  Writer w(out);
  w.u32(std::uint32_t(x.code));
  w.str(x.message.size() > wire::kMaxString ? x.message.substr(0, wire::kMaxString) : x.message);
  return out;
}

Reason decodeReason(const std::uint8_t* p, std::size_t n) {
  Reader r(p, n, "REJECT/ABORT");
  Reason x;
  x.code = ReasonCode(r.u32());
  x.message = r.str();
  r.finish();
  return x;
}

std::uint64_t dataPayloadSize(const std::vector<std::uint64_t>& valuesPerBlock) {
  std::uint64_t n = 8 + 4 + 4 + 8 + 8 + 4;
  for (auto v : valuesPerBlock) n += 4 + 4 + 8 + 8 * v;
  return n;
}

std::vector<std::uint8_t> encodeData(const DataMessage& d) {
  std::vector<std::uint64_t> sizes;
  for (const auto& f : d.fields) sizes.push_back(f.values.size());
  std::vector<std::uint8_t> out;
  out.reserve(dataPayloadSize(sizes));
  Writer w(out);
  w.u64(d.window);
  w.u32(d.iteration);
  w.u32(d.flags);
  w.f64(d.time);
  w.f64(d.residual);
  w.u32(std::uint32_t(d.fields.size()));
  for (const auto& f : d.fields) {
    if (f.components == 0 || f.values.size() % f.components)
      throw ConfigError("DATA block of field #" + std::to_string(f.field) +
                        ": value count is not a multiple of the components");
    w.u32(f.field);
    w.u32(f.components);
    w.u64(f.values.size() / f.components);
    w.f64s(f.values.data(), f.values.size());
  }
  return out;
}

DataMessage decodeData(const std::uint8_t* p, std::size_t n) {
  Reader r(p, n, "DATA");
  DataMessage d;
  d.window = r.u64();
  d.iteration = r.u32();
  d.flags = r.u32();
  d.time = r.f64();
  d.residual = r.f64();
  const std::uint32_t nb = r.u32();
  if (nb > 4096) r.fail("block count above the limit 4096");
  for (std::uint32_t i = 0; i < nb; ++i) {
    FieldBlock b;
    b.field = r.u32();
    b.components = r.u32();
    if (b.components < 1 || b.components > 9)
      r.fail("block " + std::to_string(i) + ": " + std::to_string(b.components) + " components (1..9 allowed)");
    const std::uint64_t nn = r.count(8 * b.components, "node");
    b.values.resize(nn * b.components);
    r.f64s(b.values.data(), b.values.size());
    d.fields.push_back(std::move(b));
  }
  r.finish();
  return d;
}

std::vector<std::uint8_t> frame(wire::MessageType type, std::uint64_t seq, const std::vector<std::uint8_t>& payload) {
  std::vector<std::uint8_t> out(wire::kHeaderSize + payload.size());
  wire::encodeHeader(type, seq, payload.data(), payload.size(), out.data());
  std::copy(payload.begin(), payload.end(), out.begin() + wire::kHeaderSize);
  return out;
}

wire::Header unframe(const std::uint8_t* p, std::size_t n, std::vector<std::uint8_t>& payload) {
  if (n < wire::kHeaderSize)
    throw ProtocolError(ProtocolFault::BadLength,
                        "message of " + std::to_string(n) + " bytes is shorter than the " + "32-byte header");
  const wire::Header h = wire::decodeHeader(p);
  if (h.payloadLength != n - wire::kHeaderSize)
    throw ProtocolError(ProtocolFault::BadLength, "header announces " + std::to_string(h.payloadLength) +
                                                      " payload bytes, " + std::to_string(n - wire::kHeaderSize) +
                                                      " present");
  payload.assign(p + wire::kHeaderSize, p + n);
  if (wire::crc32(payload.data(), payload.size()) != h.payloadCrc)
    throw ProtocolError(ProtocolFault::BadPayloadCrc,
                        wire::typeName(std::uint16_t(h.type)) + " payload corrupted (payload CRC-32 mismatch)");
  return h;
}

}  // namespace tq::coupler
