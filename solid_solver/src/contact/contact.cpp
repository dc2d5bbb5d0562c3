// The rock–lining dynamic contact force (paper eqs. 9–13; docs/theory.md §4).
#include "tq/contact/contact.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tq/contact/pair_prediction.hpp"

namespace tq {

InterfaceModel parseInterfaceModel(const std::string& n) {
  if (n == "dynamic_contact") return InterfaceModel::DynamicContact;
  if (n == "bonded") return InterfaceModel::Bonded;
  throw InputError("interface model '" + n +
                   "' is unknown; use dynamic_contact (the paper's eqs. 9-13: bond, separation, slip) or "
                   "bonded (the pairs never fail)");
}

AfterFailure parseAfterFailure(const std::string& n) {
  if (n == "cohesion_lost") return AfterFailure::CohesionLost;
  if (n == "cohesion_kept") return AfterFailure::CohesionKept;
  throw InputError("after_failure '" + n +
                   "' is unknown; use cohesion_lost (default: a failed pair keeps only friction) or "
                   "cohesion_kept (f_c A stays in the checks)");
}

std::string interfaceModelName(InterfaceModel m) {
  return m == InterfaceModel::DynamicContact ? "dynamic_contact" : "bonded";
}
std::string afterFailureName(AfterFailure a) {
  return a == AfterFailure::CohesionLost ? "cohesion_lost" : "cohesion_kept";
}

void ContactParams::check() const {
  auto bad = [](const std::string& what, Real v, const std::string& fix) {
    std::ostringstream os;
    os << "interface: " << what << " = " << v << " is invalid; " << fix;
    throw InputError(os.str());
  };
  if (!(staticFriction >= 0) || !std::isfinite(staticFriction))
    bad("static_friction", staticFriction, "give μs >= 0 (paper: 0.6)");
  if (!(dynamicFriction >= 0) || !(dynamicFriction <= staticFriction))
    bad("dynamic_friction", dynamicFriction, "give 0 <= μd <= μs (paper: both 0.6)");
  if (!(cohesion >= 0) || !std::isfinite(cohesion)) bad("cohesion", cohesion, "give f_c in Pa (>= 0; paper: 0.5e6)");
}

ContactPairs rockLiningPairs(const Mesh& mesh) {
  const size_t P = mesh.rockLiningPairs.size() / 2;
  const std::string where = "rock-lining interface of mesh " + mesh.source;
  if (P == 0)
    throw InputError(where +
                     ": the mesh has no node pairs (/interfaces/rock_lining); re-mesh with the "
                     "interface pairs or use a model without the interface");
  std::string face;
  Real sign = 1;
  bool onLining = true;
  if (mesh.faces.count(face_group::kLiningOuter)) {
    face = face_group::kLiningOuter;
  } else if (mesh.faces.count(face_group::kRockHole)) {
    face = face_group::kRockHole;
    sign = -1;  // rock_hole's outward normal points into the hole, i.e. from rock to lining
    onLining = false;
  } else {
    throw InputError(where +
                     ": needs the face group lining_outer (or rock_hole) for the pairs' normals and "
                     "tributary areas; it must be a physical group written to /faces/<name>");
  }
  const Index N = mesh.numNodes();
  std::vector<Real> area(size_t(N), 0.0), nsum(3 * size_t(N), 0.0);
  const auto& q = mesh.faces.at(face);
  for (size_t f = 0; f < q.size() / 4; ++f) {
    Real av[3];  // the quad's area vector (outward for counter-clockwise nodes seen from outside)
    quadAreaVector(mesh, &q[4 * f], av);
    const Real a = std::sqrt(av[0] * av[0] + av[1] * av[1] + av[2] * av[2]);
    for (int k = 0; k < 4; ++k) {
      const size_t n = size_t(q[4 * f + k]);
      area[n] += 0.25 * a;
      for (int i = 0; i < 3; ++i) nsum[3 * n + i] += av[i];
    }
  }
  Real lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (Index n = 0; n < N; ++n)
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], mesh.coords[dofIndex(n, i)]);
      hi[i] = std::max(hi[i], mesh.coords[dofIndex(n, i)]);
    }
  const Real size = std::sqrt(std::pow(hi[0] - lo[0], 2) + std::pow(hi[1] - lo[1], 2) + std::pow(hi[2] - lo[2], 2));
  ContactPairs pr;
  pr.node1.resize(P);
  pr.node2.resize(P);
  pr.normal.resize(3 * P);
  pr.area.resize(P);
  for (size_t p = 0; p < P; ++p) {
    const Index a = mesh.rockLiningPairs[2 * p], b = mesh.rockLiningPairs[2 * p + 1];
    pr.node1[p] = a;
    pr.node2[p] = b;
    Real dist = 0;
    for (int i = 0; i < 3; ++i) dist += std::pow(mesh.coords[dofIndex(a, i)] - mesh.coords[dofIndex(b, i)], 2);
    if (std::sqrt(dist) > 1e-9 * size) {
      std::ostringstream os;
      os << where << ": pair " << p << " (rock node " << a << ", lining node " << b << ") is " << std::sqrt(dist)
         << " m apart; the pairs must be coincident duplicated nodes";
      throw InputError(os.str());
    }
    const size_t n = size_t(onLining ? b : a);
    const Real len =
        std::sqrt(nsum[3 * n] * nsum[3 * n] + nsum[3 * n + 1] * nsum[3 * n + 1] + nsum[3 * n + 2] * nsum[3 * n + 2]);
    if (!(area[n] > 0) || !(len > 0)) {
      std::ostringstream os;
      os << where << ": pair " << p << " node " << n << " lies on no quad of face group " << face
         << " (no normal, no tributary area); the pairs must be the nodes of that face";
      throw InputError(os.str());
    }
    for (int i = 0; i < 3; ++i) pr.normal[3 * p + i] = sign * nsum[3 * n + i] / len;
    pr.area[p] = area[n];
  }
  return pr;
}

DynamicContact::DynamicContact(const Solver& solver, ContactPairs pairs, ContactParams params)
    : solver_(solver), pairs_(std::move(pairs)), params_(params) {
  params_.check();
  const size_t P = size_t(pairs_.size());
  if (pairs_.node2.size() != P || pairs_.normal.size() != 3 * P || pairs_.area.size() != P)
    throw InputError("dynamic contact: inconsistent pair arrays");
  state_.assign(P, std::uint8_t(PairState::Inactive));
  failed_.assign(P, 0);
  cohesive_.assign(P, 1);
  r0_.assign(3 * P, 0.0);
  force_.assign(3 * P, 0.0);
  relPrev_.assign(3 * P, 0.0);
  fn_.assign(P, 0.0);
  ft_.assign(P, 0.0);
  // Pairs that share no node are independent within a step: each reads and writes only its own
  // two nodes' forces, so they may be computed on the solver's threads.
  std::vector<Index> nodes(pairs_.node1.begin(), pairs_.node1.end());
  nodes.insert(nodes.end(), pairs_.node2.begin(), pairs_.node2.end());
  predicted_ = nodes;
  disjoint_ = nodesDistinct(std::move(nodes));
  computeOnThreads(P >= kThreadedPairs);
}

void DynamicContact::computeOnThreads(bool on) {
  const size_t P = size_t(pairs_.size());
  workTerm_.assign(on && disjoint_ ? 3 * P : 0, 0.0);
}

Index DynamicContact::count(PairState s) const {
  return Index(std::count(state_.begin(), state_.end(), std::uint8_t(s)));
}

void DynamicContact::gatheredPair(Index p, Real* out) const {
  const size_t i = size_t(p);
  out[0] = state_[i];
  out[1] = failed_[i];
  for (int d = 0; d < 3; ++d) out[2 + d] = r0_[3 * i + size_t(d)];
  out[5] = fn_[i];
  out[6] = ft_[i];
}

void DynamicContact::setGatheredPair(Index p, const Real* in) {
  const size_t i = size_t(p);
  state_[i] = std::uint8_t(in[0]);
  failed_[i] = std::uint8_t(in[1]);
  for (int d = 0; d < 3; ++d) r0_[3 * i + size_t(d)] = in[2 + d];
  fn_[i] = in[5];
  ft_[i] = in[6];
}

Real DynamicContact::opening(Index p, const NodalState& s) const {
  const Index a = pairs_.node1[size_t(p)], b = pairs_.node2[size_t(p)];
  const Real* n = &pairs_.normal[3 * size_t(p)];
  Real g = 0;
  for (int d = 0; d < 3; ++d) g += n[d] * (s.u(b, d) - s.u(a, d) - r0_[dofIndex(p, d)]);
  return -g;
}

Real DynamicContact::slip(Index p, const NodalState& s) const {
  const Index a = pairs_.node1[size_t(p)], b = pairs_.node2[size_t(p)];
  const Real* n = &pairs_.normal[3 * size_t(p)];
  Real r[3], rn = 0;
  for (int d = 0; d < 3; ++d) {
    r[d] = s.u(b, d) - s.u(a, d) - r0_[dofIndex(p, d)];
    rn += n[d] * r[d];
  }
  Real t2 = 0;
  for (int d = 0; d < 3; ++d) t2 += std::pow(r[d] - rn * n[d], 2);
  return std::sqrt(t2);
}

void DynamicContact::addForces(Real /*t*/, Real dt, NodalState& st) {
  const PairPrediction predict(solver_, dt, st);
  const PredictionTerms* kept = terms_.update(solver_, dt, st, predicted_) ? &terms_ : nullptr;
  // on ranks, the pairs another rank counts (counted_) add no work here, in either loop
  stepPairs(
      size_t(pairs_.size()), workTerm_, work_, [&](size_t p, Real* work) { stepPair(p, predict, kept, st, work); },
      [&](size_t p) { return state_[p] != std::uint8_t(PairState::Inactive) && (counted_.empty() || counted_[p]); });
}

void DynamicContact::stepPair(size_t p, const PairPrediction& predict, const PredictionTerms* terms, NodalState& st,
                              Real* work) {
  const bool leapfrog = predict.leapfrog();
  const Real* u = st.uData();
  Real* fe = st.fExtData();
  const Real* m = st.massData();
  const Real mus = params_.staticFriction, mud = params_.dynamicFriction;
  const bool dynamic = params_.model == InterfaceModel::DynamicContact;
  const Index a = pairs_.node1[p], b = pairs_.node2[p];
  Real* R = &force_[3 * p];
  if (!(m[a] > 0) || !(m[b] > 0)) {  // a side not (yet) in the model
    state_[p] = std::uint8_t(PairState::Inactive);
    for (int d = 0; d < 3; ++d) R[d] = 0;
    fn_[p] = ft_[p] = 0;
    return;
  }
  if (state_[p] == std::uint8_t(PairState::Inactive)) {
    // Becomes active (both sides installed): bonded in the current configuration.
    for (int d = 0; d < 3; ++d) {
      r0_[3 * p + d] = u[dofIndex(b, d)] - u[dofIndex(a, d)];
      relPrev_[3 * p + d] = u[dofIndex(a, d)] - u[dofIndex(b, d)];
      R[d] = 0;
    }
    state_[p] = std::uint8_t(PairState::Bonded);
    failed_[p] = 0;
    cohesive_[p] = 1;
  }
  // Work of the previous force over the last increment (the solver books the same terms).
  Real rel[3], Rnew[3] = {0, 0, 0};
  for (int d = 0; d < 3; ++d) rel[d] = u[dofIndex(a, d)] - u[dofIndex(b, d)];
  const Real* n = &pairs_.normal[3 * p];
  Real pred[3], cur[3], W[3];
  for (int d = 0; d < 3; ++d) {
    predict.pair(p, size_t(pairs_.size()), a, b, d, terms, pred[d], W[d]);
    pred[d] -= r0_[3 * p + d];
    cur[d] = -rel[d] - r0_[3 * p + d];
  }
  const Real gapN = n[0] * pred[0] + n[1] * pred[1] + n[2] * pred[2];  // Δ1n of eq. (10)
  // Gap to be closed: the whole predicted offset while the bond is intact; else the normal gap
  // and the increment of the tangential relative displacement (eq. 10).
  Real delta[3];
  if (!failed_[p]) {
    for (int d = 0; d < 3; ++d) delta[d] = pred[d];
  } else {
    Real inc[3], incN = 0;
    for (int d = 0; d < 3; ++d) {
      inc[d] = pred[d] - cur[d];
      incN += n[d] * inc[d];
    }
    for (int d = 0; d < 3; ++d) delta[d] = gapN * n[d] + inc[d] - incN * n[d];
  }
  Real Rt[3];  // trial force on node 1 that closes the gap (eq. 11 with K_d = 1/(w1+w2))
  for (int d = 0; d < 3; ++d) Rt[d] = W[d] > 0 ? delta[d] / W[d] : 0.0;
  const Real N = n[0] * Rt[0] + n[1] * Rt[1] + n[2] * Rt[2];
  Real T[3], Tm = 0;
  for (int d = 0; d < 3; ++d) {
    T[d] = Rt[d] - N * n[d];
    Tm += T[d] * T[d];
  }
  Tm = std::sqrt(Tm);
  PairState ns;
  bool fail = false;
  const Real cA = cohesive_[p] ? params_.cohesion * pairs_.area[p] : 0.0;
  auto stick = [&] {
    for (int d = 0; d < 3; ++d) Rnew[d] = Rt[d];
    return cohesive_[p] ? PairState::Bonded : PairState::Stuck;
  };
  if (!dynamic) {
    ns = stick();
  } else if (gapN < 0) {  // opening: tension
    if (state_[p] == std::uint8_t(PairState::Separated) || -N > cA || Tm > cA + mus * N) {
      ns = PairState::Separated;  // eq. (12): N = T = 0
      fail = state_[p] != std::uint8_t(PairState::Separated);
    } else {
      ns = stick();
    }
  } else {  // closing or closed: compression, no penetration
    const Real Nc = std::max(N, Real(0));
    if (Tm <= mus * Nc + cA) {
      ns = stick();
    } else {  // eq. (13): slides with |T| = μd N along the trial direction
      for (int d = 0; d < 3; ++d) Rnew[d] = N * n[d] + mud * Nc * T[d] / Tm;
      ns = PairState::Slipping;
      fail = true;
    }
  }
  if (fail) {
    failed_[p] = 1;
    if (params_.afterFailure == AfterFailure::CohesionLost) cohesive_[p] = 0;
    if (ns == PairState::Bonded) ns = PairState::Stuck;
  }
  state_[p] = std::uint8_t(ns);
  Real Rn = 0;
  for (int d = 0; d < 3; ++d) Rn += n[d] * Rnew[d];
  Real rt2 = 0;
  for (int d = 0; d < 3; ++d) rt2 += std::pow(Rnew[d] - Rn * n[d], 2);
  fn_[p] = Rn;
  ft_[p] = std::sqrt(rt2);
  // Work of the contact forces: ½(R^{n−1} + R^n)·Δ(u1 − u2) (central difference, as the
  // solver's trapezoid rule books it), R^{n−1}·Δ(u1 − u2) for the literal eqs. (3)–(4).
  const bool counted = counted_.empty() || counted_[p];
  for (int d = 0; d < 3; ++d) {
    const Real dr = rel[d] - relPrev_[3 * p + d];
    const Real term = (leapfrog ? 0.5 * (R[d] + Rnew[d]) : R[d]) * dr;
    if (work) {
      if (counted) *work += term;
    } else {
      workTerm_[3 * p + size_t(d)] = term;
    }
    relPrev_[3 * p + d] = rel[d];
    R[d] = Rnew[d];
    fe[dofIndex(a, d)] += Rnew[d];
    fe[dofIndex(b, d)] -= Rnew[d];
  }
}

}  // namespace tq
