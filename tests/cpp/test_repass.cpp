// A coupling window's re-passes over the water's reach only (Solver::planRepasses): a window the
// water does not accept is stepped again from its start, and between passes only the water's force
// on the wet nodes differs; an explicit step carries that change one element ring further at most
// (a node of level L takes it up at its updates only), so the re-pass leaves the element chunks out
// of reach as the first pass left them and takes their nodes' internal force from it. The answer
// must be the whole re-pass's, bit for bit.
//
// The model: a lined ring slice (lining 5.25-6 m in 3 layers, rock 6-60 m in 48, dynamic contact,
// Mohr-Coulomb damage in both), subcycled at 3 levels and single-rate, its inner face loaded by a
// stand-in for the water whose force changes from pass to pass, windows of 16 steps taking 1, 2 or
// 3 passes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "mc_helpers.hpp"
#include "test_helpers.hpp"
#include "tq/contact/contact.hpp"
#include "tq/coupling/coupled_stepper.hpp"

using namespace tq;

namespace {

/// The water's stand-in: a radial force on the wet nodes, f(t) (1 + 0.3 pass) each, so that every
/// pass of a window loads them differently; windows w take 1 + w % 3 passes.
class PassWater final : public NodalForceContributor, public WindowCoupling {
 public:
  PassWater(const Mesh& m, std::vector<Index> wet, Index steps) : m_(m), wet_(std::move(wet)), steps_(steps) {}
  std::string name() const override { return "pass water"; }
  void addForces(Real t, Real, NodalState& st) override {
    Real* fe = st.fExtData();
    const Real f = 1e5 * std::sin(2 * M_PI * 12 * t) * (1 + 0.3 * pass_);
    for (Index n : wet_) {
      const Real x = m_.coords[3 * size_t(n)], z = m_.coords[3 * size_t(n) + 2], r = std::hypot(x, z);
      fe[3 * size_t(n)] += f * x / r;
      fe[3 * size_t(n) + 2] += f * z / r;
    }
  }
  bool constrainLevels(std::vector<std::uint8_t>& level) const override { return lowerToFinestLevel(level, wet_); }
  bool forceGroups(std::vector<std::vector<Index>>& groups) const override {
    groups.push_back(wet_);
    return true;
  }
  bool motionReadNodes(std::vector<Index>&) const override { return true; }
  void planWindow(const NodalState&) override { pass_ = 0; }
  void planStep(Index, Real) override {}
  bool exchange(Real, const NodalState&) override {
    ++passes_;
    if (pass_ + 1 >= 1 + window_ % 3) return true;
    ++pass_;
    return false;
  }
  void acceptWindow() override { ++window_; }
  bool repeatsWindows() const override { return true; }
  Index windowSteps() const override { return steps_; }
  long passes() const { return passes_; }

 private:
  const Mesh& m_;
  std::vector<Index> wet_;
  Index steps_;
  int pass_ = 0;
  long window_ = 0, passes_ = 0;
};

/// A contributor that does not say which nodes its forces join (the default forceGroups).
class Unsaid final : public NodalForceContributor {
 public:
  std::string name() const override { return "unsaid"; }
  void addForces(Real, Real, NodalState&) override {}
};

/// Springs to the origin on some nodes of the outer rock, far beyond the water's reach, whose work
/// (½ (f + f_prev)·Δu, its state) is read from those nodes' motion at every step, as the base's
/// springs are: a re-pass must keep stepping them (motionReadNodes), `say` false: it does not tell.
class RockSprings final : public NodalForceContributor {
 public:
  RockSprings(std::vector<Index> nodes, bool say)
      : nodes_(std::move(nodes)), say_(say), uPrev_(3 * nodes_.size(), 0.0), fPrev_(3 * nodes_.size(), 0.0) {}
  std::string name() const override { return "rock springs"; }
  void addForces(Real, Real, NodalState& st) override {
    for (size_t i = 0; i < nodes_.size(); ++i)
      for (int d = 0; d < 3; ++d) {
        const Real u = st.u(nodes_[i], d), f = -kStiffness * u;
        st.fExt(nodes_[i], d) += f;
        work_ += 0.5 * (f + fPrev_[3 * i + size_t(d)]) * (u - uPrev_[3 * i + size_t(d)]);
        fPrev_[3 * i + size_t(d)] = f;
        uPrev_[3 * i + size_t(d)] = u;
      }
  }
  Real boundaryEnergy() const override { return -work_; }
  bool forceGroups(std::vector<std::vector<Index>>&) const override { return true; }
  bool motionReadNodes(std::vector<Index>& nodes) const override {
    if (say_) nodes.insert(nodes.end(), nodes_.begin(), nodes_.end());
    return say_;
  }
  void checkpoint(StateArchive& a) override {
    a.io(uPrev_);
    a.io(fPrev_);
    a.io(work_);
  }
  Real work() const { return work_; }

 private:
  static constexpr Real kStiffness = 1e7;  // N/m
  std::vector<Index> nodes_;
  bool say_;
  std::vector<Real> uPrev_, fPrev_;
  Real work_ = 0;
};

struct Result {
  std::vector<Real> u, v, stress, history;
  EnergyBalance energy;
  Real springWork = 0;
  Solver::RepassPlan plan;
  long passes = 0, restores = 0;
};

Result run(bool planned, int levels, bool unsaid = false, bool springsSay = true) {
  const Mesh l = makeRingSliceMesh({5.25, 6.0, 3, 64, 1.0, "lining"});
  const Mesh r = makeRingSliceMesh({6.0, 60.0, 48, 64, 1.0, "rock"});
  static Mesh m;
  m = tqtest::withLining(r, l);
  const Index off = r.numNodes();
  for (const char* f : {"ymin", "ymax"}) {
    for (Index q : r.faces.at(f)) m.faces["sides"].push_back(q);
    for (Index q : l.faces.at(f)) m.faces["sides"].push_back(q + off);
  }
  for (Index q : l.faces.at("outer")) m.faces["lining_outer"].push_back(q + off);
  m.faces["rock_outer"] = r.faces.at("outer");
  tqtest::pairRockWithLiningAt(m, off, 6.0);
  checkMesh(m);
  std::vector<Index> wet;
  for (Index q : l.faces.at("inner")) wet.push_back(q + off);
  std::sort(wet.begin(), wet.end());
  wet.erase(std::unique(wet.begin(), wet.end()), wet.end());
  SolverOptions opt;
  opt.damping.alpha = 1;
  auto rock = std::make_shared<MohrCoulombDamageMaterial>(tqtest::paperRock(100));
  auto lining = std::make_shared<MohrCoulombDamageMaterial>(tqtest::paperLining(100));
  Solver s(m, makeBlocksByRegion(m, {{"rock", rock}, {"lining", lining}}), opt);
  s.fixFaceGroup("sides", "y");
  s.fixFaceGroup("rock_outer", "xz");
  s.addContributor(ForcePhase::Interface, std::make_shared<DynamicContact>(s, rockLiningPairs(m), ContactParams{}));
  if (unsaid) s.addContributor(ForcePhase::Loads, std::make_shared<Unsaid>());
  std::vector<Index> far;  // the rock's nodes 45.375 m from the axis (a ring)
  for (Index n = 0; n < off; ++n)
    if (const Real rr = std::hypot(m.coords[3 * size_t(n)], m.coords[3 * size_t(n) + 2]); std::abs(rr - 45.375) < 0.1)
      far.push_back(n);
  auto springs = std::make_shared<RockSprings>(far, springsSay);
  s.addContributor(ForcePhase::Boundaries, springs);
  const Index k = 16;
  auto water = std::make_shared<PassWater>(m, wet, k);
  s.addContributor(ForcePhase::Water, water);
  s.setTimeStep(s.stableStep().dtSafe);
  s.enableSubcycling(levels);
  Result o;
  if (planned) o.plan = s.planRepasses(wet, k);
  CoupledStepper stepper(s, water.get());
  for (int w = 0; w < 60; ++w) stepper.advance([] {});
  const NodalState& st = s.state();
  o.u.assign(st.uData(), st.uData() + 3 * size_t(st.numNodes()));
  o.v.assign(st.vData(), st.vData() + 3 * size_t(st.numNodes()));
  for (const auto& b : s.blocks())
    for (Index e = 0; e < b->numElems(); ++e) {
      for (int c = 0; c < 6; ++c) o.stress.push_back(b->stress(e, c));
      o.history.push_back(b->history(mc_history::kDamage, e));
      o.history.push_back(b->history(mc_history::kDissipation, e));
    }
  o.energy = s.energy();
  o.springWork = springs->work();
  o.passes = water->passes();
  o.restores = stepper.restores();
  return o;
}

bool sameBits(Real a, Real b) { return std::memcmp(&a, &b, sizeof(Real)) == 0; }

}  // namespace

TEST(Repass, WindowsSteppedAgainOverTheWatersReachGiveTheWholeRepassBitwise) {
  // subcycled (3 levels), and single-rate, where the reach is 16 element rings plus the contact's
  // own step across the interface (a pair's force is predicted from both nodes' whole force)
  for (int levels : {3, 0}) {
    SCOPED_TRACE(levels);
    const Result whole = run(false, levels), reach = run(true, levels);
    std::printf(
        "%d levels: %ld of %ld element chunks skipped (%ld of %ld elements), %ld nodes replayed; %ld passes, "
        "%ld restores; %ld of %ld node chunks (%ld nodes) left alone%s%s\n",
        levels, long(reach.plan.skippedChunks), long(reach.plan.chunks), long(reach.plan.skippedElements),
        long(reach.plan.elements), long(reach.plan.replayNodes), reach.passes, reach.restores,
        long(reach.plan.frozenNodeChunks), long(reach.plan.nodeChunks), long(reach.plan.frozenNodes),
        reach.plan.whyNodes.empty() ? "" : ": ", reach.plan.whyNodes.c_str());
    ASSERT_TRUE(reach.plan.why.empty()) << reach.plan.why;
    if (levels > 0) {  // subcycled: the outer rock's node chunks too (the springs' nodes stepped)
      ASSERT_TRUE(reach.plan.whyNodes.empty()) << reach.plan.whyNodes;
      ASSERT_GT(reach.plan.frozenNodeChunks, 0);
      ASSERT_LT(reach.plan.frozenNodeChunks, reach.plan.nodeChunks);
    } else {
      EXPECT_EQ(reach.plan.frozenNodeChunks, 0);
    }
    ASSERT_GT(reach.plan.skippedChunks, 0) << "the outer rock must be out of the water's reach within a window";
    ASSERT_LT(reach.plan.skippedChunks, reach.plan.chunks);
    ASSERT_EQ(whole.passes, reach.passes);
    ASSERT_EQ(reach.restores, 60);  // windows of 1, 2 and 3 passes: 0 + 1 + 2 restores a cycle of three
    Real peak = 0, damage = 0;
    for (Real x : whole.u) peak = std::max(peak, std::abs(x));
    for (size_t i = 0; i < whole.history.size(); i += 2) damage = std::max(damage, whole.history[i]);
    std::printf("|u| up to %.3g m, damage up to %.3g, plastic %.4g J\n", peak, damage, whole.energy.plastic);
    ASSERT_GT(peak, 1e-6) << "the water's stand-in must move the ring";
    ASSERT_GT(whole.energy.plastic, 0.0) << "the ring must yield";
    EXPECT_EQ(whole.u, reach.u);
    EXPECT_EQ(whole.v, reach.v);
    EXPECT_EQ(whole.stress, reach.stress);
    EXPECT_EQ(whole.history, reach.history);
    ASSERT_GT(std::abs(whole.springWork), 0.0) << "the springs' nodes must move";
    EXPECT_TRUE(sameBits(whole.springWork, reach.springWork));
    for (Real EnergyBalance::*t :
         {&EnergyBalance::kinetic, &EnergyBalance::internal, &EnergyBalance::external, &EnergyBalance::damping,
          &EnergyBalance::boundary, &EnergyBalance::interface, &EnergyBalance::plastic})
      EXPECT_TRUE(sameBits(whole.energy.*t, reach.energy.*t));
  }
}

TEST(Repass, AContributorThatDoesNotSayWhoseMotionItReadsKeepsEveryNodeChunkStepped) {
  const Result r = run(true, 3, false, false);
  EXPECT_TRUE(r.plan.why.empty()) << r.plan.why;
  EXPECT_GT(r.plan.skippedChunks, 0);
  EXPECT_EQ(r.plan.frozenNodeChunks, 0);
  EXPECT_NE(r.plan.whyNodes.find("'rock springs' does not say which nodes' motion it reads"), std::string::npos)
      << r.plan.whyNodes;
}

TEST(Repass, AContributorThatDoesNotSayWhichNodesItJoinsKeepsEveryRepassWhole) {
  const Result r = run(true, 3, true);
  EXPECT_EQ(r.plan.skippedChunks, 0);
  EXPECT_NE(r.plan.why.find("'unsaid' does not say which nodes its forces join"), std::string::npos) << r.plan.why;
}
