// Save and restore of the solid's whole mutable state (tq/core/state_archive.hpp, Solver::checkpoint;
// implicit coupling windows of several solid steps are repeated from their start, so a
// restored solver must continue exactly as the saved one did).
//
// Reference: the solver's own run. The time step is deterministic (fixed sum orders, bitwise
// identical for any thread count: element_block.hpp), so a restored state stepped the same m steps
// must reproduce every value bitwise (tolerance 0, compared as bytes). Anything that a step
// changes and checkpoint() misses shows up as a difference in some recorded value.
//
// The model has every stateful part at once, and the test first asserts that each of them really
// changed during the m steps (otherwise equality would prove nothing):
//  - Mohr–Coulomb damage rock (weakened paper rock, damage on cohesion and stiffness) that yields
//    and damages under the incident pulse; the lining Mohr–Coulomb too (paper C25);
//  - the rock–lining dynamic contact (weak cohesion) whose pairs slip and separate under a
//    rocking/shearing load on the lining;
//  - the seismic boundaries: viscoelastic base (springs, dashpots, input force from the base
//    column) and free-field columns on xmin and xmax driven by a Gaussian incident pulse;
//  - tied node groups: the lining is two slabs whose coincident nodes are tied;
//  - Rayleigh damping (the β K damping stresses use the lagged strain rate: dtLast).
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>

#include "mc_helpers.hpp"
#include "staged_helpers.hpp"
#include "test_helpers.hpp"
#include "tq/boundaries/boundaries.hpp"
#include "tq/contact/contact.hpp"
#include "tq/core/constraints.hpp"
#include "tq/core/state_archive.hpp"
#include "tq/water/wet_part.hpp"

using namespace tq;
using namespace tqtest;

namespace {

constexpr Index kNx = 4;             // columns along x (2 m each)
constexpr Real kW = 2.0, kLy = 2.0;  // column width, slice thickness (m)
constexpr Real kHr = 8.0;            // rock depth (m), 4 layers
constexpr Real kHl = 0.5;            // each lining slab (m)

/// Append box `b` to `m` (new nodes), returning the node offset.
Index append(Mesh& m, const Mesh& b, Index region) {
  const Index off = m.numNodes();
  m.coords.insert(m.coords.end(), b.coords.begin(), b.coords.end());
  for (Index c : b.connectivity) m.connectivity.push_back(c + off);
  for (Index e = 0; e < b.numElems(); ++e) m.region.push_back(region);
  return off;
}

/// Coincident node pairs (node of layer `a`, node of layer `b`): nodes at the same position.
std::vector<Index> coincident(const Mesh& m, Index aBegin, Index aEnd, Index bBegin, Index bEnd) {
  std::vector<Index> out;
  for (Index i = aBegin; i < aEnd; ++i)
    for (Index j = bBegin; j < bEnd; ++j) {
      Real d = 0;
      for (int k = 0; k < 3; ++k) d += std::abs(m.coords[3 * size_t(i) + k] - m.coords[3 * size_t(j) + k]);
      if (d < 1e-9) {
        out.push_back(i);
        out.push_back(j);
      }
    }
  return out;
}

/// Rock block z ∈ [−8, 0] and a lining of two slabs z ∈ [0, 0.5], [0.5, 1]: rock–lining pairs at
/// z = 0 (contact), slab–slab pairs at z = 0.5 (tied). Faces: bottom, xmin, xmax (rock only: the
/// free-field columns), lining_outer (lower slab's bottom), top (upper slab's top).
struct Model {
  Mesh mesh;
  std::vector<Index> tiePairs;
};

Model makeModel() {
  const Mesh r = makeBoxMesh({kNx, 1, 4, 0, 0, -kHr, kNx * kW, kLy, kHr, "rock"});
  const Mesh l1 = makeBoxMesh({kNx, 1, 1, 0, 0, 0, kNx * kW, kLy, kHl, "lining"});
  const Mesh l2 = makeBoxMesh({kNx, 1, 1, 0, 0, kHl, kNx * kW, kLy, kHl, "lining"});
  Model md;
  Mesh& m = md.mesh;
  m.regionNames = {"rock", "lining"};
  append(m, r, 0);
  const Index o1 = append(m, l1, 1);
  const Index o2 = append(m, l2, 1);
  const Index end = m.numNodes();
  m.faces["bottom"] = r.faces.at("bottom");
  m.faces["xmin"] = r.faces.at("xmin");
  m.faces["xmax"] = r.faces.at("xmax");
  for (Index q : l1.faces.at("bottom")) m.faces["lining_outer"].push_back(q + o1);
  for (Index q : l2.faces.at("top")) m.faces["top"].push_back(q + o2);
  m.rockLiningPairs = coincident(m, 0, o1, o1, o2);
  md.tiePairs = coincident(m, o1, o2, o2, end);
  checkMesh(m);
  return md;
}

/// Weakened paper rock (c 20 kPa, σt 10 kPa, φ 37°, R 100): the pulse takes it far past yield.
std::shared_ptr<const Material> weakRock() {
  MohrCoulombDamageParams p = paperRock(100);
  p.cohesion = 2e4;
  p.tensileStrength = 1e4;
  p.damageEffect = DamageEffect::CohesionAndStiffness;
  return std::make_shared<MohrCoulombDamageMaterial>(p);
}

struct Run {
  Model model;
  std::unique_ptr<Solver> solver;
  std::shared_ptr<DynamicContact> contact;
  std::shared_ptr<SeismicBoundaries> seismic;
  std::shared_ptr<TiedNodeGroups> tie;
};

std::unique_ptr<Run> build() {
  auto run = std::make_unique<Run>();
  run->model = makeModel();
  const Mesh& m = run->model.mesh;
  SolverOptions opt;
  opt.damping = RayleighDamping::fromRatio(0.02, 5.0, 50.0);
  run->solver = std::make_unique<Solver>(
      m,
      makeBlocksByRegion(
          m, {{"rock", weakRock()}, {"lining", std::make_shared<MohrCoulombDamageMaterial>(paperLining(100))}}),
      opt);
  Solver& s = *run->solver;
  for (Index n = 0; n < m.numNodes(); ++n) s.fix(n, 1);  // plane strain along y
  // Seismic boundaries: viscoelastic base, free-field columns on both sides, an incident pulse in
  // x (SH) and z (P).
  SeismicBoundarySpec spec;
  spec.bottom = true;
  spec.distance = kHr;
  spec.freeFieldFaces = {"xmin", "xmax"};
  spec.damping = opt.damping;
  GaussPulse pulse;
  pulse.amplitude = 0.01;
  pulse.t0 = 0.03;
  pulse.tau = 0.008;
  std::vector<Real> t, ax, t2, az;
  pulse.sample(0.2, 2.5e-4, t, ax);
  pulse.sample(0.2, 2.5e-4, t2, az, 0.5);
  run->seismic = std::make_shared<SeismicBoundaries>(m, s.blocks(), spec, IncidentMotion(t, ax, {}, az), false);
  run->seismic->install(s.state());
  s.addContributor(ForcePhase::Boundaries, run->seismic);
  // The two lining slabs tied, the lining on the rock by the dynamic contact.
  run->tie = std::make_shared<TiedNodeGroups>("slabs", TiedNodeGroups::pairs(run->model.tiePairs));
  run->tie->install(s);
  s.addContributor(ForcePhase::Interface, run->tie);
  ContactParams cp;
  cp.staticFriction = 0.6;
  cp.dynamicFriction = 0.5;
  cp.cohesion = 5e3;
  run->contact = std::make_shared<DynamicContact>(s, rockLiningPairs(m), cp);
  s.addContributor(ForcePhase::Interface, run->contact);
  // A rocking and shearing load on the lining top (50 Hz): pulls up the x < 4 m half while pushing
  // down the other, and shears along x: pairs separate at one end and slip.
  for (Index n : m.faceNodes("top")) {
    const Real x = m.coords[3 * size_t(n)];
    std::vector<Real> tt, up, sh;
    for (int k = 0; k <= 400; ++k) {
      const Real tk = 2.5e-4 * k;
      tt.push_back(tk);
      up.push_back(std::sin(2 * M_PI * 50 * tk));
      sh.push_back(std::cos(2 * M_PI * 50 * tk));
    }
    s.addLoad({{n}, 2, (x < 0.5 * kNx * kW ? 1 : -1) * 4e4, TimeFunction{tt, up}});
    s.addLoad({{n}, 0, 4e4, TimeFunction{tt, sh}});
  }
  return run;
}

/// Everything observable after a step, as doubles (integers exactly).
std::vector<Real> observe(const Run& run) {
  const Solver& s = *run.solver;
  const NodalState& st = s.state();
  const size_t n3 = 3 * size_t(st.numNodes());
  std::vector<Real> o;
  auto add = [&](const Real* p, size_t n) { o.insert(o.end(), p, p + n); };
  o.push_back(s.time());
  o.push_back(Real(s.stepCount()));
  add(st.uData(), n3);
  add(st.vData(), n3);
  for (Index n = 0; n < st.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) o.push_back(st.a(n, d));
  add(st.fIntData(), n3);
  add(st.fExtData(), n3);
  for (Index n = 0; n < st.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) o.push_back(s.velocityAt(n, d));
  const EnergyBalance& e = s.energy();
  for (Real x : {e.kinetic, e.internal, e.damping, e.boundary, e.external, e.interface, e.plastic, e.error})
    o.push_back(x);
  for (const auto& b : s.blocks()) {
    const Index nh = Index(b->material().historyNames().size());
    for (Index el = 0; el < b->numElems(); ++el) {
      for (int c = 0; c < 6; ++c) o.push_back(b->stress(el, c));
      for (int c = 0; c < 6; ++c) o.push_back(b->strain(el, c));
      for (int h = 0; h < nh; ++h) o.push_back(b->history(h, el));
    }
    o.push_back(b->dissipatedEnergy());
  }
  const DynamicContact& c = *run.contact;
  for (Index p = 0; p < c.numPairs(); ++p) {
    o.push_back(Real(int(c.state(p))));
    o.push_back(Real(c.failed(p)));
    o.push_back(c.normalForce(p));
    o.push_back(c.tangentialForce(p));
    o.push_back(c.opening(p, st));
    o.push_back(c.slip(p, st));
  }
  o.push_back(c.dissipatedEnergy());
  for (const auto& col : run.seismic->columns()) {
    for (Index k = 0; k < col.numLevels(); ++k)
      for (int d = 0; d < 3; ++d) {
        o.push_back(col.u(k, d));
        o.push_back(col.vMean(k, d));
      }
    for (Index l = 0; l < col.numLayers(); ++l) add(col.stress(l), 6);
    o.push_back(col.energyPerArea());
  }
  o.push_back(run.seismic->boundaryEnergy());
  const TiedNodeGroups& tie = *run.tie;
  for (Index j = 0; j < Index(run.model.tiePairs.size()); ++j) add(tie.force(j), 3);
  return o;
}

/// Bytes of two records differ (bitwise; +0 and −0 count as different, NaN as equal to itself).
size_t bitwiseDiffs(const std::vector<Real>& a, const std::vector<Real>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(Real)) != 0;
  return n;
}

}  // namespace

// n steps, save, m steps recorded; restore, the same m steps again (twice, reusing the archive as a
// repeated coupling window does): every recorded value bitwise equal at every step. Two save points:
// n = 3, every pair still bonded with its cohesion (and carrying force), all of them failing in the
// m steps (a stale bond state, offset or work increment would show); n = 350, pairs slipping and
// stuck with force, the rock damaging further. m = 250 steps each.
TEST(StateArchive, RestoredSolverRepeatsEveryStepBitwise) {
  for (const Index n : {3, 350}) {
    SCOPED_TRACE("save after step " + std::to_string(n));
    auto run = build();
    Solver& s = *run->solver;
    const Index m = 250;
    for (Index k = 0; k < n; ++k) s.step();

    StateArchive ar;
    ar.beginSave();
    s.checkpoint(ar);
    ar.end();

    // What the m steps change: damage history, contact states, free field.
    const ElementBlock& rock = *s.blocks()[0];
    ASSERT_EQ(rock.name(), "rock");
    std::vector<Real> damage0(size_t(rock.numElems())), kappa0(size_t(rock.numElems()));
    for (Index e = 0; e < rock.numElems(); ++e) {
      damage0[size_t(e)] = rock.history(mc_history::kDamage, e);
      kappa0[size_t(e)] = rock.history(mc_history::kKappa1, e) + rock.history(mc_history::kKappa3, e);
    }
    const Real plastic0 = s.energy().plastic, interface0 = s.energy().interface;
    const DynamicContact& c = *run->contact;
    const Index P = c.numPairs();
    std::vector<int> prev(static_cast<size_t>(P));
    Index failed0 = 0, loaded0 = 0;
    for (Index p = 0; p < P; ++p) {
      prev[size_t(p)] = int(c.state(p));
      failed0 += c.failed(p);
      loaded0 += c.normalForce(p) != 0 || c.tangentialForce(p) != 0;
    }

    std::vector<std::vector<Real>> first;
    Index stateChanges = 0, slipping = 0, separated = 0;
    for (Index k = 0; k < m; ++k) {
      s.step();
      first.push_back(observe(*run));
      for (Index p = 0; p < P; ++p) {
        const int st = int(c.state(p));
        stateChanges += st != prev[size_t(p)];
        slipping += st == int(PairState::Slipping);
        separated += st == int(PairState::Separated);
        prev[size_t(p)] = st;
      }
    }
    Index damaged = 0, yielded = 0, failed = 0;
    Real dMax = 0;
    for (Index e = 0; e < rock.numElems(); ++e) {
      const Real d = rock.history(mc_history::kDamage, e);
      damaged += d > damage0[size_t(e)];
      yielded += rock.history(mc_history::kKappa1, e) + rock.history(mc_history::kKappa3, e) > kappa0[size_t(e)];
      dMax = std::max(dMax, d);
    }
    for (Index p = 0; p < P; ++p) failed += c.failed(p);
    Real colU = 0;
    for (const auto& col : run->seismic->columns())
      for (Index k = 0; k < col.numLevels(); ++k) colU = std::max(colU, std::abs(col.u(k, 0)));
    Real tieForce = 0;
    for (Index j = 0; j < Index(run->model.tiePairs.size()); ++j)
      tieForce = std::max(tieForce, std::abs(run->tie->force(j)[0]));
    std::printf(
        "state archive, save after step %ld (t %.4f s): %zu bytes; over the %ld recorded steps %ld of %ld rock "
        "elements damaged further (max D %.3f), %ld yielded further, plastic dissipation %.4e -> %.4e J; "
        "pairs failed %ld -> %ld of %ld, %ld carrying force at the save, %ld state changes (%ld pair-steps "
        "slipping, %ld separated), interface dissipation %.4e -> %.4e J; free-field max |u_x| %.3e m; "
        "%zu values recorded per step\n",
        long(n), s.time() - m * s.dt(), ar.bytes(), long(m), long(damaged), long(rock.numElems()), dMax, long(yielded),
        plastic0, s.energy().plastic, long(failed0), long(failed), long(P), long(loaded0), long(stateChanges),
        long(slipping), long(separated), interface0, s.energy().interface, colU, first.back().size());
    // The recorded steps exercise every part (else equality would prove nothing).
    ASSERT_GT(stateChanges, 0);
    ASSERT_GT(slipping, 0);
    ASSERT_GT(separated, 0);
    ASSERT_GT(loaded0, 0);
    ASSERT_GT(s.energy().interface, interface0);
    ASSERT_GT(colU, 1e-4);
    ASSERT_GT(tieForce, 0.0);
    ASSERT_GT(yielded, 0);
    ASSERT_GT(s.energy().plastic, plastic0);
    if (n == 3) {
      ASSERT_EQ(failed0, 0);  // bonds intact at the save ...
      ASSERT_EQ(failed, P);   // ... and all broken in the recorded steps
    } else {
      ASSERT_EQ(damaged, rock.numElems());
    }

    for (int pass = 1; pass <= 2; ++pass) {
      ar.beginRestore();
      s.checkpoint(ar);
      ar.end();
      EXPECT_EQ(s.stepCount(), n);
      size_t diffs = 0, firstBad = 0;
      Index badStep = -1;
      for (Index k = 0; k < m; ++k) {
        s.step();
        const std::vector<Real> o = observe(*run);
        const size_t d = bitwiseDiffs(o, first[size_t(k)]);
        if (d && badStep < 0) {
          badStep = k;
          while (firstBad < o.size() && std::memcmp(&o[firstBad], &first[size_t(k)][firstBad], sizeof(Real)) == 0)
            ++firstBad;
        }
        diffs += d;
      }
      std::printf("restore %d: %zu values differ over %ld steps\n", pass, diffs, long(m));
      EXPECT_EQ(diffs, 0u) << "restore " << pass << ": first difference at step " << badStep << ", value index "
                           << firstBad;
    }
  }
}

// The archive's own checks: restoring with nothing saved, or with a different checkpoint list than
// the save's, is a programming error and throws std::logic_error; a plain save/restore round trip
// gives back the values (and the sizes) saved.
TEST(StateArchive, RestoreBeforeSaveAndMismatchedListsThrow) {
  StateArchive ar;
  EXPECT_THROW(ar.beginRestore(), std::logic_error);

  std::vector<Real> v = {1.5, -2.25, 3.0};
  std::vector<std::uint8_t> b = {1, 0, 3};
  Real x = 0.125;
  Index i = 7;
  ar.beginSave();
  ar.io(v);
  ar.io(b);
  ar.io(x);
  ar.io(i);
  ar.end();
  EXPECT_EQ(ar.bytes(), 3 * sizeof(Real) + 3 + sizeof(Real) + sizeof(Index));
  v = {9.0};
  b.clear();
  x = -1;
  i = -1;
  ar.beginRestore();
  ar.io(v);
  ar.io(b);
  ar.io(x);
  ar.io(i);
  ar.end();
  EXPECT_EQ(v, (std::vector<Real>{1.5, -2.25, 3.0}));
  EXPECT_EQ(b, (std::vector<std::uint8_t>{1, 0, 3}));
  EXPECT_EQ(x, 0.125);
  EXPECT_EQ(i, 7);

  ar.beginRestore();  // fewer items than saved: detected at end()
  ar.io(v);
  EXPECT_THROW(ar.end(), std::logic_error);
  ar.beginRestore();  // more items than saved
  ar.io(v);
  ar.io(b);
  ar.io(x);
  ar.io(i);
  EXPECT_THROW(ar.io(x), std::logic_error);
  ar.beginRestore();  // an item of another size in a scalar slot
  ar.io(v);
  ar.io(b);
  int wrong = 0;
  EXPECT_THROW(ar.io(wrong), std::logic_error);
}

// Large items are copied in pieces by the threads of an OpenMP team: every byte comes back, for an
// item whose length is no multiple of a piece, on 1, 2 and 3 threads, NaN payloads and signed zeros
// included (a memcpy reference: tolerance 0).
TEST(StateArchive, LargeItemsCopiedOverThreadsComeBackByteForByte) {
  const int threads0 = omp_get_max_threads();
  std::vector<std::uint64_t> bits(300007);  // 2.4 MB: 18 pieces of 128 kB and a part
  std::uint64_t x = 0x9E3779B97F4A7C15ULL;
  for (auto& b : bits) {  // xorshift64: every bit pattern, NaNs with payloads among them
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    b = x;
  }
  std::vector<Real> v(bits.size());
  std::memcpy(v.data(), bits.data(), bits.size() * sizeof(Real));
  v[5] = -0.0;
  const std::vector<Real> original = v;
  for (const int t : {1, 2, 3}) {
    SCOPED_TRACE(std::to_string(t) + " thread(s)");
    omp_set_num_threads(t);
    StateArchive ar;
    ar.beginSave();
    ar.io(v);
    ar.end();
    std::fill(v.begin(), v.end(), 1.0);
    v.resize(10);  // restored to the saved size
    ar.beginRestore();
    ar.io(v);
    ar.end();
    ASSERT_EQ(v.size(), original.size());
    EXPECT_EQ(std::memcmp(v.data(), original.data(), v.size() * sizeof(Real)), 0);
  }
  omp_set_num_threads(threads0);
}

// A restart in another process (tq/io/restart.hpp): the archive written as bytes and read back into
// a solver built anew from the same input, which then steps on. Reference: the original solver's
// own continuation; every recorded value must be bitwise equal (tolerance 0). A part whose state is
// set by the run's history but missing from checkpoint() would leave the fresh solver elsewhere.
TEST(StateArchive, ArchiveWrittenAsBytesRestoresAFreshlyBuiltSolverBitwise) {
  const Index n = 350, m = 250;
  auto run = build();
  Solver& s = *run->solver;
  for (Index k = 0; k < n; ++k) s.step();
  StateArchive ar;
  ar.beginSave();
  s.checkpoint(ar);
  ar.end();
  std::stringstream bytes;
  ar.write(bytes);
  std::vector<std::vector<Real>> first;
  for (Index k = 0; k < m; ++k) {
    s.step();
    first.push_back(observe(*run));
  }

  auto fresh = build();  // as a resumed process: the model built from the input, never stepped
  StateArchive back;
  ASSERT_TRUE(back.read(bytes));
  EXPECT_EQ(back.layout(), ar.layout());
  back.beginRestore();
  fresh->solver->checkpoint(back);
  back.end();
  EXPECT_EQ(fresh->solver->stepCount(), n);
  size_t diffs = 0;
  Index badStep = -1;
  for (Index k = 0; k < m; ++k) {
    fresh->solver->step();
    const size_t d = bitwiseDiffs(observe(*fresh), first[size_t(k)]);
    if (d && badStep < 0) badStep = k;
    diffs += d;
  }
  EXPECT_EQ(diffs, 0u) << "first difference at step " << badStep;

  // bytes that end early are refused, and leave the archive as it was
  std::stringstream cut(bytes.str().substr(0, bytes.str().size() / 2));
  EXPECT_FALSE(back.read(cut));
  EXPECT_EQ(back.layout(), ar.layout());
}

// The water's work on a rank's part of the wetted face (tq/water/wet_part.hpp PendingWetWork): each
// step's terms are kept until the window's flush sums them over the face. A save taken with steps kept
// (inside a window) and read back, through a restart checkpoint's bytes, must leave the flush with the
// work of the run never saved; a restore at a window stepped again drops the steps kept since the save.
// Reference: the same steps booked and flushed without a save, compared as bytes (tolerance 0).
TEST(PendingWetWork, StepsKeptInsideAWindowSurviveASaveThroughBytes) {
  WetPart part;  // one part holding the whole face: 3 nodes, node 1 does not move
  part.places = {0, 1, 2};
  part.wholeCount = 3;
  part.gather = [](const std::vector<Real>& mine, size_t, std::vector<Real>& whole) { whole = mine; };
  const auto book = [&](PendingWetWork& w, Real& total, int step) {
    w.bookStep(
        &part, 3, [](size_t k) { return k != 1; },
        [&](size_t k, int d, size_t) { return 1e3 * std::sin(1.0 + step + 0.3 * Real(k) + 0.01 * d); }, total);
  };
  const auto same = [](Real a, Real b) { return std::memcmp(&a, &b, sizeof a) == 0; };

  PendingWetWork ref;  // steps 1, 2, 3 of a window, flushed at its end
  Real refTotal = 0.5;
  for (int j = 1; j <= 3; ++j) book(ref, refTotal, j);
  flushWetWork(part, {{&ref, &refTotal}});
  ASSERT_TRUE(ref.terms.empty());
  ASSERT_NE(refTotal, 0.5);

  // saved after step 2 (inside the window), written as bytes, read back into a new part
  PendingWetWork run;
  Real runTotal = 0.5;
  book(run, runTotal, 1);
  book(run, runTotal, 2);
  StateArchive saved;
  saved.beginSave();
  run.checkpoint(saved);
  saved.end();
  std::stringstream bytes;
  saved.write(bytes);
  StateArchive read;
  ASSERT_TRUE(read.read(bytes));
  PendingWetWork resumed;
  Real resumedTotal = 0.5;
  read.beginRestore();
  resumed.checkpoint(read);
  read.end();  // every item read
  ASSERT_EQ(resumed.terms.size(), 2u);
  EXPECT_EQ(resumed.terms, run.terms);
  book(resumed, resumedTotal, 3);
  flushWetWork(part, {{&resumed, &resumedTotal}});
  EXPECT_TRUE(same(resumedTotal, refTotal)) << resumedTotal << " " << refTotal;

  // a window stepped again: saved with step 1 kept, steps 2 and 3 booked, restored: step 1 alone
  // again, whole; the window's steps booked again give the reference's work
  PendingWetWork again;
  Real againTotal = 0.5;
  book(again, againTotal, 1);
  StateArchive start;
  start.beginSave();
  again.checkpoint(start);
  start.end();
  const std::vector<Real> step1 = again.terms[0];
  book(again, againTotal, 2);
  book(again, againTotal, 3);
  start.beginRestore();
  again.checkpoint(start);
  start.end();
  ASSERT_EQ(again.terms.size(), 1u);
  EXPECT_EQ(again.terms[0], step1);
  book(again, againTotal, 2);
  book(again, againTotal, 3);
  flushWetWork(part, {{&again, &againTotal}});
  EXPECT_TRUE(same(againTotal, refTotal)) << againTotal << " " << refTotal;

  // a checkpoint taken at a window's end (flushed: none kept) is the count 0 alone, as before
  StateArchive end;
  end.beginSave();
  again.checkpoint(end);
  end.end();
  EXPECT_EQ(end.layout(), std::vector<size_t>{sizeof(long long)});
}
