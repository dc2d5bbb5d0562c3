// The solid adapter of the water coupling (tq/coupling/fluid_coupling.hpp; docs/coupler.md "Solid adapter").
// The only solid source that includes the coupler's headers.
#include "tq/coupling/fluid_coupling.hpp"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <type_traits>

#include "coupling/coupling_messages.hpp"
#include "tq/coupler/errors.hpp"
#include "tq/coupler/participant.hpp"

namespace tq {

namespace cp = tq::coupler;

namespace {

/// CPU seconds of the calling thread (the exchange's own work: a blocked receive costs none).
double threadCpu() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace

struct FluidCoupling::Impl {
  Solver& solver;
  const Solver* clock;  // whose time and step the messages name
  CouplingInput in;
  WallPrediction wall;              // the interface nodes (mesh indices, ascending) and u0
  const std::vector<Index>& nodes;  // wall.nodes()
  std::vector<Real>& u0;            // [3n] displacement at the seismic start (wall.reference())
  const CarriedWater* water;        // the laws the solid carries (null: the water sends its whole force)
  // On MPI ranks: this rank's part of the wetted face, the sums over the wet nodes taken in the
  // one-process order on every part (tq/water/wet_part.hpp); null in one process.
  const WetPart* part = nullptr;
  PendingWetWork pending;               // on a part: each step's work terms, booked in step order by flushWetWork()
  std::vector<Real> force, prev;        // [3n] force added this step / last step (N)
  std::vector<Real> received;           // [3n] latest force read from the fluid
  std::vector<Real> trial;              // [3n] force used in the current prediction
  std::vector<Real> receivedPrev;       // [3n] predictor linear or damped: the force applied one window earlier
  WallMotion motion;                    // [3n] the predicted motion written (disp, vel) and its response
  std::vector<Real>&disp, &vel;         // motion.disp, motion.vel
  std::vector<std::vector<Real>> sent;  // [3n] each field written, less what the water does not see
  bool planar = false;                  // a slice: the water is sent the wall's in-plane motion only (write())
  std::vector<Real> total;              // [3n] force(): the exchanged force + the carried pressure
  std::vector<Real> dispStart;          // [3n] u − u0 at the start of the current window (k > 1)
  // Defect correction (in.defectCorrection = α > 0): the force added to every step of this window, and
  // the accepted windows' defect not repaid yet.
  std::vector<Real> carry, unpaid;  // [3n]
  std::unique_ptr<cp::Participant> p;
  cp::SchemeKind scheme = cp::SchemeKind::Implicit;
  cp::PredictorKind predictor = cp::PredictorKind::Constant;
  Real window = 0, dtPrev = 0;
  long long windows = 0;
  Index stepInWindow = 0;
  // The window being stepped: its passes so far; for implicit windows of k > 1 steps (stepped again
  // whole) the force at its start F_w. forceSet: the force of the next step is decided (planStep or
  // exchange): a solid step outside the protocol is refused.
  bool repeats = false;
  std::vector<Real> forceStart;  // [3n]
  long long pass = 0;
  bool forceSet = false;
  Real work = 0;
  // Work the fluid received from the wall, from the exchanged data: the final
  // force of each window (the fluid's own last answer) on the motion the fluid was sent.
  std::vector<Real> sent1, sent2;  // [3n] displacement sent one / two windows ago
  std::vector<Real> recvPrev;      // [3n] final force of the last window
  std::vector<Real> lagPrev;       // [3n] u − u0 one step before the last window's end (windows of k steps)
  std::vector<Real> uLast;         // [3n] u^n of the last exchange's step (windows of k steps)
  Real fluidReceived = 0;
  // Energy guard (docs/coupler.md "Energy guard"): the largest |interface work| of either side so
  // far, the floor of the reference, a note to print once when a fifth of the limit is reached.
  Real workPeak = 0, energyFloor = 0;
  bool energyWarned = false;
  std::string note;
  FluidCouplingStats stats;
  // How the link ended (CouplingMpi::finish): the handshake took place; the fluid fell silent.
  bool linked = false, silent = false;
  // Timers of the cost split: start of the stepping, and the coupler's own tallies then.
  std::chrono::steady_clock::time_point steppingStart;
  double waitAtStart = 0, mappingAtStart = 0, cpuStart = 0;
  // The solid's stepping since the last protocol part ended, and the tally it goes to (null: the
  // windows' ends): FluidCouplingStats::secondsFirstPasses, secondsRepasses.
  std::chrono::steady_clock::time_point partEnd;
  double* stepping = nullptr;
  bool initialized = false, finalized = false;
  std::vector<unsigned char> resumeBytes;  // the participant's state of a restart checkpoint

  Impl(Solver& s, const CouplingInput& ci, std::vector<Index> wet, const CarriedWater* w)
      : solver(s),
        clock(&s),
        in(ci),
        wall(s, std::move(wet)),
        nodes(wall.nodes()),
        u0(wall.reference()),
        water(w),
        disp(motion.disp),
        vel(motion.vel) {}

  /// The end of initialize() or initializeResumed(): the stepping's timers start.
  void started(std::chrono::steady_clock::time_point t0) {
    stats.secondsExchanging += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const cp::ExchangeStats xs = p->stats();
    waitAtStart = xs.secondsWaiting;
    mappingAtStart = xs.secondsMapping;
    steppingStart = partEnd = std::chrono::steady_clock::now();
    cpuStart = threadCpu();
    initialized = true;
    linked = true;
  }

  /// The interface's motion at t + Δt with the force F, and the carried laws' pressure it meets.
  void predictWithLaw(Real dt, const NodalState& st, const std::vector<Real>& F) {
    wall.predict(dt, st, F.data(), motion, water != nullptr);
    if (water) water->correct(dt, st, motion);
  }

  [[noreturn]] void fail(const std::string& what, const std::exception& e) {
    if (dynamic_cast<const cp::TimeoutError*>(&e)) silent = true;
    if (dynamic_cast<const cp::HandshakeError*>(&e)) linked = true;  // refused: both sides know
    std::ostringstream os;
    os << "water coupling: " << what << " at t = " << clock->time() << " s (solid step " << clock->stepCount()
       << "): " << e.what() << " " << couplingFix(e, in);
    throw CouplingError(os.str());
  }

  /// The implicit scheme's pass-0 window-end force `trial`, at the start of a window: the last
  /// converged force, or extrapolated from the forces applied, linear 2 F_w − F_{w−1} or damped
  /// F_w + ¾ (F_w − F_{w−1}) (F the force applied in a window, the initial force before the first;
  /// receivedPrev moves on to F_w; cp::extrapolatedValue, the coupler's own), from which both sides
  /// start: a window whose first answer already agrees with it to the tolerance needs one pass
  /// (docs/coupler.md "Predictor").
  void implicitPassZeroForce() {
    trial = received;
    if (!cp::extrapolates(predictor)) return;
    if (stats.windows > 0)  // window 0 starts from the initial force (= receivedPrev)
      for (size_t j = 0; j < trial.size(); ++j) trial[j] = cp::extrapolatedValue(predictor, force[j], receivedPrev[j]);
    else
      trial = receivedPrev;
    if (stats.windows > 0) receivedPrev = force;
  }

  /// Window of k > 1 steps: the velocity written is the window's mean, (u_end − u_start)/window,
  /// so that the water's wall flux over its one step of length `window` sweeps exactly the volume
  /// the solid's wall swept (a transpiration interface integrates the velocity, not the position).
  void markWindowStart(const NodalState& st) {
    const Real* u = st.uData();
    for (size_t k = 0; k < nodes.size(); ++k)
      for (int d = 0; d < 3; ++d) {
        const size_t j = 3 * k + size_t(d);
        dispStart[j] = u[dofIndex(nodes[k], d)] - u0[j];
      }
  }
  void windowMeanVelocity() {
    for (size_t j = 0; j < vel.size(); ++j) vel[j] = (disp[j] - dispStart[j]) / window;
  }

  /// The fluid's work, by the same trapezoid rule and pairing as the solid's booking:
  /// −½(R_f^n + R_f^{n−1})·(u_s^n − u_s^{n−1}), R_f the window's final force, u_s the motion the
  /// fluid was sent (made one window earlier). Converged exchange: R_f = the force applied and
  /// u_s = the motion made, so the sum with the solid's work is zero (to the tolerance).
  void bookReceivedWork() {
    Real sum = 0;
    sumOverWetNodes(
        part, nodes.size(), 3,
        [&](size_t k, Real* t) {
          for (size_t j = 3 * k; j < 3 * k + 3; ++j)
            t[j - 3 * k] = 0.5 * (received[j] + recvPrev[j]) * (sent1[j] - sent2[j]);
        },
        [&](size_t, const Real* t) { sum -= t[0], sum -= t[1], sum -= t[2]; });
    fluidReceived += sum;
    recvPrev = received;
    sent2.swap(sent1);
    sent1 = disp;
  }

  /// The same for an implicit window of k steps, paired as the solver pairs its own booking: the
  /// solver books ½(F^n + F^{n−1})·(u^n − u^{n−1}) with F^n the force of the step n → n+1, i.e. the
  /// water's force at t_{n+1} against the motion one step earlier. Pairing the window's forces with
  /// the window-end motion instead would leave a drift ∝ (k − 1) steps × ∫ R·a (the added mass
  /// m_a ∫a² dt) that is an artefact of the bookkeeping, not of the exchange. uLast holds u^n of the
  /// window's last step (one step before its end); for k = 1 this is bookReceivedWork().
  /// The window's two forces are weighted as the solid's steps weight them: step j applies
  /// F_w + w_j (F̃ − F_w) and books ½(F_j + F_{j−1}) on its increment, so over a window whose motion is
  /// even the solid's work is [(1 − β̄) F_w + β̄ F̃]·Δu with β̄ = ((k − 1) β + ½)/k (β the
  /// window_force_weight; ½ for the linear ramp: the trapezoid). Booking the water's side with the same
  /// β̄ keeps E_c a measure of the exchange's own inconsistency; with the trapezoid a weight β > ½ would
  /// show up as energy created, (β̄ − ½) Σ ΔF·Δu, although the water and the solid agree.
  void bookReceivedWorkWindow() {
    const Real k = Real(in.windowSteps), bbar = ((k - 1) * in.windowForceWeight + 0.5) / k;
    Real sum = 0;
    sumOverWetNodes(
        part, nodes.size(), 3,
        [&](size_t k3, Real* t) {
          for (int d = 0; d < 3; ++d) {
            const size_t j = 3 * k3 + size_t(d);
            const Real lag = uLast[j] - u0[j];
            t[d] = (bbar * received[j] + (1 - bbar) * recvPrev[j]) * (lag - lagPrev[j]);
            lagPrev[j] = lag;
          }
        },
        [&](size_t, const Real* t) { sum -= t[0], sum -= t[1], sum -= t[2]; });
    fluidReceived += sum;
    recvPrev = received;
  }

  /// At each window's end: the energy the coupling created, E_c = work + fluidReceived, against the
  /// largest interface work of either side so far (at least energyFloor). An exchange converged to
  /// the tolerance keeps E_c of the order of the tolerance times that work; E_c growing past
  /// energy_limit of it means the accepted errors feed a mode of the water and the wall, which then
  /// grows on energy the scheme makes (the 3D paper case with 16-step windows at 1e-3 did so from
  /// 13.5 s, slowly and without the sign alternation the divergence detection looks for).
  void guardEnergy() {
    // the interface work: the exchanged force's, on either side, or all the water's force on the wall
    // (the exchanged part plus what the solid carries: the volume law and the translation)
    const Real carried = water ? water->work() : 0.0;
    workPeak = std::max({workPeak, std::abs(work), std::abs(fluidReceived), std::abs(work + carried)});
    if (!(in.energyLimit > 0)) return;
    const Real ref = std::max(workPeak, energyFloor), ec = work + fluidReceived;
    if (!(ref > 0)) return;
    const Real ratio = ec / ref;
    auto where = [&] {
      std::ostringstream os;
      os << "t = " << clock->time() << " s (window " << stats.windows << ")";
      return os.str();
    };
    if (!(ratio <= in.energyLimit))
      throw InstabilityError(energyCreatedMessage(in, ec, ratio, ref, where(), water != nullptr));
    if (!energyWarned && ratio > 0.2 * in.energyLimit) {
      energyWarned = true;
      note = energyWarning(in, ec, ratio, where());
    }
  }

  void write() {
    if (!water && !planar) {
      for (const auto& name : in.writeFields) p->writeData(in.mesh, name, name == "velocity" ? vel : disp);
      return;
    }
    sent.resize(in.writeFields.size());
    std::vector<std::vector<Real>*> fields;
    for (size_t i = 0; i < sent.size(); ++i) {
      sent[i] = in.writeFields[i] == "velocity" ? vel : disp;
      // A slice's water is planar: the wall's motion along the axis (a ground motion along y) would
      // only shift its one-cell mesh along y, which the water's point forces do not follow alike on
      // its two faces; it is sent the in-plane motion.
      if (planar)
        for (size_t k = 0; k < nodes.size(); ++k) sent[i][3 * k + 1] = 0;
      fields.push_back(&sent[i]);
    }
    // The water sees the wall's motion less the carried modes (volume change, translation); the
    // fields' sums together (on a part: one gather).
    if (water) water->projectMotions(fields);
    for (size_t i = 0; i < sent.size(); ++i) p->writeData(in.mesh, in.writeFields[i], sent[i]);
  }

  /// The water's answer; with the volume law, less what would work on the carried modes.
  void read() {
    p->readData(in.mesh, "force", received);
    if (water) water->projectForce(received);
  }

  // ------------------------------------------------------------------ the protocol, per window
  // (tq/coupling/fluid_coupling.hpp; docs/coupler.md "Solid adapter", "Windows of several steps")

  /// The window's plan (CoupledStepper::window, before its first step): the interface's motion at
  /// the start (windows of k > 1 steps send the window's mean velocity); the window-end force `trial`
  /// of the first pass — implicit: the predictor's (implicitPassZeroForce()); paper and explicit:
  /// none, the water answers the motion the other forces make — and, for windows stepped again
  /// whole, the force at the window's start F_w (the last window's, the initial force before the first).
  void plan(const NodalState& st) {
    if (in.windowSteps > 1) markWindowStart(st);
    if (scheme != cp::SchemeKind::Implicit) {
      std::fill(trial.begin(), trial.end(), 0.0);
      return;
    }
    if (repeats) forceStart = stats.windows > 0 ? force : receivedPrev;
    implicitPassZeroForce();
  }

  /// The force step j < k of a window applies. Implicit: F_w + w_j (F̃ − F_w) with
  /// w_j = 1 − (1 − j/k) · 2(1 − β), β the window_force_weight (½: the linear ramp j/k; β > ½ leans
  /// toward the window-end force, the window's mean weight ≈ β; docs/coupler.md "Window force
  /// weight"). Explicit: the last answer, held.
  void stepForce() {
    if (scheme == cp::SchemeKind::Explicit) {
      force = received;
      return;
    }
    const Real k = Real(in.windowSteps);
    const Real w = 1 - (1 - Real(stepInWindow) / k) * 2 * (1 - in.windowForceWeight);
    for (size_t j = 0; j < force.size(); ++j) force[j] = forceStart[j] + w * (trial[j] - forceStart[j]);
  }

  /// One pass of the window's end: the interface's motion at t + Δt predicted with the window-end
  /// force `trial` and the carried laws (windows of k > 1 steps: the window's mean velocity),
  /// written, the coupler advanced, the water's force read. The force this step applies: explicit —
  /// the answer (the corrector of the prediction); paper and implicit — `trial`, so that the water
  /// saw exactly the motion the step makes (paper: R3 of the predictor pass; implicit: the force
  /// being iterated). True when the water accepted the window; else `trial` is its answer, with which
  /// the next pass steps the window again.
  bool exchange(Real dt, const NodalState& st) {
    ++pass;
    stepInWindow = 0;
    predictWithLaw(dt, st, trial);
    if (in.windowSteps > 1) windowMeanVelocity();
    write();
    p->advance(dt);
    read();
    force = scheme == cp::SchemeKind::Explicit ? received : trial;
    if (repeats)  // u^n of the window's last step, for the booking once it is accepted
      for (size_t k = 0; k < nodes.size(); ++k)
        for (int d = 0; d < 3; ++d) uLast[3 * k + size_t(d)] = st.uData()[dofIndex(nodes[k], d)];
    const bool accepted = !p->requiresReadingCheckpoint();
    if (!accepted) trial = received;
    forceSet = accepted || !repeats;  // a one-step window's step is predicted again, not taken
    return accepted;
  }

  /// The window accepted, its last step taken: the water's work booked (windows stepped again whole
  /// pair it as the solver pairs its own steps), the defect carried, the counters, pass 0 of the next
  /// window.
  ///
  /// Defect correction (α = in.defectCorrection > 0; docs/coupler.md "Defect correction"): the window
  /// was accepted with its end force F̃ a residual e = F̃ − R from the water's last answer R. Over the
  /// window the solid received [(1 − β̄) F_w + β̄ F̃]·Δu, the water booked [(1 − β̄) R_w + β̄ R]·Δu (F_w,
  /// R_w the window before's): (1 − β̄) e_w + β̄ e of energy the exchange made. The defect −e joins
  /// the unpaid sum D, and the next window's steps each add c = α D (D −= c): with α = 1 the difference
  /// of window w+1 is β̄ (e_{w+1} − e_w)·Δu, summing to −β̄ Σ e_w·(Δu_{w+1} − Δu_w) (the residual meets
  /// the change of the motion between windows, not the motion); with α < 1 the defect is repaid over
  /// about 1/α windows, and a residual that alternates window to window is not doubled.
  void acceptWindow() {
    if (repeats)
      bookReceivedWorkWindow();
    else
      bookReceivedWork();
    if (in.defectCorrection > 0)
      for (size_t j = 0; j < carry.size(); ++j) {
        unpaid[j] += received[j] - trial[j];
        carry[j] = in.defectCorrection * unpaid[j];
        unpaid[j] -= carry[j];
      }
    ++stats.windows;
    stats.passes += pass;
    stats.maxPasses = std::max(stats.maxPasses, pass);
    pass = 0;
  }

  /// The cost split's tallies for the coupler part of a step that began at t0 (wall) and c0 (CPU).
  void timeCoupler(std::chrono::steady_clock::time_point t0, double c0) {
    const auto t1 = std::chrono::steady_clock::now();
    if (stepping) *stepping += std::chrono::duration<double>(t0 - partEnd).count();
    partEnd = t1;
    const double inCoupler = std::chrono::duration<double>(t1 - t0).count();
    stats.secondsExchanging += inCoupler;
    stats.secondsInCoupler += inCoupler;
    stats.secondsCoupled = std::chrono::duration<double>(t1 - steppingStart).count();
    const double c1 = threadCpu();
    stats.cpuInCoupler += c1 - c0;
    stats.cpuCoupled = c1 - cpuStart;
  }

  /// A part of the protocol, timed in the cost split, a coupler error turned into a CouplingError.
  template <class F>
  auto timed(F&& part) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = threadCpu();
    try {
      if constexpr (std::is_void_v<decltype(part())>) {
        part();
        timeCoupler(t0, c0);
      } else {
        auto r = part();
        timeCoupler(t0, c0);
        return r;
      }
    } catch (const cp::CouplerError& e) {
      fail("exchange with '" + in.partner + "' failed", e);
    }
  }
};

FluidCoupling::FluidCoupling(Solver& solver, const CouplingInput& in, const CarriedWater* water)
    : impl_(std::make_unique<Impl>(solver, in, wallNodes(solver.mesh(), in.face), water)) {
  Impl& I = *impl_;
  // Interface vertices: mesh node index as id, the face's quads as triangles.
  std::vector<std::int64_t> ids(I.nodes.begin(), I.nodes.end());
  std::vector<std::int32_t> tri;
  const auto& quads = solver.mesh().faces.at(in.face);
  auto local = [&](Index n) {
    return std::int32_t(std::lower_bound(I.nodes.begin(), I.nodes.end(), n) - I.nodes.begin());
  };
  for (size_t q = 0; q + 3 < quads.size(); q += 4) {
    const std::int32_t a = local(quads[q]), b = local(quads[q + 1]), cc = local(quads[q + 2]), d = local(quads[q + 3]);
    tri.insert(tri.end(), {a, b, cc, a, cc, d});
  }
  setUp(std::move(ids), std::move(tri));
}

FluidCoupling::FluidCoupling(Solver& solver, const CouplingInput& in, const CarriedWater* water, const WetPart& part,
                             std::vector<Index> nodes, std::vector<std::int64_t> ids)
    : impl_(std::make_unique<Impl>(solver, in, std::move(nodes), water)) {
  impl_->part = &part;
  if (in.map != "coincident")
    throw InputError("/coupling map " + in.map +
                     ": the solid on ranks exchanges each rank's part of the wetted face with the coincident map "
                     "only; set /coupling map coincident, or run tq-solid as one process");
  setUp(std::move(ids), {});
}

void FluidCoupling::setUp(std::vector<std::int64_t> ids, std::vector<std::int32_t> tri) {
  Impl& I = *impl_;
  const Solver& solver = I.solver;
  const CouplingInput& in = I.in;
  const Mesh& mesh = solver.mesh();
  const size_t n3 = 3 * I.nodes.size();
  for (std::vector<Real>* v : {&I.force, &I.prev, &I.received, &I.trial, &I.receivedPrev, &I.dispStart, &I.forceStart,
                               &I.sent1, &I.sent2, &I.recvPrev, &I.lagPrev, &I.total, &I.uLast, &I.carry, &I.unpaid})
    v->assign(n3, 0.0);
  I.motion.resize(n3);
  I.planar = mesh.slice;

  // The energy guard's floor: the work of the scale forces on the scale motion of one window over
  // every wetted node (coupling_scales.py: force ρ a r A, displacement a window², the absolute
  // tolerances divided by the relative one); 26 J on the 3D paper case. Below it E_c is round-off
  // against round-off (at rest, before the wave arrives).
  if (in.energyFloor > 0)
    I.energyFloor = in.energyFloor;
  else if (in.absoluteTolForce > 0 && in.absoluteTolDisplacement > 0 && in.tolerance > 0)
    I.energyFloor = Real(I.part ? I.part->wholeCount : I.nodes.size()) * (in.absoluteTolForce / in.tolerance) *
                    (in.absoluteTolDisplacement / in.tolerance);

  // The window: k solid steps (the run set the solver's step from /coupling window_size before; the
  // number of windows is /coupling's, decided by the case: fluid_case.coupling_windows).
  I.window = in.windowSize > 0 ? in.windowSize : Real(in.windowSteps) * solver.dt();
  if (in.windows < 1)
    throw InputError("/coupling: windows " + std::to_string(in.windows) +
                     " is not a number of coupling windows; give windows >= 1 (both sides run the same count)");
  I.windows = in.windows;

  cp::CouplingConfig c;
  c.first = in.participant;
  c.second = in.partner;
  c.windowSize = I.window;
  c.maxWindows = std::uint64_t(I.windows);
  c.maxIterations = int(in.maxIterations);
  c.tolerance = in.tolerance;
  c.initialRelaxation = in.initialRelaxation;
  c.reuse = int(in.reuse);
  cp::TransportOptions t;
  try {
    c.scheme = cp::parseScheme(in.scheme);
    c.acceleration = cp::parseAcceleration(in.acceleration);
    c.predictor = cp::parsePredictor(in.predictor);
    c.residualScale = cp::parseResidualScale(in.residualScale);
    c.meshes.push_back({in.mesh, cp::parseMapKind(in.map), in.participant, in.mapTolerance});
    for (const auto& f : in.writeFields)
      c.fields.push_back({in.mesh, f, 3, in.participant, cp::MapConstraint::Consistent,
                          f == "velocity" ? in.absoluteTolVelocity : in.absoluteTolDisplacement});
    c.fields.push_back({in.mesh, "force", 3, in.partner, cp::MapConstraint::Conservative, in.absoluteTolForce});
    c.validate();
  } catch (const cp::CouplerError& e) {
    throw InputError(std::string("/coupling: ") + e.what());
  }
  I.scheme = c.scheme;
  I.predictor = c.predictor;
  I.repeats = in.windowSteps > 1 && c.scheme == cp::SchemeKind::Implicit;
  t.kind = in.transport == "mpi" ? cp::TransportKind::Mpi : cp::TransportKind::Tcp;
  t.addressFile = in.addressFile;
  t.receiveTimeout = in.timeout;
  t.connectTimeout = in.connectTimeout > 0 ? in.connectTimeout : in.timeout;

  // Interface vertices: the ids, the reference coordinates, the triangles.
  std::vector<double> xyz(n3);
  for (size_t k = 0; k < I.nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) xyz[3 * k + d] = mesh.coords[dofIndex(I.nodes[k], d)];
  try {
    I.p = std::make_unique<cp::Participant>(in.participant, c, t, in.token);
    if (I.part && I.part->parts > 1) I.p->setPart(I.part->part, I.part->parts);
    I.p->setMeshVertices(in.mesh, std::move(ids), std::move(xyz), std::move(tri));
  } catch (const cp::CouplerError& e) {
    throw InputError(std::string("/coupling: ") + e.what());
  }
}

FluidCoupling::~FluidCoupling() = default;  // the Participant sends ABORT when not finalized

void FluidCoupling::initialize() {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    I.p->initialize();
    I.read();
    I.receivedPrev = I.received;  // R_{−1} of an extrapolating predictor: window 0 starts from the initial force
    I.recvPrev = I.received;      // R_0 of the work booking (its first increment is zero for k = 1)
  } catch (const cp::CouplerError& e) {
    I.fail("could not start the coupling with '" + I.in.partner + "'", e);
  }
  I.started(t0);
}

void FluidCoupling::initializeResumed() {
  Impl& I = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  if (I.resumeBytes.empty()) throw CouplingError("water coupling: resume without a restored coupling state");
  try {
    I.p->initializeResumed(I.resumeBytes);
  } catch (const cp::CouplerError& e) {
    I.fail("could not resume the coupling with '" + I.in.partner + "'", e);
  }
  I.started(t0);
}

void FluidCoupling::restartState(StateArchive& a) {
  Impl& I = *impl_;
  if (a.saving()) I.resumeBytes = I.p->saveState();
  a.io(I.resumeBytes);
  for (std::vector<Real>* v : {&I.u0, &I.received, &I.trial, &I.receivedPrev, &I.disp, &I.vel, &I.dispStart,
                               &I.forceStart, &I.sent1, &I.sent2, &I.recvPrev, &I.lagPrev, &I.carry, &I.unpaid})
    a.io(*v);
  a.io(I.pass);
  a.io(I.fluidReceived);
  a.io(I.workPeak);
  a.io(I.energyWarned);
  a.io(I.stats.windows);
  a.io(I.stats.passes);
  a.io(I.stats.maxPasses);
  a.io(I.stats.secondsExchanging);
}

long long FluidCoupling::windowsDone() const { return impl_->stats.windows; }

void FluidCoupling::finalize() {
  Impl& I = *impl_;
  if (!I.initialized || I.finalized) return;
  try {
    I.p->finalize();
  } catch (const cp::CouplerError& e) {
    I.fail("the clean end of the coupling failed", e);
  }
  I.finalized = true;
}

void FluidCoupling::tellTimeBy(const Solver& clock) { impl_->clock = &clock; }

void FluidCoupling::abort(const std::string& reason) noexcept {
  if (impl_->p && !impl_->finalized) impl_->p->abort(reason);
  impl_->finalized = true;
}

std::string FluidCoupling::name() const { return "water coupling on '" + impl_->in.face + "'"; }

// ------------------------------------------------------------------ the protocol's parts (CoupledStepper)
void FluidCoupling::planWindow(const NodalState& st) {
  Impl& I = *impl_;
  if (!I.initialized) throw CouplingError("water coupling: a window before initialize()");
  if (!I.p->isCouplingOngoing())  // past the last window (never in tq-solid: its loop stops there)
    throw CouplingError("water coupling: the solid stepped past the last coupling window (t_end = " +
                        std::to_string(endTime()) + " s); stop the time loop when ongoing() is false");
  I.timed([&] { I.plan(st); });
  I.stepping = &I.stats.secondsFirstPasses;
}

void FluidCoupling::planStep(Index j, Real dt) {
  Impl& I = *impl_;
  I.timed([&] {
    I.stepInWindow = j;
    I.stepForce();
    I.p->advance(dt);
  });
  I.forceSet = true;
}

bool FluidCoupling::exchange(Real dt, const NodalState& st) {
  Impl& I = *impl_;
  const bool accepted = I.timed([&] { return I.exchange(dt, st); });
  I.stepping = accepted ? nullptr : &I.stats.secondsRepasses;
  return accepted;
}

void FluidCoupling::acceptWindow() {
  impl_->timed([&] { impl_->acceptWindow(); });
  impl_->stepping = nullptr;
  impl_->guardEnergy();
}

// The step's force: the window's (planStep's, or the exchange's), added to f_ext; its work booked over
// u^{n−1} → u^n exactly as the solver books f_ext (trapezoid).
void FluidCoupling::addForces(Real /*t*/, Real dt, NodalState& st) {
  Impl& I = *impl_;
  if (!I.forceSet)
    throw CouplingError(
        "water coupling: a solid step outside the coupled protocol; step the coupled solid with "
        "CoupledStepper (tq/coupling/coupled_stepper.hpp)");
  I.forceSet = false;
  Real* fe = st.fExtData();
  const Real* v = st.vData();
  // The work of the moving dofs, in the order of the wet nodes (on a part: kept for flushWetWork()).
  I.pending.bookStep(
      I.part, I.nodes.size(), [&](size_t k) { return st.mass(I.nodes[k]) > 0; },
      [&](size_t k, int d, size_t j) {
        const size_t i = dofIndex(I.nodes[k], d);
        const Real f = I.force[j] + I.carry[j];
        fe[i] += f;
        return 0.5 * (f + I.prev[j]) * I.dtPrev * v[i];
      },
      I.work);
  for (size_t j = 0; j < I.prev.size(); ++j) I.prev[j] = I.force[j] + I.carry[j];
  I.dtPrev = dt;
}

void FluidCoupling::checkpoint(StateArchive& a) {
  Impl& I = *impl_;
  a.io(I.force);
  a.io(I.prev);
  a.io(I.work);
  a.io(I.dtPrev);
  a.io(I.stepInWindow);
  if (I.part) I.pending.checkpoint(a);  // the steps whose work is not booked yet
}

WetWorkBook FluidCoupling::workBook() { return {&impl_->pending, &impl_->work}; }

bool FluidCoupling::repeatsWindows() const { return impl_->repeats; }
Index FluidCoupling::windowSteps() const { return impl_->in.windowSteps; }
bool FluidCoupling::windowOpen() const { return impl_->stepInWindow != 0; }

bool FluidCoupling::ongoing() const { return impl_->p && impl_->initialized && impl_->p->isCouplingOngoing(); }
Real FluidCoupling::endTime() const { return Real(impl_->windows) * impl_->window; }
Real FluidCoupling::windowSize() const { return impl_->window; }
long long FluidCoupling::windowCount() const { return impl_->windows; }
Real FluidCoupling::fluidWork() const { return impl_->work; }
Real FluidCoupling::fluidReceivedWork() const { return impl_->fluidReceived; }
Real FluidCoupling::couplingEnergy() const { return impl_->work + impl_->fluidReceived; }
Real FluidCoupling::interfaceWorkPeak() const { return impl_->workPeak; }
Real FluidCoupling::energyFloor() const { return impl_->energyFloor; }
std::string FluidCoupling::takeNote() {
  std::string n;
  n.swap(impl_->note);
  return n;
}
FluidCouplingStats FluidCoupling::stats() const {
  FluidCouplingStats s = impl_->stats;
  if (impl_->p && impl_->initialized) {
    const cp::ExchangeStats xs = impl_->p->stats();
    s.secondsWaiting = xs.secondsWaiting - impl_->waitAtStart;
    s.secondsMapping = xs.secondsMapping - impl_->mappingAtStart;
    s.unconvergedWindows = (long long)impl_->p->state().unconvergedWindows;
  }
  return s;
}
const std::vector<Index>& FluidCoupling::nodes() const { return impl_->nodes; }
const std::vector<Real>& FluidCoupling::force() const {
  Impl& I = *impl_;
  I.total = I.force;
  for (size_t j = 0; j < I.total.size(); ++j) I.total[j] += I.carry[j];
  if (I.water)
    for (size_t j = 0; j < I.total.size(); ++j) I.total[j] += I.water->force()[j];
  return I.total;
}

bool FluidCoupling::partnerReleased() const { return impl_->linked && !impl_->silent; }

std::string FluidCoupling::describe() const {
  const Impl& I = *impl_;
  return describeCoupling(I.in, I.window, I.windows, I.part ? I.part->wholeCount : I.nodes.size(), I.water);
}

}  // namespace tq
