// The staged analysis (tq/app/stages.hpp; docs/solid_solver.md "Staged initial state").
#include "tq/app/stages.hpp"

#include "tq/contact/contact.hpp"
#include "tq/contact/joints.hpp"
#include "tq/elements/hex8.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace tq {

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

Real zTopOf(const Mesh& m) {
  Real z = -std::numeric_limits<Real>::max();
  for (Index n = 0; n < m.numNodes(); ++n) z = std::max(z, m.coords[dofIndex(n, 2)]);
  return z;
}

Real zBottomOf(const Mesh& m) {
  Real z = std::numeric_limits<Real>::max();
  for (Index n = 0; n < m.numNodes(); ++n) z = std::min(z, m.coords[dofIndex(n, 2)]);
  return z;
}

}  // namespace

PrescribedSlip::PrescribedSlip(const FaultOffsetInput& in, const NodalState& state)
    : nodes_(in.nodes), d_(in.displacement), u0_(3 * in.nodes.size()), t0_(in.startTime), rise_(in.riseTime) {
  for (size_t i = 0; i < nodes_.size(); ++i)
    for (int d = 0; d < 3; ++d) u0_[3 * i + d] = state.u(nodes_[i], d);
}

Real PrescribedSlip::ramp(Real t) const {
  if (t <= t0_) return 0;
  if (t >= t0_ + rise_) return 1;
  return 0.5 * (1 - std::cos(M_PI * (t - t0_) / rise_));
}

void PrescribedSlip::addForces(Real t, Real dt, NodalState& state) {
  const Real r = ramp(t + dt);
  for (size_t i = 0; i < nodes_.size(); ++i)
    for (int d = 0; d < 3; ++d) state.u(nodes_[i], d) = u0_[3 * i + d] + r * d_[3 * i + d];
}

void HeldExcavationLoad::addForces(Real, Real, NodalState& state) {
  if (released_) return;
  Real* fe = state.fExtData();
  const size_t n = std::min(f_.size(), 3 * size_t(state.numNodes()));
  for (size_t i = 0; i < n; ++i) fe[i] += f_[i];
}

StagedAnalysis::StagedAnalysis(const SolidInput& in, const Mesh& mesh, Solver& solver, const RankPart* part)
    : in_(in),
      mesh_(mesh),
      model_(part ? *part->global : mesh),
      solver_(solver),
      part_(part ? std::make_unique<RankPart>(*part) : nullptr) {
  const StagedInput& S = in.staged;
  if (!S.present) throw InputError("solid input '" + in.path + "': no stages (version 1 input)");
  const Real lambda = S.stages.releaseFraction;
  if (!(lambda >= 0 && lambda <= 1))
    throw InputError("solid input '" + in.path + "', /stages: release_fraction = " + std::to_string(lambda) +
                     " must lie in [0, 1]");
  if (lambda < 1 && !(S.stages.has("excavation") && S.stages.has("lining")))
    throw InputError("solid input '" + in.path +
                     "', /stages: release_fraction < 1 holds part of the excavation "
                     "load until the lining stage: the sequence needs both 'excavation' and 'lining'");
  for (auto& b : solver_.blocks())
    if (b->name() == S.stages.liningRegion) linings_.push_back(b.get());
  if (const Index r = model_.regionIndex(S.stages.liningRegion); r >= 0)
    hasLining_ = std::find(model_.region.begin(), model_.region.end(), r) != model_.region.end();
  if (S.drm.present()) {
    try {
      drm_ = std::make_shared<DomainReduction>(mesh_, solver_.blocks(), S.drm, solver_.options().damping.beta);
    } catch (const InputError& e) {
      throw InputError("solid input '" + in.path + "', " + e.what());
    }
  }
  const bool liningStage = S.stages.has("lining");
  if (liningStage) {
    if (!hasLining_)
      throw InputError("solid input '" + in.path + "', /stages: the lining stage needs region '" +
                       S.stages.liningRegion + "' in mesh " + model_.source +
                       " (set lining_region or remove the stage)");
    if (model_.rockLiningPairs.empty())
      throw InputError("mesh " + model_.source +
                       " has no /interfaces/rock_lining node pairs, which the lining "
                       "stage needs to join the lining to the rock");
  }
  if (S.faultOffset.present)
    for (Index n : S.faultOffset.nodes)
      if (n < 0 || n >= model_.numNodes())
        throw InputError("solid input '" + in.path + "', /fault_offset: node " + std::to_string(n) +
                         " is not a node of mesh " + model_.source + " (" + std::to_string(model_.numNodes()) +
                         " nodes); rewrite the input from its mesh");
  if (S.stages.has("hydrostatic") && !model_.faces.count(S.hydrostatic.face))
    model_.faceNodes(S.hydrostatic.face);  // throws the missing-group message
  if (S.stages.has("seismic")) {
    if (S.bottom.present) axisFace(model_, S.bottom.face);  // throws if missing or not a plane
    for (const auto& f : S.freeField.faces) axisFace(model_, f);
    for (const auto& f : S.freeField.sharedColumnFaces) axisFace(model_, f);
  }
}

void StagedAnalysis::sumRanks(Real* v, int n) const {
  if (RankExchange* rx = solver_.rankExchange()) rx->sumAll(v, n);
}

std::vector<Real> StagedAnalysis::toLocal(const std::vector<Real>& global) const {
  if (!part_) return global;
  std::vector<Real> f(3 * size_t(mesh_.numNodes()), 0.0);
  const std::vector<Index>& loc = *part_->localNode;
  for (size_t n = 0; n < loc.size(); ++n)
    if (loc[n] >= 0)
      for (size_t d = 0; d < 3; ++d) f[3 * size_t(loc[n]) + d] = global[3 * n + d];
  return f;
}

bool StagedAnalysis::isLining(const ElementBlock* b) const {
  return std::find(linings_.begin(), linings_.end(), b) != linings_.end();
}

namespace {

/// The ground's density profile for the overburden: each region outside the lining occupies the
/// heights of its elements, and where regions share a height they must have the same density
/// (horizontal layers do; a region beside another of another density has no single overburden).
/// The overburden at z is then q + g ∫_z^{z_top} ρ(ζ) dζ, the highest region's density carried up
/// to z_top when the ground surface lies above the mesh, and a gap between regions taking the
/// density of the region above it.
struct OverburdenProfile {
  struct Band {
    Real lo, hi, rho;
    std::string region;
  };
  std::vector<Band> bands;  // disjoint, sorted from the top down

  Real integral(Real z, Real zTop) const {
    Real s = 0, above = zTop;
    for (size_t i = 0; i < bands.size() && above > z; ++i) {
      const Band& b = bands[i];
      // From `above` down to this band's top: above the mesh (the top band's density) or a gap
      // (the density of the band above it).
      const Real fill = i == 0 ? b.rho : bands[i - 1].rho;
      if (above > b.hi) s += fill * (above - std::max(b.hi, z));
      const Real hi = std::min(b.hi, above);
      if (hi > z) s += b.rho * (hi - std::max(b.lo, z));
      above = std::min(above, b.lo);
    }
    if (above > z && !bands.empty()) s += bands.back().rho * (above - z);
    return s;
  }
};

/// The heights a ground region's elements span, and its density.
struct HeightRange {
  Real lo, hi, rho;
  std::string name;
};

OverburdenProfile overburdenProfile(const std::vector<HeightRange>& ranges) {
  using Range = HeightRange;
  Real span = 0;
  for (const Range& r : ranges) span = std::max(span, r.hi - r.lo);
  const Real tol = 1e-9 * std::max(1.0, span);
  // Cut the heights at every region's ends; each piece takes the density of the regions over it.
  std::vector<Real> cuts;
  for (const Range& r : ranges) {
    cuts.push_back(r.lo);
    cuts.push_back(r.hi);
  }
  std::sort(cuts.begin(), cuts.end(), std::greater<Real>());
  OverburdenProfile p;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    const Real hi = cuts[i], lo = cuts[i + 1];
    if (hi - lo <= tol) continue;
    const Real mid = 0.5 * (hi + lo);
    const Range* have = nullptr;
    for (const Range& r : ranges) {
      if (!(r.lo < mid && mid < r.hi)) continue;
      if (have && std::abs(have->rho - r.rho) > 1e-9 * have->rho) {
        std::ostringstream os;
        os << "in-situ stress: regions '" << have->name << "' (density " << have->rho << " kg/m³) and '" << r.name
           << "' (" << r.rho << " kg/m³) share the heights around z = " << mid
           << " m, so the overburden is not one number there: the ground's regions must be horizontal layers, "
              "or give one overburden density (/in_situ density)";
        throw InputError(os.str());
      }
      have = &r;
    }
    if (have) p.bands.push_back({lo, hi, have->rho, have->name});
  }
  return p;
}

}  // namespace

void StagedAnalysis::setInSituStress() {
  const InSituInput& I = in_.staged.inSitu;
  const Real zTop = std::isfinite(I.zTop) ? I.zTop : zTopOf(model_);
  // One overburden density for all (/in_situ density), or the layered profile of the regions: the
  // heights of each block's elements (on ranks: of each region's, over every rank).
  OverburdenProfile profile;
  if (!(I.density > 0)) {
    constexpr Real kFar = std::numeric_limits<Real>::max();
    std::vector<HeightRange> ranges;
    const auto span = [&](const ElementBlock& b, HeightRange& r) {
      for (Index e = 0; e < b.numElems(); ++e)
        for (int k = 0; k < 8; ++k) {
          const Real z = mesh_.coords[dofIndex(b.node(e, k), 2)];
          r.lo = std::min(r.lo, z);
          r.hi = std::max(r.hi, z);
        }
    };
    if (!part_) {
      for (const auto& b : solver_.blocks())
        if (!isLining(b.get()) && b->numElems() > 0) {
          HeightRange r{kFar, -kFar, b->material().density(), b->name()};
          span(*b, r);
          ranges.push_back(r);
        }
    } else {
      RankExchange& rx = *solver_.rankExchange();
      for (size_t g = 0; g < model_.regionNames.size(); ++g) {
        const std::string& name = model_.regionNames[g];
        if (name == in_.staged.stages.liningRegion) continue;
        HeightRange r{kFar, -kFar, 0, name};
        for (const auto& b : solver_.blocks())
          if (b->name() == name) {
            r.rho = b->material().density();
            span(*b, r);
          }
        r.lo = rx.minAll(r.lo);
        r.hi = rx.maxAll(r.hi);
        r.rho = rx.maxAll(r.rho);
        if (r.lo <= r.hi) ranges.push_back(r);
      }
    }
    profile = overburdenProfile(ranges);
  }
  for (auto& b : solver_.blocks()) {
    if (isLining(b.get())) continue;
    for (Index e = 0; e < b->numElems(); ++e) {
      Real zc = 0;
      for (int k = 0; k < 8; ++k) zc += 0.125 * mesh_.coords[dofIndex(b->node(e, k), 2)];
      // Overburden, tension positive: σv = −(q + g ∫_z^{z_top} ρ dζ).
      const Real load = I.density > 0 ? I.density * (zTop - zc) : profile.integral(zc, zTop);
      const Real sv = -(I.surcharge + I.gravity * load);
      b->setStress(e, XX, I.kx * sv);
      b->setStress(e, YY, I.ky * sv);
      b->setStress(e, ZZ, I.kz * sv);
      b->setStress(e, XY, 0);
      b->setStress(e, YZ, 0);
      b->setStress(e, ZX, 0);
    }
  }
}

StageReport StagedAnalysis::relaxStage(const std::string& name, std::ostream& log, double progressSeconds) {
  const StagesInput& st = in_.staged.stages;
  StageReport rep;
  rep.name = name;
  const double t0 = now();
  double last = t0;
  Index lastSteps = 0;
  Real lastRatio = 0;
  RelaxParams rp;
  rp.tolerance = st.tolerance;
  rp.maxSteps = st.maxSteps;
  rp.massScaling = st.massScaling;
  // The ratio at each check, for the trend said when the stage does not converge.
  std::vector<std::pair<Index, Real>> history;
  rp.onCheck = [&](const RelaxResult& r) {
    history.emplace_back(r.steps, r.ratio);
    const double t = now();
    if (t - last < progressSeconds || r.converged) return;
    // ETA from the recent convergence rate of log(ratio) per step.
    std::ostringstream eta;
    if (lastRatio > 0 && r.ratio < lastRatio && r.ratio > 0) {
      const double perStep = std::log(lastRatio / r.ratio) / double(r.steps - lastSteps);
      const double stepsLeft = std::log(r.ratio / st.tolerance) / perStep;
      const double rate = double(r.steps - lastSteps) / (t - last);
      eta << ", ETA " << std::setprecision(2) << stepsLeft / rate << " s";
    }
    log << "  stage " << name << ": step " << r.steps << ", unbalanced ratio " << std::setprecision(3) << r.ratio
        << " (tolerance " << st.tolerance << "), " << std::setprecision(4) << double(r.steps - lastSteps) / (t - last)
        << " steps/s" << eta.str() << std::endl;
    last = t;
    lastSteps = r.steps;
    lastRatio = r.ratio;
  };
  // Start each stage from rest: the previous relaxation leaves velocities of the order of its
  // residual.
  NodalState& s = solver_.state();
  for (Index n = 0; n < s.numNodes(); ++n)
    for (int d = 0; d < 3; ++d) s.v(n, d) = 0;
  // The reference of the ratio: the out-of-balance force this stage starts from (its load: the
  // released core tractions, the lining's weight, the water pressure), but at least 1e-6 of the
  // model's force scale (so a stage that adds no load does not chase round-off).
  solver_.computeForces(true);
  Real f2[2] = {0, 0};  // |f_int|², |f_ext|²
  for (Index i = 0; i < 3 * s.numNodes(); ++i) {
    if (!counts(i / 3)) continue;
    f2[0] += s.fIntData()[i] * s.fIntData()[i];
    f2[1] += s.fExtData()[i] * s.fExtData()[i];
  }
  sumRanks(f2, 2);
  const Real r0 = solver_.residualNorm(), scale = std::sqrt(std::max(f2[0], f2[1]));
  rp.referenceForce = std::max({r0, 1e-6 * scale, std::numeric_limits<Real>::min()});
  const RelaxResult r = solver_.relax(rp);
  rep.steps = r.steps;
  rep.ratio = r.ratio;
  rep.converged = r.converged;
  rep.wallSeconds = now() - t0;
  log << "  stage " << name << ": equilibrium " << (r.converged ? "reached" : "NOT reached") << " after " << r.steps
      << " relaxation steps, unbalanced-force ratio " << std::setprecision(3) << r.ratio << " (tolerance "
      << st.tolerance << "), " << std::setprecision(3) << rep.wallSeconds << " s" << std::endl;
  if (!r.converged) throw InstabilityError(notInEquilibrium(name, r, history));
  return rep;
}

std::string StagedAnalysis::notInEquilibrium(const std::string& name, const RelaxResult& r,
                                             const std::vector<std::pair<Index, Real>>& history) {
  const StagesInput& st = in_.staged.stages;
  // Where the unbalanced force f_ext - f_int (free dofs) is, region by region, taken at rest.
  solver_.computeForces(true);
  const NodalState& s = solver_.state();
  const Index N = s.numNodes();
  // Each node's region: that of the first block (in block order) with an element on it.
  std::vector<int> region(size_t(N), -1);
  const auto& blocks = solver_.blocks();
  const size_t R = mesh_.regionNames.size();
  for (size_t b = 0; b < blocks.size(); ++b)
    for (Index e = 0; e < blocks[b]->numElems(); ++e)
      for (int k = 0; k < 8; ++k) {
        int& g = region[size_t(blocks[b]->node(e, k))];
        if (g < 0) g = int(mesh_.region[size_t(blocks[b]->meshElem(e))]);
      }
  std::vector<Real> share(R + 1, 0.0);  // per region, then the total
  Real largest = -1;
  Index at = 0;
  for (Index n = 0; n < N; ++n) {
    if (!counts(n)) continue;
    Real r2 = 0;
    for (int d = 0; d < 3; ++d) {
      if (solver_.isFixed(n, d)) continue;
      const size_t i = dofIndex(n, d);
      const Real f = s.fExtData()[i] - s.fIntData()[i];
      r2 += f * f;
    }
    share[R] += r2;
    if (region[size_t(n)] >= 0) share[size_t(region[size_t(n)])] += r2;
    if (r2 > largest) largest = r2, at = n;
  }
  // The largest nodal force's place: x, y, z and region (on ranks: of the rank that holds the
  // largest, the lowest such rank).
  Real where[4] = {0, 0, 0, -1};
  if (largest >= 0)
    for (int d = 0; d < 3; ++d) where[d] = mesh_.coords[3 * size_t(at) + size_t(d)];
  if (largest >= 0) where[3] = region[size_t(at)];
  if (RankExchange* rx = solver_.rankExchange()) {
    sumRanks(share.data(), int(share.size()));
    const Real top = rx->maxAll(largest);
    const int first = int(rx->minAll(largest == top ? Real(part_->rank) : Real(1e9)));
    Real mine[5] = {0, 0, 0, 0, 0};
    if (part_->rank == first) mine[0] = where[0], mine[1] = where[1], mine[2] = where[2], mine[3] = where[3] + 1;
    sumRanks(mine, 4);
    where[0] = mine[0], where[1] = mine[1], where[2] = mine[2], where[3] = mine[3] - 1;
    largest = top;
  }
  const Real total = share[R];
  share.pop_back();
  std::ostringstream os;
  os << std::setprecision(3) << "stage '" << name << "' did not reach static equilibrium in " << r.steps
     << " relaxation steps (unbalanced-force ratio " << r.ratio << ", tolerance " << st.tolerance << "). ";
  if (total > 0) {
    const size_t worst = size_t(std::max_element(share.begin(), share.end()) - share.begin());
    const Real* x = where;
    const int g = int(where[3]);
    os << "Not in equilibrium: the " << (g >= 0 ? mesh_.regionNames[size_t(g)] : std::string("mesh"))
       << " near (x, y, z) = (" << x[0] << ", " << x[1] << ", " << x[2] << ") m, the largest unbalanced nodal force ("
       << std::sqrt(largest) << " N); the " << mesh_.regionNames[worst] << " holds " << std::fixed
       << std::setprecision(0) << 100 * share[worst] / total << " % of the unbalance. " << std::defaultfloat
       << std::setprecision(3);
  }
  // The trend over the second half of the steps: still falling (more steps reach it), or not.
  Real half = history.empty() ? r.ratio : history.front().second;
  for (const auto& [steps, ratio] : history)
    if (steps <= r.steps / 2) half = ratio;
  if (half > 0 && r.ratio < 0.5 * half) {
    const double perStep = std::log(half / r.ratio) / double(r.steps - r.steps / 2);
    const double more = std::log(r.ratio / st.tolerance) / perStep;
    // the steps to the tolerance at the recent rate, 20 % on top, rounded up to a hundred
    const Index enough = Index(std::ceil((double(r.steps) + 1.2 * more) / 100.0)) * 100;
    os << "The ratio was still falling (" << half << " -> " << r.ratio << " over the last " << r.steps - r.steps / 2
       << " steps): raise stages.relaxation_max_steps to about " << enough << ".";
  } else {
    os << "The ratio did not fall over the last " << r.steps - r.steps / 2 << " steps (" << half << " -> " << r.ratio
       << "): that part keeps moving under this stage's load - a part free to move as a rigid body (check the "
          "supports), or ground or lining yielding without end (check its strength against the load there).";
  }
  os << " (docs/solid_solver.md \"Staged initial state\")";
  return os.str();
}

void StagedAnalysis::installInterface(std::ostream& log, StageReport& rep) {
  if (in_.staged.liningJoints.present) {
    if (part_)  // a joint's pairs are read by global node number and predicted from one whole state
      throw InputError("solid input '" + in_.path +
                       "', /lining_joints: the lining's joints do not run on ranks; run without --distributed");
    // The lining's joints first: their forces are among the lining's when the rock-lining
    // interface (contact or tie, same phase) predicts or shares its pairs' motion.
    auto j =
        std::make_shared<LiningJoints>(solver_, readJointPairs(in_.meshPath), jointParamsFrom(in_.staged.liningJoints));
    solver_.addContributor(ForcePhase::Interface, j);
    log << "  lining joints: " << j->numJoints() << " joints, " << j->numPairs() << " node pairs" << std::endl;
  }
  const InterfaceInput& R = in_.staged.rockLining;
  if (R.present && R.model == "dynamic_contact") {
    // The paper's dynamic contact force method (eqs. 9-13, tq/contact/contact.hpp): each pair bonds in
    // its current configuration once both sides have mass, then separates or slips.
    // On ranks: the pairs this rank holds (both nodes, or neither: the layout holds a pair's nodes
    // together), each computed by every rank that holds it and counted by the owner of its rock node.
    ContactPairs all = rockLiningPairs(model_), pairs;
    if (!part_) {
      pairs = all;
    } else {
      for (Index p = 0; p < all.size(); ++p) {
        const Index a = local(all.node1[size_t(p)]), b = local(all.node2[size_t(p)]);
        if ((a < 0) != (b < 0))
          throw std::logic_error("rock-lining pair " + std::to_string(p) + " is held by halves on a rank");
        if (a < 0) continue;
        pairs.node1.push_back(a);
        pairs.node2.push_back(b);
        for (int d = 0; d < 3; ++d) pairs.normal.push_back(all.normal[3 * size_t(p) + size_t(d)]);
        pairs.area.push_back(all.area[size_t(p)]);
        contactPairIndex_.push_back(p);
        contactPairOwned_.push_back(counts(a) ? 1 : 0);
      }
    }
    auto c = std::make_shared<DynamicContact>(solver_, std::move(pairs), contactParamsFrom(R));
    if (part_) c->countOnly(contactPairOwned_);
    solver_.addContributor(ForcePhase::Interface, c);
    interface_ = c;
    rep.note = "rock-lining interface: dynamic contact (" + std::to_string(all.size()) + " pairs)";
    log << "  " << rep.note << std::endl;
    return;
  }
  std::vector<std::vector<Index>> groups = TiedNodeGroups::pairs(model_.rockLiningPairs);
  const size_t tied = groups.size();
  if (part_) {  // the pairs this rank holds, on its nodes
    std::vector<std::vector<Index>> mine;
    for (auto& g : groups) {
      for (Index& n : g) n = local(n);
      if (std::all_of(g.begin(), g.end(), [](Index n) { return n >= 0; })) mine.push_back(g);
    }
    groups = std::move(mine);
  }
  auto tie = std::make_shared<TiedNodeGroups>("rock-lining interface (bonded)", std::move(groups));
  tie->install(solver_);
  interface_ = tie;
  solver_.addContributor(ForcePhase::Interface, tie);
  rep.note = "rock-lining interface: bonded (tied pairs: " + std::to_string(tied) + ")";
}

void StagedAnalysis::holdUnreleasedLoad(std::ostream& log, StageReport& rep) {
  // The excavation load is the out-of-balance force the stage starts from: f_int − f_ext of the
  // in-situ stress on a mesh without the tunnel core (the released core tractions). Adding
  // (1 − λ) of it to the external forces leaves λ of it for the excavation stage to relax.
  const Real keep = 1 - in_.staged.stages.releaseFraction;
  NodalState& s = solver_.state();
  solver_.computeForces(true);
  std::vector<Real> f(3 * size_t(s.numNodes()), 0.0);
  Real f2 = 0;
  for (Index n = 0; n < s.numNodes(); ++n) {
    if (!(s.mass(n) > 0)) continue;  // inactive (the lining's nodes): no force on them
    for (int d = 0; d < 3; ++d) {
      if (solver_.isFixed(n, d)) continue;  // the support takes its share; no force to hold
      const size_t i = dofIndex(n, d);
      f[i] = keep * (s.fIntData()[i] - s.fExtData()[i]);
      if (counts(n)) f2 += f[i] * f[i];
    }
  }
  sumRanks(&f2, 1);
  unreleased_ = std::make_shared<HeldExcavationLoad>(std::move(f));
  solver_.addContributor(ForcePhase::Loads, unreleased_);
  std::ostringstream os;
  os.precision(4);
  os << "release fraction " << in_.staged.stages.releaseFraction << ": " << 100 * in_.staged.stages.releaseFraction
     << " % of the excavation load released with the rock alone; the rest, |f| = " << std::sqrt(f2)
     << " N, held until the lining is active";
  rep.note = os.str();
  log << "  stage excavation: " << rep.note << std::endl;
}

void StagedAnalysis::activateLining(std::ostream& log, StageReport& rep) {
  // Installed stress-free into the displaced rock: the lining's own nodes never moved (no mass
  // while inactive), so its displacement reference is the state at activation; the tie keeps
  // the pairs' increments equal from here on.
  for (ElementBlock* lining : linings_)
    for (Index e = 0; e < lining->numElems(); ++e) lining->setActive(e, true, solver_.state());
  solver_.rebuild();
  installInterface(log, rep);
}

void StagedAnalysis::runStatics(std::ostream& log, double progressSeconds) {
  const StagedInput& S = in_.staged;
  const auto& seq = S.stages.sequence;
  if (S.stages.has("lining")) {
    // Not installed yet: no mass, no stiffness; its nodes stay at rest until the lining stage.
    // (The time step stays the one of the complete model.)
    for (ElementBlock* lining : linings_)
      for (Index e = 0; e < lining->numElems(); ++e) lining->setActive(e, false, solver_.state());
    solver_.rebuild();
  }
  if (!S.stages.has("lining") && hasLining_ && !model_.rockLiningPairs.empty() && !interface_) {
    StageReport rep;
    rep.name = "interface";
    installInterface(log, rep);  // lining present from the start: tie it now
    reports_.push_back(rep);
  }
  for (size_t i = 0; i < seq.size(); ++i) {
    const std::string& name = seq[i];
    if (name == "seismic") break;
    const bool excavationNext = i + 1 < seq.size() && seq[i + 1] == "excavation";
    log << "tq-solid: stage " << name << std::endl;
    if (name == "in_situ") {
      setInSituStress();
      if (excavationNext) {
        // The mesh has no tunnel core: the in-situ stress leaves the released core tractions on
        // the hole; the excavation stage relaxes them.
        StageReport rep;
        rep.name = name;
        solver_.computeForces(true);
        rep.ratio = solver_.unbalancedRatio(true);
        rep.note = "in-situ stress set; unbalanced ratio before excavation " + std::to_string(rep.ratio);
        log << "  stage in_situ: stresses set (kx " << S.inSitu.kx << ", ky " << S.inSitu.ky << ", kz " << S.inSitu.kz
            << ", g " << S.inSitu.gravity << " m/s²); unbalanced ratio " << rep.ratio << " (released core tractions)"
            << std::endl;
        reports_.push_back(rep);
      } else {
        reports_.push_back(relaxStage(name, log, progressSeconds));
      }
    } else if (name == "excavation") {
      if (S.stages.releaseFraction < 1) {
        StageReport note;
        holdUnreleasedLoad(log, note);
        StageReport rep = relaxStage(name, log, progressSeconds);
        rep.note = note.note;
        reports_.push_back(rep);
      } else {
        reports_.push_back(relaxStage(name, log, progressSeconds));
      }
    } else if (name == "lining") {
      StageReport note;
      activateLining(log, note);
      if (unreleased_ && !unreleased_->released()) {
        // The rest of the excavation load, released on rock and lining together.
        unreleased_->release();
        std::ostringstream os;
        os.precision(4);
        os << "; the held " << 100 * (1 - S.stages.releaseFraction)
           << " % of the excavation load released with rock and lining together";
        note.note += os.str();
        log << "  stage lining: the held " << 100 * (1 - S.stages.releaseFraction)
            << " % of the excavation load released with rock and lining together" << std::endl;
      }
      StageReport rep = relaxStage(name, log, progressSeconds);
      rep.note = note.note;
      reports_.push_back(rep);
    } else if (name == "fault_offset") {
      reports_.push_back(faultOffsetStage(log, progressSeconds));
    } else if (name == "hydrostatic") {
      const HydrostaticInput& H = S.hydrostatic;
      pressure_ = std::make_shared<ConstantNodalForces>(
          "hydrostatic pressure", toLocal(pressureNodalForces(model_, H.face, [&H](const Real x[3]) {
            return std::max<Real>(0, H.pressureAtAxis - H.unitWeight * (x[2] - H.zAxis));
          })));
      solver_.addContributor(ForcePhase::Loads, pressure_);
      StageReport rep = relaxStage(name, log, progressSeconds);
      std::ostringstream os;
      os << "p = " << H.pressureAtAxis << " Pa at z = " << H.zAxis << " m, gradient " << H.unitWeight << " N/m^3 on '"
         << H.face << "'";
      rep.note = os.str();
      reports_.push_back(rep);
    }
  }
}

StageReport StagedAnalysis::faultOffsetStage(std::ostream& log, double progressSeconds) {
  const FaultOffsetInput& F = in_.staged.faultOffset;
  NodalState& st = solver_.state();
  const size_t n = F.nodes.size();
  std::vector<Real> start(3 * n);
  Real largest = 0;
  for (size_t i = 0; i < n; ++i) {
    Real d2 = 0;
    for (int d = 0; d < 3; ++d) {
      solver_.fix(F.nodes[i], d);
      start[3 * i + d] = st.u(F.nodes[i], d);
      d2 += F.displacement[3 * i + d] * F.displacement[3 * i + d];
    }
    largest = std::max(largest, std::sqrt(d2));
  }
  StageReport rep;
  for (Index k = 1; k <= F.increments; ++k) {
    // The nodes are fixed (a zero increment each step): the relaxation keeps them where they are put.
    const Real share = Real(k) / Real(F.increments);
    for (size_t i = 0; i < n; ++i)
      for (int d = 0; d < 3; ++d) st.u(F.nodes[i], d) = start[3 * i + d] + share * F.displacement[3 * i + d];
    const Index before = rep.steps;
    const double wall = rep.wallSeconds;
    rep = relaxStage("fault_offset", log, progressSeconds);
    rep.steps += before;
    rep.wallSeconds += wall;
  }
  std::ostringstream os;
  os.precision(4);
  os << n << " nodes moved (largest displacement " << largest << " m) in " << F.increments
     << " increment(s), held in x, y, z";
  rep.note = os.str();
  log << "  stage fault_offset: " << rep.note << std::endl;
  return rep;
}

void StagedAnalysis::switchToDynamics(std::ostream& log) {
  const StagedInput& S = in_.staged;
  NodalState& st = solver_.state();
  const Index N = st.numNodes();
  // 1. Forces at the equilibrium state, at rest (also brings every element's strain record to the
  //    current displacement, so the first seismic step starts from a zero increment).
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) st.v(n, d) = 0;
  solver_.computeForces(true);
  std::vector<Real> r(3 * size_t(N));
  Real f2[2] = {0, 0};  // |f_int|², |f_ext|²
  for (size_t i = 0; i < r.size(); ++i) {
    r[i] = st.fIntData()[i] - st.fExtData()[i];
    if (!counts(Index(i / 3))) continue;
    f2[0] += st.fIntData()[i] * st.fIntData()[i];
    f2[1] += st.fExtData()[i] * st.fExtData()[i];
  }
  sumRanks(f2, 2);
  const Real ref = std::sqrt(std::max(f2[0], f2[1]));
  // 2. The seismic record starts here: velocities 0, displacements relative to this state.
  solver_.resetMotion();
  // 3. Supports replaced by dynamic boundaries: a dof is released when every support group that
  //    fixes it is replaced.
  std::set<std::string> replaced;
  if (S.bottom.present) replaced.insert(S.bottom.face);
  for (const auto& f : S.freeField.faces) replaced.insert(f);
  for (const auto& f : S.freeField.sharedColumnFaces) replaced.insert(f);
  for (const auto& f : S.periodic.faces) replaced.insert(f);
  std::vector<char> keep(3 * size_t(N), 0), byReplaced(3 * size_t(N), 0);
  // Periodic faces: their nodes' supports along the faces' normal give way to the tie (in a slice
  // the plane-strain u_y = 0 of every node, all of which lie on the two faces).
  std::vector<std::vector<Index>> periodicPairs;
  if (S.periodic.present) {
    periodicPairs = TiedNodeGroups::periodicPairs(mesh_, S.periodic.faces[0], S.periodic.faces[1]);
    const int axis = axisFace(mesh_, S.periodic.faces[0]).axis;
    for (const auto& p : periodicPairs)
      for (Index n : p) byReplaced[dofIndex(n, axis)] = 1;
  }
  for (const auto& [group, dirs] : in_.fixed) {
    const auto nodes = model_.faceNodes(group);
    for (char c : dirs) {
      const int d = c == 'x' ? 0 : c == 'y' ? 1 : 2;
      for (Index g : nodes)
        if (const Index n = local(g); n >= 0) (replaced.count(group) ? byReplaced : keep)[dofIndex(n, d)] = 1;
    }
  }
  // The fault offset's nodes: held by the stage, released here with their reactions held (the
  // supports of their face groups that stay, e.g. the y-faces' rollers, stay).
  if (S.stages.has("fault_offset"))
    for (Index n : S.faultOffset.nodes)
      for (int d = 0; d < 3; ++d) byReplaced[dofIndex(n, d)] = 1;
  // A slip during the shaking: its nodes keep (or take) a support in every direction, no reaction held.
  const bool slipping = S.faultOffset.dynamic();
  if (slipping)
    for (Index n : S.faultOffset.nodes)
      for (int d = 0; d < 3; ++d) {
        if (!solver_.isFixed(n, d)) solver_.fix(n, d);
        keep[dofIndex(n, d)] = 1;
      }
  if (mesh_.slice && !S.periodic.present)
    for (Index n = 0; n < N; ++n) keep[dofIndex(n, 1)] = 1;  // plane strain stays
  std::vector<Real> held(3 * size_t(N), 0.0);
  Real react2 = 0, corr2 = 0;
  Index released = 0;
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) {
      const size_t i = dofIndex(n, d);
      if (solver_.isFixed(n, d)) {
        if (byReplaced[i] && !keep[i]) {
          solver_.release(n, d);
          held[i] = r[i];  // the reaction the support gave
          if (counts(n)) react2 += r[i] * r[i], ++released;
        }
      } else if (S.stages.equilibriumCorrection && st.mass(n) > 0) {
        held[i] = r[i];  // residual out-of-balance of the relaxation, held constant
        if (counts(n)) corr2 += r[i] * r[i];
      }
    }
  {
    Real sums[3] = {react2, corr2, Real(released)};
    sumRanks(sums, 3);
    react2 = sums[0], corr2 = sums[1], released = Index(std::llround(sums[2]));
  }
  correctionRatio_ = ref > 0 ? std::sqrt(corr2) / ref : 0;
  held_ = std::make_shared<ConstantNodalForces>("held support reactions", held);
  solver_.addContributor(ForcePhase::Loads, held_);
  StageReport rep;
  rep.name = "switch";
  {
    std::ostringstream os;
    os.precision(3);
    os << released << " support dofs released, reactions |R| = " << std::sqrt(react2)
       << " N held as forces; residual held (equilibrium correction) |r|/|f| = " << correctionRatio_;
    rep.note = os.str();
    log << "tq-solid: switch to the seismic stage: " << rep.note << std::endl;
  }
  // 4. Seismic boundaries.
  if (S.bottom.present || S.freeField.present) {
    SeismicBoundarySpec spec;
    spec.bottom = S.bottom.present;
    spec.bottomFace = S.bottom.face;
    spec.alphaN = S.bottom.alphaN > 0 ? S.bottom.alphaN : (mesh_.slice ? 1.0 : 4.0 / 3.0);
    spec.alphaT = S.bottom.alphaT > 0 ? S.bottom.alphaT : (mesh_.slice ? 0.5 : 2.0 / 3.0);
    spec.halfSpace = {S.bottom.rho, S.bottom.cp, S.bottom.cs};
    spec.freeFieldFaces = S.freeField.faces;
    spec.sharedColumnFaces = S.freeField.sharedColumnFaces;
    spec.columnFace = S.bottom.columnFace;
    spec.damping = solver_.options().damping;
    spec.distance = S.bottom.distance;
    if (!(spec.distance > 0)) {
      // Default R: from the tunnel axis to the base, else the model height.
      const Real zb = zBottomOf(model_);
      Real zAxis = std::numeric_limits<Real>::quiet_NaN();
      if (S.hydrostatic.present && S.hydrostatic.unitWeight > 0) zAxis = S.hydrostatic.zAxis;
      if (!std::isfinite(zAxis)) zAxis = tunnelAxisZ(model_);
      spec.distance = std::isfinite(zAxis) ? zAxis - zb : zTopOf(model_) - zb;
    }
    const MotionInput& M = S.motion;
    IncidentMotion motion = M.present ? IncidentMotion(M.time, M.ax, M.ay, M.az) : IncidentMotion();
    if (part_) {  // built on the whole model, as in one process, then kept where it acts on this rank
      seismic_ =
          std::make_shared<SeismicBoundaries>(model_, part_->elementMaterial, spec, std::move(motion), model_.slice);
      seismic_->restrictToNodes(*part_->localNode, *part_->owned);
    } else {
      seismic_ = std::make_shared<SeismicBoundaries>(mesh_, solver_.blocks(), spec, std::move(motion), mesh_.slice);
    }
    seismic_->install(st);
    solver_.addContributor(ForcePhase::Boundaries, seismic_);
    std::ostringstream os;
    os.precision(4);
    if (spec.bottom) {
      const auto k = seismic_->springPerArea();
      const auto c = seismic_->dashpotPerArea();
      os << "viscoelastic base '" << spec.bottomFace << "': R = " << spec.distance << " m, K_T " << k[0] << ", K_N "
         << k[2] << " N/m^3, C_T " << c[0] << ", C_N " << c[2] << " N s/m^3";
    }
    if (!spec.freeFieldFaces.empty()) {
      os << (spec.bottom ? "; " : "") << "free-field sides:";
      for (const auto& f : spec.freeFieldFaces) os << " " << f;
      for (const auto& f : spec.sharedColumnFaces)
        os << " " << f << " (" << spec.freeFieldFaces.front() << "'s column)";
      os << " (" << seismic_->columns().size() << " column(s), " << seismic_->baseColumn().numLayers() << " layers)";
    }
    log << "  " << os.str() << std::endl;
    rep.note += "; " + os.str();
  }
  // The domain reduction layer's effective forces, with the boundaries (absorbing ones outside it).
  if (drm_) {
    solver_.addContributor(ForcePhase::Boundaries, drm_);
    std::ostringstream os;
    os << "domain reduction layer: " << drm_->numLayerElements() << " elements, " << drm_->numInner() << " inner and "
       << drm_->numOuter() << " outer nodes (" << drm_->numDistinctCouplings()
       << " distinct element couplings), free field of " << S.drm.time.size() << " samples to " << S.drm.time.back()
       << " s";
    log << "  " << os.str() << std::endl;
    rep.note += "; " + os.str();
  }
  // The fault's slip: puts its nodes each step (they are held, so no other force moves them).
  if (slipping) {
    slip_ = std::make_shared<PrescribedSlip>(S.faultOffset, st);
    solver_.addContributor(ForcePhase::Boundaries, slip_);
    std::ostringstream os;
    os.precision(4);
    os << "fault slip: " << S.faultOffset.nodes.size() << " nodes held and moved over t = " << S.faultOffset.startTime
       << " … " << S.faultOffset.startTime + S.faultOffset.riseTime << " s (cosine ramp)";
    log << "  " << os.str() << std::endl;
    rep.note += "; " + os.str();
  }
  // 5. Periodic faces: tied in the last phase (ForcePhase::Ties), after the interface's tie or
  //    contact and the water coupling added later, so each pair shares every force its members
  //    get and stays one to round-off.
  if (S.periodic.present) {
    auto tie = std::make_shared<TiedNodeGroups>("periodic faces " + S.periodic.faces[0] + "-" + S.periodic.faces[1],
                                                periodicPairs);
    tie->checkUniformMembers(st);
    tie->install(solver_);
    solver_.addContributor(ForcePhase::Ties, tie);
    std::ostringstream os;
    os << "periodic faces " << S.periodic.faces[0] << ", " << S.periodic.faces[1] << ": " << tie->numGroups()
       << " node pairs tied in x, y, z";
    log << "  " << os.str() << std::endl;
    rep.note += "; " + os.str();
  }
  reports_.push_back(rep);
  solver_.setTime(0);
}

std::string elementSizeWarning(const Solver& solver, Real f) {
  if (!(f > 0)) return "";
  const Mesh& m = solver.mesh();
  Index count = 0, total = 0, worstElem = -1;
  Real worst = 0, worstH = 0, worstCs = 0;
  std::string worstBlock;
  for (const auto& b : solver.blocks()) {
    const Real cs = std::sqrt(b->material().elasticModuli().mu / b->material().density());
    const Real limit = cs / (8 * f);
    for (Index e = 0; e < b->numElems(); ++e) {
      Real shortest = 0, h = 0;
      hex8::edgeLengthRange(m.coords.data(), &m.connectivity[8 * size_t(b->meshElem(e))], shortest, h);
      ++total;
      if (h > limit) {
        ++count;
        if (h / limit > worst) {
          worst = h / limit;
          worstElem = b->meshElem(e);
          worstBlock = b->name();
          worstH = h;
          worstCs = cs;
        }
      }
    }
  }
  if (count == 0) return "";
  std::ostringstream os;
  os.precision(4);
  os << "warning: " << count << " of " << total << " elements are larger than λ_min/8 = c_s/(8 f) for the motion's "
     << "cut-off f = " << f << " Hz (Kuhlemeyer & Lysmer 1973); worst: element " << worstElem << " of '" << worstBlock
     << "', longest edge " << worstH << " m > " << worstCs / (8 * f) << " m (c_s = " << worstCs << " m/s), " << worst
     << " times the limit. Waves near " << f << " Hz are under-resolved there: refine the mesh "
     << "(mesh.max_element_size) or lower the cut-off.";
  return os.str();
}

}  // namespace tq
