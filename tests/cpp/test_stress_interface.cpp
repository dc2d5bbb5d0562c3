// Stability stress test: a nearly singular rock–lining interface — very soft rock and
// a pull-off load that separates every pair, so that the lining becomes a free body held by
// nothing, then is pushed back onto the (still vibrating) soft rock and lands on it.
//
// Model: a lining slab (3 × 3 columns of 1 m, 0.5 m thick, C25: E 28 GPa, ν 0.17, ρ 2500) on a
// rock block (3 × 3 × 4 elements, 2 m deep, bottom fixed) whose Young's modulus is the paper's
// 8 GPa divided by 1e3 and by 1e4 (8 MPa, 0.8 MPa: a rock–lining stiffness ratio of 3.5e3 and
// 3.5e4), 16 duplicated node pairs with the dynamic contact force (μs = μd = 0.6), cohesion
// scaled with the rock (f_c = 0.5 MPa × 1e-3 or 1e-4, so that the rock strain at separation,
// f_c/E_r = 6.25e-5, stays small). No damping (nothing hides a bad force). A uniform upward
// traction q(t) on the lining top rises to f_c at 1 s (all the interface can carry), then
// reverses to a push of 0.3 f_c that brings the flying lining back onto the vibrating rock, where
// it lands and bounces (undamped: the landings are the only dissipation).
//
// References and tolerances (docs/verification.md, "nearly singular interface"):
//  - contact laws at every step and pair (eqs. 11–13; exact in the method, so round-off
//    tolerances): a separated pair carries exactly zero force; a bonded pair's tension is at most
//    f_c A and its shear at most f_c A + μs N (relative 1e-9); a pair whose cohesion is lost carries
//    no tension (N ≥ −1e-9 f_c A) and at most μs N shear; a slipping pair has |T| = μd N (1e-9);
//  - no interpenetration: the opening −n·(u2 − u1) ≥ −1e-12 m at every step (the method closes the
//    predicted gap exactly; the existing pull-off test's bound);
//  - every pair separates, and at a total pull F ≤ f_c ΣA (1 %: the interface cannot carry more
//    than its total cohesion; the ramp is slow against the lining-on-rock mode, so inertia adds
//    less than that);
//  - while all pairs are separated the lining is a free body: the change of its momentum equals the
//    impulse of the applied traction (Newton; 1e-9 relative — the contact force must be exactly
//    zero, any leak shows here);
//  - the lining comes back: after the flight, pairs close again (re-contact) with the opening
//    bound above holding through every landing, and the landings only dissipate energy (the
//    accumulated interface term never below −1e-9 of the largest term, > 0 at the end; single
//    steps may return a little, as the trapezoid booking of a force switching off does);
//  - the separation starts at the edge pairs (soft rock with free sides loads them above their
//    area share) below f_c ΣA and peels through all pairs within a few steps (printed);
//  - the energy balance (kinetic + strain + interface dissipation − external work) closes within
//    1 % over the whole run (the solid verification's balance tolerance), and every value stays finite.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "mc_helpers.hpp"
#include "test_helpers.hpp"
#include "tq/contact/contact.hpp"

using namespace tq;
using namespace tqtest;

namespace {

constexpr Real kW = 1.0;   // column width (m)
constexpr Index kN = 3;    // columns per side
constexpr Real kHr = 2.0;  // rock depth (m), 4 elements
constexpr Real kHl = 0.5;  // lining thickness (m), 1 element
constexpr Real kRhoLining = 2500;

/// Rock block z ∈ [−kHr, 0] under a lining slab z ∈ [0, kHl], interface nodes duplicated (rock
/// node, lining node) and listed as pairs; the lining bottom is `lining_outer` (normal −z).
Mesh softStack() { return pairedStack(kN, kN, 4, 1, kHr, kHl, kW, false); }

/// Tributary area of each node of a face group (a quarter of each adjacent quad).
std::map<Index, Real> tributary(const Mesh& m, const std::string& group) {
  std::map<Index, Real> a;
  const auto& q = m.faces.at(group);
  for (size_t k = 0; k < q.size() / 4; ++k) {
    Real c[3];
    quadDiagonalCross(m, q, k, c);
    const Real area = 0.5 * std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    for (int i = 0; i < 4; ++i) a[q[4 * k + i]] += area / 4;
  }
  return a;
}

}  // namespace

TEST(NearlySingularInterface, SoftRockPullOffSeparatesEveryPairObeysTheContactLawsAndLandsAgain) {
  for (const Real soften : {1e3, 1e4}) {
    const Mesh m = softStack();
    const Real Er = 8e9 / soften;
    ContactParams cp;
    cp.staticFriction = cp.dynamicFriction = 0.6;
    cp.cohesion = 0.5e6 / soften;
    SolverOptions opt;  // no damping
    Solver s(m, makeBlocksByRegion(m, {{"rock", elastic(Er, 0.25, 2700)}, {"lining", elastic(28e9, 0.17, kRhoLining)}}),
             opt);
    s.fixFaceGroup("bottom", "xyz");
    auto contact = std::make_shared<DynamicContact>(s, rockLiningPairs(m), cp);
    s.addContributor(ForcePhase::Interface, contact);
    const Index P = contact->numPairs();
    ASSERT_EQ(P, 16);
    Real areaTotal = 0;
    for (Index p = 0; p < P; ++p) areaTotal += contact->pairs().area[size_t(p)];
    ASSERT_NEAR(areaTotal, kN * kN * kW * kW, 1e-12);
    const Real cA = cp.cohesion * areaTotal;
    // Traction history (units of f_c): ramp to 1 by tRamp, then a push of 0.3.
    const Real tRamp = 1.0, tEnd = 3.0;
    const TimeFunction q{{0.0, tRamp, tRamp + 1e-9, 100.0}, {0.0, 1.0, -0.3, -0.3}};
    for (const auto& [n, a] : tributary(m, "top")) s.addLoad({{n}, 2, cp.cohesion * a, q});
    std::vector<Index> liningNodes;
    Real liningMass = 0;
    for (Index n = m.numNodes() - (kN + 1) * (kN + 1) * 2; n < m.numNodes(); ++n) {
      liningNodes.push_back(n);
      liningMass += s.state().mass(n);
    }
    ASSERT_NEAR(liningMass, kRhoLining * kN * kN * kW * kW * kHl, 1e-9 * liningMass);
    auto momentumZ = [&] {
      Real pz = 0;
      for (Index n : liningNodes) pz += s.state().mass(n) * s.state().v(n, 2);
      return pz;
    };

    Real worstLaw = 0, minOpening = 0, maxErr = 0, fFirst = -1, fAll = -1, maxOpening = 0;
    Real tFirst = -1, tAll = -1, tLand = -1, minDiss = 0;
    Index landings = 0, prevSep = 0;
    Index lawViolations = 0;
    // Free flight bookkeeping: momentum and impulse over the longest all-separated interval.
    bool flying = false;
    Real p0 = 0, impulse = 0, flightT0 = 0, bestFlight = 0, flightRelErr = 0, flightDp = 0;
    bool finite = true;
    while (s.time() < tEnd) {
      const Real tForce = s.time();
      const Real pBefore = momentumZ();
      s.step();
      const Index sep = contact->count(PairState::Separated);
      // Contact laws, every pair, this step's force.
      for (Index p = 0; p < P; ++p) {
        const Real N = contact->normalForce(p), T = contact->tangentialForce(p);
        const Real ca = cp.cohesion * contact->pairs().area[size_t(p)];
        Real excess = 0;
        switch (contact->state(p)) {
          case PairState::Separated:
            excess = std::abs(N) + std::abs(T);
            break;
          case PairState::Bonded:
            excess = std::max(-N - ca, T - (ca + cp.staticFriction * N));
            break;
          case PairState::Stuck:
            excess = std::max(-N, T - cp.staticFriction * N);
            break;
          case PairState::Slipping:
            excess = std::abs(T - cp.dynamicFriction * std::max(N, Real(0)));
            break;
          case PairState::Inactive:
            excess = 1;
            break;
        }
        worstLaw = std::max(worstLaw, excess / ca);
        if (excess > 1e-9 * ca) ++lawViolations;
        const Real op = contact->opening(p, s.state());
        minOpening = std::min(minOpening, op);
        maxOpening = std::max(maxOpening, op);
        finite = finite && std::isfinite(N) && std::isfinite(T) && std::isfinite(op);
      }
      if (fFirst < 0 && sep > 0) {
        fFirst = q(tForce) * cA;
        tFirst = tForce;
      }
      if (fAll < 0 && sep == P) {
        fAll = q(tForce) * cA;
        tAll = tForce;
      }
      if (fAll > 0 && prevSep == P && sep < P) {  // a landing: pairs close after a flight
        ++landings;
        if (tLand < 0) tLand = s.time();
      }
      prevSep = sep;
      // The interface only dissipates: its accumulated term is never negative.
      const EnergyBalance& en = s.energy();
      const Real scale = std::max({std::abs(en.external), std::abs(en.kinetic) + std::abs(en.internal), Real(1e-300)});
      minDiss = std::min(minDiss, en.interface / scale);
      // Free flight: this step's contact force was zero on every pair.
      if (sep == P) {
        if (!flying) {
          flying = true;
          p0 = pBefore;
          impulse = 0;
          flightT0 = tForce;
        }
        impulse += s.dt() * q(tForce) * cA;
        const Real dp = momentumZ() - p0;
        if (s.time() - flightT0 > bestFlight) {
          bestFlight = s.time() - flightT0;
          flightDp = dp;
          flightRelErr = std::abs(dp - impulse) / std::max(std::abs(impulse), std::abs(dp));
        }
      } else {
        flying = false;
      }
      if (s.time() > 0.1 * tRamp) maxErr = std::max(maxErr, s.energy().error);
      finite = finite && std::isfinite(s.energy().error);
    }
    Real finalOpening = 0;
    for (Index p = 0; p < P; ++p) finalOpening = std::max(finalOpening, contact->opening(p, s.state()));
    std::printf(
        "soft rock E/%.0e (E_r %.1e Pa, f_c %.0f Pa, dt %.3e s, %ld steps): first separation at F = %.4f f_c "
        "SumA (t %.4f s), all %d pairs at %.4f f_c SumA (%.1f ms later); free flight %.3f s: dp %.6e N s vs "
        "impulse (rel. %.1e); max opening %.3e m; first landing t %.3f s, %ld landings; min opening %.2e m; "
        "worst law excess %.1e f_c A (%ld violations); interface dissipation %.4e J (min over the run "
        "%.1e of the scale); max balance error %.2e; final opening %.2e m, states bonded %d separated %d slipping %d "
        "stuck %d\n",
        soften, Er, cp.cohesion, s.dt(), long(s.stepCount()), fFirst / cA, tFirst, int(P), fAll / cA,
        1e3 * (tAll - tFirst), bestFlight, flightDp, flightRelErr, maxOpening, tLand, long(landings), minOpening,
        worstLaw, long(lawViolations), s.energy().interface, minDiss, maxErr, finalOpening,
        int(contact->count(PairState::Bonded)), int(contact->count(PairState::Separated)),
        int(contact->count(PairState::Slipping)), int(contact->count(PairState::Stuck)));
    EXPECT_TRUE(finite);
    EXPECT_EQ(lawViolations, 0);
    EXPECT_GE(minOpening, -1e-12);  // no interpenetration
    ASSERT_GT(fAll, 0) << "not every pair separated";
    EXPECT_LE(fAll, 1.01 * cA);     // the interface carried no more than its total cohesion
    EXPECT_GT(bestFlight, 0.1);     // a real free flight (many steps), not a one-step blip
    EXPECT_GT(maxOpening, 1e-3);    // the lining really left the rock (> 1 mm)
    EXPECT_LT(flightRelErr, 1e-9);  // Newton for the free lining: zero contact force
    EXPECT_GE(landings, 1) << "the lining did not come back";
    EXPECT_GT(s.energy().interface, 0.0);  // the landings dissipated energy
    EXPECT_GE(minDiss, -1e-9);
    EXPECT_LT(maxErr, 0.01);
  }
}
