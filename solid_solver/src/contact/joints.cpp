// The lining's joints: a normal and a shear spring per pair, tension cut-off, optional friction
// (tq/contact/joints.hpp; docs/theory.md "Lining joints").
#include "tq/contact/joints.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tq/contact/pair_prediction.hpp"

namespace tq {

namespace {
constexpr int kAxis = 1;  // the tunnel axis (y): every joint's normal
}

void JointParams::check() const {
  auto bad = [](const std::string& what, Real v, const std::string& fix) {
    std::ostringstream os;
    os << "lining joints: " << what << " = " << v << " is invalid; " << fix;
    throw InputError(os.str());
  };
  if (!(normalStiffness > 0) || !std::isfinite(normalStiffness))
    bad("normal_stiffness", normalStiffness, "give k_n > 0 in Pa/m");
  if (!(shearStiffness > 0) || !std::isfinite(shearStiffness))
    bad("shear_stiffness", shearStiffness, "give k_s > 0 in Pa/m");
  if (!(tensileStrength >= 0) || !std::isfinite(tensileStrength))
    bad("tensile_strength", tensileStrength, "give f_t >= 0 in Pa");
  if (!std::isfinite(friction)) bad("friction", friction, "give mu >= 0, or a negative value for no cap");
}

void JointPairs::check(const std::string& where, Index numNodes) const {
  const size_t P = nodeA.size();
  if (nodeB.size() != P || area.size() != P || joint.size() != P)
    throw InputError(where + ": the joint datasets differ in length (pairs, area, joint)");
  for (size_t p = 0; p < P; ++p) {
    if (nodeA[p] < 0 || nodeA[p] >= numNodes || nodeB[p] < 0 || nodeB[p] >= numNodes)
      throw InputError(where + ": pair " + std::to_string(p) + " names a node outside the mesh");
    if (joint[p] < 0 || joint[p] >= numJoints())
      throw InputError(where + ": pair " + std::to_string(p) + " names joint " + std::to_string(joint[p]) + " of " +
                       std::to_string(numJoints()));
    if (!(area[p] > 0)) throw InputError(where + ": pair " + std::to_string(p) + " has no tributary area");
  }
}

LiningJoints::LiningJoints(const Solver& solver, JointPairs pairs, JointParams params)
    : solver_(solver), pairs_(std::move(pairs)), params_(params) {
  params_.check();
  pairs_.check("lining joints", solver_.mesh().numNodes());
  const size_t P = size_t(pairs_.size());
  state_.assign(P, std::uint8_t(JointState::Inactive));
  cracked_.assign(P, 0);
  r0_.assign(3 * P, 0.0);
  sp_.assign(3 * P, 0.0);
  force_.assign(3 * P, 0.0);
  relPrev_.assign(3 * P, 0.0);
  // Pairs that share no node are independent within a step: each reads and writes only its own
  // two nodes' forces, so they may be computed on the solver's threads.
  predicted_ = pairs_.nodeA;
  predicted_.insert(predicted_.end(), pairs_.nodeB.begin(), pairs_.nodeB.end());
  disjoint_ = nodesDistinct(predicted_);
  computeOnThreads(P >= kThreadedPairs);
}

void LiningJoints::computeOnThreads(bool on) { workTerm_.assign(on && disjoint_ ? 3 * size_t(pairs_.size()) : 0, 0.0); }

void LiningJoints::relative(Index p, const NodalState& s, Real r[3]) const {
  const Index a = pairs_.nodeA[size_t(p)], b = pairs_.nodeB[size_t(p)];
  for (int d = 0; d < 3; ++d) r[d] = s.u(b, d) - s.u(a, d) - r0_[3 * size_t(p) + d];
}

void LiningJoints::addForces(Real /*t*/, Real dt, NodalState& st) {
  const PairPrediction predict(solver_, dt, st);
  const PredictionTerms* kept = terms_.update(solver_, dt, st, predicted_) ? &terms_ : nullptr;
  stepPairs(
      size_t(pairs_.size()), workTerm_, work_, [&](size_t p, Real* work) { stepPair(p, predict, kept, st, work); },
      [&](size_t p) { return state_[p] != std::uint8_t(JointState::Inactive); });
}

void LiningJoints::stepPair(size_t p, const PairPrediction& predict, const PredictionTerms* terms, NodalState& st,
                            Real* work) {
  const bool leapfrog = predict.leapfrog();
  const Real* u = st.uData();
  Real* fe = st.fExtData();
  const Real* m = st.massData();
  const Index a = pairs_.nodeA[p], b = pairs_.nodeB[p];
  Real* F = &force_[3 * p];
  if (!(m[a] > 0) || !(m[b] > 0)) {  // a side not (yet) in the model
    state_[p] = std::uint8_t(JointState::Inactive);
    for (int d = 0; d < 3; ++d) F[d] = 0;
    return;
  }
  if (state_[p] == std::uint8_t(JointState::Inactive)) {  // installed: unstressed in its current configuration
    for (int d = 0; d < 3; ++d) {
      r0_[3 * p + d] = u[dofIndex(b, d)] - u[dofIndex(a, d)];
      relPrev_[3 * p + d] = -r0_[3 * p + d];
      sp_[3 * p + d] = 0;
      F[d] = 0;
    }
    state_[p] = std::uint8_t(JointState::Closed);
    cracked_[p] = 0;
  }
  Real pred[3], W[3], Fn[3] = {0, 0, 0};
  for (int d = 0; d < 3; ++d) {
    predict.pair(p, size_t(pairs_.size()), a, b, d, terms, pred[d], W[d]);
    pred[d] -= r0_[3 * p + d];
  }
  const Real A = pairs_.area[p];
  const Real kn = params_.normalStiffness * A, ks = params_.shearStiffness * A;
  const Real g = pred[kAxis];
  JointState ns = JointState::Closed;
  Real N = 0;
  if (cracked_[p] && g > 0) {
    ns = JointState::Open;
  } else {
    N = kn * g / (1 + kn * W[kAxis]);  // tension > 0
    if (N > params_.tensileStrength * A && N > 0) {
      ns = JointState::Open;
      cracked_[p] = 1;
      N = 0;
    }
  }
  Fn[kAxis] = N;
  if (ns == JointState::Open) {
    // no shear while open; it takes up again from where the pair closes
    for (int d = 0; d < 3; ++d)
      if (d != kAxis) sp_[3 * p + d] = pred[d];
  } else {
    Real T[3] = {0, 0, 0}, Tm = 0;
    for (int d = 0; d < 3; ++d) {
      if (d == kAxis) continue;
      T[d] = ks * (pred[d] - sp_[3 * p + d]) / (1 + ks * W[d]);
      Tm += T[d] * T[d];
    }
    Tm = std::sqrt(Tm);
    const Real cap = params_.friction >= 0 ? params_.friction * std::max(-N, Real(0)) : -1;
    if (cap >= 0 && Tm > cap) {
      const Real scale = Tm > 0 ? cap / Tm : 0;
      for (int d = 0; d < 3; ++d) {
        if (d == kAxis) continue;
        T[d] *= scale;
        // the slip that leaves the spring at T with the gap it closes to: s_end − T / k_s
        sp_[3 * p + d] = pred[d] - W[d] * T[d] - T[d] / ks;
      }
      ns = JointState::Slipping;
    }
    for (int d = 0; d < 3; ++d)
      if (d != kAxis) Fn[d] = T[d];
  }
  state_[p] = std::uint8_t(ns);
  // Work of the joint forces, booked as the solver books its own (central difference: the
  // trapezoid rule), on the relative motion u_a − u_b.
  for (int d = 0; d < 3; ++d) {
    const Real rel = u[3 * size_t(a) + d] - u[3 * size_t(b) + d];
    const Real dr = rel - relPrev_[3 * p + d];
    const Real term = (leapfrog ? 0.5 * (F[d] + Fn[d]) : F[d]) * dr;
    if (work)
      *work += term;
    else
      workTerm_[3 * p + size_t(d)] = term;
    relPrev_[3 * p + d] = rel;
    F[d] = Fn[d];
    fe[3 * size_t(a) + d] += Fn[d];
    fe[3 * size_t(b) + d] -= Fn[d];
  }
}

std::vector<JointSummary> LiningJoints::summaries(const NodalState& s) const {
  const Index J = numJoints();
  std::vector<JointSummary> out(static_cast<size_t>(J));
  // area-weighted sums per joint: A, A g, A x, A z, A s_x, A s_z; the plane fit's moments
  std::vector<Real> sa(size_t(J), 0), sg(size_t(J), 0), sx(size_t(J), 0), sz(size_t(J), 0), ssx(size_t(J), 0),
      ssz(size_t(J), 0);
  std::vector<char> seen(size_t(J), 0);
  const auto& xyz = solver_.mesh().coords;
  for (Index p = 0; p < numPairs(); ++p) {
    const size_t j = size_t(pairs_.joint[size_t(p)]);
    Real r[3];
    relative(p, s, r);
    const Real A = pairs_.area[size_t(p)];
    const Index a = pairs_.nodeA[size_t(p)];
    JointSummary& o = out[j];
    const Real sl = std::sqrt(r[0] * r[0] + r[2] * r[2]);
    if (!seen[j]) {
      o.openingMax = o.openingMin = r[kAxis];
      seen[j] = 1;
    }
    o.openingMax = std::max(o.openingMax, r[kAxis]);
    o.openingMin = std::min(o.openingMin, r[kAxis]);
    o.slipMax = std::max(o.slipMax, sl);
    o.axialForce += force_[3 * size_t(p) + kAxis];
    sa[j] += A;
    sg[j] += A * r[kAxis];
    sx[j] += A * xyz[3 * size_t(a)];
    sz[j] += A * xyz[3 * size_t(a) + 2];
    ssx[j] += A * r[0];
    ssz[j] += A * r[2];
  }
  // the opening's least-squares plane g = g0 + gx (x − x̄) + gz (z − z̄), area-weighted
  std::vector<Real> mxx(size_t(J), 0), mxz(size_t(J), 0), mzz(size_t(J), 0), mgx(size_t(J), 0), mgz(size_t(J), 0);
  for (Index p = 0; p < numPairs(); ++p) {
    const size_t j = size_t(pairs_.joint[size_t(p)]);
    if (!(sa[j] > 0)) continue;
    Real r[3];
    relative(p, s, r);
    const Real A = pairs_.area[size_t(p)];
    const Index a = pairs_.nodeA[size_t(p)];
    const Real dx = xyz[3 * size_t(a)] - sx[j] / sa[j], dz = xyz[3 * size_t(a) + 2] - sz[j] / sa[j];
    const Real dg = r[kAxis] - sg[j] / sa[j];
    mxx[j] += A * dx * dx;
    mxz[j] += A * dx * dz;
    mzz[j] += A * dz * dz;
    mgx[j] += A * dx * dg;
    mgz[j] += A * dz * dg;
  }
  for (size_t j = 0; j < size_t(J); ++j) {
    if (!(sa[j] > 0)) continue;
    JointSummary& o = out[j];
    o.opening = sg[j] / sa[j];
    o.slip = std::hypot(ssx[j], ssz[j]) / sa[j];
    const Real det = mxx[j] * mzz[j] - mxz[j] * mxz[j];
    if (det > 0) {
      o.rotationX = (mgx[j] * mzz[j] - mgz[j] * mxz[j]) / det;
      o.rotationZ = (mgz[j] * mxx[j] - mgx[j] * mxz[j]) / det;
    }
  }
  return out;
}

}  // namespace tq
