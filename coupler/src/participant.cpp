// Participant: handshake, maps, data buffers, and the scheme driving the exchange.
#include "tq/coupler/participant.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <utility>

namespace tq::coupler {

using wire::MessageType;

struct Participant::MeshState {
  MeshVertices own;
  MeshVertices partner;
  bool iMap = false;
  std::unique_ptr<ConsistentMap> mineToPartner;  ///< targets: partner nodes
  std::unique_ptr<ConsistentMap> partnerToMine;  ///< targets: my nodes
  std::unique_ptr<ConservativeMap> mineToPartnerT, partnerToMineT;
};

struct Participant::Field {
  FieldSpec spec;
  int index = 0;
  bool write = false;
  int comps = 3;
  std::size_t ownNodes = 0, wireNodes = 0;
  std::size_t offset = 0;                         ///< written: into written_ (own layout); read: into received_ (wire)
  const ConsistentMap* consistent = nullptr;      ///< applied when not null
  const ConservativeMap* conservative = nullptr;  ///< applied when not null
  std::vector<double> own;                        ///< read fields: values on my nodes
  std::vector<double> wire;                       ///< written fields: values as sent
};

Participant::Participant(std::string name, CouplingConfig config, TransportOptions transport, std::string token)
    : name_(std::move(name)), config_(std::move(config)), transport_(std::move(transport)), token_(std::move(token)) {
  config_.validate();
  partner_ = config_.partnerOf(name_);
  amFirst_ = name_ == config_.first;
  if (token_.empty())
    throw ConfigError("participant '" + name_ +
                      "': an empty run token is not allowed; the "
                      "launcher must give both sides the same per-run token");
  if (!(transport_.connectTimeout > 0) || !(transport_.receiveTimeout > 0))
    throw ConfigError("participant '" + name_ + "': timeouts must be positive");
  for (const auto& m : config_.meshes) {
    auto st = std::make_unique<MeshState>();
    st->own.name = m.name;
    st->iMap = config_.mappingSideOf(m) == name_;
    meshes_[m.name] = std::move(st);
  }
}

namespace {
/// For each point of `at` (3 coordinates each), the index of the nearest of `points` within `tol`
/// (m), or −1: the pairing of the coincident map.
std::vector<long> coincidentWith(const std::vector<double>& points, const std::vector<double>& at, double tol) {
  std::vector<long> out(at.size() / 3, -1);
  if (points.empty()) return out;
  const KdTree tree(points.data(), points.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i) {
    double d2 = 0;
    const std::size_t s = tree.nearest(at.data() + 3 * i, &d2);
    if (std::sqrt(d2) <= tol) out[i] = long(s);
  }
  return out;
}

double meshTolerance(const CouplingConfig& c, const std::string& mesh) {
  for (const auto& m : c.meshes)
    if (m.name == mesh) return m.tolerance;
  return 0.0;
}

/// A node of a partner in parts that pairs with one of mine: its part, its index in that part's
/// mesh, and the index of my node.
struct PartPair {
  std::uint32_t part;
  std::size_t theirs, mine;
};

/// The nodes of the partner's parts (their HELLOs, in part order) on mesh `mesh` that pair with my
/// nodes `own` by the coincident map within `tol`, in part order, then node order. Each of my nodes
/// belongs to one part: one paired by two parts is written to `bad`, naming the node, both parts
/// and my node. `holder[o]` is the part that pairs my node o, −1 for none.
std::vector<PartPair> pairWithParts(const MeshVertices& own, const std::vector<Hello>& parts, const std::string& mesh,
                                    double tol, const std::string& me, std::vector<int>& holder, std::ostream& bad) {
  std::vector<PartPair> out;
  holder.assign(own.ids.size(), -1);
  std::vector<std::int64_t> heldAs(own.ids.size(), 0);
  for (std::uint32_t q = 0; q < parts.size(); ++q)
    for (const auto& pm : parts[q].meshes) {
      if (pm.name != mesh) continue;
      const std::vector<long> pair = coincidentWith(own.coordinates, pm.coordinates, tol);
      for (std::size_t i = 0; i < pm.ids.size(); ++i) {
        if (pair[i] < 0) continue;  // another part of mine holds it, or none (said where it matters)
        const auto o = std::size_t(pair[i]);
        if (holder[o] >= 0)
          bad << "\n  - mesh '" << mesh << "': node " << pm.ids[i] << " is in part " << holder[o] << " (as node "
              << heldAs[o] << ") and in part " << q << " (each node belongs to one part; node " << own.ids[o] << " of '"
              << me << "')";
        holder[o] = int(q);
        heldAs[o] = pm.ids[i];
        out.push_back({q, i, o});
      }
    }
  return out;
}

/// Appends node `i` of `from` (its id and coordinates) to `to`.
void appendNode(MeshVertices& to, const MeshVertices& from, std::size_t i) {
  to.ids.push_back(from.ids[i]);
  to.coordinates.insert(to.coordinates.end(), from.coordinates.begin() + std::ptrdiff_t(3 * i),
                        from.coordinates.begin() + std::ptrdiff_t(3 * i + 3));
}

/// The mesh named `name` of a HELLO (there is one when the meshes matched).
const MeshVertices* meshNamed(const Hello& h, const std::string& name) {
  for (const auto& pm : h.meshes)
    if (pm.name == name) return &pm;
  return nullptr;
}
}  // namespace

std::string partAddressFile(const std::string& addressFile, std::uint32_t part) {
  return part == 0 ? addressFile : addressFile + ".part" + std::to_string(part);
}

std::vector<Endpoint*> Participant::links() const {
  std::vector<Endpoint*> all;
  if (link_) all.push_back(link_.get());
  for (const auto& l : partLinks_) all.push_back(l.get());
  return all;
}

void Participant::setPart(int part, int parts, std::shared_ptr<PartGroup> group) {
  if (initialized_) throw ConfigError("participant '" + name_ + "': setPart after initialize()");
  if (parts < 1 || parts > 65536 || part < 0 || part >= parts)
    throw ConfigError("participant '" + name_ + "': part " + std::to_string(part) + " of " + std::to_string(parts) +
                      " is not a part (0 <= part < parts <= 65536)");
  part_ = std::uint32_t(part);
  parts_ = std::uint32_t(parts);
  group_ = std::move(group);
}

namespace {
/// The sums of a participant in parts, completed over its parts through their PartGroup.
class GroupSums final : public SumCombiner {
 public:
  explicit GroupSums(std::shared_ptr<PartGroup> g) : group_(std::move(g)) {}
  void combine(std::vector<ExactSum>& sums) const override {
    std::vector<std::int64_t> limbs;
    limbs.reserve(sums.size() * std::size_t(ExactSum::kLimbs));
    for (const auto& s : sums) s.appendTo(limbs);
    group_->sumAll(limbs);
    for (std::size_t i = 0; i < sums.size(); ++i) sums[i].readFrom(limbs, i * std::size_t(ExactSum::kLimbs));
  }
  std::size_t total(std::size_t mine) const override {
    std::vector<std::int64_t> n{std::int64_t(mine)};
    group_->sumAll(n);
    return std::size_t(n[0]);
  }

 private:
  std::shared_ptr<PartGroup> group_;
};
}  // namespace

const SumCombiner& Participant::sums() const {
  static const OnePiece one;
  if (sums_) return *sums_;
  return one;
}

Participant::~Participant() {
  if (link_ && link_->open() && !finalized_)
    abort("participant '" + name_ +
          "' was destroyed before finalize() (its solver stopped "
          "on an error)");
}

void Participant::setMeshVertices(const std::string& mesh, std::vector<std::int64_t> ids, std::vector<double> xyz,
                                  std::vector<std::int32_t> tri) {
  auto it = meshes_.find(mesh);
  if (it == meshes_.end())
    throw ConfigError("participant '" + name_ + "': mesh '" + mesh + "' is not in the coupling configuration");
  if (initialized_) throw ConfigError("participant '" + name_ + "': setMeshVertices after initialize()");
  if (xyz.size() != 3 * ids.size())
    throw ConfigError("participant '" + name_ + "', mesh '" + mesh + "': " + std::to_string(ids.size()) + " ids but " +
                      std::to_string(xyz.size()) + " coordinates (3 per node expected)");
  if (tri.size() % 3)
    throw ConfigError("participant '" + name_ + "', mesh '" + mesh + "': triangle list length is not a multiple of 3");
  for (auto t : tri)
    if (t < 0 || std::size_t(t) >= ids.size())
      throw ConfigError("participant '" + name_ + "', mesh '" + mesh + "': triangle refers to node " +
                        std::to_string(t) + " of " + std::to_string(ids.size()));
  std::vector<std::int64_t> sorted = ids;
  std::sort(sorted.begin(), sorted.end());
  const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
  if (dup != sorted.end())
    throw ConfigError("participant '" + name_ + "', mesh '" + mesh + "': node id " + std::to_string(*dup) +
                      " appears more than once");
  for (double v : xyz)
    if (!std::isfinite(v)) throw ConfigError("participant '" + name_ + "', mesh '" + mesh + "': non-finite coordinate");
  auto& own = it->second->own;
  own.ids = std::move(ids);
  own.coordinates = std::move(xyz);
  own.triangles = std::move(tri);
}

std::string Participant::where() const {
  std::ostringstream s;
  const auto& st = scheme_->state();
  s << "window " << st.window + 1 << " of " << config_.maxWindows << ", pass " << st.iteration + 1
    << " (t = " << double(st.window + 1) * config_.windowSize << " s)";
  return s.str();
}

template <class F>
auto Participant::guarded(const char* what, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const PartnerLostError&) {
    // the partner is gone or already stopping: nothing to tell, but to its other parts when it is in parts
    if (links().size() <= 1) {
      if (link_) link_->close();
    } else {
      abort(std::string(what) + ": a part of '" + partner_ + "' stopped");
    }
    finalized_ = true;
    throw;
  } catch (const CouplerError& e) {
    abort(std::string(what) + ": " + e.what());
    throw;
  }
}

Hello Participant::makeHello() const {
  Hello h;
  h.token = token_;
  h.participant = name_;
  h.partner = partner_;
  h.config = config_;
  for (const auto& m : config_.meshes) h.meshes.push_back(meshes_.at(m.name)->own);
  h.part = part_;
  h.parts = parts_;
  return h;
}

std::string Participant::checkPartner(const Hello& theirs) const {
  std::ostringstream s;
  if (theirs.participant != partner_)
    s << "\n  - it is participant '" << theirs.participant << "', expected '" << partner_ << "'";
  if (theirs.partner != name_)
    s << "\n  - it expects to couple with '" << theirs.partner << "', this is '" << name_ << "'";
  s << describeDifferences(config_, theirs.config, "'" + partner_ + "'");
  for (const auto& m : config_.meshes) {
    const MeshVertices* pm = nullptr;
    for (const auto& x : theirs.meshes)
      if (x.name == m.name) pm = &x;
    if (!pm) {
      s << "\n  - it sent no vertices for interface mesh '" << m.name << "'";
      continue;
    }
    const auto& own = meshes_.at(m.name)->own;
    if (m.mapping == MapKind::Coincident && pm->size() != own.size())
      s << "\n  - interface mesh '" << m.name << "' has " << own.size() << " nodes here and " << pm->size() << " on '"
        << partner_
        << "'; a coincident (1:1) map needs equal counts (use the projection map for "
           "non-matching meshes)";
  }
  for (const auto& x : theirs.meshes) {
    bool known = false;
    for (const auto& m : config_.meshes) known |= m.name == x.name;
    if (!known) s << "\n  - it sent vertices for unknown mesh '" << x.name << "'";
  }
  return s.str();
}

void Participant::buildMaps(const Hello& theirs) {
  for (const auto& m : config_.meshes) {
    auto& st = *meshes_.at(m.name);
    for (const auto& x : theirs.meshes)
      if (x.name == m.name) st.partner = x;
    if (!st.iMap) continue;
    bool needM2P = false, needP2M = false;
    for (const auto& f : config_.fields) {
      if (f.mesh != m.name) continue;
      const bool iWrite = f.writer == name_;
      const bool consistent = f.constraint == MapConstraint::Consistent;
      (iWrite == consistent ? needM2P : needP2M) = true;
    }
    const auto builder = makeMapBuilder(m.mapping, m.tolerance);
    auto view = [](const MeshVertices& v) {
      SurfaceView s;
      s.coordinates = v.coordinates.data();
      s.nodes = v.size();
      s.triangles = v.triangles.data();
      s.numTriangles = v.triangles.size() / 3;
      s.ids = v.ids.data();
      return s;
    };
    try {
      if (needM2P) {
        st.mineToPartner = std::make_unique<ConsistentMap>(builder->build(view(st.own), view(st.partner)));
        st.mineToPartnerT = std::make_unique<ConservativeMap>(st.mineToPartner->transpose());
      }
      if (needP2M) {
        if (builder->needsSourceTriangles() && st.partner.triangles.empty())
          throw MapError(
              "the fields read consistently (or written conservatively) "
              "need the surface triangles of '" +
              partner_ +
              "', which it "
              "did not send");
        st.partnerToMine = std::make_unique<ConsistentMap>(builder->build(view(st.partner), view(st.own)));
        st.partnerToMineT = std::make_unique<ConservativeMap>(st.partnerToMine->transpose());
      }
    } catch (const MapError& e) {
      throw MapError("interface mesh '" + m.name + "' between '" + name_ + "' (" + std::to_string(st.own.size()) +
                     " nodes) and '" + partner_ + "' (" + std::to_string(st.partner.size()) + " nodes): " + e.what());
    }
  }
  // Field buffers.
  fields_.clear();
  std::size_t wOff = 0, rOff = 0;
  std::vector<std::uint64_t> partnerBlocks;
  for (std::size_t i = 0; i < config_.fields.size(); ++i) {
    const auto& spec = config_.fields[i];
    auto f = std::make_unique<Field>();
    f->spec = spec;
    f->index = int(i);
    f->write = spec.writer == name_;
    f->comps = spec.components;
    const auto& st = *meshes_.at(spec.mesh);
    f->ownNodes = st.own.size();
    f->wireNodes = st.iMap ? st.partner.size() : st.own.size();
    if (st.iMap) {
      const bool consistent = spec.constraint == MapConstraint::Consistent;
      if (f->write)
        consistent ? void(f->consistent = st.mineToPartner.get()) : void(f->conservative = st.partnerToMineT.get());
      else
        consistent ? void(f->consistent = st.partnerToMine.get()) : void(f->conservative = st.mineToPartnerT.get());
    }
    const std::size_t ownVals = f->ownNodes * std::size_t(f->comps);
    const std::size_t wireVals = f->wireNodes * std::size_t(f->comps);
    if (f->write) {
      f->offset = wOff;
      wOff += ownVals;
      f->wire.assign(wireVals, 0.0);
    } else {
      f->offset = rOff;
      rOff += wireVals;
      f->own.assign(ownVals, 0.0);
      partnerBlocks.push_back(wireVals);
    }
    fields_.push_back(std::move(f));
  }
  writtenSlices_.clear();
  receivedSlices_.clear();
  for (const auto& f : fields_) {
    const std::size_t n = (f->write ? f->ownNodes : f->wireNodes) * std::size_t(f->comps);
    (f->write ? writtenSlices_ : receivedSlices_).push_back({f->spec.name, f->offset, n, f->spec.absoluteTolerance});
  }
  written_.assign(wOff, 0.0);
  received_.assign(rOff, 0.0);
  partnerDataBytes_ = dataPayloadSize(partnerBlocks);
}

void Participant::runAcceptor(Deadline deadline) {
  TransportOptions t = transport_;  // a part r > 0 publishes its own address file
  t.addressFile = partAddressFile(t.addressFile, part_);
  auto listener = makeListener(t, name_, partner_);
  std::vector<std::string> refused;
  auto refusedText = [&] {
    std::string s;
    for (const auto& r : refused) s += "\n  - refused: " + r;
    return s;
  };
  // The partner's parts (one for a partner in one piece), each with its HELLO, by part.
  std::vector<std::unique_ptr<Endpoint>> eps;
  std::vector<Hello> hellos;
  std::uint32_t expected = 1, arrived = 0, firstPart = 0;
  auto rejectOne = [](Endpoint& ep, ReasonCode code, const std::string& text) {
    try {
      ep.send(MessageType::Reject, encodeReason({code, text}), Deadline::in(2.0), "handshake");
    } catch (const CouplerError&) {
    }
  };
  auto rejectAll = [&](ReasonCode code, const std::string& text) {
    for (auto& ep : eps)
      if (ep) rejectOne(*ep, code, text), ep->close();
  };
  while (arrived < expected) {
    std::unique_ptr<Channel> ch;
    try {
      ch = listener->accept(deadline);
    } catch (const TimeoutError& e) {
      std::string waiting;
      if (arrived > 0)
        waiting = " (" + std::to_string(arrived) + " of the " + std::to_string(expected) + " parts of '" + partner_ +
                  "' connected)";
      rejectAll(ReasonCode::ProtocolViolation,
                "participant '" + name_ + "' timed out waiting for the other parts of '" + partner_ + "'" + waiting);
      throw TimeoutError(std::string(e.what()) + " (connect timeout " + std::to_string(deadline.seconds) + " s)" +
                         waiting + refusedText());
    }
    auto ep = std::make_unique<Endpoint>(std::move(ch), name_, partner_);
    Message m;
    Hello h;
    // A connection that says nothing must not hold the port until the connect timeout: a
    // real partner sends HELLO right after connecting, so it gets at most 10 s.
    Deadline helloBy = Deadline::in(std::min(10.0, std::max(0.0, deadline.remaining())));
    const bool ownDeadline = helloBy.at < deadline.at;
    if (!ownDeadline) helloBy = deadline;
    try {
      m = ep->receive(helloBy, "HELLO (handshake)");
      if (m.header.type != MessageType::Hello)
        throw ProtocolError(ProtocolFault::UnexpectedType, "a " + wire::typeName(std::uint16_t(m.header.type)) +
                                                               " message arrived where HELLO starts the handshake");
      h = decodeHello(m.payload.data(), m.payload.size());
    } catch (const ProtocolError& e) {
      if (e.fault() == ProtocolFault::BadVersion) {
        rejectOne(*ep, ReasonCode::WrongVersion, e.what());
        rejectAll(ReasonCode::WrongVersion, e.what());
        throw HandshakeError(e.what());
      }
      if (!listener->canAcceptAgain()) throw;
      rejectOne(*ep, ReasonCode::ProtocolViolation, e.what());
      refused.push_back(std::string("a foreign or malformed connection (") + e.what() + ")");
      continue;
    } catch (const TransportError& e) {
      const bool timedOut = dynamic_cast<const TimeoutError*>(&e) != nullptr;
      if (!listener->canAcceptAgain() || (timedOut && !ownDeadline)) throw;
      refused.push_back(std::string("a connection that closed before its HELLO (") + e.what() + ")");
      continue;
    }
    if (h.token != token_) {
      const std::string text = "participant '" + name_ + "' refused the connection of '" + h.participant +
                               "': its run token differs (it belongs to another run, or the two sides were "
                               "given different tokens)";
      rejectOne(*ep, ReasonCode::WrongToken, text);
      if (!listener->canAcceptAgain()) throw HandshakeError(text);
      refused.push_back("'" + h.participant + "' with a different run token");
      continue;
    }
    if (arrived == 0) {
      expected = std::max<std::uint32_t>(1, h.parts);
      eps.resize(expected);
      hellos.resize(expected);
      firstPart = h.part;
    }
    std::string problem;
    if (h.parts != expected)
      problem =
          "it says it is in " + std::to_string(h.parts) + " parts, its first part said " + std::to_string(expected);
    else if (h.part >= expected || eps[h.part])
      problem = "part " + std::to_string(h.part) + " of " + std::to_string(h.parts) + " connected twice or is no part";
    else if (h.parts > 1 && amFirst_ == false)
      problem = "a partner in parts connects to the configuration's first participant";
    else if (arrived > 0 && (h.participant != hellos[firstPart].participant || h.partner != hellos[firstPart].partner ||
                             !describeDifferences(hellos[firstPart].config, h.config, "'" + partner_ + "'").empty()))
      problem = "its part " + std::to_string(h.part) + " is not the same participant as its part " +
                std::to_string(firstPart) +
                describeDifferences(hellos[firstPart].config, h.config, "'" + partner_ + "'");
    if (!problem.empty()) {
      const std::string text = "participant '" + name_ + "' cannot couple with '" + h.participant + "' in " +
                               std::to_string(h.parts) + " parts: " + problem;
      rejectOne(*ep, ReasonCode::ConfigMismatch, text);
      rejectAll(ReasonCode::ConfigMismatch, text);
      throw HandshakeError(text);
    }
    eps[h.part] = std::move(ep);
    hellos[h.part] = std::move(h);
    ++arrived;
  }
  Hello h = hellos[0];
  if (expected > 1) {
    // The partner in parts: each part's HELLO carries its own nodes; the nodes that pair with mine,
    // in part order, are my partner's mesh, each of my nodes paired by one part only.
    routed_ = true;
    std::ostringstream bad;
    for (auto& m : h.meshes) {
      const auto it = meshes_.find(m.name);
      if (it == meshes_.end()) continue;
      const MeshVertices& own = it->second->own;
      std::vector<int> holder;
      auto& nodes = partNodes_[m.name];
      nodes.assign(expected, {});
      MeshVertices merged;
      merged.name = m.name;
      for (const PartPair& pp :
           pairWithParts(own, hellos, m.name, meshTolerance(config_, m.name), name_, holder, bad)) {
        nodes[pp.part].push_back(merged.ids.size());
        appendNode(merged, *meshNamed(hellos[pp.part], m.name), pp.theirs);
      }
      for (std::size_t o = 0; o < own.ids.size(); ++o)
        if (holder[o] < 0)
          bad << "\n  - mesh '" << m.name << "': node " << own.ids[o] << " of '" << name_ << "' is in no part of '"
              << partner_ << "'";
      m = std::move(merged);
    }
    if (!bad.str().empty()) {
      const std::string text = "participant '" + name_ + "' cannot couple with '" + h.participant + "' in " +
                               std::to_string(expected) + " parts:" + bad.str();
      rejectAll(ReasonCode::MeshMismatch, text);
      throw HandshakeError(text);
    }
  }
  acceptPartner(h, rejectAll);
  for (auto& ep : eps) ep->send(MessageType::Welcome, encodeHello(makeHello()), deadline, "handshake");
  for (auto& ep : eps) {
    const Message r = ep->receive(deadline, "READY (handshake)");
    if (r.header.type == MessageType::Reject) {
      const Reason why = decodeReason(r.payload.data(), r.payload.size());
      rejectAll(ReasonCode::MeshMismatch, why.message);
      throw HandshakeError("participant '" + name_ + "' was refused by its partner: " + why.message);
    }
    if (r.header.type != MessageType::Ready)
      throw ProtocolError(ProtocolFault::UnexpectedType, "participant '" + name_ + "' expected READY from '" +
                                                             partner_ + "', got " +
                                                             wire::typeName(std::uint16_t(r.header.type)));
  }
  link_ = std::move(eps[0]);
  for (std::size_t q = 1; q < eps.size(); ++q) partLinks_.push_back(std::move(eps[q]));
}

void Participant::acceptPartner(const Hello& theirs,
                                const std::function<void(ReasonCode, const std::string&)>& reject) {
  Hello h = theirs;
  if (parts_ > 1)  // a part: the partner's nodes that pair with this part's (coincident maps), in its order
    for (auto& m : h.meshes) {
      const auto it = meshes_.find(m.name);
      if (it == meshes_.end()) continue;
      const std::vector<long> pair =
          coincidentWith(it->second->own.coordinates, m.coordinates, meshTolerance(config_, m.name));
      MeshVertices sub;
      sub.name = m.name;
      for (std::size_t i = 0; i < m.ids.size(); ++i)
        if (pair[i] >= 0) {
          sub.ids.push_back(m.ids[i]);
          sub.coordinates.insert(sub.coordinates.end(), m.coordinates.begin() + std::ptrdiff_t(3 * i),
                                 m.coordinates.begin() + std::ptrdiff_t(3 * i + 3));
        }
      m = std::move(sub);
    }
  const std::string problems = checkPartner(h);
  if (!problems.empty()) {
    const std::string text =
        "participant '" + name_ + "' cannot couple with '" + h.participant + "': the configurations differ:" + problems;
    reject(ReasonCode::ConfigMismatch, text);
    throw HandshakeError(text);
  }
  try {
    buildMaps(h);
  } catch (const MapError& e) {
    reject(ReasonCode::MeshMismatch, e.what());
    throw HandshakeError(e.what());
  }
}

void Participant::runConnector(Deadline deadline) {
  link_ = std::make_unique<Endpoint>(connectTo(transport_, name_, partner_, deadline), name_, partner_);
  // REJECT to every part connected so far, then closed
  auto reject = [&](ReasonCode code, const std::string& text) {
    for (Endpoint* l : links()) {
      try {
        l->send(MessageType::Reject, encodeReason({code, text}), Deadline::in(2.0), "handshake");
      } catch (const CouplerError&) {
      }
      l->close();
    }
  };
  // HELLO to one part, its WELCOME (or REJECT) back, its token checked
  auto greet = [&](Endpoint& ep) {
    ep.send(MessageType::Hello, encodeHello(makeHello()), deadline, "handshake");
    Message m;
    try {
      m = ep.receive(deadline, "WELCOME (handshake answer)");
    } catch (const ProtocolError& e) {
      if (e.fault() == ProtocolFault::BadVersion) {
        reject(ReasonCode::WrongVersion, e.what());
        throw HandshakeError(e.what());
      }
      reject(ReasonCode::ProtocolViolation, e.what());
      throw;
    }
    if (m.header.type == MessageType::Reject) {
      const Reason why = decodeReason(m.payload.data(), m.payload.size());
      for (Endpoint* l : links()) l->close();
      throw HandshakeError("participant '" + name_ + "' was refused by its partner: " + why.message);
    }
    if (m.header.type != MessageType::Welcome) {
      const std::string text =
          "participant '" + name_ + "' expected WELCOME or REJECT, got " + wire::typeName(std::uint16_t(m.header.type));
      reject(ReasonCode::ProtocolViolation, text);
      throw ProtocolError(ProtocolFault::UnexpectedType, text);
    }
    const Hello h = decodeHello(m.payload.data(), m.payload.size());
    if (h.token != token_) {
      const std::string text = "participant '" + name_ + "' refused '" + h.participant +
                               "': its run token differs (another run's participant)";
      reject(ReasonCode::WrongToken, text);
      throw HandshakeError(text);
    }
    return h;
  };
  Hello h = greet(*link_);
  if (h.parts > 1 || parts_ > 1) {
    // The partner in parts: each part's WELCOME carries its own nodes; the parts together are the
    // partner's interface, checked as one (its nodes in part order), each node in one part only.
    // This side in parts: the partner's nodes that pair with this part's, each node of this part
    // paired once.
    routed_ = true;
    std::string problem;  // the first reason it cannot be
    if (transport_.connectPort > 0) problem = "a partner in parts is found through its address files, not a port";
    for (const auto& m : config_.meshes)
      if (config_.mappingSideOf(m) != partner_ || m.mapping != MapKind::Coincident)
        problem = "mesh '" + m.name + "': a partner in parts maps every mesh with the coincident map";
    if (amFirst_) problem = "a partner in parts must be the configuration's first participant";
    if (h.part != 0) problem = "the address file names part " + std::to_string(h.part) + ", not part 0";
    if (!problem.empty()) {
      const std::string text = "participant '" + name_ + "' cannot couple with '" + h.participant + "' in " +
                               std::to_string(h.parts) + " parts: " + problem;
      reject(ReasonCode::ConfigMismatch, text);
      throw HandshakeError(text);
    }
    std::vector<Hello> parts{h};
    for (std::uint32_t r = 1; r < h.parts; ++r) {
      TransportOptions t = transport_;
      t.addressFile = partAddressFile(transport_.addressFile, r);
      partLinks_.push_back(std::make_unique<Endpoint>(connectTo(t, name_, partner_, deadline), name_, partner_));
      parts.push_back(greet(*partLinks_.back()));
      const std::string differ = describeDifferences(config_, parts.back().config, "'" + partner_ + "'");
      if (parts.back().participant != h.participant || parts.back().partner != h.partner || !differ.empty()) {
        const std::string text = "participant '" + name_ + "': part " + std::to_string(r) + " of '" + h.participant +
                                 "' is not the same participant as its part 0 (participant '" +
                                 parts.back().participant + "', partner '" + parts.back().partner + "')" + differ;
        reject(ReasonCode::ConfigMismatch, text);
        throw HandshakeError(text);
      }
      if (parts.back().part != r || parts.back().parts != h.parts) {
        const std::string text = "participant '" + name_ + "': address file '" + t.addressFile + "' names part " +
                                 std::to_string(parts.back().part) + " of " + std::to_string(parts.back().parts) +
                                 ", expected part " + std::to_string(r) + " of " + std::to_string(h.parts);
        reject(ReasonCode::ProtocolViolation, text);
        throw HandshakeError(text);
      }
    }
    std::ostringstream bad;
    for (auto& m : h.meshes) {
      const auto it = meshes_.find(m.name);
      if (it == meshes_.end()) continue;
      // where each of my nodes is: the part holding the node that pairs with it (one only)
      const MeshVertices& own = it->second->own;
      std::vector<int> holder;
      auto& nodes = partNodes_[m.name];
      nodes.assign(h.parts, {});
      MeshVertices merged;  // the union, in part order (this side in parts: the nodes paired with mine)
      merged.name = m.name;
      if (parts_ == 1)
        for (const Hello& part : parts)
          if (const MeshVertices* pm = meshNamed(part, m.name)) {
            const auto base = std::int32_t(merged.ids.size());
            merged.ids.insert(merged.ids.end(), pm->ids.begin(), pm->ids.end());
            merged.coordinates.insert(merged.coordinates.end(), pm->coordinates.begin(), pm->coordinates.end());
            for (auto t : pm->triangles) merged.triangles.push_back(base + t);
          }
      const std::vector<PartPair> pairs =
          pairWithParts(own, parts, m.name, meshTolerance(config_, m.name), name_, holder, bad);
      if (parts_ > 1)
        for (const PartPair& pp : pairs) appendNode(merged, *meshNamed(parts[pp.part], m.name), pp.theirs);
      for (std::size_t i = 0; i < own.ids.size(); ++i) {
        if (holder[i] >= 0)
          nodes[std::size_t(holder[i])].push_back(i);
        else if (parts_ > 1)
          bad << "\n  - mesh '" << m.name << "': node " << own.ids[i] << " of part " << part_ << " of '" << name_
              << "' is in no part of '" << h.participant << "'";
      }
      m = std::move(merged);
    }
    if (!bad.str().empty()) {
      const std::string text = "participant '" + name_ + "' cannot couple with '" + h.participant + "' in " +
                               std::to_string(h.parts) + " parts:" + bad.str();
      reject(ReasonCode::MeshMismatch, text);
      throw HandshakeError(text);
    }
  }
  acceptPartner(h, reject);
  for (Endpoint* l : links()) l->send(MessageType::Ready, {}, deadline, "handshake");
}

double Participant::initialize() {
  connect();
  guarded("initialize", [&] { scheme_->initialize(*this); });
  return getMaxTimeStepSize();
}

namespace {
// "TQRS" + version: a participant's restart state (version 3: IQN-ILS keeps its columns' Gram matrix)
constexpr std::uint32_t kStateMagic = 0x54515253 + 2;
}  // namespace

void Participant::checkpoint(StateIo& io) {
  std::uint32_t magic = kStateMagic;
  io.io(magic);
  if (magic != kStateMagic)
    throw ConfigError("participant '" + name_ +
                      "': not a coupler restart state of this version (another build, or another file); run the "
                      "condition afresh");
  io.io(timeInWindow_);
  io.io(written_);
  io.io(received_);
  for (auto& f : fields_) {
    io.io(f->own);
    io.io(f->wire);
  }
  io.io(exchanges_);
  scheme_->checkpoint(io);
  if (monitor_) monitor_->checkpoint(io);
}

std::vector<unsigned char> Participant::saveState() const {
  if (!initialized_ || finalized_ || !scheme_->state().windowComplete)
    throw ConfigError("participant '" + name_ + "': saveState() only right after a completed window (" + where() + ")");
  std::vector<unsigned char> bytes;
  StateIo io = StateIo::saver(bytes);
  const_cast<Participant*>(this)->checkpoint(io);  // saving changes nothing
  return bytes;
}

double Participant::initializeResumed(const std::vector<unsigned char>& state) {
  connect();
  guarded("resume", [&] {
    StateIo io = StateIo::loader(state);
    checkpoint(io);
    if (!io.exhausted())
      throw ConfigError("participant '" + name_ +
                        "': the restart state is longer than this configuration's "
                        "(another interface or scheme)");
    scheme_->resume(*this);
  });
  return getMaxTimeStepSize();
}

double Participant::connect() {
  if (initialized_) throw ConfigError("participant '" + name_ + "': initialize() called twice");
  for (const auto& m : config_.meshes)
    if (meshes_.at(m.name)->own.size() == 0 && parts_ == 1)  // a part may hold none of a mesh's nodes
      throw ConfigError("participant '" + name_ + "': interface mesh '" + m.name +
                        "' has no vertices; call setMeshVertices() before initialize()");
  const bool listen = transport_.role == ConnectRole::Listen || (transport_.role == ConnectRole::Auto && amFirst_);
  if (parts_ > 1) {
    std::string problem;  // the first reason it cannot be
    for (const auto& m : config_.meshes)
      if (config_.mappingSideOf(m) != config_.first || m.mapping != MapKind::Coincident)
        problem =
            "the first participant, '" + config_.first + "', must map mesh '" + m.name + "' with the coincident map";
    if (transport_.kind != TransportKind::Tcp || transport_.addressFile.empty())
      problem = "it must couple over TCP with an address file";
    if (amFirst_ && !listen) problem = "it must listen (the partner connects to every part)";
    if (!amFirst_ && listen) problem = "it must connect (each of its parts connects to every part of the first)";
    if (!amFirst_ && !group_)
      problem = "it needs a PartGroup to add its parts' sums (it decides each window on the whole interface)";
    if (!problem.empty())
      throw ConfigError("participant '" + name_ + "' in " + std::to_string(parts_) + " parts: " + problem);
    if (!amFirst_) sums_ = std::make_unique<GroupSums>(group_);
  }
  const Deadline deadline = Deadline::in(transport_.connectTimeout);
  if (listen)
    runAcceptor(deadline);
  else
    runConnector(deadline);
  link_->setExpectedDataSize(partnerDataBytes_);
  if (routed_) {  // each link carries the read fields on the nodes the two parts share
    for (std::size_t r = 0; r < partnerParts(); ++r) {
      std::vector<std::uint64_t> blocks;
      for (const auto& f : fields_)
        if (!f->write) blocks.push_back(partNodes_.at(f->spec.mesh)[r].size() * std::size_t(f->comps));
      partDataBytes_.push_back(dataPayloadSize(blocks));
      links()[r]->setExpectedDataSize(partDataBytes_.back());
    }
  }
  if (sums_) {  // the second in parts: each field's values on every part (its sums' counts)
    for (auto* slices : {&writtenSlices_, &receivedSlices_})
      for (auto& f : *slices) f.total = sums_->total(f.size);
  }
  scheme_ = makeScheme(config_, name_);
  // The divergence monitor where the whole interface is: the first in one piece, over what it reads;
  // else the second, over what it sends (in parts: each part its piece, the sums completed).
  if (amFirst_ && parts_ == 1) monitor_ = std::make_unique<DivergenceMonitor>(config_, receivedSlices_, name_);
  if (!amFirst_ && partnerParts() > 1) {
    monitor_ = std::make_unique<DivergenceMonitor>(config_, writtenSlices_, name_);
    monitor_->useSums(sums());
  }
  initialized_ = true;
  return 0.0;
}

Participant::Field& Participant::field(const std::string& mesh, const std::string& name, bool write,
                                       const char* caller) {
  return const_cast<Field&>(std::as_const(*this).field(mesh, name, write, caller));
}

const Participant::Field& Participant::field(const std::string& mesh, const std::string& name, bool write,
                                             const char* caller) const {
  if (!initialized_) throw ConfigError("participant '" + name_ + "': " + caller + " before initialize()");
  const int i = config_.fieldIndex(mesh, name);
  if (i < 0)
    throw ConfigError("participant '" + name_ + "': " + caller + " of unknown field '" + name + "' on mesh '" + mesh +
                      "'");
  const Field& f = *fields_[std::size_t(i)];
  if (f.write != write)
    throw ConfigError("participant '" + name_ + "': " + caller + " of field '" + name + "', which is " +
                      (f.write ? "written" : "read") + " by this side");
  return f;
}

void Participant::writeData(const std::string& mesh, const std::string& name, const double* v, std::size_t n) {
  Field& f = field(mesh, name, true, "writeData");
  const std::size_t want = f.ownNodes * std::size_t(f.comps);
  if (n != want)
    throw ConfigError("participant '" + name_ + "': writeData of '" + name + "' with " + std::to_string(n) +
                      " values, expected " + std::to_string(want) + " (" + std::to_string(f.ownNodes) + " nodes x " +
                      std::to_string(f.comps) + ")");
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) {
      const std::string text = "participant '" + name_ + "' wrote a non-finite value of '" + name + "' (node " +
                               std::to_string(i / f.comps) + ") in " + where() + ": the solution has blown up";
      abort(text);
      throw DivergenceError(text);
    }
  std::copy(v, v + n, written_.begin() + std::ptrdiff_t(f.offset));
}

void Participant::readData(const std::string& mesh, const std::string& name, double* v, std::size_t n) const {
  const Field& f = field(mesh, name, false, "readData");
  if (n != f.own.size())
    throw ConfigError("participant '" + name_ + "': readData of '" + name + "' into " + std::to_string(n) +
                      " values, expected " + std::to_string(f.own.size()));
  std::copy(f.own.begin(), f.own.end(), v);
}

void Participant::readData(const std::string& mesh, const std::string& name, std::vector<double>& v) const {
  const Field& f = field(mesh, name, false, "readData");
  v = f.own;
}

void Participant::sendData(std::uint64_t window, std::uint32_t iteration, std::uint32_t fl, double residual) {
  DataMessage d;
  d.window = window;
  d.iteration = iteration;
  d.flags = fl;
  d.time = double(window + 1) * config_.windowSize;
  d.residual = residual;
  const auto t0 = Clock::now();
  for (auto& f : fields_) {
    if (!f->write) continue;
    const double* src = written_.data() + f->offset;
    if (f->consistent)
      f->consistent->apply(src, f->comps, f->wire.data());
    else if (f->conservative)
      f->conservative->apply(src, f->comps, f->wire.data());
    else
      std::copy(src, src + f->wire.size(), f->wire.begin());
    d.fields.push_back({std::uint32_t(f->index), std::uint32_t(f->comps), f->wire});
  }
  secondsMapping_ += std::chrono::duration<double>(Clock::now() - t0).count();
  std::ostringstream ctx;
  ctx << "window " << window + 1 << ", pass " << iteration + 1;
  if (!routed_) {
    link_->send(MessageType::Data, encodeData(d), Deadline::in(transport_.receiveTimeout), ctx.str());
    return;
  }
  // a partner in parts, or this side in parts: each link the values of the nodes it carries
  const std::vector<Endpoint*> all = links();
  for (std::size_t r = 0; r < all.size(); ++r) {
    DataMessage part = d;
    std::size_t b = 0;
    for (const auto& f : fields_) {
      if (!f->write) continue;
      const auto& nodes = partNodes_.at(f->spec.mesh)[r];
      const std::size_t c = std::size_t(f->comps);
      std::vector<double>& v = part.fields[b++].values;
      v.resize(nodes.size() * c);
      for (std::size_t q = 0; q < nodes.size(); ++q)
        for (std::size_t k = 0; k < c; ++k) v[q * c + k] = f->wire[nodes[q] * c + k];
    }
    all[r]->send(MessageType::Data, encodeData(part), Deadline::in(transport_.receiveTimeout),
                 ctx.str() + " to part " + std::to_string(r));
  }
}

ExchangePort::Received Participant::receiveData(std::uint64_t window, std::uint32_t iteration) {
  std::ostringstream what;
  what << "DATA of window " << window + 1 << " of " << config_.maxWindows << ", pass " << iteration + 1
       << " (t = " << double(window + 1) * config_.windowSize << " s)";
  Received got;
  for (std::size_t r = 0; r < partnerParts(); ++r) receivePart(r, window, iteration, what.str(), got);
  const auto t0 = Clock::now();
  for (auto& f : fields_) {
    if (f->write) continue;
    const double* src = received_.data() + f->offset;
    if (f->consistent)
      f->consistent->apply(src, f->comps, f->own.data());
    else if (f->conservative)
      f->conservative->apply(src, f->comps, f->own.data());
    else
      std::copy(src, src + f->own.size(), f->own.begin());
  }
  secondsMapping_ += std::chrono::duration<double>(Clock::now() - t0).count();
  ++exchanges_;
  return got;
}

// One DATA message into received_: the partner's (r = 0), or part r's of a partner in parts, its
// values on that part's nodes put in their places; the flags and residual those of part 0.
void Participant::receivePart(std::size_t r, std::uint64_t window, std::uint32_t iteration, const std::string& due,
                              Received& got) {
  const std::string from =
      partLinks_.empty() ? "'" + partner_ + "'" : "part " + std::to_string(r) + " of '" + partner_ + "'";
  // (this side in parts with the partner in one piece: routed_, one link)
  const Message m = links()[r]->receive(Deadline::in(transport_.receiveTimeout), due);
  if (m.header.type == MessageType::Bye)
    throw PartnerLostError(from + " ended the coupling (BYE) while '" + name_ + "' was waiting for " + due);
  if (m.header.type != MessageType::Data)
    throw ProtocolError(ProtocolFault::UnexpectedType, "participant '" + name_ + "' got " +
                                                           wire::typeName(std::uint16_t(m.header.type)) + " from " +
                                                           from + " while waiting for " + due);
  const DataMessage d = decodeData(m.payload.data(), m.payload.size());
  if (d.window != window || d.iteration != iteration) {
    std::ostringstream s;
    s << "participant '" << name_ << "' and " << from << " are out of step: it sent "
      << "window " << d.window + 1 << ", pass " << d.iteration + 1 << " while " << due << " was due";
    throw ProtocolError(ProtocolFault::BadPayload, s.str());
  }
  std::size_t b = 0;
  for (auto& f : fields_) {
    if (f->write) continue;
    const std::size_t c = std::size_t(f->comps);
    const std::vector<std::size_t>* nodes = routed_ ? &partNodes_.at(f->spec.mesh)[r] : nullptr;
    const std::size_t n = nodes ? nodes->size() : f->wireNodes;
    if (b >= d.fields.size() || d.fields[b].field != std::uint32_t(f->index) ||
        d.fields[b].components != std::uint32_t(f->comps) || d.fields[b].values.size() != n * c)
      throw ProtocolError(ProtocolFault::BadPayload,
                          "participant '" + name_ + "': DATA from " + from + " does not carry field '" + f->spec.name +
                              "' as agreed in the handshake (block " + std::to_string(b) + ")");
    const std::vector<double>& v = d.fields[b].values;
    for (double x : v)
      if (!std::isfinite(x))
        throw DivergenceError(from + " sent non-finite values of '" + f->spec.name + "' in " + due +
                              ": the partner's solution has blown up");
    double* dst = received_.data() + f->offset;
    if (!nodes)
      std::copy(v.begin(), v.end(), dst);
    else
      for (std::size_t q = 0; q < n; ++q)
        for (std::size_t k = 0; k < c; ++k) dst[(*nodes)[q] * c + k] = v[q * c + k];
    ++b;
  }
  if (b != d.fields.size())
    throw ProtocolError(ProtocolFault::BadPayload,
                        "participant '" + name_ + "': DATA from " + from + " carries more field blocks than agreed");
  if (r == 0) {
    got = {d.flags, d.residual};
  } else if (d.flags != got.flags ||
             !(d.residual == got.residual || (std::isnan(d.residual) && std::isnan(got.residual)))) {
    std::ostringstream s;  // the second's parts decide together: every part sends the same
    s.precision(17);
    s << "participant '" << name_ << "': " << from << " sent flags " << d.flags << " and residual " << d.residual
      << " in " << due << ", its part 0 flags " << got.flags << " and residual " << got.residual
      << " (the parts of one participant decide together)";
    throw ProtocolError(ProtocolFault::BadPayload, s.str());
  }
}

std::vector<double>& Participant::writtenValues() { return written_; }
const std::vector<double>& Participant::receivedValues() const { return received_; }

double Participant::advance(double dt) {
  if (!initialized_) throw ConfigError("participant '" + name_ + "': advance before initialize()");
  if (!isCouplingOngoing()) throw ConfigError("participant '" + name_ + "': advance after the coupling has ended");
  const double remaining = config_.windowSize - timeInWindow_;
  if (!(dt > 0) || dt > remaining * (1 + 1e-9) + 1e-15)
    throw ConfigError("participant '" + name_ + "': advance(" + std::to_string(dt) + " s) but " +
                      std::to_string(remaining) + " s are left in the coupling window: use getMaxTimeStepSize()");
  timeInWindow_ += dt;
  if (timeInWindow_ < config_.windowSize * (1 - 1e-9)) {
    scheme_->clearFlags();
    return getMaxTimeStepSize();
  }
  timeInWindow_ = 0.0;
  guarded("advance", [&] {
    scheme_->endWindow(*this);
    const SchemeState& st = scheme_->state();
    if (monitor_ && st.windowComplete) {
      const bool unconverged = config_.scheme == SchemeKind::Implicit && !(st.residual < config_.tolerance);
      monitor_->windowDone(st.window - 1, amFirst_ ? received_ : written_, unconverged, st.residual);
    }
  });
  return getMaxTimeStepSize();
}

bool Participant::isCouplingOngoing() const { return initialized_ && !finalized_ && scheme_->state().ongoing; }
bool Participant::isTimeWindowComplete() const { return initialized_ && scheme_->state().windowComplete; }
bool Participant::requiresWritingCheckpoint() const { return initialized_ && scheme_->state().writeCheckpoint; }
bool Participant::requiresReadingCheckpoint() const { return initialized_ && scheme_->state().readCheckpoint; }
double Participant::getMaxTimeStepSize() const { return config_.windowSize - timeInWindow_; }

const SchemeState& Participant::state() const {
  if (!scheme_) throw ConfigError("participant '" + name_ + "': state() before initialize()");
  return scheme_->state();
}

double Participant::windowStartTime() const {
  return scheme_ ? double(scheme_->state().window) * config_.windowSize : 0.0;
}

std::vector<std::size_t> Participant::partnerPartNodes(const std::string& mesh) const {
  if (!routed_) return {partnerVertexCount(mesh)};
  std::vector<std::size_t> n;
  const auto it = partNodes_.find(mesh);
  if (it == partNodes_.end()) throw ConfigError("unknown mesh '" + mesh + "'");
  for (const auto& nodes : it->second) n.push_back(nodes.size());
  return n;
}

std::size_t Participant::partnerVertexCount(const std::string& mesh) const {
  auto it = meshes_.find(mesh);
  if (it == meshes_.end()) throw ConfigError("unknown mesh '" + mesh + "'");
  return it->second->partner.size();
}

ExchangeStats Participant::stats() const {
  ExchangeStats s;
  s.exchanges = exchanges_;
  s.secondsMapping = secondsMapping_;
  for (const Endpoint* l : links()) {
    s.secondsInTransport += l->secondsInTransport();
    s.secondsWaiting += l->secondsWaiting();
    s.bytesSent += l->bytesSent();
    s.bytesReceived += l->bytesReceived();
  }
  return s;
}

void Participant::finalize() {
  if (finalized_) return;
  if (!initialized_ || !link_ || !link_->open()) {
    finalized_ = true;
    for (Endpoint* l : links()) l->close();
    return;
  }
  if (scheme_->state().ongoing) {
    abort("participant '" + name_ + "' finalized before the end of the coupling, in " + where());
    return;
  }
  guarded("finalize", [&] {
    for (Endpoint* l : links())
      l->send(MessageType::Bye, encodeReason({ReasonCode::SolverError, ""}), Deadline::in(transport_.receiveTimeout),
              "end of coupling");
    for (Endpoint* l : links()) {
      const Message m = l->receive(Deadline::in(transport_.receiveTimeout), "BYE (end of coupling)");
      if (m.header.type != MessageType::Bye)
        throw ProtocolError(ProtocolFault::UnexpectedType, "participant '" + name_ + "' expected BYE from '" +
                                                               partner_ + "', got " +
                                                               wire::typeName(std::uint16_t(m.header.type)));
    }
  });
  for (Endpoint* l : links()) l->close();
  finalized_ = true;
}

void Participant::abort(const std::string& reason) noexcept {
  for (Endpoint* l : links()) {
    try {
      if (l->open())
        l->send(MessageType::Abort, encodeReason({ReasonCode::SolverError, reason}),
                Deadline::in(std::min(2.0, transport_.receiveTimeout)), "abort");
    } catch (...) {
    }
    l->close();
  }
  finalized_ = true;
}

}  // namespace tq::coupler
