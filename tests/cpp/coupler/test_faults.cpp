// Fault handling: a killed or hung partner stops the other side within the timeout with a
// message naming partner, window and what was expected; malformed, foreign, out-of-step or
// other-version messages are refused with a clear error (and the partner is told).
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cstring>

#include "coupler_test_util.hpp"
#include "tq/coupler/messages.hpp"

extern char** environ;

using namespace tqtest;

namespace {

/// The dummy participant as a separate process.
class DummyProcess {
 public:
  explicit DummyProcess(std::vector<std::string> args) {
    args.insert(args.begin(), TQ_COUPLER_DUMMY);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, TQ_COUPLER_DUMMY, nullptr, nullptr, argv.data(), environ) != 0) pid_ = -1;
  }
  ~DummyProcess() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  void kill9() {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  bool started() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
};

using Secs = std::chrono::duration<double>;

/// A hand-driven peer speaking raw frames, to inject faults the library never produces.
struct RawPeer {
  std::unique_ptr<Channel> ch;
  std::uint64_t seq = 0;
  RawPeer(const std::filesystem::path& dir, const std::string& me) {
    ch = connectTo(tcp(dir), me, "solid", Deadline::in(5));
  }
  void send(wire::MessageType t, const std::vector<std::uint8_t>& payload) {
    const auto m = frame(t, seq++, payload);
    ch->send(m.data(), m.size(), Deadline::in(5));
  }
  void sendRaw(const std::vector<std::uint8_t>& bytes) { ch->send(bytes.data(), bytes.size(), Deadline::in(5)); }
  Message receive() {
    Message m;
    std::uint8_t h[32];
    ch->receive(h, 32, Deadline::in(5));
    m.header = wire::decodeHeader(h);
    m.payload.resize(m.header.payloadLength);
    ch->receive(m.payload.data(), m.payload.size(), Deadline::in(5));
    return m;
  }
  /// Plays the fluid's side of the handshake correctly.
  void handshake(const CouplingConfig& c, const scenario::Ring& r, const std::string& token) {
    Hello h{token, "fluid", "solid", c, {{"wall", r.fluidIds(), r.fluidCoordinates(), {}}}};
    send(wire::MessageType::Hello, encodeHello(h));
    const Message w = receive();
    ASSERT_EQ(w.header.type, wire::MessageType::Welcome);
    send(wire::MessageType::Ready, {});
  }
};

std::vector<std::uint8_t> withHeaderVersion(std::vector<std::uint8_t> m, std::uint16_t v) {
  m[4] = std::uint8_t(v);
  m[5] = std::uint8_t(v >> 8);
  const std::uint32_t crc = wire::crc32(m.data(), 28);
  for (int i = 0; i < 4; ++i) m[28 + std::size_t(i)] = std::uint8_t(crc >> (8 * i));
  return m;
}

/// The dummy fluid's arguments: `scheme`, 50 windows of 1 ms, a 5 s timeout, hanging at window
/// `hangAt`.
std::vector<std::string> hangingFluid(const std::filesystem::path& dir, const std::string& token,
                                      const std::string& scheme, const std::string& hangAt) {
  return {"--role",           "fluid", "--token",          token,
          "--scheme",         scheme,  "--windows",        "50",
          "--window-size",    "0.001", "--max-iterations", "30",
          "--tolerance",      "1e-10", "--address-file",   (dir / "wall.addr").string(),
          "--hang-at-window", hangAt,  "--timeout",        "5"};
}

/// A solid's run of 50 one-millisecond windows against the dummy fluid (a process of its own)
/// that hangs at window `hangAt`.
struct AgainstHangingFluid {
  std::filesystem::path dir = freshDir();
  CouplingConfig c;
  scenario::Ring r;
  DummyProcess fluid;
  AgainstHangingFluid(SchemeKind scheme, const std::string& token, const std::string& hangAt)
      : c(ringConfig(scheme, 50)),
        fluid(hangingFluid(dir, token, scheme == SchemeKind::Explicit ? "explicit" : "implicit", hangAt)) {}
};

/// The solid couples (the ring's velocity at t = 0 each window) until its partner's fault stops it
/// with `Error`: the error's message and how long the last advance waited (s).
template <class Error>
std::pair<std::string, double> coupleUntilStopped(Participant& p, const scenario::Ring& r, double dt) {
  const auto v = scenario::field(r, true, true, 0.0);
  std::string msg;
  std::chrono::steady_clock::time_point t0;
  try {
    while (p.isCouplingOngoing()) {
      p.writeData("wall", "velocity", v);
      t0 = std::chrono::steady_clock::now();
      p.advance(dt);
    }
  } catch (const Error& e) {
    msg = e.what();
  }
  return {msg, Secs(std::chrono::steady_clock::now() - t0).count()};
}

}  // namespace

TEST(Faults, KilledPartnerStopsTheSolidAtOnceWithAClearMessage) {
  AgainstHangingFluid run(SchemeKind::Explicit, "tok-kill", "3");
  ASSERT_TRUE(run.fluid.started());
  Participant p("solid", run.c, tcp(run.dir, 5.0), "tok-kill");
  startOnRing(p, run.r, true);
  std::thread killer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    run.fluid.kill9();
  });
  const auto [msg, waited] = coupleUntilStopped<PartnerLostError>(p, run.r, run.c.windowSize);
  killer.join();
  EXPECT_TRUE(contains(msg, "participant 'solid' waiting for DATA of window 4 of 50")) << msg;
  EXPECT_TRUE(contains(msg, "from 'fluid'")) << msg;
  EXPECT_TRUE(contains(msg, "end of stream") || contains(msg, "reset")) << msg;
  // Blocked from window 4's send until the kill (~0.5 s), far below the 5 s timeout.
  EXPECT_LT(waited, 2.0);
  EXPECT_FALSE(p.isCouplingOngoing());
  EXPECT_NO_THROW(p.finalize());  // finalize after the loss is harmless
}

TEST(Faults, HungPartnerStopsTheSolidAfterTheTimeout) {
  AgainstHangingFluid run(SchemeKind::Implicit, "tok-hang", "2");
  ASSERT_TRUE(run.fluid.started());
  auto t = tcp(run.dir, 5.0);
  t.receiveTimeout = 1.0;
  Participant p("solid", run.c, t, "tok-hang");
  startOnRing(p, run.r, true);
  const auto [msg, waited] = coupleUntilStopped<TimeoutError>(p, run.r, run.c.windowSize);
  EXPECT_TRUE(contains(msg, "waiting for DATA of window 3 of 50, pass 1")) << msg;
  EXPECT_TRUE(contains(msg, "within the timeout of 1 s")) << msg;
  EXPECT_GT(waited, 0.95);
  EXPECT_LT(waited, 3.0);
}

TEST(Faults, ForeignConnectionIsRefusedAndThePartnerStillCouples) {
  const auto dir = freshDir();
  const auto c = ringConfig(SchemeKind::Explicit, 3);
  scenario::Ring r;
  std::string foreignGot;
  const auto [es, ef] = runPair(
      [&] {
        Participant p("solid", c, tcp(dir), "tok-foreign");
        startOnRing(p, r, true);
        coupleSteadily(p, "velocity", scenario::field(r, true, true, 0), c.windowSize);
        p.finalize();
      },
      [&] {
        {  // a stranger knocks first: an HTTP request on the coupler's port
          RawPeer stranger(dir, "stranger");
          const std::string http = "GET / HTTP/1.1\r\nHost: localhost\r\n\r\n";
          stranger.sendRaw({http.begin(), http.end()});
          const Message m = stranger.receive();
          foreignGot = wire::typeName(std::uint16_t(m.header.type)) + ": " +
                       decodeReason(m.payload.data(), m.payload.size()).message;
        }
        Participant p("fluid", c, tcp(dir), "tok-foreign");
        startOnRing(p, r, false);
        coupleSteadily(p, "force", scenario::field(r, false, false, 0), c.windowSize);
        p.finalize();
      });
  rethrowIf(es);
  rethrowIf(ef);
  EXPECT_TRUE(contains(foreignGot, "REJECT: ")) << foreignGot;
  EXPECT_TRUE(contains(foreignGot, "not a TunnelQuake coupler message")) << foreignGot;
}

TEST(Faults, OtherProtocolVersionIsRefusedWithBothVersionsNamed) {
  const auto dir = freshDir();
  const auto c = ringConfig(SchemeKind::Explicit, 3);
  scenario::Ring r;
  Message answer;
  const auto [es, ef] = runPair(
      [&] {
        Participant p("solid", c, tcp(dir), "tok-ver");
        startOnRing(p, r, true);
      },
      [&] {
        RawPeer peer(dir, "fluid");
        Hello h{"tok-ver", "fluid", "solid", c, {{"wall", r.fluidIds(), r.fluidCoordinates(), {}}}};
        peer.sendRaw(withHeaderVersion(frame(wire::MessageType::Hello, 0, encodeHello(h)),
                                       std::uint16_t(wire::kProtocolVersion + 1)));
        answer = peer.receive();
      });
  rethrowIf(ef);
  const std::string m = messageOf<HandshakeError>(es);
  EXPECT_TRUE(contains(m, "version " + std::to_string(wire::kProtocolVersion + 1) +
                              " received, this build speaks version " + std::to_string(wire::kProtocolVersion)))
      << m;
  ASSERT_EQ(answer.header.type, wire::MessageType::Reject);
  EXPECT_EQ(decodeReason(answer.payload.data(), answer.payload.size()).code, ReasonCode::WrongVersion);
}

// A partner that sends a bad DATA message mid-run: every kind is refused with its fault, the
// message says what was wrong, and the sender is told with ABORT.
struct Corruption {
  const char* name;
  ProtocolFault fault;
  const char* text;
};

void PrintTo(const Corruption& c, std::ostream* os) { *os << c.name; }

class MalformedData : public ::testing::TestWithParam<Corruption> {};

TEST_P(MalformedData, IsRefusedAndThePeerIsTold) {
  const auto dir = freshDir();
  const auto c = ringConfig(SchemeKind::Explicit, 5);
  scenario::Ring r;
  const Corruption k = GetParam();
  Message told;
  const auto [es, ef] = runPair(
      [&] {
        Participant p("solid", c, tcp(dir), "tok-bad");
        startOnRing(p, r, true);
        coupleSteadily(p, "velocity", scenario::field(r, true, true, 0), c.windowSize);
      },
      [&] {
        RawPeer peer(dir, "fluid");
        peer.handshake(c, r, "tok-bad");
        const Message first = peer.receive();  // the solid's DATA of window 1
        ASSERT_EQ(first.header.type, wire::MessageType::Data);
        DataMessage d;
        d.window = std::string(k.name) == "out_of_step" ? 3 : 0;
        d.fields.push_back({1, 3, scenario::field(r, false, false, 0)});
        auto m = frame(wire::MessageType::Data, peer.seq++, encodeData(d));
        const std::string n = k.name;
        if (n == "payload_crc") m[40] ^= 0x10;
        if (n == "sequence") m[8] = 7, m = withHeaderVersion(m, wire::kProtocolVersion);
        if (n == "huge_length") {
          m[16 + 5] = 0x40;  // announce ~1 TB of payload
          m = withHeaderVersion(m, wire::kProtocolVersion);
        }
        if (n == "foreign") std::memcpy(m.data(), "HTTP", 4);
        if (n == "unknown_type") m[6] = 77, m = withHeaderVersion(m, wire::kProtocolVersion);
        peer.sendRaw(m);
        told = peer.receive();
      });
  rethrowIf(ef);
  try {
    rethrowIf(es);
    FAIL() << "malformed DATA accepted";
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.fault(), k.fault) << e.what();
    EXPECT_TRUE(contains(e.what(), k.text)) << e.what();
    EXPECT_TRUE(contains(e.what(), "participant 'solid'")) << e.what();
    EXPECT_TRUE(contains(e.what(), "DATA of window 1 of 5")) << e.what();
  }
  ASSERT_EQ(told.header.type, wire::MessageType::Abort);
  EXPECT_TRUE(contains(decodeReason(told.payload.data(), told.payload.size()).message, k.text));
}

INSTANTIATE_TEST_SUITE_P(
    Coupler, MalformedData,
    ::testing::Values(Corruption{"payload_crc", ProtocolFault::BadPayloadCrc, "payload corrupted"},
                      Corruption{"sequence", ProtocolFault::BadSequence, "sequence number 7 where 2"},
                      Corruption{"huge_length", ProtocolFault::BadLength, "the handshake fixed exactly"},
                      Corruption{"foreign", ProtocolFault::BadMagic, "'HTTP'"},
                      Corruption{"unknown_type", ProtocolFault::UnknownType, "unknown message type 77"},
                      Corruption{"out_of_step", ProtocolFault::BadPayload, "out of step"}),
    [](const auto& info) { return std::string(info.param.name); });
