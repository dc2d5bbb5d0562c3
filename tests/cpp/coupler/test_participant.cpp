// Two participants over loopback TCP: data flow of the three schemes, checkpoint protocol,
// handshake refusals, and the added-mass model problem that separates explicit from implicit
// coupling.
#include <cmath>

#include "coupler_test_util.hpp"

using namespace tqtest;

namespace {

/// Replay fakes in-process: the solid writes the prescribed velocity, the fluid the prescribed
/// force; each records the largest difference between what it read and the prescription.
struct ReplayResult {
    double maxErr = 0;
    std::uint64_t passes = 0, windows = 0, writeCkpt = 0, readCkpt = 0;
};

ReplayResult replay(Participant& p, const scenario::Ring& r, bool solid) {
    ReplayResult out;
    setRing(p, r, solid);
    p.initialize();
    const double dt = p.config().windowSize;
    std::vector<double> got;
    while (p.isCouplingOngoing()) {
        if (p.requiresWritingCheckpoint()) ++out.writeCkpt;
        const auto w = p.state().window;
        const double tEnd = double(w + 1) * dt;
        if (!solid || (p.state().iteration == 0 && w > 0)) {
            p.readData("wall", solid ? "force" : "velocity", got);
            const auto want = scenario::field(r, solid, !solid, solid ? double(w) * dt : tEnd);
            for (std::size_t i = 0; i < got.size(); ++i)
                out.maxErr = std::max(out.maxErr, std::abs(got[i] - want[i]));
        }
        p.writeData("wall", solid ? "velocity" : "force", scenario::field(r, solid, solid, tEnd));
        p.advance(dt);
        ++out.passes;
        if (p.requiresReadingCheckpoint()) ++out.readCkpt;
    }
    out.windows = p.state().window;
    p.finalize();
    return out;
}

}  // namespace

class SchemeReplay : public ::testing::TestWithParam<SchemeKind> {};

TEST_P(SchemeReplay, EverySideReadsExactlyWhatThePartnerPrescribed) {
    const auto dir = freshDir();
    const SchemeKind scheme = GetParam();
    const auto c = ringConfig(scheme, 12);
    scenario::Ring r;
    ReplayResult rs, rf;
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", c, tcp(dir), "tok-replay");
            rs = replay(p, r, true);
        },
        [&] {
            Participant p("fluid", c, tcp(dir), "tok-replay");
            rf = replay(p, r, false);
        });
    rethrowIf(es);
    rethrowIf(ef);
    // The coincident map is a permutation: values arrive bit-exactly.
    EXPECT_EQ(rs.maxErr, 0.0);
    EXPECT_EQ(rf.maxErr, 0.0);
    EXPECT_EQ(rs.windows, 12u);
    EXPECT_EQ(rf.windows, 12u);
    // Passes per window: explicit 1, paper 2 (predictor, corrector), implicit with replayed
    // (input-independent) data: Aitken reaches the fixed point at the third pass.
    const std::uint64_t perWindow = scheme == SchemeKind::Explicit ? 1 : scheme == SchemeKind::Paper ? 2 : 3;
    EXPECT_EQ(rs.passes, 12 * perWindow);
    EXPECT_EQ(rf.passes, 12 * perWindow);
    // Checkpoints: written at each window start, read at each repeated pass (none if explicit).
    const std::uint64_t wc = scheme == SchemeKind::Explicit ? 0 : 12;
    EXPECT_EQ(rs.writeCkpt, wc);
    EXPECT_EQ(rf.writeCkpt, wc);
    EXPECT_EQ(rs.readCkpt, 12 * (perWindow - 1));
    EXPECT_EQ(rf.readCkpt, 12 * (perWindow - 1));
}

INSTANTIATE_TEST_SUITE_P(Coupler, SchemeReplay,
                         ::testing::Values(SchemeKind::Explicit, SchemeKind::Paper,
                                           SchemeKind::Implicit),
                         [](const auto& info) { return std::string(schemeName(info.param)); });

TEST(Participant, SubcyclingExchangesOncePerWindow) {
    const auto dir = freshDir();
    auto c = ringConfig(SchemeKind::Explicit, 4, 1e-3);
    scenario::Ring r;
    std::uint64_t solidSteps = 0, exchanges = 0;
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", c, tcp(dir), "tok-sub");
            setRing(p, r, true);
            p.initialize();
            const auto v = scenario::field(r, true, true, 0);
            while (p.isCouplingOngoing()) {
                p.writeData("wall", "velocity", v);
                p.advance(std::min(0.25e-3, p.getMaxTimeStepSize()));  // 4 solid steps per window
                ++solidSteps;
            }
            exchanges = p.stats().exchanges;
            p.finalize();
        },
        [&] {
            Participant p("fluid", c, tcp(dir), "tok-sub");
            setRing(p, r, false);
            p.initialize();
            while (p.isCouplingOngoing()) {
                p.writeData("wall", "force", scenario::field(r, false, false, 0));
                p.advance(p.getMaxTimeStepSize());
            }
            p.finalize();
        });
    rethrowIf(es);
    rethrowIf(ef);
    EXPECT_EQ(solidSteps, 16u);
    EXPECT_EQ(exchanges, 4u);
}

TEST(Participant, StepLargerThanTheWindowIsAClearError) {
    const auto dir = freshDir();
    auto c = ringConfig(SchemeKind::Explicit, 2, 1e-3);
    scenario::Ring r;
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", c, tcp(dir), "tok-dt");
            setRing(p, r, true);
            p.initialize();
            p.writeData("wall", "velocity", scenario::field(r, true, true, 0));
            p.advance(2e-3);
        },
        [&] {
            Participant p("fluid", c, tcp(dir), "tok-dt");
            setRing(p, r, false);
            p.initialize();
            p.writeData("wall", "force", scenario::field(r, false, false, 0));
            p.advance(1e-3);
        });
    EXPECT_TRUE(contains(messageOf<ConfigError>(es), "left in the coupling window"));
    // The solid's participant was destroyed without finalize: the fluid is told at once.
    EXPECT_TRUE(contains(messageOf<PartnerLostError>(ef), "destroyed before finalize"));
}

// ------------------------------------------------------------------ handshake refusals
TEST(Handshake, WrongTokenIsRefusedAndTheListenerKeepsWaiting) {
    const auto dir = freshDir();
    const auto c = ringConfig(SchemeKind::Explicit, 2);
    scenario::Ring r;
    const auto t0 = std::chrono::steady_clock::now();
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", c, tcp(dir, 1.5), "token-of-run-A");
            setRing(p, r, true);
            p.initialize();
        },
        [&] {
            Participant p("fluid", c, tcp(dir, 1.5), "token-of-run-B");
            setRing(p, r, false);
            p.initialize();
        });
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string f = messageOf<HandshakeError>(ef);
    EXPECT_TRUE(contains(f, "run token differs")) << f;
    EXPECT_FALSE(contains(f, "token-of-run")) << "the token itself must not be revealed";
    // The listener refused the stranger and went on waiting for its own partner until the
    // connect timeout, then said what it refused.
    const std::string sm = messageOf<TimeoutError>(es);
    EXPECT_TRUE(contains(sm, "did not connect in time")) << sm;
    EXPECT_TRUE(contains(sm, "refused: 'fluid' with a different run token")) << sm;
    EXPECT_LT(s, 1.5 + 2.0);
}

TEST(Handshake, DifferentInterfaceSizeIsRefusedOnBothSides) {
    const auto dir = freshDir();
    const auto c = ringConfig(SchemeKind::Explicit, 2);
    scenario::Ring rs, rf;
    rf.nTheta = 60;
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", c, tcp(dir), "tok-size");
            setRing(p, rs, true);
            p.initialize();
        },
        [&] {
            Participant p("fluid", c, tcp(dir), "tok-size");
            setRing(p, rf, false);
            p.initialize();
        });
    const std::string a = messageOf<HandshakeError>(es), b = messageOf<HandshakeError>(ef);
    EXPECT_TRUE(contains(a, "has 128 nodes here and 120 on 'fluid'")) << a;
    EXPECT_TRUE(contains(b, "refused by its partner")) << b;
    EXPECT_TRUE(contains(b, "120 on 'fluid'")) << b;
}

TEST(Handshake, DifferentConfigurationIsListedItemByItem) {
    const auto dir = freshDir();
    auto cs = ringConfig(SchemeKind::Implicit, 2, 1e-3);
    auto cf = cs;
    cf.windowSize = 2e-3;
    cf.fields[1].components = 1;
    scenario::Ring r;
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", cs, tcp(dir), "tok-cfg");
            setRing(p, r, true);
            p.initialize();
        },
        [&] {
            Participant p("fluid", cf, tcp(dir), "tok-cfg");
            setRing(p, r, false);
            p.initialize();
        });
    const std::string a = messageOf<HandshakeError>(es);
    EXPECT_TRUE(contains(a, "window size (s): here 0.001")) << a;
    EXPECT_TRUE(contains(a, "'force' components: here 3, 'fluid' has 1")) << a;
    EXPECT_TRUE(contains(messageOf<HandshakeError>(ef), "window size")) << "fluid side";
}

TEST(Handshake, UnmatchedInterfaceNodesAreListed) {
    const auto dir = freshDir();
    const auto c = ringConfig(SchemeKind::Explicit, 2);
    scenario::Ring r;
    const auto [es, ef] = runPair(
        [&] {
            Participant p("solid", c, tcp(dir), "tok-map");
            setRing(p, r, true);
            p.initialize();
        },
        [&] {
            Participant p("fluid", c, tcp(dir), "tok-map");
            auto xyz = r.fluidCoordinates();
            xyz[3 * 7 + 1] += 0.01;  // one water point 1 cm off
            p.setMeshVertices("wall", r.fluidIds(), xyz);
            p.initialize();
        });
    const std::string a = messageOf<HandshakeError>(es), b = messageOf<HandshakeError>(ef);
    EXPECT_TRUE(contains(a, "1 of 128 target nodes")) << a;
    EXPECT_TRUE(contains(a, "(id " + std::to_string(r.fluidIds()[7]) + ")")) << a;
    EXPECT_TRUE(contains(b, "1 of 128 target nodes")) << b;
}

// ------------------------------------------------------------------ added-mass model problem
namespace {

/// Each interface node's x motion is a mass–spring m ẍ + k x = f (explicit, symplectic Euler);
/// the "fluid" is incompressible added mass: f = −m_a (v_{n+1} − v_n)/Δt. Converged coupling
/// is the monolithic oscillator of mass m + m_a. Returns the solid's x history of node 0 and
/// the largest |x| seen.
struct OscResult {
    std::vector<double> x0;
    double maxAbs = 0;
    std::uint64_t passes = 0;
    std::exception_ptr solidError, fluidError;
};

OscResult oscillate(SchemeKind scheme, AccelerationKind acc, double ratio, int windows) {
    const auto dir = freshDir();
    auto c = ringConfig(scheme, std::uint64_t(windows), 1e-3);
    c.acceleration = acc;
    c.tolerance = 1e-10;
    c.maxIterations = 40;
    scenario::Ring r;
    r.nTheta = 8;
    r.nLayers = 1;
    const int n = r.nodes();
    const double m = 1.0, ma = ratio * m, k = 4 * M_PI * M_PI * 25.0 * (m + ma);  // 5 Hz coupled
    const double dt = c.windowSize;
    OscResult out;
    std::tie(out.solidError, out.fluidError) = runPair(
        [&] {
            Participant p("solid", c, tcp(dir), "tok-osc");
            setRing(p, r, true);
            p.initialize();
            std::vector<double> x(n), v(n, 0.0), xs, vs, f, vel(3 * std::size_t(n), 0.0);
            for (int i = 0; i < n; ++i) x[std::size_t(i)] = 0.01 * std::cos(r.theta(i));
            while (p.isCouplingOngoing()) {
                if (p.requiresWritingCheckpoint()) xs = x, vs = v;
                p.readData("wall", "force", f);
                for (int i = 0; i < n; ++i) {
                    auto u = std::size_t(i);
                    v[u] += dt * (-k * x[u] + f[3 * u]) / m;
                    x[u] += dt * v[u];
                    vel[3 * u] = v[u];
                }
                p.writeData("wall", "velocity", vel);
                p.advance(dt);
                ++out.passes;
                if (p.requiresReadingCheckpoint()) {
                    x = xs, v = vs;
                } else {
                    out.x0.push_back(x[0]);
                    for (double xi : x) out.maxAbs = std::max(out.maxAbs, std::abs(xi));
                    if (!std::isfinite(out.maxAbs) || out.maxAbs > 1e6) {
                        p.abort("diverged");
                        return;
                    }
                }
            }
            p.finalize();
        },
        [&] {
            Participant p("fluid", c, tcp(dir), "tok-osc");
            setRing(p, r, false);
            p.initialize();
            std::vector<double> vOld(3 * std::size_t(n), 0.0), vs, vNew, f(3 * std::size_t(n));
            while (p.isCouplingOngoing()) {
                if (p.requiresWritingCheckpoint()) vs = vOld;
                p.readData("wall", "velocity", vNew);
                for (std::size_t i = 0; i < f.size(); ++i) f[i] = -ma * (vNew[i] - vOld[i]) / dt;
                p.writeData("wall", "force", f);
                p.advance(dt);
                if (p.requiresReadingCheckpoint())
                    vOld = vs;
                else
                    vOld = vNew;
            }
            p.finalize();
        });
    return out;
}

/// The monolithic reference: the same integrator with mass m + m_a.
std::vector<double> monolithic(double ratio, int windows) {
    const double m = 1.0 + ratio, k = 4 * M_PI * M_PI * 25.0 * m, dt = 1e-3;
    double x = 0.01, v = 0;
    std::vector<double> out;
    for (int i = 0; i < windows; ++i) {
        v += dt * (-k * x) / m;
        x += dt * v;
        out.push_back(x);
    }
    return out;
}

}  // namespace

TEST(AddedMass, ImplicitCouplingMatchesTheMonolithicOscillatorAtRatioFive) {
    for (auto acc : {AccelerationKind::Aitken, AccelerationKind::IqnIls}) {
        const auto res = oscillate(SchemeKind::Implicit, acc, 5.0, 100);
        rethrowIf(res.solidError);
        rethrowIf(res.fluidError);
        const auto ref = monolithic(5.0, 100);
        ASSERT_EQ(res.x0.size(), ref.size());
        double err = 0;
        for (std::size_t i = 0; i < ref.size(); ++i) err = std::max(err, std::abs(res.x0[i] - ref[i]));
        EXPECT_LT(err, 1e-8 * 0.01) << accelerationName(acc);  // amplitude 0.01 m
        EXPECT_LT(res.passes, 100u * 8) << accelerationName(acc) << ": too many passes";
        std::cout << "[ info ] added-mass ratio 5, " << accelerationName(acc) << ": "
                  << double(res.passes) / 100.0 << " passes per window\n";
    }
}

TEST(AddedMass, ExplicitCouplingIsStableBelowRatioOneAndDivergesAbove) {
    // Staggered exchange: the lagged added-mass force amplifies the interface acceleration by
    // −m_a/m every window (VERIFICATION.md, Causin et al. 2005).
    const auto stable = oscillate(SchemeKind::Explicit, AccelerationKind::None, 0.5, 200);
    rethrowIf(stable.solidError);
    EXPECT_LT(stable.maxAbs, 0.02);
    const auto unstable = oscillate(SchemeKind::Explicit, AccelerationKind::None, 5.0, 200);
    EXPECT_GT(unstable.maxAbs, 1e6);  // the solid stopped itself on the blow-up
    // ... and the fluid was told why rather than left waiting.
    EXPECT_TRUE(contains(messageOf<PartnerLostError>(unstable.fluidError), "diverged"));
}
