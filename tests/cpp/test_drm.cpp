// The domain reduction method (tq/boundaries/drm.hpp): a box of homogeneous ground with a free top
// surface, a one-element DRM layer on its sides and bottom, one element of ground outside it and the
// viscoelastic boundaries (SeismicBoundaries with no input motion: dashpots and the base springs)
// around that. The layer is driven by the closed-form free field of a plane P, SV or SH wave of any
// incidence and azimuth in a homogeneous half-space: the incident wave plus the reflected P and S
// waves whose amplitudes make the surface traction-free (solved here from σ_iz = 0, the 2×2 system of
// Aki & Richards 2002 §5.2.4, without their sign conventions).
//
// Bielak et al. (2003): inside the layer the model's motion is the free field; outside it (the
// layer's outer nodes and beyond) only the field scattered by what is inside remains: nothing here.
#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "input_fixture.hpp"
#include "test_helpers.hpp"
#include "tq/app/app.hpp"
#include "tq/boundaries/boundaries.hpp"
#include "tq/boundaries/drm.hpp"
#include "tq/io/mesh.hpp"
#include "tq/materials/material_mc.hpp"

using namespace tq;
namespace K = tq::input_schema::key;

namespace {

constexpr Real kPi = 3.14159265358979323846;
constexpr Real kRho = 2000, kCs = 200, kNu = 0.25;
const Real kG = kRho * kCs * kCs, kE = 2 * kG * (1 + kNu), kLam = 2 * kG * kNu / (1 - 2 * kNu),
           kCp = std::sqrt((kLam + 2 * kG) / kRho);

/// Ricker wavelet f(τ) = U (1 − 2a²) e^{−a²}, a = π fc (τ − t0), and its first two derivatives.
struct Ricker {
  Real U = 1e-3, fc = 5, t0 = 1.5 / 5;
  void eval(Real tau, Real out[3]) const {
    const Real a = kPi * fc * (tau - t0), g = std::exp(-a * a), w = kPi * fc;
    out[0] = U * (1 - 2 * a * a) * g;
    out[1] = U * w * (4 * a * a * a - 6 * a) * g;
    out[2] = U * w * w * (-8 * a * a * a * a + 24 * a * a - 6) * g;
  }
};

/// A plane wave and its reflections at the free surface z = zs of a homogeneous half-space.
struct HalfSpaceField {
  struct Wave {
    Real s[3], d[3], A;  // slowness (s/m), unit polarization, amplitude
  };
  std::vector<Wave> waves;
  Real ref[3] = {0, 0, 0};
  Real shift = 0;  // τ = t − shift − s·(x − ref): every wave is still at rest at t = 0 in the box
  Ricker f;

  /// kind "P", "SV" or "SH"; theta from the vertical, phi the azimuth from x (degrees).
  HalfSpaceField(const std::string& kind, Real thetaDeg, Real phiDeg, Real zs, const Real lo[3], const Real hi[3]) {
    const Real th = thetaDeg * kPi / 180, ph = phiDeg * kPi / 180;
    const Real h[3] = {std::cos(ph), std::sin(ph), 0}, hp[3] = {-std::sin(ph), std::cos(ph), 0};
    const Real cInc = kind == "P" ? kCp : kCs, p = std::sin(th) / cInc;
    auto make = [&](Real c, Real sinA, bool up, int pol) {  // pol 0 P, 1 SV, 2 SH
      const Real cosA = std::sqrt(1 - sinA * sinA), vz = up ? cosA : -cosA;
      Wave w{};
      for (int i = 0; i < 3; ++i) {
        const Real k = sinA * h[i] + (i == 2 ? vz : 0);
        w.s[i] = k / c;
        // P along k; SV in the vertical plane, perpendicular to k (cos h − sin ez upwards,
        // cos h + sin ez downwards); SH horizontal, across the plane.
        w.d[i] = pol == 0 ? k : pol == 1 ? cosA * h[i] + (i == 2 ? (up ? -sinA : sinA) : 0) : hp[i];
      }
      w.A = 1;
      return w;
    };
    if (kind == "SH") {
      waves = {make(kCs, kCs * p, true, 2), make(kCs, kCs * p, false, 2)};
    } else {
      waves = {make(cInc, cInc * p, true, kind == "P" ? 0 : 1), make(kCp, kCp * p, false, 0),
               make(kCs, kCs * p, false, 1)};
      // Traction-free surface: Σ A_w [μ(d_h s_z + d_z s_h), λ d·s + 2μ d_z s_z] = 0, A_inc = 1.
      Real m[3][2];
      for (int w = 0; w < 3; ++w) {
        const Wave& W = waves[size_t(w)];
        const Real dh = W.d[0] * h[0] + W.d[1] * h[1], sh = W.s[0] * h[0] + W.s[1] * h[1];
        const Real ds = W.d[0] * W.s[0] + W.d[1] * W.s[1] + W.d[2] * W.s[2];
        m[w][0] = kG * (dh * W.s[2] + W.d[2] * sh);
        m[w][1] = kLam * ds + 2 * kG * W.d[2] * W.s[2];
      }
      const Real det = m[1][0] * m[2][1] - m[2][0] * m[1][1];
      waves[1].A = (-m[0][0] * m[2][1] + m[2][0] * m[0][1]) / det;
      waves[2].A = (-m[1][0] * m[0][1] + m[0][0] * m[1][1]) / det;
    }
    ref[0] = 0.5 * (lo[0] + hi[0]);
    ref[1] = 0.5 * (lo[1] + hi[1]);
    ref[2] = zs;
    shift = 0;
    for (const Wave& w : waves)
      for (int c = 0; c < 8; ++c) {
        const Real x[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]};
        Real sx = 0;
        for (int i = 0; i < 3; ++i) sx += w.s[i] * (x[i] - ref[i]);
        shift = std::min(shift, sx);
      }
  }
  /// u, v, a (each [3]) at x, t; with incidentOnly the incident wave alone.
  void at(const Real x[3], Real t, Real* u, Real* v, Real* a, bool incidentOnly = false) const {
    for (int i = 0; i < 3; ++i) u[i] = v[i] = a[i] = 0;
    for (size_t k = 0; k < (incidentOnly ? 1 : waves.size()); ++k) {
      const Wave& w = waves[k];
      Real sx = 0, F[3];
      for (int i = 0; i < 3; ++i) sx += w.s[i] * (x[i] - ref[i]);
      f.eval(t + shift - sx, F);
      for (int i = 0; i < 3; ++i) {
        u[i] += w.A * w.d[i] * F[0];
        v[i] += w.A * w.d[i] * F[1];
        a[i] += w.A * w.d[i] * F[2];
      }
    }
  }
};

struct DrmCase {
  const char* kind;
  Real theta, phi;
};
std::ostream& operator<<(std::ostream& os, const DrmCase& c) {
  return os << c.kind << "_" << int(c.theta) << "_" << int(c.phi);
}

/// The box: nOut elements of ground outside a one-element layer on each side and below an inner
/// region nIn × nIn × nInZ, element size h; the top is free.
struct DrmBox {
  Index nOut = 1, nIn = 12, nInZ = 12;
  Real h = 1.0;
  Mesh mesh;
  BoxSpec spec;
  Real bLo[3], bHi[3];             // the inner region (closed), its boundary the b nodes
  std::vector<std::uint8_t> kind;  // per node: 0 inside (closed inner region), 1 e, 2 beyond
  DrmFreeField field;

  explicit DrmBox(Real hh, Index nin, Index ninz) : nIn(nin), nInZ(ninz), h(hh) {
    const Index n = 2 * (nOut + 1) + nIn;
    spec.nx = spec.ny = n;
    spec.nz = nOut + 1 + nInZ;
    spec.lx = spec.ly = n * h;
    spec.lz = spec.nz * h;
    mesh = makeBoxMesh(spec);
    for (int i = 0; i < 2; ++i) {
      bLo[i] = (nOut + 1) * h;
      bHi[i] = (nOut + 1 + nIn) * h;
    }
    bLo[2] = (nOut + 1) * h;
    bHi[2] = spec.lz;
    const Real tol = 1e-6 * h;
    kind.assign(size_t(mesh.numNodes()), 2);
    for (Index k = 0; k < mesh.numNodes(); ++k) {
      const Real* x = &mesh.coords[3 * size_t(k)];
      bool inside = true, onB = false, inOuter = true;
      for (int i = 0; i < 3; ++i) {
        inside = inside && x[i] > bLo[i] - tol && x[i] < bHi[i] + tol;
        inOuter = inOuter && x[i] > bLo[i] - h - tol && x[i] < bHi[i] + (i == 2 ? 0 : h) + tol;
        onB = onB || std::abs(x[i] - bLo[i]) < tol || (i < 2 && std::abs(x[i] - bHi[i]) < tol);
      }
      if (inside) {
        kind[size_t(k)] = 0;
        if (onB) {
          field.nodes.push_back(k);
          field.internal.push_back(1);
        }
      } else if (inOuter) {
        kind[size_t(k)] = 1;
        field.nodes.push_back(k);
        field.internal.push_back(0);
      }
    }
  }
  void sampleField(const HalfSpaceField& ff, Real dtRecord, Real tEnd) {
    const size_t N = field.nodes.size();
    field.time.clear();
    field.u.clear();
    field.v.clear();
    field.a.clear();
    for (Index k = 0; k * dtRecord <= tEnd + 1e-12; ++k) {
      const Real t = k * dtRecord;
      field.time.push_back(t);
      for (size_t i = 0; i < N; ++i) {
        Real u[3], v[3], a[3];
        ff.at(&mesh.coords[3 * size_t(field.nodes[i])], t, u, v, a);
        field.u.insert(field.u.end(), u, u + 3);
        field.v.insert(field.v.end(), v, v + 3);
        field.a.insert(field.a.end(), a, a + 3);
      }
    }
  }
};

struct DrmRun {
  Real insideL2 = 0;     // worst node: ‖u − u0‖₂ / ‖u0‖₂ over the record
  Real outsideMax = 0;   // worst node beyond the inner region: ‖u‖₂ / ‖incident‖₂
  Real outsidePeak = 0;  // max |u| there / incident peak
  Real secondsPerStep = 0, secondsPerStepNoDrm = 0;
  Index steps = 0, layerElems = 0;
};

DrmRun runBox(DrmBox& box, const HalfSpaceField& ff, Real tEnd, bool timeWithout = false) {
  box.sampleField(ff, 2e-3, tEnd);
  SeismicBoundarySpec spec;
  spec.bottom = true;
  spec.distance = 50 * box.h * box.nIn;  // springs K = αG/R: soft, far-away ground
  spec.halfSpace = {kRho, kCp, kCs};
  spec.freeFieldFaces = {"xmin", "xmax", "ymin", "ymax"};
  auto makeSolver = [&](bool withDrm, DrmRun& r) {
    auto s = std::make_unique<Solver>(
        box.mesh, makeBlocksByRegion(box.mesh, {{"rock", tqtest::elastic(kE, kNu, kRho)}}), SolverOptions{});
    auto sb = std::make_shared<SeismicBoundaries>(box.mesh, s->blocks(), spec, IncidentMotion(), false);
    sb->install(s->state());
    s->addContributor(ForcePhase::Boundaries, sb);
    if (withDrm) {
      auto drm = std::make_shared<DomainReduction>(box.mesh, s->blocks(), box.field, 0.0);
      r.layerElems = drm->numLayerElements();
      s->addContributor(ForcePhase::Boundaries, drm);
    }
    return s;
  };
  DrmRun r;
  auto s = makeSolver(true, r);
  const Index N = box.mesh.numNodes();
  std::vector<Real> errSq(size_t(N), 0), refSq(size_t(N), 0), uSq(size_t(N), 0);
  Real incSq = 0, incPeak = 0, outPeak = 0;
  const Real probe[3] = {box.bLo[0], box.bLo[1], box.bLo[2]};
  const auto t0 = std::chrono::steady_clock::now();
  while (s->time() < tEnd) {
    s->step();
    ++r.steps;
    const Real t = s->time();
    Real u0[3], v0[3], a0[3];
    ff.at(probe, t, u0, v0, a0, true);
    const Real inc2 = u0[0] * u0[0] + u0[1] * u0[1] + u0[2] * u0[2];
    incSq += inc2;
    incPeak = std::max(incPeak, std::sqrt(inc2));
    for (Index k = 0; k < N; ++k) {
      const Real* x = &box.mesh.coords[3 * size_t(k)];
      Real e2 = 0, r2 = 0, m2 = 0;
      if (box.kind[size_t(k)] == 0) {
        ff.at(x, t, u0, v0, a0);
        for (int d = 0; d < 3; ++d) {
          const Real u = s->state().u(k, d);
          e2 += (u - u0[d]) * (u - u0[d]);
          r2 += u0[d] * u0[d];
        }
        errSq[size_t(k)] += e2;
        refSq[size_t(k)] += r2;
      } else {
        for (int d = 0; d < 3; ++d) m2 += s->state().u(k, d) * s->state().u(k, d);
        uSq[size_t(k)] += m2;
        outPeak = std::max(outPeak, std::sqrt(m2));
      }
    }
  }
  for (Index k = 0; k < N; ++k) {
    if (box.kind[size_t(k)] == 0)
      r.insideL2 = std::max(r.insideL2, std::sqrt(errSq[size_t(k)] / refSq[size_t(k)]));
    else
      r.outsideMax = std::max(r.outsideMax, std::sqrt(uSq[size_t(k)] / incSq));
  }
  r.outsidePeak = outPeak / incPeak;
  (void)t0;
  if (timeWithout) {
    // Cost: the same steps with and without the layer's forces (no comparison work in the loop).
    DrmRun dummy;
    for (int withDrm = 1; withDrm >= 0; --withDrm) {
      auto sv = makeSolver(withDrm == 1, dummy);
      const auto a = std::chrono::steady_clock::now();
      for (Index k = 0; k < r.steps; ++k) sv->step();
      const Real sec = std::chrono::duration<Real>(std::chrono::steady_clock::now() - a).count() / Real(r.steps);
      (withDrm ? r.secondsPerStep : r.secondsPerStepNoDrm) = sec;
    }
  }
  return r;
}

class DrmPlaneWave : public ::testing::TestWithParam<DrmCase> {};

/// The free field `D` written as the /drm group of the solver input `path` (the layout
/// drm_input.write_drm_group writes from Python).
void writeDrmGroup(const std::string& path, const DrmFreeField& D) {
  auto f = h5::openFile(path, true);
  auto g = h5::ensureGroup(f, "/drm");
  h5::writeInts(g, K::drm::nodes.name, D.nodes.data(), {D.nodes.size()});
  const std::vector<Index> flags(D.internal.begin(), D.internal.end());
  h5::writeInts(g, K::drm::internal.name, flags.data(), {flags.size()});
  h5::writeDoubles(g, K::drm::time.name, D.time.data(), {D.time.size()});
  const std::vector<hsize_t> dims = {D.time.size(), D.nodes.size(), 3};
  h5::writeDoubles(g, K::drm::u.name, D.u.data(), dims);
  h5::writeDoubles(g, K::drm::v.name, D.v.data(), dims);
  h5::writeDoubles(g, K::drm::a.name, D.a.data(), dims);
}

}  // namespace

// Inside the layer the motion is the free field within 1 % (L2 over the record, worst node);
// outside it the scattered field is under 2 % of the incident wave (L2, worst node).
TEST_P(DrmPlaneWave, FreeFieldInsideNothingOutside) {
  const DrmCase c = GetParam();
  DrmBox box(1.0, 12, 12);
  const Real lo[3] = {0, 0, 0}, hi[3] = {box.spec.lx, box.spec.ly, box.spec.lz};
  HalfSpaceField ff(c.kind, c.theta, c.phi, box.spec.lz, lo, hi);
  const DrmRun r = runBox(box, ff, 1.0);
  std::printf(
      "DRM %s θ=%g° φ=%g°: %d steps, %d layer elements of %d; inside max ‖u−u0‖/‖u0‖ %.2e; outside max "
      "‖u‖/‖u_inc‖ %.2e, peak %.2e\n",
      c.kind, c.theta, c.phi, int(r.steps), int(r.layerElems), int(box.mesh.numElems()), r.insideL2, r.outsideMax,
      r.outsidePeak);
  EXPECT_LT(r.insideL2, 0.01);
  EXPECT_LT(r.outsideMax, 0.02);
}

INSTANTIATE_TEST_SUITE_P(HomogeneousHalfSpace, DrmPlaneWave,
                         ::testing::Values(DrmCase{"SV", 0, 0}, DrmCase{"P", 0, 0}, DrmCase{"SH", 0, 0},
                                           DrmCase{"SV", 30, 0}, DrmCase{"SV", 30, 45}),
                         [](const auto& info) {
                           std::ostringstream os;
                           os << info.param;
                           return os.str();
                         });

// A DRM layer that reaches into a nonlinear (Mohr–Coulomb) region is refused when the layer is
// built, naming the element, the block and the fix; with an elastic material there it is accepted.
TEST(DrmLayer, NonlinearMaterialInTheLayerIsRefused) {
  DrmBox box(1.0, 4, 4);
  box.field.time = {0.0, 1.0};
  box.field.u.assign(2 * 3 * box.field.nodes.size(), 0.0);
  box.field.v = box.field.a = box.field.u;
  tq::MohrCoulombDamageParams mc;
  mc.elastic = {kE, kNu, kRho};
  mc.cohesion = 1e6;
  mc.frictionAngle = 35;
  mc.tensileStrength = 1e6;
  const auto nonlinear = std::make_shared<MohrCoulombDamageMaterial>(mc);
  Solver bad(box.mesh, makeBlocksByRegion(box.mesh, {{"rock", nonlinear}}), SolverOptions{});
  try {
    DomainReduction drm(box.mesh, bad.blocks(), box.field, 0.0);
    FAIL() << "a Mohr-Coulomb layer was accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("block 'rock'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("mohr_coulomb_damage"), std::string::npos) << msg;
    EXPECT_NE(msg.find("linear elastic"), std::string::npos) << msg;
  }
  Solver good(box.mesh, makeBlocksByRegion(box.mesh, {{"rock", tqtest::elastic(kE, kNu, kRho)}}), SolverOptions{});
  const DomainReduction drm(box.mesh, good.blocks(), box.field, 0.0);
  // 4 × 4 inner columns of 4 elements: the layer is the 6 × 6 ring around them, 5 deep, less the
  // 4 × 4 inside, plus the 6 × 6 slab below: 20 × 4 + 36 = 116 elements.
  EXPECT_EQ(drm.numLayerElements(), 20 * 4 + 36);
}

// Refused free fields: a node that is not in the mesh, flags without inner nodes, samples out of order.
TEST(DrmLayer, UnusableFreeFieldIsRefused) {
  DrmBox box(1.0, 4, 4);
  DrmFreeField f = box.field;
  f.time = {0.0, 1.0};
  f.u.assign(2 * 3 * f.nodes.size(), 0.0);
  f.v = f.a = f.u;
  EXPECT_NO_THROW(checkDrmFreeField(f, box.mesh.numNodes()));
  DrmFreeField g = f;
  g.nodes[0] = box.mesh.numNodes();
  EXPECT_THROW(checkDrmFreeField(g, box.mesh.numNodes()), InputError);
  g = f;
  std::fill(g.internal.begin(), g.internal.end(), std::uint8_t(0));
  EXPECT_THROW(checkDrmFreeField(g, box.mesh.numNodes()), InputError);
  g = f;
  g.time = {1.0, 0.0};
  EXPECT_THROW(checkDrmFreeField(g, box.mesh.numNodes()), InputError);
}

// The layer's forces against each layer element's own forces, formed here from the element kernel
// (ElementBlock::elementForces at the free field placed on the element's outer corners alone, then on
// its inner corners alone): P_b = −K_be w_e, P_e = +K_eb w_b, w = u0 + β u̇0 interpolated in time
// (docs/theory.md §6.2). The box's nodes are moved at random so that no two layer elements are alike.
// A sequence of times as a run visits them: with a step finer than the samples the layer forms its
// product at the samples and interpolates the forces (two products at the first time, one when a
// sample is new, none otherwise, and one for a sample held past the end or before the start), with a
// step coarser than them the product of the interpolated field (one a call). Tolerance 1e-12 of the
// largest force (round-off of sums of a few dozen terms). The forces are summed node by node, so they
// are bit for bit the same on 1, 2 and 3 threads.
TEST(DrmLayer, ForcesEqualTheElementsOwnForAnyThreadCount) {
  DrmBox box(1.0, 8, 8);
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> U(-1, 1);
  for (Real& x : box.mesh.coords) x += 0.15 * U(rng);
  const size_t N = box.field.nodes.size();
  ASSERT_GE(N, 512u);  // large enough for the threaded path
  const Real beta = 2e-3;
  box.field.time = {0.0, 0.2, 0.7, 1.0};
  const size_t T = box.field.time.size();
  for (auto* arr : {&box.field.u, &box.field.v, &box.field.a}) {
    arr->resize(T * 3 * N);
    for (Real& x : *arr) x = 1e-3 * U(rng);
  }
  Solver s(box.mesh, makeBlocksByRegion(box.mesh, {{"rock", tqtest::elastic(kE, kNu, kRho)}}), SolverOptions{});

  // The reference at time t, element by element.
  const Index nn = box.mesh.numNodes();
  std::vector<std::int8_t> side(size_t(nn), -1);  // 1 inner, 0 outer, −1 not a layer node
  for (size_t i = 0; i < N; ++i) side[size_t(box.field.nodes[i])] = std::int8_t(box.field.internal[i]);
  Index layer = 0;
  auto reference = [&](Real t) {
    const auto& tt = box.field.time;
    size_t k = 0;
    Real a = 0;
    if (t >= tt.back()) {
      k = T - 2, a = 1;
    } else if (t > tt.front()) {
      while (tt[k + 1] <= t) ++k;
      a = (t - tt[k]) / (tt[k + 1] - tt[k]);
    }
    std::vector<Real> w(3 * size_t(nn), 0.0);
    for (size_t i = 0; i < N; ++i)
      for (int d = 0; d < 3; ++d) {
        const size_t k1 = (k * N + i) * 3 + size_t(d), k2 = ((k + 1) * N + i) * 3 + size_t(d);
        w[3 * size_t(box.field.nodes[i]) + size_t(d)] =
            (1 - a) * box.field.u[k1] + a * box.field.u[k2] + beta * ((1 - a) * box.field.v[k1] + a * box.field.v[k2]);
      }
    std::vector<Real> ref(3 * size_t(nn), 0.0), probe(3 * size_t(nn), 0.0);
    layer = 0;
    for (const auto& b : s.blocks())
      for (Index e = 0; e < b->numElems(); ++e) {
        int inner = 0, outer = 0;
        for (int k8 = 0; k8 < 8; ++k8) {
          const int sd = side[size_t(b->node(e, k8))];
          inner += sd == 1;
          outer += sd == 0;
        }
        if (inner + outer < 8 || inner == 0 || outer == 0) continue;
        ++layer;
        Real f0[24], f[24];
        b->elementForces(e, probe.data(), f0);
        for (int from = 0; from < 2; ++from) {  // from the outer corners' w onto the inner ones, then back
          for (int k8 = 0; k8 < 8; ++k8) {
            const Index n = b->node(e, k8);
            for (int d = 0; d < 3; ++d)
              probe[3 * size_t(n) + size_t(d)] = side[size_t(n)] == from ? w[3 * size_t(n) + size_t(d)] : 0.0;
          }
          b->elementForces(e, probe.data(), f);
          for (int k8 = 0; k8 < 8; ++k8) {
            const Index n = b->node(e, k8);
            if (side[size_t(n)] == from) continue;
            for (int d = 0; d < 3; ++d)
              ref[3 * size_t(n) + size_t(d)] += (from == 0 ? -1.0 : 1.0) * (f[3 * k8 + d] - f0[3 * k8 + d]);
          }
          for (int k8 = 0; k8 < 8; ++k8)
            for (int d = 0; d < 3; ++d) probe[3 * size_t(b->node(e, k8)) + size_t(d)] = 0.0;
        }
      }
    return ref;
  };
  // (t, Δt, the products formed so far after the call)
  struct Call {
    Real t, dt;
    Index products;
  };
  const Call calls[] = {
      {0.3, 1e-4, 2},   // samples 1 and 2
      {0.35, 1e-4, 2},  // both kept
      {0.8, 1e-4, 3},   // sample 2 kept, 3 new
      {1.2, 1e-4, 3},   // past the end: sample 3 held
      {0.0, 1e-4, 4},   // the start: sample 0 alone
      {0.1, 0.4, 5},    // a step coarser than the samples: the interpolated field's product
      {0.05, 0.4, 6},   //   (also where a sample is kept: 0)
  };
  std::vector<std::vector<Real>> refs;
  std::vector<Real> bigs;
  for (const Call& c : calls) {
    refs.push_back(reference(c.t));
    Real big = 0;
    for (Real x : refs.back()) big = std::max(big, std::abs(x));
    ASSERT_GT(big, 0.0);
    bigs.push_back(big);
  }

  const int threads0 = omp_get_max_threads();
  std::vector<std::vector<Real>> first;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    DomainReduction drm(box.mesh, s.blocks(), box.field, beta);
    EXPECT_GT(drm.numDistinctCouplings(), drm.numLayerElements() / 2);
    ASSERT_EQ(layer, drm.numLayerElements());
    for (size_t c = 0; c < std::size(calls); ++c) {
      Real* fe = s.state().fExtData();
      std::fill(fe, fe + 3 * size_t(nn), 0.0);
      drm.addForces(calls[c].t, calls[c].dt, s.state());
      std::vector<Real> got(fe, fe + 3 * size_t(nn));
      Real err = 0;
      for (size_t i = 0; i < got.size(); ++i) err = std::max(err, std::abs(got[i] - refs[c][i]));
      std::printf(
          "DRM layer forces, %d thread(s), t = %g s, dt = %g s: %d layer elements, %d distinct couplings, %d "
          "products; largest difference from the elements' own forces %.2e of the largest force\n",
          threads, calls[c].t, calls[c].dt, int(drm.numLayerElements()), int(drm.numDistinctCouplings()),
          int(drm.numProducts()), err / bigs[c]);
      EXPECT_LT(err, 1e-12 * bigs[c]) << threads << " thread(s), t = " << calls[c].t;
      EXPECT_EQ(drm.numProducts(), calls[c].products) << "t = " << calls[c].t;
      if (first.size() <= c)
        first.push_back(got);
      else
        EXPECT_TRUE(got == first[c]) << threads << " threads differ from one, t = " << calls[c].t;
    }
  }
  omp_set_num_threads(threads0);
}

// The same through tq-solid: solid_input.h5 with /drm (the free field of SV at 30°, azimuth 30°, at
// the layer's nodes, sampled every 2 ms), /boundaries (viscoelastic base, free-field sides, no
// /motion), only the seismic stage; the monitors in results.h5 against the closed form.
TEST(DrmLayer, TqSolidReadsTheFreeFieldFromSolidInput) {
  const auto dir = std::filesystem::temp_directory_path() / ("tq_drm_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  DrmBox box(1.0, 12, 12);
  const Real lo[3] = {0, 0, 0}, hi[3] = {box.spec.lx, box.spec.ly, box.spec.lz};
  HalfSpaceField ff("SV", 30, 30, box.spec.lz, lo, hi);
  const Real tEnd = 1.0;
  box.sampleField(ff, 2e-3, tEnd);
  writeMeshH5(box.mesh, (dir / "mesh.h5").string());
  SolidInput in;
  in.tEnd = tEnd;
  in.materials = {{"rock", elasticValues({kE, kNu, kRho})}};
  in.monitorDt = 2e-3;
  in.progressSeconds = 100;
  in.ringForces = false;
  // Inside: the surface centre and a node on the inner boundary b; outside: beyond the layer.
  const Real c = 0.5 * box.spec.lx;
  in.monitors = {{"surface", {c, c, box.spec.lz}}, {"b", {box.bLo[0], c, 6.0}}, {"outside", {0.0, c, 6.0}}};
  in.staged.present = true;
  in.staged.stages.sequence = {"seismic"};
  in.staged.bottom.present = true;
  in.staged.bottom.face = "bottom";
  in.staged.bottom.distance = 600;
  in.staged.freeField.present = true;
  in.staged.freeField.faces = {"xmin", "xmax", "ymin", "ymax"};
  test::writeInputFile(in, (dir / "solid_input.h5").string(), "mesh.h5");
  writeDrmGroup((dir / "solid_input.h5").string(), box.field);
  std::ostringstream out, err;
  const int rc =
      runSolid({(dir / "solid_input.h5").string(), "-o", (dir / "results.h5").string(), "--threads", "1"}, out, err);
  ASSERT_EQ(rc, 0) << err.str() << out.str();
  EXPECT_NE(out.str().find("domain reduction layer: 820 elements"), std::string::npos) << out.str();
  auto r = h5::openFile((dir / "results.h5").string());
  Real incSq = 0;
  for (const char* name : {"surface", "b", "outside"}) {
    std::vector<hsize_t> d;
    const auto t = h5::readDoubles(r, std::string("/monitors/") + name + "/time");
    const auto u = h5::readDoubles(r, std::string("/monitors/") + name + "/u", &d);
    const Real x[3] = {h5::readDoubleAttr(h5::openGroup(r, std::string("/monitors/") + name), "x"),
                       h5::readDoubleAttr(h5::openGroup(r, std::string("/monitors/") + name), "y"),
                       h5::readDoubleAttr(h5::openGroup(r, std::string("/monitors/") + name), "z")};
    Real eSq = 0, rSq = 0, mSq = 0;
    for (size_t k = 0; k < d[0]; ++k) {
      Real u0[3], v0[3], a0[3], ui[3];
      ff.at(x, t[k], u0, v0, a0);
      ff.at(x, t[k], ui, v0, a0, true);
      for (int i = 0; i < 3; ++i) {
        eSq += std::pow(u[3 * k + size_t(i)] - u0[i], 2);
        rSq += u0[i] * u0[i];
        mSq += u[3 * k + size_t(i)] * u[3 * k + size_t(i)];
        if (std::string(name) == "surface") incSq += ui[i] * ui[i];
      }
    }
    if (std::string(name) == "outside") {
      std::printf("tq-solid with /drm, SV 30°/30°: outside the layer ‖u‖/‖u_inc‖ %.2e\n", std::sqrt(mSq / incSq));
      EXPECT_LT(std::sqrt(mSq / incSq), 0.02);
    } else {
      std::printf("tq-solid with /drm, SV 30°/30°: %s ‖u − u0‖/‖u0‖ %.2e (%zu samples)\n", name, std::sqrt(eSq / rSq),
                  size_t(d[0]));
      EXPECT_LT(std::sqrt(eSq / rSq), 0.01);
    }
  }
  // The same input with a Mohr–Coulomb rock: `tq-solid --check` refuses it before anything runs.
  MohrCoulombDamageParams mc;
  mc.elastic = {kE, kNu, kRho};
  mc.cohesion = 1e6;
  mc.frictionAngle = 35;
  mc.tensileStrength = 1e6;
  in.materials = {{"rock", mohrCoulombDamageValues(mc)}};
  test::writeInputFile(in, (dir / "nonlinear.h5").string(), "mesh.h5");
  writeDrmGroup((dir / "nonlinear.h5").string(), box.field);
  std::ostringstream out2, err2;
  EXPECT_EQ(runSolid({(dir / "nonlinear.h5").string(), "--check"}, out2, err2), 2);
  EXPECT_NE(err2.str().find("must be linear elastic"), std::string::npos) << err2.str();
  std::printf("%s", err2.str().c_str());
  std::filesystem::remove_all(dir);
}
