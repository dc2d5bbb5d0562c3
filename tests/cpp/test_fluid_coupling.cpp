// The solid side of the water coupling (solid half; docs/coupler.md
// "Solid adapter"): tq::FluidCoupling in a real Solver against a fake fluid participant (a second
// tq::coupler::Participant in a thread, over loopback TCP) that replays a prescribed force.
//
//  (a) The paper's lining (a = 4.5 m, b = 5.25 m, 3 elements through, 48 around) bonded in rock
//      (to 20 b, outer face fixed) under a uniform internal pressure p_i delivered as interface
//      forces by the fake fluid, relaxed to static equilibrium: lining hoop stresses and contact
//      pressure within 3 % of the closed form (tunnelquake.references.lined_tunnel_internal_pressure)
//      and equal to the same pressure applied as the solid's own load to round-off.
//  (c) The predictor: with a zero force from the fluid the coupled run equals the uncoupled run
//      bitwise, for the explicit, paper and implicit schemes.
//  (d) A prescribed force through the coupler gives the uncoupled run with that force as its own
//      load bitwise, and the work booked as /energy/fluid_work equals the solver's external work.
//  (f) Implicit windows of k = 4 solid steps (the time loop saves the solver's state at
//      each window start and steps a window the water did not accept again from it, as tq-solid's
//      loop in app.cpp does): a zero fluid force leaves the run bitwise unchanged although every
//      window is stepped at least twice; a uniform pressure through the coupler relaxed by damping
//      gives the lined-tunnel closed form within the same 3 %, and equals bitwise the uncoupled run
//      whose own load ramps over the first window as the windowed coupling's force does; the
//      fluid's work booked per window does not drift after window 0.
// The fault case (b) (fluid killed mid-run) runs tq-solid itself: tests/python/test_solid_coupling.py.
#include <gtest/gtest.h>
#include <omp.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <thread>

#include "tq/boundaries/boundaries.hpp"
#include "tq/core/state_archive.hpp"
#include "tq/coupler/participant.hpp"
#include "tq/coupling/coupled_stepper.hpp"
#include "tq/coupling/fluid_coupling.hpp"
#include "tq/io/input.hpp"
#include "tq/io/mesh.hpp"
#include "tq/water/carried_water.hpp"

using namespace tq;
namespace cp = tq::coupler;

namespace {

// One solver thread: the fake fluid runs in a second thread, and CI has 2 shared cores (with
// OpenMP barriers on oversubscribed cores each step could wait a scheduler quantum).
const int kOneThread = (omp_set_num_threads(1), 1);

constexpr Real kEr = 8e9, kNur = 0.27, kRhor = 2700;   // rock (paper Table 1)
constexpr Real kEl = 28e9, kNul = 0.17, kRhol = 2500;  // lining, C25
constexpr Real kA = 4.5, kB = 5.25;

/// A lined ring's radii and materials (default: the paper's lining and rock).
struct RingGeometry {
  Real a = kA, b = kB;        ///< the lining's inner and outer radius (m)
  Real El = kEl, nul = kNul;  ///< lining
  Real Er = kEr, nur = kNur;  ///< rock
};

/// Full ring slice a ≤ r ≤ 20 b: 3 lining elements to b, then rock with square-ish elements growing
/// geometrically; regions lining (0) and rock (1) share their nodes (bonded). Faces lining_inner,
/// outer, ymin, ymax.
Mesh linedRing(Index nAround = 48, const RingGeometry& G = {}) {
  RingSpec rs;
  const Real dth = 2 * M_PI / Real(nAround);
  std::vector<Real> radii;
  for (int j = 0; j <= 3; ++j) radii.push_back(G.a + (G.b - G.a) * j / 3.0);
  while (radii.back() < 20 * G.b) radii.push_back(radii.back() * (1 + dth));
  rs.rInner = G.a;
  rs.rOuter = radii.back();
  rs.nRadial = Index(radii.size()) - 1;
  rs.nAround = nAround;
  rs.width = 1.0;
  Mesh m = makeRingSliceMesh(rs);
  const Index NR = rs.nRadial + 1, NT = nAround;
  for (Index y = 0; y < 2; ++y)
    for (Index r = 0; r < NR; ++r)
      for (Index t = 0; t < NT; ++t) {
        const Index n = t + NT * (r + NR * y);
        const Real th = 2 * M_PI * t / Real(nAround);
        m.coords[3 * size_t(n)] = radii[size_t(r)] * std::cos(th);
        m.coords[3 * size_t(n) + 2] = radii[size_t(r)] * std::sin(th);
      }
  m.regionNames = {"lining", "rock"};
  for (Index e = 0; e < m.numElems(); ++e) m.region[size_t(e)] = e / NT < 3 ? 0 : 1;
  m.faces["lining_inner"] = m.faces.at("inner");
  m.faces.erase("inner");
  return m;
}

SolidInput ringInput(Real alpha = 0, Real beta = 0, const RingGeometry& G = {}) {
  SolidInput in;
  in.materials = {{"lining", elasticValues({G.El, G.nul, kRhol})}, {"rock", elasticValues({G.Er, G.nur, kRhor})}};
  in.fixed = {{"outer", "xyz"}};
  in.options.damping.alpha = alpha;
  in.options.damping.beta = beta;
  in.tEnd = 1;
  return in;
}

std::filesystem::path freshDir(const std::string& tag) {
  static std::atomic<int> counter{0};
  auto d = std::filesystem::temp_directory_path() /
           ("tq-solid-coupling-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" + tag);
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

CouplingInput couplingInput(const std::filesystem::path& dir, const std::string& scheme, Index windows) {
  CouplingInput c;
  c.present = true;
  c.scheme = scheme;
  c.windows = windows;
  c.tolerance = 1e-10;
  c.maxIterations = 10;
  c.acceleration = "aitken";
  c.addressFile = (dir / "wall.addr").string();
  c.token = "test-token-" + std::to_string(::getpid());
  c.timeout = 10;
  return c;
}

/// The configuration the adapter builds (the handshake compares every item).
cp::CouplingConfig configOf(const CouplingInput& in, Real window) {
  cp::CouplingConfig c;
  c.first = in.participant;
  c.second = in.partner;
  c.windowSize = window;
  c.maxWindows = std::uint64_t(in.windows);
  c.maxIterations = int(in.maxIterations);
  c.tolerance = in.tolerance;
  c.initialRelaxation = in.initialRelaxation;
  c.reuse = int(in.reuse);
  c.predictor = cp::parsePredictor(in.predictor);
  c.scheme = cp::parseScheme(in.scheme);
  c.acceleration = cp::parseAcceleration(in.acceleration);
  c.meshes.push_back({in.mesh, cp::MapKind::Coincident, in.participant, in.mapTolerance});
  for (const auto& f : in.writeFields)
    c.fields.push_back({in.mesh, f, 3, in.participant, cp::MapConstraint::Consistent});
  c.fields.push_back({in.mesh, "force", 3, in.partner, cp::MapConstraint::Conservative});
  return c;
}

/// A fake fluid in a thread: its vertices are the solid's interface nodes in reverse order with
/// other ids (the coincident map must find the permutation); every window it sends the nodal
/// forces `force(t_end of window)` given on the solid's interface nodes ([3n], solid order), or,
/// with `respond`, `respond(t_end, u_s)` of the displacement u_s the solid sent ([3n], solid order).
class FakeFluid {
 public:
  using Force = std::function<std::vector<Real>(Real)>;
  using Response = std::function<std::vector<Real>(Real, const std::vector<Real>&)>;
  FakeFluid(const CouplingInput& in, Real window, const Mesh& mesh, const std::vector<Index>& solidNodes, Force force)
      : FakeFluid(
            in, window, mesh, solidNodes, [force](Real t, const std::vector<Real>&) { return force(t); }, false) {}
  FakeFluid(const CouplingInput& in, Real window, const Mesh& mesh, const std::vector<Index>& solidNodes,
            Response respond, bool readsMotion = true)
      : thread_([=, &mesh] {
          try {
            cp::TransportOptions t;
            t.addressFile = in.addressFile;
            t.connectTimeout = t.receiveTimeout = in.timeout;
            cp::Participant p(in.partner, configOf(in, window), t, in.token);
            const size_t n = solidNodes.size();
            std::vector<std::int64_t> ids(n);
            std::vector<double> xyz(3 * n);
            for (size_t k = 0; k < n; ++k) {
              const size_t s = n - 1 - k;
              ids[k] = 500000 + std::int64_t(s);
              for (int d = 0; d < 3; ++d) xyz[3 * k + d] = mesh.coords[3 * size_t(solidNodes[s]) + d];
            }
            p.setMeshVertices(in.mesh, ids, xyz);
            p.initialize();
            std::vector<double> f(3 * n), uf(3 * n);
            std::vector<Real> us(3 * n);
            while (p.isCouplingOngoing()) {
              if (readsMotion) {
                p.readData(in.mesh, "displacement", uf);
                for (size_t k = 0; k < n; ++k)
                  for (int d = 0; d < 3; ++d) us[3 * (n - 1 - k) + d] = uf[3 * k + d];
              }
              const std::vector<Real> fs = respond((double(p.state().window) + 1) * window, us);
              for (size_t k = 0; k < n; ++k)
                for (int d = 0; d < 3; ++d) f[3 * k + d] = fs[3 * (n - 1 - k) + d];
              p.writeData(in.mesh, "force", f);
              p.advance(p.getMaxTimeStepSize());
              ++passes_;
            }
            p.finalize();
          } catch (const cp::PartnerLostError& e) {
            partnerLost_ = e.what();  // the solid stopped before the last window (allowed in tests)
          } catch (const std::exception& e) {
            error_ = e.what();
          }
        }) {}
  ~FakeFluid() {
    if (thread_.joinable()) thread_.join();
  }
  void join() { thread_.join(); }
  const std::string& error() const { return error_; }
  long long passes() const { return passes_; }

 private:
  std::string error_, partnerLost_;
  std::atomic<long long> passes_{0};
  std::thread thread_;
};

/// The interface nodes of `lining_inner` in ascending order (the adapter's order).
std::vector<Index> interfaceNodes(const Mesh& m) {
  auto n = m.faceNodes("lining_inner");
  std::sort(n.begin(), n.end());
  n.erase(std::unique(n.begin(), n.end()), n.end());
  return n;
}

std::vector<Real> onNodes(const std::vector<Real>& all, const std::vector<Index>& nodes) {
  std::vector<Real> out(3 * nodes.size());
  for (size_t k = 0; k < nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) out[3 * k + d] = all[3 * size_t(nodes[k]) + d];
  return out;
}

struct RingStatics {
  Real hoopIn = 0, hoopOut = 0, pc = 0;
  std::vector<Real> u;
  Index steps = 0;
};

/// Lamé fit σθθ = A + B/r², σrr = A − B/r² over the lining's elements.
RingStatics lameFit(const Solver& s) {
  const ElementBlock* lin = nullptr;
  for (const auto& b : s.blocks())
    if (b->name() == "lining") lin = b.get();
  const Mesh& m = s.mesh();
  Real s11 = 0, s22 = 0, r1 = 0, r2 = 0;
  for (Index e = 0; e < lin->numElems(); ++e) {
    Real c[3] = {0, 0, 0};
    for (int k = 0; k < 8; ++k)
      for (int d = 0; d < 3; ++d) c[d] += 0.125 * m.coords[3 * size_t(lin->node(e, k)) + d];
    const Real r = std::hypot(c[0], c[2]), cs = c[0] / r, sn = c[2] / r;
    const Real sxx = lin->stress(e, XX), szz = lin->stress(e, ZZ), sxz = lin->stress(e, ZX);
    const Real rad = sxx * cs * cs + szz * sn * sn + 2 * sxz * cs * sn;
    const Real hoop = sxx * sn * sn + szz * cs * cs - 2 * sxz * cs * sn;
    const Real q = 1 / (r * r);
    s11 += 2;
    s22 += 2 * q * q;
    r1 += hoop + rad;
    r2 += q * hoop - q * rad;
  }
  const Real A = r1 / s11, B = r2 / s22;
  RingStatics out;
  out.hoopIn = A + B / (kA * kA);
  out.hoopOut = A + B / (kB * kB);
  out.pc = -(A - B / (kB * kB));
  out.u.assign(s.state().uData(), s.state().uData() + 3 * size_t(m.numNodes()));
  return out;
}

RelaxParams relaxParams(Real refForce) {
  RelaxParams rp;
  rp.tolerance = 1e-6;
  rp.maxSteps = 60000;
  rp.checkEvery = 10;
  rp.referenceForce = refForce;
  return rp;
}

Real norm(const std::vector<Real>& v) {
  Real s = 0;
  for (Real x : v) s += x * x;
  return std::sqrt(s);
}

}  // namespace

namespace {

/// How the windows of a coupled run went, seen from the time loop.
struct WindowLog {
  long long windows = 0;    ///< windows completed
  long long restores = 0;   ///< windows stepped again from their saved start
  long long minPasses = 0;  ///< fewest passes of one window (1 + its restores)
  long long steps = 0;      ///< solid steps taken, repeated ones included
};

/// Step `s` until the coupling ends with tq-solid's own time-loop step (CoupledStepper: with
/// implicit windows of several steps the state is saved at each window start and restored when the
/// water did not accept the window).
WindowLog stepCoupled(Solver& s, FluidCoupling& ad) {
  WindowLog log;
  CoupledStepper stepper(s, &ad);
  while (ad.ongoing()) {
    const long long restores = stepper.restores();
    stepper.advance([] {});
    const long long passes = 1 + stepper.restores() - restores;  // a window taken back: one more pass
    log.minPasses = log.windows == 0 ? passes : std::min(log.minPasses, passes);
    ++log.windows;
  }
  log.restores = stepper.restores();
  log.steps = stepper.steps();
  return log;
}

/// The windowed coupling's force in window 0, as the solid's own load: step j of the first k applies
/// (j/k) F, added in ForcePhase::Water where the adapter adds its force (the window ramps from the initial force, zero
/// here, to the water's answer F, computed as the adapter computes it: F_w + (j/k)(F − F_w) with F_w = 0), then F.
class RampedForces final : public NodalForceContributor {
 public:
  RampedForces(std::vector<Real> f, Index k) : f_(std::move(f)), k_(k) {}
  std::string name() const override { return "ramped own load"; }
  void addForces(Real, Real, NodalState& st) override {
    ++j_;
    const Real w = Real(j_) / Real(k_);
    Real* fe = st.fExtData();
    for (size_t i = 0; i < f_.size(); ++i)
      if (f_[i] != 0) fe[i] += j_ < k_ ? 0.0 + w * (f_[i] - 0.0) : f_[i];
  }

 private:
  std::vector<Real> f_;
  Index k_;
  Index j_ = 0;
};

/// A short damped dynamic run of the ring: a load pulse on a few outer-lining nodes, with or
/// without the coupling (the fake fluid sending `fluidForce`), and optionally `ownForce` on the
/// interface as the solid's own load (ramped over the first `ownRamp` steps if > 0). Returns u and
/// v of every node after `steps` steps. `window` solid steps per coupling window; `alpha` the
/// mass-proportional damping (1/s).
struct DynResult {
  std::vector<Real> u, v;
  Real external = 0, fluidWork = 0, fluidReceived = 0, couplingEnergy = 0;
  long long passes = 0, maxPasses = 0;
  WindowLog windows;
  RingStatics statics;
  Real residual = 0;  ///< |f_ext − f_int|₂ over the free dofs at the end (N)
};

/// A short inward push (2 MN a node over `length` = 4 ms, triangular) on the crown of the lining's outside.
NodalLoad crownPulse(const Mesh& mesh, Real length = 0.004) {
  NodalLoad pulse;
  for (Index n = 0; n < mesh.numNodes(); ++n)
    if (std::abs(mesh.coords[3 * size_t(n)] - kB) < 1e-9 && std::abs(mesh.coords[3 * size_t(n) + 2]) < 1e-9)
      pulse.nodes.push_back(n);
  pulse.direction = 0;
  pulse.forcePerNode = -2e6;
  pulse.function = {{0, 0.5 * length, length}, {0, 1, 0}};
  return pulse;
}

DynResult dynamicRun(const Mesh& mesh, const std::string& scheme, bool coupled,
                     std::function<std::vector<Real>(Real)> fluidForce, const std::vector<Real>& ownForce, Index steps,
                     bool withPulse = true, Index window = 1, Real alpha = 2.0, Index ownRamp = 0) {
  SolidInput in = ringInput(alpha, 1e-5);
  auto s = buildSolver(in, mesh);
  if (withPulse) s->addLoad(crownPulse(mesh));
  if (!ownForce.empty()) {
    if (ownRamp > 0)
      s->addContributor(ForcePhase::Water, std::make_shared<RampedForces>(ownForce, ownRamp));
    else
      s->addContributor(ForcePhase::Loads, std::make_shared<ConstantNodalForces>("own", ownForce));
  }
  DynResult out;
  if (coupled) {
    const auto dir = freshDir(scheme);
    CouplingInput ci = couplingInput(dir, scheme, steps / window);
    ci.windowSteps = window;
    auto ad = std::make_shared<FluidCoupling>(*s, ci);
    FakeFluid fluid(ci, ad->windowSize(), mesh, interfaceNodes(mesh), fluidForce);
    ad->initialize();
    s->addContributor(ForcePhase::Water, ad);
    out.windows = stepCoupled(*s, *ad);
    EXPECT_FALSE(ad->ongoing());
    ad->finalize();
    fluid.join();
    EXPECT_EQ(fluid.error(), "");
    EXPECT_EQ(fluid.passes(), out.passes = ad->stats().passes);  // one fluid pass per exchange
    EXPECT_EQ(s->stepCount(), steps);  // repeated steps are taken back: the clock counts each step once
    out.fluidWork = ad->fluidWork();
    out.fluidReceived = ad->fluidReceivedWork();
    out.couplingEnergy = ad->couplingEnergy();
    out.passes = ad->stats().passes;
    out.maxPasses = ad->stats().maxPasses;
  } else {
    for (Index k = 0; k < steps; ++k) s->step();
  }
  out.u.assign(s->state().uData(), s->state().uData() + 3 * size_t(mesh.numNodes()));
  out.v.assign(s->state().vData(), s->state().vData() + 3 * size_t(mesh.numNodes()));
  out.external = s->energy().external;
  out.statics = lameFit(*s);
  out.residual = s->residualNorm();
  return out;
}

}  // namespace

// (c) Zero force from the fluid: the coupled run is the uncoupled run, bit for bit, whatever the
// scheme (the predictor only reads the state; the paper and implicit schemes repeat the window).
TEST(SolidCoupling, ZeroFluidForceLeavesTheRunBitwiseUnchanged) {
  const Mesh mesh = linedRing(24);
  const Index steps = 150;
  const DynResult ref = dynamicRun(mesh, "explicit", false, {}, {}, steps);
  const size_t n3 = 3 * interfaceNodes(mesh).size();
  Real umax = 0;
  for (Real x : ref.u) umax = std::max(umax, std::abs(x));
  ASSERT_GT(umax, 1e-7);  // the pulse moved the ring
  for (const char* scheme : {"explicit", "paper", "implicit"}) {
    const DynResult c = dynamicRun(
        mesh, scheme, true, [n3](Real) { return std::vector<Real>(n3, 0.0); }, {}, steps);
    size_t diff = 0;
    for (size_t i = 0; i < ref.u.size(); ++i) diff += (c.u[i] != ref.u[i]) + (c.v[i] != ref.v[i]);
    std::printf("zero fluid force, scheme %s: %zu of %zu values differ, %lld passes in %lld windows (max %lld)\n",
                scheme, diff, 2 * ref.u.size(), c.passes, (long long)steps, c.maxPasses);
    EXPECT_EQ(diff, 0u) << scheme;
    EXPECT_EQ(c.fluidWork, 0.0);
    EXPECT_EQ(c.passes, std::string(scheme) == "explicit" ? steps : 2 * steps) << scheme;
  }
}

// (f, a) Implicit windows of k = 4 solid steps with a zero fluid force: the coupled run equals the
// uncoupled run bit for bit (tolerance 0: the adapter adds exactly zero and a restored state
// continues exactly as the saved one, test_state_archive.cpp), and every window was really stepped
// again from its saved start (≥ 2 passes: the implicit scheme judges convergence on a second pass).
TEST(SolidCoupling, ImplicitWindowsOfSeveralStepsRepeatFromTheirStartBitwise) {
  const Mesh mesh = linedRing(24);
  const Index steps = 152, k = 4;
  const DynResult ref = dynamicRun(mesh, "explicit", false, {}, {}, steps);
  const size_t n3 = 3 * interfaceNodes(mesh).size();
  Real umax = 0;
  for (Real x : ref.u) umax = std::max(umax, std::abs(x));
  ASSERT_GT(umax, 1e-7);  // the pulse moved the ring
  const DynResult c = dynamicRun(
      mesh, "implicit", true, [n3](Real) { return std::vector<Real>(n3, 0.0); }, {}, steps, true, k);
  size_t diff = 0;
  for (size_t i = 0; i < ref.u.size(); ++i) diff += (c.u[i] != ref.u[i]) + (c.v[i] != ref.v[i]);
  std::printf(
      "zero fluid force, implicit windows of %ld steps: %zu of %zu values differ; %lld windows, %lld passes "
      "(min %lld, max %lld a window), %lld restores, %lld solid steps taken for %ld\n",
      long(k), diff, 2 * ref.u.size(), c.windows.windows, c.passes, c.windows.minPasses, c.maxPasses,
      c.windows.restores, c.windows.steps, long(steps));
  EXPECT_EQ(diff, 0u);
  EXPECT_EQ(c.fluidWork, 0.0);
  EXPECT_EQ(c.windows.windows, steps / k);
  EXPECT_GE(c.windows.minPasses, 2);                            // every window was stepped again from its checkpoint
  EXPECT_EQ(c.passes, c.windows.windows + c.windows.restores);  // one exchange per pass
  EXPECT_EQ(c.windows.steps, k * c.passes);                     // each pass steps the whole window
}

// (a) Uniform internal pressure through the coupler (explicit, one step a window) = closed form (3 %) =
// the same pressure as the solid's own load (round-off: the own load is added in the Loads phase, the
// coupler's in the Water phase). The ring is brought to rest by mass-proportional damping (α = 60 1/s,
// as in (f, b)): a coupled solid steps through CoupledStepper, not relax(). At rest when the residual is
// below 1e-6 of the load (relax()'s tolerance).
TEST(SolidCoupling, FakeFluidPressureGivesTheLinedTunnelClosedForm) {
  const Real pi = 1000 * 9.81 * 123;  // 123 m of water, 1.207 MPa
  const Mesh mesh = linedRing();
  const auto nodes = interfaceNodes(mesh);
  const std::vector<Real> fAll = pressureNodalForces(mesh, "lining_inner", [pi](const Real*) { return pi; });
  const std::vector<Real> fIf = onNodes(fAll, nodes);
  const Index steps = 10000;
  const Real alpha = 60;
  const DynResult own = dynamicRun(mesh, "explicit", false, {}, fAll, steps, false, 1, alpha);
  const DynResult cpl = dynamicRun(
      mesh, "explicit", true, [&](Real) { return fIf; }, {}, steps, false, 1, alpha);
  // Closed form (VERIFICATION.md; tunnelquake.references.lined_tunnel_internal_pressure).
  const Real Gl = kEl / (2 * (1 + kNul)), Gm = kEr / (2 * (1 + kNur)), a = kA, b = kB;
  const Real den = Gl * (b * b - a * a) + Gm * ((1 - 2 * kNul) * b * b + a * a);
  const Real pcRef = pi * 2 * Gm * (1 - kNul) * a * a / den;
  const Real hinRef = pi * (Gl * (a * a + b * b) + Gm * ((1 - 2 * kNul) * b * b - a * a)) / den;
  const Real houtRef = pi * 2 * a * a * (Gl - Gm * kNul) / den;
  Real du = 0, umax = 0;
  for (size_t i = 0; i < own.u.size(); ++i) {
    du = std::max(du, std::abs(cpl.u[i] - own.u[i]));
    umax = std::max(umax, std::abs(own.u[i]));
  }
  const Real ratio = cpl.residual / norm(fAll);
  std::printf(
      "lined ring, pressure %.4g MPa through the coupler (%lld exchanges, %ld steps damped to rest, residual %.2e "
      "of the load): contact pressure %+.2f %%, inner hoop %+.2f %%, outer hoop %+.2f %% vs closed form (p_c %.4g, "
      "hoop %.4g / %.4g MPa); max |u_coupled - u_own| / max |u| = %.3g\n",
      pi / 1e6, cpl.passes, long(steps), ratio, 100 * (cpl.statics.pc / pcRef - 1),
      100 * (cpl.statics.hoopIn / hinRef - 1), 100 * (cpl.statics.hoopOut / houtRef - 1), pcRef / 1e6, hinRef / 1e6,
      houtRef / 1e6, du / umax);
  ASSERT_LT(ratio, 1e-6) << "not at rest yet";
  EXPECT_NEAR(cpl.statics.pc / pcRef, 1, 0.03);
  EXPECT_NEAR(cpl.statics.hoopIn / hinRef, 1, 0.03);
  EXPECT_NEAR(cpl.statics.hoopOut / houtRef, 1, 0.03);
  EXPECT_LE(du, 1e-12 * umax);
  EXPECT_NEAR(cpl.statics.hoopIn, own.statics.hoopIn, 1e-12 * std::abs(own.statics.hoopIn));
  EXPECT_NEAR(cpl.statics.pc, own.statics.pc, 1e-12 * std::abs(own.statics.pc));
  EXPECT_EQ(cpl.passes, steps);  // one exchange per solid step
}

// (f, b) The lined tunnel's closed form through implicit windows of 4 steps: the uniform pressure of
// (a) from the fake fluid, the ring brought to rest by mass-proportional damping (α = 60 1/s, about
// twice the lowest radial mode's ω ≈ cp/(4 × 100 m) × 2π ≈ 30 rad/s: every mode decays at least as
// e^(−30 t)) instead of relax() (whose steps cannot be taken back). References: the closed form,
// 3 % (as (a): the mesh's discretisation, VERIFICATION.md), reached once the residual is below
// 1e-6 of the load (relax()'s tolerance in (a)); and the uncoupled run under the same load as the
// solid's own, ramped over the first window as the windowed coupling applies it, bitwise (tolerance
// 0: the same force values added in the same order). What differs from a one-step window: window 0
// ramps from the initial force (0) to the water's answer, (j/4) F at its step j, where one-step
// windows apply F from the first step; the transient differs, the rest state does not (printed:
// the constant-load run's difference at the end).
TEST(SolidCoupling, ImplicitWindowsOfSeveralStepsGiveTheLinedTunnelClosedForm) {
  const Real pi = 1000 * 9.81 * 123;
  const Mesh mesh = linedRing();
  const auto nodes = interfaceNodes(mesh);
  const std::vector<Real> fAll = pressureNodalForces(mesh, "lining_inner", [pi](const Real*) { return pi; });
  const std::vector<Real> fIf = onNodes(fAll, nodes);
  const Index k = 4, steps = 4 * 2500;
  const Real alpha = 60;
  const DynResult own = dynamicRun(mesh, "implicit", false, {}, fAll, steps, false, 1, alpha, k);
  const DynResult flat = dynamicRun(mesh, "implicit", false, {}, fAll, steps, false, 1, alpha, 0);
  const DynResult c = dynamicRun(
      mesh, "implicit", true, [&](Real) { return fIf; }, {}, steps, false, k, alpha);
  const Real Gl = kEl / (2 * (1 + kNul)), Gm = kEr / (2 * (1 + kNur)), a = kA, b = kB;
  const Real den = Gl * (b * b - a * a) + Gm * ((1 - 2 * kNul) * b * b + a * a);
  const Real pcRef = pi * 2 * Gm * (1 - kNul) * a * a / den;
  const Real hinRef = pi * (Gl * (a * a + b * b) + Gm * ((1 - 2 * kNul) * b * b - a * a)) / den;
  const Real houtRef = pi * 2 * a * a * (Gl - Gm * kNul) / den;
  size_t diff = 0;
  Real umax = 0, dFlat = 0;
  for (size_t i = 0; i < own.u.size(); ++i) {
    diff += (c.u[i] != own.u[i]) + (c.v[i] != own.v[i]);
    umax = std::max(umax, std::abs(own.u[i]));
    dFlat = std::max(dFlat, std::abs(flat.u[i] - c.u[i]));
  }
  const Real ratio = c.residual / norm(fAll);
  std::printf(
      "lined ring, pressure %.4g MPa through implicit windows of %ld steps, damped to rest (%ld steps, %lld "
      "windows, %lld passes, max %lld a window, min %lld; residual %.2e of the load): contact pressure "
      "%+.2f %%, inner hoop %+.2f %%, outer hoop %+.2f %% vs closed form; %zu values differ from the "
      "own-load run ramped over window 0; max |u - u(load constant from step 1)| / max |u| = %.2e\n",
      pi / 1e6, long(k), long(steps), c.windows.windows, c.passes, c.maxPasses, c.windows.minPasses, ratio,
      100 * (c.statics.pc / pcRef - 1), 100 * (c.statics.hoopIn / hinRef - 1), 100 * (c.statics.hoopOut / houtRef - 1),
      diff, dFlat / umax);
  ASSERT_LT(ratio, 1e-6) << "not at rest yet";
  EXPECT_NEAR(c.statics.pc / pcRef, 1, 0.03);
  EXPECT_NEAR(c.statics.hoopIn / hinRef, 1, 0.03);
  EXPECT_NEAR(c.statics.hoopOut / houtRef, 1, 0.03);
  EXPECT_EQ(diff, 0u);
  EXPECT_GE(c.windows.minPasses, 2);
  EXPECT_EQ(c.windows.windows, steps / k);
}

// A coupled solid steps only through CoupledStepper: a plain Solver::step() (or relax()) with the
// adapter among the contributors would add a force no exchange decided, and is refused, naming the fix.
TEST(SolidCoupling, AStepOutsideTheCoupledProtocolIsRefused) {
  const Mesh mesh = linedRing(24);
  SolidInput in = ringInput();
  auto s = buildSolver(in, mesh);
  auto ad = std::make_shared<FluidCoupling>(*s, couplingInput(freshDir("outside"), "explicit", 10));
  s->addContributor(ForcePhase::Water, ad);
  try {
    s->step();
    FAIL() << "a step outside the protocol was taken";
  } catch (const CouplingError& e) {
    EXPECT_NE(std::string(e.what()).find("CoupledStepper"), std::string::npos) << e.what();
  }
}

// (d) A prescribed time-varying interface force through the coupler = the same force as the
// solid's own load (bitwise for a force constant in time), and its booked work = the solver's
// external work (the only external force besides the pulse, which is off here).
TEST(SolidCoupling, PrescribedForceMatchesOwnLoadAndItsWorkIsBooked) {
  const Mesh mesh = linedRing(24);
  const auto nodes = interfaceNodes(mesh);
  const Real p = 2e5;
  const std::vector<Real> fAll = pressureNodalForces(mesh, "lining_inner", [p](const Real*) { return p; });
  const std::vector<Real> fIf = onNodes(fAll, nodes);
  const Index steps = 200;
  const DynResult ref = dynamicRun(mesh, "explicit", false, {}, fAll, steps, false);
  const DynResult c = dynamicRun(
      mesh, "explicit", true, [&](Real) { return fIf; }, {}, steps, false);
  size_t diff = 0;
  for (size_t i = 0; i < ref.u.size(); ++i) diff += (c.u[i] != ref.u[i]) + (c.v[i] != ref.v[i]);
  std::printf(
      "prescribed pressure %.3g Pa through the coupler: %zu values differ from the own-load run; fluid work "
      "%.6e J, solver external work %.6e J (own-load run %.6e J)\n",
      p, diff, c.fluidWork, c.external, ref.external);
  EXPECT_EQ(diff, 0u);
  EXPECT_GT(c.fluidWork, 0.0);
  EXPECT_NEAR(c.external, ref.external, 1e-12 * std::abs(ref.external));
  EXPECT_NEAR(c.fluidWork, c.external, 1e-12 * std::abs(c.external));  // the only external force
}

// (e) Interface energy: the work the fluid receives, from the exchanged data, is
// the opposite of the work on the solid when the exchange is converged (implicit: the force applied
// is the fluid's answer to the motion sent), so the energy the scheme creates vanishes; the
// explicit scheme sends a prediction without the force and applies the force to another motion.
TEST(SolidCoupling, ConvergedExchangeCreatesNoInterfaceEnergy) {
  const Mesh mesh = linedRing(24);
  const auto nodes = interfaceNodes(mesh);
  const std::vector<Real> fAll = pressureNodalForces(mesh, "lining_inner", [](const Real*) { return 2e5; });
  const std::vector<Real> fIf = onNodes(fAll, nodes);
  const Index steps = 200;
  for (const char* scheme : {"implicit", "explicit"}) {
    const DynResult c = dynamicRun(
        mesh, scheme, true, [&](Real) { return fIf; }, {}, steps, false);
    std::printf("scheme %s: work on the solid %.9e J, received by the fluid %.9e J, created by the scheme %.3e J\n",
                scheme, c.fluidWork, c.fluidReceived, c.couplingEnergy);
    EXPECT_GT(c.fluidWork, 0.0) << scheme;
    EXPECT_EQ(c.couplingEnergy, c.fluidWork + c.fluidReceived) << scheme;
    if (std::string(scheme) == "implicit")
      EXPECT_LT(std::abs(c.couplingEnergy), 1e-9 * c.fluidWork);
    else  // the force does work on the difference between the motion made and the one sent
      EXPECT_GT(std::abs(c.couplingEnergy), 1e-6 * c.fluidWork);
  }
}

// (f, c) The fluid's work in implicit windows of k steps (bookReceivedWorkWindow): with a constant
// prescribed force every window after the first is converged with R = the force the solid applied,
// and the booking pairs it with the motion as the solid's own trapezoid does (lagged one step), so
// the energy the scheme creates does not change after window 0 (drift between 200 and 400 steps
// below 1e-12 of the work: round-off). Window 0 ramps from the initial force 0 to F over its k
// steps while the fluid books one trapezoid ½(0 + F)·(u^(k−1) − 0): their difference, computed here
// independently from the uncoupled run with the ramped own load, is the whole created energy
// (1e-9 relative: round-off of the sums). The solid's booked work equals the solver's external work
// of that uncoupled run (1e-12).
TEST(SolidCoupling, ImplicitWindowsBookTheFluidWorkWithoutDrift) {
  const Mesh mesh = linedRing(24);
  const auto nodes = interfaceNodes(mesh);
  const std::vector<Real> fAll = pressureNodalForces(mesh, "lining_inner", [](const Real*) { return 2e5; });
  const std::vector<Real> fIf = onNodes(fAll, nodes);
  const Index k = 4;
  // Window 0's mismatch: Σ_{j=2..k} ½(F_j + F_{j−1})·(u^{j−1} − u^{j−2}) − ½ F·u^{k−1}, F_j = (j/k) F.
  Real mismatch = 0;
  {
    auto s = buildSolver(ringInput(2.0, 1e-5), mesh);
    s->addContributor(ForcePhase::Water, std::make_shared<RampedForces>(fAll, k));
    std::vector<std::vector<Real>> u(1, std::vector<Real>(s->state().uData(), s->state().uData() + fAll.size()));
    for (Index j = 0; j < k; ++j) {
      s->step();
      u.emplace_back(s->state().uData(), s->state().uData() + fAll.size());
    }
    for (size_t i = 0; i < fAll.size(); ++i) {
      for (Index j = 2; j <= k; ++j) {
        const Real Fj = j < k ? Real(j) / Real(k) * fAll[i] : fAll[i], Fm = Real(j - 1) / Real(k) * fAll[i];
        mismatch += 0.5 * (Fj + Fm) * (u[size_t(j - 1)][i] - u[size_t(j - 2)][i]);
      }
      mismatch -= 0.5 * fAll[i] * u[size_t(k - 1)][i];
    }
  }
  Real created[2], work[2];
  for (int r = 0; r < 2; ++r) {
    const Index steps = 200 * (r + 1);
    const DynResult c = dynamicRun(
        mesh, "implicit", true, [&](Real) { return fIf; }, {}, steps, false, k);
    const DynResult own = dynamicRun(mesh, "implicit", false, {}, fAll, steps, false, 1, 2.0, k);
    std::printf(
        "implicit windows of %ld steps, constant force, %ld steps: work on the solid %.9e J (own-load run's "
        "external work %.9e J), received by the fluid %.9e J, created %.6e J; window 0's ramp mismatch "
        "%.6e J\n",
        long(k), long(steps), c.fluidWork, own.external, c.fluidReceived, c.couplingEnergy, mismatch);
    EXPECT_NEAR(c.fluidWork, own.external, 1e-12 * std::abs(own.external));
    EXPECT_NEAR(c.couplingEnergy, mismatch, 1e-9 * std::abs(c.fluidWork));
    created[r] = c.couplingEnergy;
    work[r] = c.fluidWork;
  }
  EXPECT_NEAR(created[1], created[0], 1e-12 * std::max(work[0], work[1]));
}

// (g) The energy guard (docs/coupler.md "Energy guard"). The water is a Winkler spring on every
// wetted node, R = −k u_s (u_s the displacement the fluid was sent): a conservative partner, so any
// energy the exchange shows is the scheme's. Converged implicit windows make none (|E_c| ~ round-off
// of the work), and the guard stays silent even at a limit of 1e-6. The explicit scheme applies
// each answer one window late, R^n = −k u^{n−1} = −k u^n + k Δt v: a negative damper k Δt, so the
// exchange creates energy (E_c > 0, still rising at the end; the ring's own damping keeps it at ≈ 2 %
// of the work here instead of running away). With energy_limit L the run stops with InstabilityError
// at the first window end where E_c > L × max(largest interface work so far, floor) — found here from
// the unguarded run's own series — naming the key and the window.
namespace {

struct GuardRun {
  std::vector<Real> ratio;  ///< E_c / max(peak |work|) at each window end (this test's own bookkeeping)
  Real couplingEnergy = 0, peak = 0;
  long long windows = 0;
  std::string stopped;  ///< the InstabilityError's message, empty if the run completed
};

GuardRun springRun(const std::string& scheme, Real limit, Index windows) {
  const Real k = 2e9;  // N/m per node and component
  const Mesh mesh = linedRing(24);
  auto s = buildSolver(ringInput(2.0, 1e-5), mesh);
  s->addLoad(crownPulse(mesh));
  const auto dir = freshDir("guard_" + scheme);
  CouplingInput ci = couplingInput(dir, scheme, windows);
  ci.writeFields = {"displacement"};
  ci.energyLimit = limit;
  ci.energyFloor = 1.0;  // J, 1/300 of the run's interface work: the start (E_c ≈ work ≈ 0) is not judged
  auto ad = std::make_shared<FluidCoupling>(*s, ci);
  FakeFluid fluid(ci, ad->windowSize(), mesh, interfaceNodes(mesh), [k](Real, const std::vector<Real>& u) {
    std::vector<Real> f(u.size());
    for (size_t i = 0; i < u.size(); ++i) f[i] = -k * u[i];
    return f;
  });
  ad->initialize();
  s->addContributor(ForcePhase::Water, ad);
  GuardRun out;
  CoupledStepper stepper(*s, ad.get());
  Real peak = 0;
  try {
    while (ad->ongoing())
      stepper.advance([&] {
        peak = std::max({peak, std::abs(ad->fluidWork()), std::abs(ad->fluidReceivedWork())});
        out.ratio.push_back(ad->couplingEnergy() / std::max(peak, ci.energyFloor));
      });
    ad->finalize();
  } catch (const InstabilityError& e) {
    out.stopped = e.what();
    ad->abort("test: the guard stopped the solid");
  }
  fluid.join();
  EXPECT_EQ(fluid.error(), "") << scheme;
  out.couplingEnergy = ad->couplingEnergy();
  out.peak = ad->interfaceWorkPeak();
  out.windows = ad->stats().windows;
  return out;
}

}  // namespace

TEST(SolidCoupling, EnergyGuardStopsAnExchangeThatCreatesEnergyAndOnlyThat) {
  const Index windows = 1500;
  const GuardRun implicit = springRun("implicit", 1e-6, windows);
  std::printf("implicit, spring water: %lld windows, E_c %.3e J of peak work %.6e J, stopped: '%s'\n", implicit.windows,
              implicit.couplingEnergy, implicit.peak, implicit.stopped.c_str());
  EXPECT_EQ(implicit.stopped, "");
  EXPECT_EQ(implicit.windows, windows);
  EXPECT_GT(implicit.peak, 0.0);
  EXPECT_LT(std::abs(implicit.couplingEnergy), 1e-6 * implicit.peak);

  const GuardRun free = springRun("explicit", 0, windows);
  ASSERT_EQ(free.stopped, "");
  ASSERT_EQ(free.ratio.size(), size_t(windows));
  const Real maxRatio = *std::max_element(free.ratio.begin(), free.ratio.end());
  std::printf(
      "explicit, spring water, no limit: E_c %.6e J of peak work %.6e J (ratio at the end %.4f, largest %.4f)\n",
      free.couplingEnergy, free.peak, free.ratio.back(), maxRatio);
  EXPECT_GT(free.couplingEnergy, 0.0);                              // the lag is a negative damper: energy is created
  EXPECT_GT(free.ratio.back(), free.ratio[free.ratio.size() / 2]);  // and keeps rising
  const Real limit = 0.5 * maxRatio;
  const auto first = size_t(std::find_if(free.ratio.begin(), free.ratio.end(), [&](Real r) { return r > limit; }) -
                            free.ratio.begin());
  ASSERT_LT(first, free.ratio.size());
  const GuardRun guarded = springRun("explicit", limit, windows);
  std::printf(
      "explicit with energy_limit %.4f: stopped after %lld windows (first window above it in the free run: "
      "%zu): %s\n",
      limit, guarded.windows, first, guarded.stopped.c_str());
  EXPECT_EQ(guarded.windows, (long long)first + 1);
  EXPECT_NE(guarded.stopped.find("coupling.energy_limit"), std::string::npos);
  EXPECT_NE(guarded.stopped.find("window " + std::to_string(first + 1)), std::string::npos);
}

namespace {

/// A water of pure added mass on every wetted node and component: R = −m_a a_w, a_w = (u_s − 2u_w + u_{w−1})/Δ²
/// the window-end acceleration of the motion the fluid was sent (u_w, u_{w−1}: the last two accepted
/// window-end displacements), as an incompressible water's pressure answers a wall accelerating.
struct AddedMassRun {
  std::vector<Real> crown;  ///< u_x of the inner crown node (node 0) at each window end
  std::string stopped;
  long long windows = 0, passes = 0;
  Real nodeMass = 0;                      ///< lumped mass of the inner crown node (kg)
  Real couplingEnergy = 0, workPeak = 0;  ///< E_c and the largest interface work (J) at the end
};

/// Fully converged windows (tolerance 1e-10, no reuse, constant predictor): what remains is the
/// coupled time discretization, not the iteration. A looser `tolerance` accepts residuals; `defect` > 0
/// carries that share of the unpaid defect into each next window (CouplingInput::defectCorrection).
AddedMassRun addedMassRun(Real ma, Index k, Real beta, Index steps, Real tolerance = 1e-10, Real defect = 0) {
  const Mesh mesh = linedRing(24);
  auto s = buildSolver(ringInput(2.0, 1e-5), mesh);
  s->addLoad(crownPulse(mesh, 0.04));
  const auto dir = freshDir("am");
  CouplingInput ci = couplingInput(dir, "implicit", steps / k);
  ci.windowSteps = k;
  ci.windowForceWeight = beta;
  ci.acceleration = "iqn-ils";
  ci.tolerance = tolerance;
  ci.defectCorrection = defect;
  ci.maxIterations = 30;
  auto ad = std::make_shared<FluidCoupling>(*s, ci);
  const Real window = ad->windowSize();
  struct History {
    Real t = -1;
    std::vector<Real> last, uw, uw1;
  };
  auto h = std::make_shared<History>();
  FakeFluid fluid(ci, window, mesh, interfaceNodes(mesh), [h, ma, window](Real t, const std::vector<Real>& u) {
    if (h->uw.empty()) h->last = h->uw = h->uw1 = std::vector<Real>(u.size(), 0.0);
    if (t != h->t) {  // a new window: the last motion sent in the previous one was accepted
      if (h->t >= 0) {
        h->uw1 = h->uw;
        h->uw = h->last;
      }
      h->t = t;
    }
    h->last = u;
    std::vector<Real> f(u.size());
    for (size_t i = 0; i < u.size(); ++i) f[i] = -ma * (u[i] - 2 * h->uw[i] + h->uw1[i]) / (window * window);
    return f;
  });
  ad->initialize();
  s->addContributor(ForcePhase::Water, ad);
  AddedMassRun out;
  try {
    CoupledStepper stepper(*s, ad.get());
    while (ad->ongoing()) stepper.advance([&] { out.crown.push_back(s->state().u(0, 0)); });
    ad->finalize();
  } catch (const std::exception& e) {
    out.stopped = e.what();
    ad->abort("test: stopped");
  }
  fluid.join();
  out.windows = ad->stats().windows;
  out.passes = ad->stats().passes;
  out.nodeMass = s->state().mass(0);
  out.couplingEnergy = ad->couplingEnergy();
  out.workPeak = ad->interfaceWorkPeak();
  return out;
}

}  // namespace

// (h) The window force weight (docs/coupler.md "Window force weight"). A water of pure added mass
// m_a on every wetted node (R = −m_a × the window-end acceleration of the motion sent, as above)
// through fully converged implicit windows (tolerance 1e-10). One-step windows are the monolithic
// system (m + m_a) a = f to the tolerance — the reference. Windows of 16 steps whose steps ramp the
// force linearly from the window's start to its end (β = ½, the former only choice) are unstable
// at m_a = 20,000 kg a node (107 × the crown node's 187 kg): a period-two mode grows, and the divergence
// detection stops the run (window 12; before its growth was taken over the last 8 windows, the
// velocity limit did, "exploding"), although every window is converged — the coupled time
// discretization, not the iteration, is at fault (the paper case in 3D: docs/stability.md). Leaning the steps' force
// toward the window-end force (β = ¾) damps that mode and follows the reference's crown displacement, a 40 ms pulse,
// within 5 % at every window end (measured 4.2 %; β = ½ at m_a = 5,000 kg (27×), where it is stable: 2.7 %, β = ¾ 2.5
// %: the window's coarse acceleration, not β, sets that difference).
TEST(SolidCoupling, WindowForceWeightDampsThePeriodTwoAddedMassMode) {
  const Real ma = 20000;
  const Index steps = 3200, k = 16;
  const AddedMassRun ref = addedMassRun(ma, 1, 0.5, steps);
  ASSERT_EQ(ref.stopped, "");
  ASSERT_EQ(ref.crown.size(), size_t(steps));
  const AddedMassRun ramp = addedMassRun(ma, k, 0.5, steps);
  const AddedMassRun lean = addedMassRun(ma, k, 0.75, steps);
  Real d = 0, m = 0;
  for (size_t w = 0; w < lean.crown.size(); ++w) {
    const Real r = ref.crown[(w + 1) * size_t(k) - 1];
    d = std::max(d, std::abs(lean.crown[w] - r));
    m = std::max(m, std::abs(r));
  }
  std::printf(
      "added mass %g kg a node (%.1f x the crown node's %.1f kg): one-step windows %lld passes; windows of %ld "
      "steps, beta 1/2: %lld windows, stopped: %s; beta 3/4: %lld windows, %lld passes, crown u_x within %.2f %% "
      "of the one-step run's peak %.4g mm\n",
      ma, ma / ref.nodeMass, ref.nodeMass, ref.passes, long(k), ramp.windows,
      ramp.stopped.substr(std::min(ramp.stopped.find("participant"), ramp.stopped.size()), 150).c_str(), lean.windows,
      lean.passes, 100 * d / m, 1e3 * m);
  EXPECT_NE(ramp.stopped.find("changed sign window after window"), std::string::npos) << ramp.stopped;
  EXPECT_LT(ramp.windows, steps / k);
  ASSERT_EQ(lean.stopped, "");
  ASSERT_EQ(lean.crown.size(), size_t(steps / k));
  EXPECT_LT(d / m, 0.05);
}

// (i) The water's work over a window of k steps is booked with the weights the solid's steps give
// the window's two forces, β̄ = ((k − 1) β + ½)/k (docs/coupler.md "Energy"). With fully converged
// windows (the added-mass water above, 27 × the crown node's mass), E_c is then the difference of the
// solid's per-step rule and the window's rule on this coarse 40 ms pulse (−0.73 % of the interface
// work at β = ½, measured), and leaning the force toward the window's end changes it by less than
// 0.5 % of the work (−1.08 % at β = ¾), never into created energy. Booked with the trapezoid, β = ¾
// read as +20.3 % of the work created — (β̄ − ½) Σ ΔF·Δu, energy the exchange did not create (measured
// by booking with β̄ = ½: this test then fails).
TEST(SolidCoupling, FluidWorkIsBookedWithTheWindowForceWeight) {
  const Real ma = 5000;
  const Index steps = 3200, k = 16;
  Real ratio[2] = {0, 0};
  int i = 0;
  for (const Real beta : {0.5, 0.75}) {
    const AddedMassRun r = addedMassRun(ma, k, beta, steps);
    ASSERT_EQ(r.stopped, "");
    std::printf(
        "added mass %g kg a node, windows of %ld steps, beta %.2f: E_c %.3e J of the largest interface work "
        "%.4e J (%.2e)\n",
        ma, long(k), beta, r.couplingEnergy, r.workPeak, r.couplingEnergy / r.workPeak);
    ASSERT_GT(r.workPeak, 0);
    ratio[i++] = r.couplingEnergy / r.workPeak;
  }
  EXPECT_LT(ratio[0], 0);  // the rules' difference takes energy out here
  EXPECT_LT(ratio[1], 0);  // and the lean adds none
  EXPECT_LT(std::abs(ratio[1] - ratio[0]), 5e-3);
}

namespace {

/// Quasi-static water pressure of a water-filled lined circular cavity in elastic rock under a
/// uniform far-field strain (docs/theory.md §5.3; plane strain, tension positive, p compression
/// positive). Only the in-plane mean strain ε_m = (ε_xx + ε_zz)/2 changes the cavity's area (the
/// deviatoric part, cos 2θ, leaves it unchanged), so the problem is the axisymmetric one: in each
/// ring u = A r + B/r, σ_rr = 2(λ+μ)A − 2μB/r²; the water p = −K·2u(a)/a (K = ∞: u(a) = 0); σ_rr(a) =
/// −p; u and σ_rr continuous at b; and at the rock's outer radius R the isotropic part of the
/// prescribed displacement, u(R) = ε_m R (R = ∞: A_rock = ε_m).
Real cavityWaterPressure(Real epsMean, Real K, Real El, Real nul, Real Er, Real nur, Real a, Real b, Real R) {
  const Real ml = El / (2 * (1 + nul)), ll = El * nul / ((1 + nul) * (1 - 2 * nul));
  const Real mr = Er / (2 * (1 + nur)), lr = Er * nur / ((1 + nur) * (1 - 2 * nur));
  // unknowns x = (A_l, B_l, A_r, B_r)
  Real M[4][5] = {};
  if (std::isinf(K)) {
    M[0][0] = 1, M[0][1] = 1 / (a * a);
  } else {  // 2(λl+μl)A_l − 2μl B_l/a² − 2K(A_l + B_l/a²) = 0
    M[0][0] = 2 * (ll + ml) - 2 * K, M[0][1] = -2 * ml / (a * a) - 2 * K / (a * a);
  }
  M[1][0] = b, M[1][1] = 1 / b, M[1][2] = -b, M[1][3] = -1 / b;
  M[2][0] = 2 * (ll + ml), M[2][1] = -2 * ml / (b * b), M[2][2] = -2 * (lr + mr), M[2][3] = 2 * mr / (b * b);
  if (std::isinf(R)) {
    M[3][2] = 1, M[3][4] = epsMean;
  } else {
    M[3][2] = R, M[3][3] = 1 / R, M[3][4] = epsMean * R;
  }
  for (int c = 0; c < 4; ++c) {  // Gauss–Jordan with partial pivoting
    int piv = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::abs(M[r][c]) > std::abs(M[piv][c])) piv = r;
    for (int k = 0; k < 5; ++k) std::swap(M[c][k], M[piv][k]);
    for (int r = 0; r < 4; ++r)
      if (r != c) {
        const Real f = M[r][c] / M[c][c];
        for (int k = c; k < 5; ++k) M[r][k] -= f * M[c][k];
      }
  }
  const Real Al = M[0][4] / M[0][0], Bl = M[1][4] / M[1][1];
  // p = −σ_rr(a) of the lining (= −K·2u(a)/a; the constraint's multiplier when K = ∞)
  return -(2 * (ll + ml) * Al - 2 * ml * Bl / (a * a));
}

struct CavityRun {
  Real pv = 0, pMonitor = 0, volume = 0;
  Index steps = 0;
};

/// The lined ring (bonded, elastic), its outer circle R = 20 b moved to the plane P wave's uniform
/// strain ε_zz = eps (u_z = eps z, u_x = 0: the quasi-static limit of a vertically travelling P
/// wave much longer than the tunnel), relaxed to equilibrium with the water's volume law in the
/// adapter and a fake water sending no remainder (a static load has no inertial pressure).
CavityRun cavityUnderPWave(const Mesh& mesh, const RingGeometry& G, const std::string& law, Real K, Real eps) {
  SolidInput in = ringInput(0, 0, G);
  in.fixed = {{"outer", "xyz"}, {"ymin", "y"}, {"ymax", "y"}};
  auto s = buildSolver(in, mesh);
  const auto nodes = interfaceNodes(mesh);
  CouplingInput ci;
  ci.volumeLaw = law;
  ci.bulkModulus = K;
  auto water = std::make_shared<CarriedWater>(*s, ci);  // the laws alone: no coupler, no water solver
  s->addContributor(ForcePhase::Water, water);
  for (Index n : mesh.faceNodes("outer")) s->state().u(n, 2) = eps * mesh.coords[3 * size_t(n) + 2];
  // reference force: the far-field stress on the outer circle's area
  const Real ref = G.Er * eps * 2 * M_PI * 20 * G.b;
  const RelaxResult r = s->relax(relaxParams(ref));
  EXPECT_TRUE(r.converged) << r.ratio;
  CavityRun out;
  out.pv = water->volumePressure();
  out.volume = water->enclosedVolume();
  out.steps = r.steps;
  // the total pressure on the wall node at the crown, from the force the carried water adds
  const auto& F = water->force();
  Real best = -1;
  for (size_t k = 0; k < nodes.size(); ++k) {
    const Real x = mesh.coords[3 * size_t(nodes[k])], z = mesh.coords[3 * size_t(nodes[k]) + 2];
    if (z > 0 && std::abs(x) < 1e-9 && (best < 0 || z > best)) {
      best = z;
      // the crown's area vector points +z out of the water, |A| = a quarter of each of the 4 quads
      // it corners (2 around × the two faces of the 1 m slice) = half a chord × 1 m: p = F_z / A
      const Real A = G.a * std::sin(M_PI / 48);
      out.pMonitor = F[3 * k + 2] / A;
    }
  }
  return out;
}

}  // namespace

// The water pressure of a water-filled lined cavity in rock under a slow plane P wave: the volume
// law carried by the solid (compressible K = 2.2 GPa and incompressible) against the plane-strain
// Lamé closed form (docs/theory.md §5.3), within 2 % (the tolerance; the discretisation of
// 48 × 3 lining elements and the faceted wall give ~0.3 %), for the paper's tunnel and for another:
// a 7 m bore with a 0.5 m lining of 35 GPa in rock of 20 GPa.
TEST(SolidCoupling, VolumeLawGivesTheWaterPressureOfALinedCavityUnderASlowPWave) {
  RingGeometry other;
  other.a = 3.0, other.b = 3.5, other.El = 35e9, other.nul = 0.2, other.Er = 20e9, other.nur = 0.25;
  for (const RingGeometry& G : {RingGeometry{}, other}) {
    const Mesh mesh = linedRing(48, G);
    const Real eps = 1e-4;
    Real rOut = 0;
    for (Index n : mesh.faceNodes("outer"))
      rOut = std::max(rOut, std::hypot(mesh.coords[3 * size_t(n)], mesh.coords[3 * size_t(n) + 2]));
    for (const std::string law : {"compressible", "incompressible"}) {
      const Real K = law == "compressible" ? 2.2e9 : std::numeric_limits<Real>::infinity();
      const CavityRun run = cavityUnderPWave(mesh, G, law, law == "compressible" ? K : 0.0, eps);
      const Real pRef = cavityWaterPressure(eps / 2, K, G.El, G.nul, G.Er, G.nur, G.a, G.b, rOut);
      const Real pInf =
          cavityWaterPressure(eps / 2, K, G.El, G.nul, G.Er, G.nur, G.a, G.b, std::numeric_limits<Real>::infinity());
      // The faceted 48-gon's area against the circle's: V = ½ N r² sin(2π/N) × width 1 m.
      const Real vPoly = 0.5 * 48 * G.a * G.a * std::sin(2 * M_PI / 48);
      std::printf(
          "cavity a = %.2f m, b = %.2f m under a slow P wave (eps_zz %.1e), %s water: p_v %.5g Pa, crown "
          "%.5g Pa; closed form %.5g Pa (outer radius %.1f m; infinite rock %.5g Pa): %+.3f %%; volume %.4f "
          "m^3 (48-gon %.4f); %lld relaxation steps\n",
          G.a, G.b, eps, law.c_str(), run.pv, run.pMonitor, pRef, rOut, pInf, 100 * (run.pv / pRef - 1), run.volume,
          vPoly, (long long)run.steps);
      EXPECT_NEAR(run.pv / pRef, 1, 0.02);
      EXPECT_NEAR(run.pMonitor / pRef, 1, 0.02);
      EXPECT_NEAR(run.volume / vPoly, 1, 1e-9);
    }
  }
}

namespace {

struct TubeRun {
  std::vector<Real> p;  ///< station pressures at the sample (Pa), in order of y
  Real aRadial = 0;     ///< the inner wall's mean radial acceleration there (m/s²)
  Real area = 0;        ///< the water's cross-section (m²)
  Real omega = 0;       ///< rad/s: the drive's ω
};

/// A lining tube a = 3 m, b = 3.6 m, length L along y in nAxial layers, its ends closed by `endYmin`
/// and `endYmax` (a reservoir: open, or a valve), its outer
/// face moved radially by u(t) = U (1 − cos ωt)² / 4 (at rest at t = 0, slow against the ring's own
/// breathing), the ends held axially (plane strain), water inside through the volume law of open
/// ends and a fake water sending no remainder; sampled at ωt = π/2.
TubeRun breathingOpenTube(const std::string& law, Real K, Real L, Index nAxial,
                          const std::string& endYmin = "reservoir", const std::string& endYmax = "reservoir") {
  RingSpec rs;
  rs.rInner = 3.0, rs.rOuter = 3.6, rs.nRadial = 3, rs.nAround = 32, rs.width = L, rs.nAxial = nAxial;
  Mesh mesh = makeRingSliceMesh(rs);
  mesh.faces["lining_inner"] = mesh.faces.at("inner");
  mesh.faces.erase("inner");
  SolidInput in;
  in.materials = {{"lining", elasticValues({30e9, 0.2, 2500})}};
  in.fixed = {{"outer", "xyz"}, {"ymin", "y"}, {"ymax", "y"}};
  in.tEnd = 1;
  auto s = buildSolver(in, mesh);
  const auto nodes = interfaceNodes(mesh);
  const Real omega = 2 * M_PI * 2.0, U = 1e-4, tSample = 0.5 * M_PI / omega;
  const Index steps = Index(std::ceil(tSample / s->dt()));
  CouplingInput ci;
  ci.volumeLaw = law;
  ci.bulkModulus = K;
  ci.waterDensity = 1000;
  ci.waterEnds = "open";
  ci.axialDensity = 1000;
  ci.endYmin = endYmin;
  ci.endYmax = endYmax;
  auto water = std::make_shared<CarriedWater>(*s, ci);  // the laws alone: no coupler, no water solver
  s->addContributor(ForcePhase::Water, water);
  const auto outer = mesh.faceNodes("outer");
  auto meanRadial = [&] {
    Real sum = 0;
    for (Index n : nodes) {
      const Real x = mesh.coords[3 * size_t(n)], z = mesh.coords[3 * size_t(n) + 2], r = std::hypot(x, z);
      sum += (s->state().u(n, 0) * x + s->state().u(n, 2) * z) / r;
    }
    return sum / Real(nodes.size());
  };
  TubeRun out;
  std::vector<Real> ur;
  for (Index i = 0; i < steps; ++i) {
    const Real t = s->time(), c = std::cos(omega * t), u = U * (1 - c) * (1 - c) / 4;
    for (Index n : outer) {
      const Real x = mesh.coords[3 * size_t(n)], z = mesh.coords[3 * size_t(n) + 2], r = std::hypot(x, z);
      s->state().u(n, 0) = u * x / r;
      s->state().u(n, 2) = u * z / r;
    }
    ur.push_back(meanRadial());
    s->step();
    if (i + 1 == steps) out.p = water->stationPressures();
  }
  ur.push_back(meanRadial());
  const size_t m = ur.size();  // the last step's pressure made u^{n+1}: the acceleration about u^n
  out.aRadial = (ur[m - 1] - 2 * ur[m - 2] + ur[m - 3]) / (s->dt() * s->dt());
  out.area = 0.5 * 32 * 9.0 * std::sin(2 * M_PI / 32);  // the 32-gon's
  out.omega = omega;
  return out;
}

}  // namespace

// Open ends: the water's volume law per plane of wet nodes, joined by the axial plug flow with
// p = 0 at both ends, against the long-wave closed form of a breathing open tube (docs/coupler.md
// "Open ends"): ∂²p/∂y² + k² p = ρ Ä / A (Ä the cross-section's acceleration, uniform along the
// tube; k = Ω/c for water of sound speed c answering at frequency Ω, k = 0 incompressible), p(0) =
// p(L) = 0: p(y) = (ρ Ä / (A k²)) [1 − cos k(y − L/2) / cos(kL/2)], the parabola −ρ Ä y (L − y) / (2A)
// when k → 0. At the sample ωt = π/2 the drive U (1 − cos ωt)²/4 accelerates the wall through its 2ω
// component alone (the ω part's acceleration is zero there, and so is its in-phase pressure), so
// Ω = 2ω. The lining's outer face is held on the drive: its compliance to the water's ~1 kPa is
// 1e-6 of the motion, so c is the water's own. Tolerance 2 % of the mid-length value at every
// station (the issue's; the start from rest leaves the water column's own modes ringing, measured
// ±0.5 % against the steady closed form), for incompressible water and K = 2.2 GPa, on two lengths.
TEST(SolidCoupling, OpenEndsVolumeLawGivesThePlugFlowPressureOfABreathingTube) {
  for (const auto& [L, nAx] : std::vector<std::pair<Real, Index>>{{24.0, 12}, {40.0, 10}})
    for (const std::string law : {"incompressible", "compressible"}) {
      const Real K = 2.2e9, rho = 1000;
      const TubeRun run = breathingOpenTube(law, law == "compressible" ? K : 0.0, L, nAx);
      ASSERT_EQ(run.p.size(), size_t(nAx + 1));
      const Real Add = 32 * 3.0 * std::sin(2 * M_PI / 32) * run.aRadial;  // dA/du_r of the 32-gon × ü_r
      const Real k = law == "compressible" ? 2 * run.omega / std::sqrt(K / rho) : 0.0;
      auto closedForm = [&](Real y) {
        if (k == 0) return -rho * Add * y * (L - y) / (2 * run.area);
        return rho * Add / (run.area * k * k) * (1 - std::cos(k * (y - L / 2)) / std::cos(k * L / 2));
      };
      const Real refMid = closedForm(L / 2), mid = run.p[size_t(nAx / 2)];
      Real worst = 0;
      for (size_t j = 0; j < run.p.size(); ++j)
        worst = std::max(worst, std::abs(run.p[j] - closedForm(L * Real(j) / Real(nAx))) / std::abs(refMid));
      std::printf(
          "open tube L = %.0f m (%lld layers), %s water: mid-length p %.5g Pa, closed form %.5g Pa (%+.3f %%; "
          "the incompressible parabola %.5g Pa); worst station %.3f %% of the mid value; wall acceleration "
          "%.4g m/s^2\n",
          L, (long long)nAx, law.c_str(), mid, refMid, 100 * (mid / refMid - 1), -rho * Add * L * L / (8 * run.area),
          100 * worst, run.aRadial);
      EXPECT_NEAR(mid / refMid, 1, 0.02);
      EXPECT_LT(worst, 0.02);
      EXPECT_EQ(run.p.front(), 0.0);
      EXPECT_EQ(run.p.back(), 0.0);
    }
}

// A closed valve at y = L (docs/theory.md §5.4): the end plane a station with no flow out. The same
// equation with p(0) = 0 and ∂p/∂y = 0 at L (the open tube of 2L's half, the valve its mid plane):
// p(y) = (ρ Ä / (A k²)) [1 − cos k(y − L) / cos(kL)], −ρ Ä y (2L − y) / (2A) incompressible. Tolerance
// 2 % of the valve's value at every station, as for the open tube.
TEST(SolidCoupling, ValveEndVolumeLawGivesThePlugFlowPressureOfATubeClosedAtOneEnd) {
  for (const bool valveAtYmax : {true, false})
    for (const std::string law : {"incompressible", "compressible"}) {
      const Real K = 2.2e9, rho = 1000, L = 20.0;
      const Index nAx = 10;
      const TubeRun run = valveAtYmax
                              ? breathingOpenTube(law, law == "compressible" ? K : 0.0, L, nAx, "reservoir", "valve")
                              : breathingOpenTube(law, law == "compressible" ? K : 0.0, L, nAx, "valve", "reservoir");
      ASSERT_EQ(run.p.size(), size_t(nAx + 1));
      const Real Add = 32 * 3.0 * std::sin(2 * M_PI / 32) * run.aRadial;
      const Real k = law == "compressible" ? 2 * run.omega / std::sqrt(K / rho) : 0.0;
      auto closedForm = [&](Real y) {  // y from the reservoir
        if (k == 0) return -rho * Add * y * (2 * L - y) / (2 * run.area);
        return rho * Add / (run.area * k * k) * (1 - std::cos(k * (y - L)) / std::cos(k * L));
      };
      auto fromReservoir = [&](size_t j) { return L * Real(valveAtYmax ? j : size_t(nAx) - j) / Real(nAx); };
      const Real refValve = closedForm(L), valve = valveAtYmax ? run.p.back() : run.p.front();
      Real worst = 0;
      for (size_t j = 0; j < run.p.size(); ++j)
        worst = std::max(worst, std::abs(run.p[j] - closedForm(fromReservoir(j))) / std::abs(refValve));
      std::printf(
          "tube L = %.0f m, a valve at y_%s, %s water: valve p %.5g Pa, closed form %.5g Pa (%+.3f %%); "
          "worst station %.3f %% of the valve's\n",
          L, valveAtYmax ? "max" : "min", law.c_str(), valve, refValve, 100 * (valve / refValve - 1), 100 * worst);
      EXPECT_NEAR(valve / refValve, 1, 0.02);
      EXPECT_LT(worst, 0.02);
      EXPECT_EQ(valveAtYmax ? run.p.front() : run.p.back(), 0.0);
    }
}

// (j) Defect correction (docs/coupler.md "Defect correction"). The added-mass water above (27 × the
// crown node's mass), windows of 16 steps at β = ¾, accepted at a loose tolerance: each accepted
// residual e = F̃ − R makes (1 − β̄) e_w + β̄ e of energy over its window; carried whole (α = 1) as −e
// into the next window's steps, what is left is β̄ Σ e_w·(Δu_{w+1} − Δu_w); with α = ¼ a quarter of
// the unpaid defect a window. The reference is the same run converged to 1e-10 (its E_c, −1.08 % of
// the interface work, is the windows' rule against the steps', not the exchange: test (i)).
// Measured, E_c beyond the reference's, without → α = 1 → α = ¼: 1e-3 2.2e-4 → 1.6e-5 → 1.2e-5;
// 3e-3 1.6e-3 → 8.7e-5 → 2.7e-4; 1e-2 3.9e-3 → 7.2e-5 → 3.2e-4; the crown's largest difference
// 9.9e-6 → 2.1e-6 → 6.0e-6, 4.9e-5 → 8.8e-6 → 2.5e-5, 8.3e-5 → 1.6e-5 → 5.6e-5; the passes
// 1,002 → 1,055 → 1,014, 911 → 962 → 926, 826 → 861 → 845. At 3e-2 the residuals are not small
// against the window's change and α = 1 gains no energy (−7.5e-4 → −8.5e-4; the crown 2.0×): not
// asserted.
TEST(SolidCoupling, DefectCorrectionKeepsALooseToleranceFromCreatingEnergy) {
  const Real ma = 5000;
  const Index steps = 3200, k = 16;
  const AddedMassRun ref = addedMassRun(ma, k, 0.75, steps);
  ASSERT_EQ(ref.stopped, "");
  for (const Real tol : {1e-3, 3e-3, 1e-2}) {
    Real energy[3], crown[3];
    long long passes[3];
    const Real alphas[3] = {0, 1, 0.25};
    for (const int defect : {0, 1, 2}) {
      const AddedMassRun r = addedMassRun(ma, k, 0.75, steps, tol, alphas[defect]);
      ASSERT_EQ(r.stopped, "");
      ASSERT_EQ(r.crown.size(), ref.crown.size());
      Real d = 0, m = 0;
      for (size_t w = 0; w < ref.crown.size(); ++w) {
        d = std::max(d, std::abs(r.crown[w] - ref.crown[w]));
        m = std::max(m, std::abs(ref.crown[w]));
      }
      energy[defect] = std::abs(r.couplingEnergy - ref.couplingEnergy) / ref.workPeak;
      crown[defect] = d / m;
      passes[defect] = r.passes;
    }
    std::printf(
        "tolerance %g: E_c beyond the converged run's, of the interface work, %.3e without the defect correction, "
        "%.3e with alpha 1, %.3e with 1/4; the crown's largest difference %.3e, %.3e, %.3e; passes %lld, %lld, %lld "
        "(converged: %lld)\n",
        tol, energy[0], energy[1], energy[2], crown[0], crown[1], crown[2], passes[0], passes[1], passes[2],
        ref.passes);
    EXPECT_LT(energy[1], 0.1 * energy[0]) << tol;
    EXPECT_LT(energy[1], 1e-4) << tol;
    EXPECT_LT(crown[1], 0.3 * crown[0]) << tol;
    EXPECT_LT(double(passes[1]), 1.1 * double(passes[0])) << tol;
    EXPECT_LT(energy[2], 0.2 * energy[0]) << tol;  // a quarter a window: less gained, fewer passes spent
    EXPECT_LT(crown[2], 0.8 * crown[0]) << tol;
    EXPECT_LT(double(passes[2]), 1.05 * double(passes[0])) << tol;
  }
}
