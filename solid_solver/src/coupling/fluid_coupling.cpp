// The solid adapter of the water coupling (tq/coupling/fluid_coupling.hpp; docs/coupler.md "Solid adapter").
// The only solid source that includes the coupler's headers.
#include "tq/coupling/fluid_coupling.hpp"

#include <omp.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <thread>

#include "tq/coupler/errors.hpp"
#include "tq/coupler/participant.hpp"

namespace tq {

namespace cp = tq::coupler;

namespace {

/// The cause-specific advice appended to a coupler error.
std::string fixFor(const std::exception& e, const CouplingInput& in) {
  std::ostringstream os;
  if (dynamic_cast<const cp::TimeoutError*>(&e))
    os << "The water solver sent nothing within the coupling timeout of " << in.timeout
       << " s. Fix: see the water solver's log (hung or crashed); if it is only slow, raise coupling.timeout "
          "(solid_input.h5 /coupling timeout).";
  else if (dynamic_cast<const cp::PartnerLostError*>(&e))
    os << "The water solver stopped or closed the connection. Fix: see the water solver's log for its error, "
          "correct it and start the run again.";
  else if (dynamic_cast<const cp::HandshakeError*>(&e))
    os << "The water solver is configured differently or belongs to another run. Fix: start both sides from "
          "the same `tunnelquake run` (same coupling section, mesh and token).";
  else if (dynamic_cast<const cp::ProtocolError*>(&e))
    os << "A malformed or out-of-step message arrived. Fix: check that both sides are built from the same "
          "release; a foreign program may have connected to the coupling port.";
  else if (dynamic_cast<const cp::DivergenceError*>(&e)) {
    // the coupler's message names the cause and the first fix; one more when it applies
    if (in.scheme == "implicit" && in.windowSteps > 1 && in.windowForceWeight < 1)
      os << "Or raise coupling.window_force_weight toward 1 (here " << in.windowForceWeight
         << "; docs/coupler.md \"Window force weight\").";
  } else if (dynamic_cast<const cp::MapError*>(&e))
    os << "The interface meshes do not match. Fix: regenerate the water mesh from the same geometry as mesh.h5 "
          "(its interface points must coincide with the solid's '"
       << in.face << "' nodes), or use map projection.";
  else if (dynamic_cast<const cp::TransportError*>(&e))
    os << "The connection to the water solver failed. Fix: check the address file '" << in.addressFile
       << "' and that both sides run on this machine (or set transport mpi under mpirun).";
  else
    os << "Fix: check /coupling in solid_input.h5 against the water side's configuration.";
  return os.str();
}

/// CPU seconds of the calling thread (the exchange's own work: a blocked receive costs none).
double threadCpu() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace

struct FluidCoupling::Impl {
  Solver& solver;
  CouplingInput in;
  std::vector<Index> nodes;        // interface nodes (mesh indices, ascending)
  std::vector<Real> u0;            // [3n] displacement at the seismic start (reference)
  std::vector<Real> force, prev;   // [3n] force added this step / last step (N)
  std::vector<Real> received;      // [3n] latest force read from the fluid
  std::vector<Real> trial;         // [3n] force used in the current prediction
  std::vector<Real> receivedPrev;  // [3n] predictor linear: the force applied one window earlier
  std::vector<Real> disp, vel;     // [3n] predicted motion written
  std::vector<Real> dispStart;     // [3n] u − u0 at the start of the current window (k > 1)
  std::unique_ptr<cp::Participant> p;
  cp::SchemeKind scheme = cp::SchemeKind::Implicit;
  Real window = 0, dtPrev = 0;
  long long windows = 0;
  Index stepInWindow = 0;
  // The window being stepped: its passes so far; for implicit windows of k > 1 steps (stepped again
  // whole) the force at its start F_w and the request to the time loop to step it again.
  bool repeats = false;
  std::vector<Real> forceStart;  // [3n]
  long long pass = 0;
  bool repeat = false;
  Real work = 0;
  // Work the fluid received from the wall, from the exchanged data: the final
  // force of each window (the fluid's own last answer) on the motion the fluid was sent.
  std::vector<Real> sent1, sent2;  // [3n] displacement sent one / two windows ago
  std::vector<Real> recvPrev;      // [3n] final force of the last window
  std::vector<Real> lagPrev;       // [3n] u − u0 one step before the last window's end (windows of k steps)
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
  bool initialized = false, finalized = false;
  std::vector<unsigned char> resumeBytes;  // the participant's state of a restart checkpoint

  // The water's volume law, carried here (docs/coupler.md "Volume law in the solid"): the pressure
  // p_j of station j acts on its wet nodes as p_j g_i, g the nodes' area vectors out of the water, and
  // is set implicitly each step from the volume change the step makes, s_j^{n+1} = Σ_{i∈j} g_i·(u_i^{n+1}
  // − u0_i). A closed section is one station: p = −κ s^{n+1} (κ = K/V), or s^{n+1} = 0
  // (incompressible). With open ends each plane of wet nodes normal to the axis y is a station, the
  // volume W_j that left it flows along the axis as a plug, and p = 0 at the two end planes
  // (docs/coupler.md "Open ends"): p_j = −κ_j (s_j + W_j), or s_j + W_j = 0.
  bool volumeLaw = false, incompressible = false;
  bool planar = false;             // a slice: the water is sent the wall's in-plane motion only (write())
  Real volume = 0;                 // m³: all the enclosed water
  std::vector<Real> g;             // [3n] m²
  std::vector<Real> respU, respV;  // [3n] ∂u^{n+1}/∂f and ∂v^{n+½}/∂f of the last prediction
  std::vector<Real> scratchU, scratchV, sent;
  Real volumeWork = 0;
  bool openEnds = false;
  size_t S = 1;                      // stations
  std::vector<size_t> station;       // [n] the station of each wet node
  std::vector<Real> Vs, compliance;  // [S] m³, and V_j/K (0: incompressible) in m³/Pa
  // Open ends: segment j joins stations j and j+1, Q̇_j = cAx_j (p_j − p_{j+1}) with cAx = A/(ρ h);
  // Q [S−1] the axial flux at t^{n−½} (m³/s), W [S] the volume that has left each station (m³).
  std::vector<Real> cAx, Q, W;
  std::vector<Real> ps, psPrev;  // [S] Pa: the stations' pressure this step and the last
  // The water's rigid translation in the section's plane (x, z), carried here too when
  // /coupling water_density is given: a station's mean displacement is ū_j = T_j u = (1/V_j) Σ_{i∈j}
  // r_i (g_i·u_i) (r_i = x_i − c_j, c_j the station's water centroid; exact for incompressible water,
  // ∫u dV = ∮ (x − c) u·n dA), and its force on the wall is the pressure p = r·λ_j/V_j with resultant
  // λ_j = −ρ_w V_j ā_j, ā_j = T_j a, implicit in the step like p_j. The exchange then carries neither
  // the volume change nor the translation.
  bool translation = false;
  Real rhoW = 0;
  std::vector<Real> r;             // [2n] (x − c_j, z − c_j) of each wet node
  std::vector<Real> lam, lamPrev;  // [2S] N: the water's in-plane resultant −ρ V_j ā_j this step
  // The oblique projection the exchange sees, station by station: P u = u − B C⁻¹ Aᵀu removes the
  // carried modes from a motion (B: g and the uniform x, z translations; Aᵀ: the volume change g·u
  // and T u), Pᵀ F = F − A C⁻ᵀ BᵀF from a force; m = 1 (volume) or 3 (volume, translation) modes.
  int modes = 0;
  std::vector<Real> Cinv;   // [9 S] row-major 3 × 3 per station
  std::vector<Real> total;  // [3n] force added this step: the water's answer + the carried pressure
  // Work space of the laws (per station).
  mutable std::vector<Real> sums, alpha, beta, sPrime, suPrime, pScratch, lamScratch, tri;

  explicit Impl(Solver& s) : solver(s) {}

  /// The end of initialize() or initializeResumed(): the stepping's timers start.
  void started(std::chrono::steady_clock::time_point t0) {
    stats.secondsExchanging += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const cp::ExchangeStats xs = p->stats();
    waitAtStart = xs.secondsWaiting;
    mappingAtStart = xs.secondsMapping;
    steppingStart = std::chrono::steady_clock::now();
    cpuStart = threadCpu();
    initialized = true;
    linked = true;
  }

  /// The stations: one for a closed section; with open ends, the planes of wet nodes along y, whose
  /// positions (ascending) it returns.
  std::vector<Real> buildStations(const Mesh& mesh) {
    const size_t n = nodes.size();
    station.assign(n, 0);
    S = 1;
    if (!openEnds) return {};
    std::vector<Real> ys(n);
    for (size_t k = 0; k < n; ++k) ys[k] = mesh.coords[3 * size_t(nodes[k]) + 1];
    std::vector<Real> planes = ys;
    std::sort(planes.begin(), planes.end());
    const Real tol = 1e-9 * std::max<Real>(1, planes.back() - planes.front());
    planes.erase(std::unique(planes.begin(), planes.end(), [&](Real a, Real b) { return b - a <= tol; }), planes.end());
    S = planes.size();
    if (S < 3)
      throw InputError("/coupling water_ends open: the wetted face '" + in.face + "' has " + std::to_string(S) +
                       " plane(s) of nodes along the axis y; the open-ends law needs at least 3 (two elements "
                       "along the axis). Use water_ends closed for a slice");
    for (size_t k = 0; k < n; ++k) {
      const auto it = std::lower_bound(planes.begin(), planes.end(), ys[k] - tol);
      station[k] = size_t(it - planes.begin());
    }
    return planes;
  }

  /// g and the stations' volumes V_j from the wetted face's quads: each quad's area vector (half the
  /// cross product of its diagonals) oriented away from the wetted section's centroid, a quarter to
  /// each corner; a quad's volume is ½ S_q·(x_q − c)⊥ (the divergence of the in-section position is 2:
  /// the section's area times the length along the axis y), a quarter to each corner's station, and
  /// the water's centroid c_j from ∫(x − c)_k dV = ⅓ ∮ (x − c)_k (x − c)⊥·n.
  void buildVolumeLaw(const Mesh& mesh) {
    const size_t n = nodes.size();
    g.assign(3 * n, 0.0);
    auto x = [&](Index node, int d) { return mesh.coords[3 * size_t(node) + size_t(d)]; };
    Real c[3] = {0, 0, 0};
    for (Index node : nodes)
      for (int d = 0; d < 3; ++d) c[d] += x(node, d) / Real(n);
    const std::vector<Real> planes = buildStations(mesh);
    const auto& quads = mesh.faces.at(in.face);
    Vs.assign(S, 0.0);
    std::vector<Real> cw(2 * S, 0.0), Vseg(S > 1 ? S - 1 : 0, 0.0);
    for (size_t q = 0; q + 3 < quads.size(); q += 4) {
      Real sq[3], xq[3] = {0, 0, 0};
      quadAreaVector(mesh, &quads[q], sq);
      for (int d = 0; d < 3; ++d)
        for (int k = 0; k < 4; ++k) xq[d] += 0.25 * x(quads[q + size_t(k)], d);
      const Real radial = sq[0] * (xq[0] - c[0]) + sq[2] * (xq[2] - c[2]);  // (x − c)⊥, axis y
      const Real sign = radial < 0 ? -1.0 : 1.0;
      size_t jmin = S, jmax = 0;
      for (int k = 0; k < 4; ++k) {
        const size_t i = size_t(std::lower_bound(nodes.begin(), nodes.end(), quads[q + size_t(k)]) - nodes.begin());
        const size_t j = station[i];
        jmin = std::min(jmin, j), jmax = std::max(jmax, j);
        Vs[j] += 0.125 * sign * radial;
        cw[2 * j] += 0.25 * sign * (xq[0] - c[0]) * radial / 3;
        cw[2 * j + 1] += 0.25 * sign * (xq[2] - c[2]) * radial / 3;
        for (int d = 0; d < 3; ++d) g[3 * i + size_t(d)] += 0.25 * sign * sq[d];
      }
      if (openEnds) {
        if (jmax != jmin + 1)
          throw InputError("/coupling water_ends open: a quad of the wetted face '" + in.face +
                           "' does not join two neighbouring planes of nodes along the axis y; the open-ends law "
                           "needs the wetted face built of layers along the axis (an extruded mesh)");
        Vseg[jmin] += 0.5 * sign * radial;
      }
    }
    volume = 0;
    for (size_t j = 0; j < S; ++j) {
      volume += Vs[j];
      if (!(Vs[j] > 0))
        throw InputError("/coupling volume_law: the face '" + in.face + "' encloses no volume about the axis y (" +
                         std::to_string(Vs[j]) + " m³" + (S > 1 ? " at station " + std::to_string(j) : "") +
                         "); the volume law needs the wetted face of a closed section, or of a tube");
    }
    compliance.assign(S, 0.0);
    for (size_t j = 0; j < S; ++j) compliance[j] = incompressible ? 0.0 : Vs[j] / in.bulkModulus;
    // the plug flow's A/(ρ h) of each segment: A = V_seg / h
    cAx.assign(S > 1 ? S - 1 : 0, 0.0);
    for (size_t j = 0; j + 1 < S; ++j) {
      const Real h = planes[j + 1] - planes[j];
      cAx[j] = Vseg[j] / (in.axialDensity * h * h);
    }
    Q.assign(S > 1 ? S - 1 : 0, 0.0);
    W.assign(S, 0.0);
    ps.assign(S, 0.0);
    psPrev.assign(S, 0.0);
    lam.assign(2 * S, 0.0);
    lamPrev.assign(2 * S, 0.0);
    translation = in.waterDensity > 0;
    rhoW = in.waterDensity;
    r.assign(2 * n, 0.0);
    for (size_t k = 0; k < n; ++k) {
      const size_t j = station[k];
      r[2 * k] = x(nodes[k], 0) - (c[0] + cw[2 * j] / Vs[j]);
      r[2 * k + 1] = x(nodes[k], 2) - (c[2] + cw[2 * j + 1] / Vs[j]);
    }
    buildProjection();
    respU.assign(3 * n, 0.0);
    respV.assign(3 * n, 0.0);
    scratchU.assign(3 * n, 0.0);
    scratchV.assign(3 * n, 0.0);
    sums.assign(12 * S, 0.0);
    alpha.assign(2 * S, 0.0);
    beta.assign(2 * S, 0.0);
    sPrime.assign(S, 0.0);
    suPrime.assign(S, 0.0);
    pScratch.assign(S, 0.0);
    lamScratch.assign(2 * S, 0.0);
    tri.assign(2 * S, 0.0);
  }

  /// The carried laws on a prediction (predict() just made `du`, `dv` = u^{n+1} − u0 and v^{n+½} with
  /// the other forces; `v` = v^{n−½}): the correction is the pressure field p_c(x) = p_j + r·λ_j/V_j on
  /// station j's wet nodes (force g_i p_c(x_i), response respU/respV: the update is linear in the
  /// force), with
  ///   volume:       p_j = −κ_j (s_j^{n+1} + W_j^{n+1}) (incompressible: s_j^{n+1} + W_j^{n+1} = 0),
  ///                 s_j^{n+1} = g·du after the correction, W = 0 for a closed section; open ends:
  ///                 W_j^{n+1} = W_j^n + Δt (Q_j − Q_{j−1})^{n+½}, Q_j^{n+½} = Q_j^{n−½} + Δt cAx_j (p_j − p_{j+1}),
  ///                 p = 0 at the end planes;
  ///   translation:  λ_j = −ρ V_j ā_j,  ā_j = T_j (v^{n+½} − v^{n−½})/Δt after the correction.
  /// Each station's translation is eliminated first (λ_j = α_j + β_j p_j), which leaves one equation in
  /// p for a closed section, and a tridiagonal system in the interior stations' p for open ends.
  /// Writes p [S] and λ [2S] (the work space when null).
  void applyCarriedLaws(Real dt, const Real* v, std::vector<Real>& du, std::vector<Real>& dv, Real* pOut,
                        Real* lamOut) const {
    if (!pOut) pOut = pScratch.data();
    if (!lamOut) lamOut = lamScratch.data();
    std::fill(sums.begin(), sums.end(), 0.0);
    // per station: 0 s*, 1 SU, 2–3 SUr, 4–5 SVr, 6–9 SVrr, 10–11 a0
    Real SUall = 0;
    for (size_t k = 0; k < nodes.size(); ++k) {
      Real* s = &sums[12 * station[k]];
      Real qU = 0, qV = 0, gdv = 0;
      for (int d = 0; d < 3; ++d) {
        const size_t j = 3 * k + size_t(d);
        s[0] += g[j] * du[j];
        qU += g[j] * g[j] * respU[j];
        qV += g[j] * g[j] * respV[j];
        gdv += g[j] * (dv[j] - v[3 * size_t(nodes[k]) + size_t(d)]);
      }
      s[1] += qU;
      SUall += qU;
      if (!translation) continue;
      for (int a = 0; a < 2; ++a) {
        const Real ra = r[2 * k + size_t(a)];
        s[2 + a] += qU * ra;
        s[4 + a] += qV * ra;
        s[10 + a] += ra * gdv;
        for (int b = 0; b < 2; ++b) s[6 + 2 * a + b] += qV * ra * r[2 * k + size_t(b)];
      }
    }
    if (!(SUall > 0)) {
      std::fill(pOut, pOut + S, 0.0);
      std::fill(lamOut, lamOut + 2 * S, 0.0);
      return;
    }
    // each station's translation: (I + f SVrr/V) λ = −f V a0 − f SVr p, f = ρ/Δt, a0 = (1/V) Σ r g·Δv
    for (size_t j = 0; j < S; ++j) {
      const Real* s = &sums[12 * j];
      sPrime[j] = s[0], suPrime[j] = s[1];
      if (!translation) continue;
      const Real V = Vs[j], f = rhoW / dt;
      const Real b00 = 1 + f * s[6] / V, b01 = f * s[7] / V, b10 = f * s[8] / V, b11 = 1 + f * s[9] / V;
      const Real det = b00 * b11 - b01 * b10;
      const Real ra0 = -f * s[10], ra1 = -f * s[11], rb0 = -f * s[4], rb1 = -f * s[5];
      alpha[2 * j] = (b11 * ra0 - b01 * ra1) / det, alpha[2 * j + 1] = (b00 * ra1 - b10 * ra0) / det;
      beta[2 * j] = (b11 * rb0 - b01 * rb1) / det, beta[2 * j + 1] = (b00 * rb1 - b10 * rb0) / det;
      sPrime[j] += (s[2] * alpha[2 * j] + s[3] * alpha[2 * j + 1]) / V;
      suPrime[j] += (s[2] * beta[2 * j] + s[3] * beta[2 * j + 1]) / V;
    }
    if (!openEnds) {
      pOut[0] = -sPrime[0] / (suPrime[0] + compliance[0]);
    } else {
      // interior stations 1 … S−2 (Thomas): −dt² c_{j−1} p_{j−1} + D_j p_j − dt² c_j p_{j+1} = rhs_j
      pOut[0] = pOut[S - 1] = 0;
      const Real dt2 = dt * dt;
      Real* cp = tri.data();  // modified super-diagonal
      Real* dp = cp + S;      // modified right-hand side
      for (size_t j = 1; j + 1 < S; ++j) {
        const Real sub = j > 1 ? -dt2 * cAx[j - 1] : 0.0, sup = -dt2 * cAx[j];
        const Real D = suPrime[j] + compliance[j] + dt2 * (cAx[j - 1] + cAx[j]);
        const Real rhs = -(sPrime[j] + W[j] + dt * (Q[j] - Q[j - 1]));
        const Real den = D - (j > 1 ? sub * cp[j - 1] : 0.0);
        cp[j] = sup / den;
        dp[j] = (rhs - (j > 1 ? sub * dp[j - 1] : 0.0)) / den;
      }
      for (size_t j = S - 2; j >= 1; --j) pOut[j] = dp[j] - (j + 2 < S ? cp[j] * pOut[j + 1] : 0.0);
    }
    for (size_t j = 0; j < S; ++j) {
      lamOut[2 * j] = translation ? alpha[2 * j] + beta[2 * j] * pOut[j] : 0.0;
      lamOut[2 * j + 1] = translation ? alpha[2 * j + 1] + beta[2 * j + 1] * pOut[j] : 0.0;
    }
    for (size_t k = 0; k < nodes.size(); ++k) {
      const Real pc = carried(k, pOut, lamOut);
      for (int d = 0; d < 3; ++d) {
        const size_t j = 3 * k + size_t(d);
        du[j] += respU[j] * g[j] * pc;
        dv[j] += respV[j] * g[j] * pc;
      }
    }
  }

  /// The carried pressure at wet node k for station pressures p and resultants λ.
  Real carried(size_t k, const Real* p, const Real* l) const {
    const size_t j = station[k];
    return translation ? p[j] + (r[2 * k] * l[2 * j] + r[2 * k + 1] * l[2 * j + 1]) / Vs[j] : p[j];
  }

  /// Open ends: the axial plug flow moves on with this step's station pressures.
  void advanceAxialFlow(Real dt) {
    if (!openEnds) return;
    for (size_t j = 0; j + 1 < S; ++j) Q[j] += dt * cAx[j] * (ps[j] - ps[j + 1]);
    for (size_t j = 1; j + 1 < S; ++j) W[j] += dt * (Q[j] - Q[j - 1]);
  }

  /// Gauss–Jordan with partial pivoting on a 3 × 4 augmented matrix; the solution ends in column 3.
  static void solve3(Real M[3][4]) {
    for (int c = 0; c < 3; ++c) {
      int piv = c;
      for (int q = c + 1; q < 3; ++q)
        if (std::abs(M[q][c]) > std::abs(M[piv][c])) piv = q;
      for (int k = 0; k < 4; ++k) std::swap(M[c][k], M[piv][k]);
      for (int q = 0; q < 3; ++q)
        if (q != c) {
          const Real f = M[q][c] / M[c][c];
          for (int k = c; k < 4; ++k) M[q][k] -= f * M[c][k];
        }
    }
    for (int q = 0; q < 3; ++q) M[q][3] /= M[q][q];
  }

  /// C_j = A_jᵀB_j of each station's carried modes and its inverse (see `Cinv`).
  void buildProjection() {
    modes = translation ? 3 : 1;
    Cinv.assign(9 * S, 0.0);
    // columns of B: g, the uniform x and z translations; rows of Aᵀ: g·, T_x, T_z (on the station's nodes)
    auto Bcol = [&](int m, size_t k, int d) -> Real {
      if (m == 0) return g[3 * k + size_t(d)];
      return (m == 1 && d == 0) || (m == 2 && d == 2) ? 1.0 : 0.0;
    };
    auto Arow = [&](int m, size_t k, int d) -> Real {
      if (m == 0) return g[3 * k + size_t(d)];
      return r[2 * k + size_t(m - 1)] * g[3 * k + size_t(d)] / Vs[station[k]];
    };
    std::vector<Real> C(9 * S, 0.0);
    for (size_t k = 0; k < nodes.size(); ++k)
      for (int a = 0; a < modes; ++a)
        for (int b = 0; b < modes; ++b)
          for (int d = 0; d < 3; ++d) C[9 * station[k] + size_t(3 * a + b)] += Arow(a, k, d) * Bcol(b, k, d);
    for (size_t j = 0; j < S; ++j) {
      if (modes == 1) {
        Cinv[9 * j] = 1 / C[9 * j];
        continue;
      }
      for (int b = 0; b < 3; ++b) {  // column b of C⁻¹: the solution of C x = e_b
        Real M[3][4];
        for (int a = 0; a < 3; ++a) {
          for (int c2 = 0; c2 < 3; ++c2) M[a][c2] = C[9 * j + size_t(3 * a + c2)];
          M[a][3] = a == b ? 1.0 : 0.0;
        }
        solve3(M);
        for (int a = 0; a < 3; ++a) Cinv[9 * j + size_t(3 * a + b)] = M[a][3];
      }
    }
  }

  /// predict() with the carried laws: `disp`/`vel` hold the motion of the force F plus the carried pressure.
  void predictWithLaw(Real dt, const NodalState& st, const std::vector<Real>& F) {
    predict(dt, st, F, disp, vel);
    if (volumeLaw) applyCarriedLaws(dt, st.vData(), disp, vel, nullptr, nullptr);
  }

  [[noreturn]] void fail(const std::string& what, const std::exception& e) {
    if (dynamic_cast<const cp::TimeoutError*>(&e)) silent = true;
    if (dynamic_cast<const cp::HandshakeError*>(&e)) linked = true;  // refused: both sides know
    std::ostringstream os;
    os << "water coupling: " << what << " at t = " << solver.time() << " s (solid step " << solver.stepCount()
       << "): " << e.what() << " " << fixFor(e, in);
    throw CouplingError(os.str());
  }

  /// Predicted u^{n+1} − u0 and v^{n+½} of the interface nodes with the extra force F, by the
  /// solver's own update (Solver::updateNodes).
  void predict(Real dt, const NodalState& st, const std::vector<Real>& F, std::vector<Real>& disp,
               std::vector<Real>& vel) {
    const bool leapfrog = solver.options().integrator == Integrator::CentralDifference;
    const Real alpha = solver.massDampingCoefficient();
    const Real* u = st.uData();
    const Real* v = st.vData();
    const Real* fi = st.fIntData();
    const Real* fe = st.fExtData();
    const Real* cb = st.dashpotData();
    for (size_t k = 0; k < nodes.size(); ++k) {
      const Index n = nodes[k];
      const Real mn = st.mass(n);
      for (int d = 0; d < 3; ++d) {
        const size_t i = 3 * size_t(n) + size_t(d), j = 3 * k + size_t(d);
        if (!(mn > 0)) {  // node of no active element: the solver holds it at rest
          disp[j] = u[i] - u0[j];
          vel[j] = 0;
          if (volumeLaw) respU[j] = respV[j] = 0;
          continue;
        }
        const Real fr = solver.isFixed(n, d) ? 0.0 : 1.0;
        const Real f = (fe[i] + F[j]) - fi[i], cm = alpha * mn;
        Real vn, du;
        if (leapfrog) {
          const Real mdt = mn / dt, ch = 0.5 * (cm + cb[i]);
          vn = fr * ((mdt - ch) * v[i] + f) / (mdt + ch);
          du = dt * vn;
          if (volumeLaw) respV[j] = fr / (mdt + ch), respU[j] = dt * respV[j];
        } else {
          const Real acc = fr * (f - (cm + cb[i]) * v[i]) / mn;
          du = dt * v[i] + 0.5 * dt * dt * acc;
          vn = fr * (2 * du / dt - v[i]);
          if (volumeLaw) respU[j] = fr * 0.5 * dt * dt / mn, respV[j] = fr * dt / mn;
        }
        disp[j] = (u[i] + du) - u0[j];
        vel[j] = vn;
      }
    }
  }

  /// The implicit scheme's pass-0 window-end force `trial`, at the start of a window: the last
  /// converged force, or with the linear predictor 2 F_w − F_{w−1} (F the force applied in a window,
  /// the initial force before the first; receivedPrev moves on to F_w), from which both sides start:
  /// a window whose first answer already agrees with it to the tolerance needs one pass
  /// (docs/coupler.md "Predictor").
  void implicitPassZeroForce() {
    trial = received;
    if (in.predictor != "linear") return;
    if (stats.windows > 0)  // window 0 starts from the initial force (= receivedPrev)
      for (size_t j = 0; j < trial.size(); ++j) trial[j] = 2.0 * force[j] - receivedPrev[j];
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
        dispStart[j] = u[3 * size_t(nodes[k]) + size_t(d)] - u0[j];
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
    Real wf = 0;
    for (size_t j = 0; j < received.size(); ++j) wf -= 0.5 * (received[j] + recvPrev[j]) * (sent1[j] - sent2[j]);
    fluidReceived += wf;
    recvPrev = received;
    sent2.swap(sent1);
    sent1 = disp;
  }

  /// The same for an implicit window of k steps, paired as the solver pairs its own booking: the
  /// solver books ½(F^n + F^{n−1})·(u^n − u^{n−1}) with F^n the force of the step n → n+1, i.e. the
  /// water's force at t_{n+1} against the motion one step earlier. Pairing the window's forces with
  /// the window-end motion instead would leave a drift ∝ (k − 1) steps × ∫ R·a (the added mass
  /// m_a ∫a² dt) that is an artefact of the bookkeeping, not of the exchange. `st` holds u^n of the
  /// window's last step (one step before its end); for k = 1 this is bookReceivedWork().
  /// The window's two forces are weighted as the solid's steps weight them: step j applies
  /// F_w + w_j (F̃ − F_w) and books ½(F_j + F_{j−1}) on its increment, so over a window whose motion is
  /// even the solid's work is [(1 − β̄) F_w + β̄ F̃]·Δu with β̄ = ((k − 1) β + ½)/k (β the
  /// window_force_weight; ½ for the linear ramp: the trapezoid). Booking the water's side with the same
  /// β̄ keeps E_c a measure of the exchange's own inconsistency; with the trapezoid a weight β > ½ would
  /// show up as energy created, (β̄ − ½) Σ ΔF·Δu, although the water and the solid agree.
  void bookReceivedWorkWindow(const NodalState& st) {
    const Real* u = st.uData();
    const Real k = Real(in.windowSteps), bbar = ((k - 1) * in.windowForceWeight + 0.5) / k;
    Real wf = 0;
    for (size_t k3 = 0; k3 < nodes.size(); ++k3)
      for (int d = 0; d < 3; ++d) {
        const size_t j = 3 * k3 + size_t(d);
        const Real lag = u[3 * size_t(nodes[k3]) + size_t(d)] - u0[j];
        wf -= (bbar * received[j] + (1 - bbar) * recvPrev[j]) * (lag - lagPrev[j]);
        lagPrev[j] = lag;
      }
    fluidReceived += wf;
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
    workPeak = std::max({workPeak, std::abs(work), std::abs(fluidReceived), std::abs(work + volumeWork)});
    if (!(in.energyLimit > 0)) return;
    const Real ref = std::max(workPeak, energyFloor), ec = work + fluidReceived;
    if (!(ref > 0)) return;
    const Real ratio = ec / ref;
    auto where = [&] {
      std::ostringstream os;
      os << "t = " << solver.time() << " s (window " << stats.windows << ")";
      return os.str();
    };
    if (!(ratio <= in.energyLimit)) {
      std::ostringstream os;
      os << "the water coupling created energy: " << ec << " J at " << where() << ", " << 100 * ratio
         << " % of the largest interface work so far (" << ref
         << " J), above coupling.energy_limit = " << in.energyLimit << ". The scheme (" << in.scheme << ", windows of "
         << in.windowSteps << " step(s), tolerance " << in.tolerance
         << ") accepts errors that feed a weakly damped mode of the water and the lining; the results past "
            "the point where /energy/coupling_energy left zero are not trustworthy. ";
      if (!volumeLaw)
        os << "If the water's section is closed (a slice, or closed ends), let the solid carry its volume law "
              "(coupling.volume_law: solid): the whole pressure exchanged created energy from 3.3 s on the "
              "example slice with K = 22 GPa, and ran the record with the law in the solid. Otherwise ";
      os << "lower coupling.tolerance (e.g. ten times)";
      if (in.windowSteps > 1 && in.windowForceWeight < 1)
        os << ", or raise coupling.window_force_weight toward 1 (here " << in.windowForceWeight << ")";
      os << " (docs/coupler.md \"Energy guard\"; a shorter window did not help: windows of 8 steps stopped "
            "sooner than 16 on the example slice)";
      throw InstabilityError(os.str());
    }
    if (!energyWarned && ratio > 0.2 * in.energyLimit) {
      energyWarned = true;
      std::ostringstream os;
      os << "warning: the water coupling has created " << ec << " J at " << where() << ", " << 100 * ratio
         << " % of the largest interface work so far; the run stops at " << 100 * in.energyLimit
         << " % (coupling.energy_limit)";
      note = os.str();
    }
  }

  /// With the volume law the exchange leaves the carried modes to the solid: a motion sent loses them
  /// (P u: no volume change, and no translation of the water), a force read loses what would work on
  /// them (Pᵀ F: no work on a volume change or a rigid translation; its resultant goes to the solid).
  void projectMotion(std::vector<Real>& x) const {
    std::fill(sums.begin(), sums.begin() + 6 * long(S), 0.0);  // m [3S], then c [3S]
    for (size_t k = 0; k < nodes.size(); ++k) {
      Real* m = &sums[3 * station[k]];
      for (int d = 0; d < 3; ++d) {
        const Real xv = x[3 * k + size_t(d)], gv = g[3 * k + size_t(d)];
        m[0] += gv * xv;
        if (modes == 3) m[1] += r[2 * k] * gv * xv / Vs[station[k]], m[2] += r[2 * k + 1] * gv * xv / Vs[station[k]];
      }
    }
    for (size_t j = 0; j < S; ++j)
      for (int a = 0; a < modes; ++a)
        for (int b = 0; b < modes; ++b)
          sums[3 * (S + j) + size_t(a)] += Cinv[9 * j + size_t(3 * a + b)] * sums[3 * j + size_t(b)];
    for (size_t k = 0; k < nodes.size(); ++k) {
      const Real* c = &sums[3 * (S + station[k])];
      for (int d = 0; d < 3; ++d) x[3 * k + size_t(d)] -= c[0] * g[3 * k + size_t(d)];
      if (modes == 3) x[3 * k] -= c[1], x[3 * k + 2] -= c[2];
    }
  }
  void projectForce(std::vector<Real>& f) const {
    std::fill(sums.begin(), sums.begin() + 6 * long(S), 0.0);
    for (size_t k = 0; k < nodes.size(); ++k) {
      Real* m = &sums[3 * station[k]];
      for (int d = 0; d < 3; ++d) m[0] += g[3 * k + size_t(d)] * f[3 * k + size_t(d)];
      if (modes == 3) m[1] += f[3 * k], m[2] += f[3 * k + 2];
    }
    for (size_t j = 0; j < S; ++j)
      for (int a = 0; a < modes; ++a)  // Cᵀ⁻¹ = (C⁻¹)ᵀ
        for (int b = 0; b < modes; ++b)
          sums[3 * (S + j) + size_t(a)] += Cinv[9 * j + size_t(3 * b + a)] * sums[3 * j + size_t(b)];
    for (size_t k = 0; k < nodes.size(); ++k) {
      const size_t j = station[k];
      const Real* c = &sums[3 * (S + j)];
      const Real pc = c[0] + (modes == 3 ? (c[1] * r[2 * k] + c[2] * r[2 * k + 1]) / Vs[j] : 0.0);
      for (int d = 0; d < 3; ++d) f[3 * k + size_t(d)] -= pc * g[3 * k + size_t(d)];
    }
  }

  void write() {
    for (const auto& name : in.writeFields) {
      if (!volumeLaw && !planar) {
        p->writeData(in.mesh, name, name == "velocity" ? vel : disp);
        continue;
      }
      sent = name == "velocity" ? vel : disp;
      // A slice's water is planar: the wall's motion along the axis (a ground motion along y) would
      // only shift its one-cell mesh along y, which the water's point forces do not follow alike on
      // its two faces; it is sent the in-plane motion.
      if (planar)
        for (size_t k = 0; k < nodes.size(); ++k) sent[3 * k + 1] = 0;
      // The water sees the wall's motion less the carried modes (volume change, translation).
      if (volumeLaw) projectMotion(sent);
      p->writeData(in.mesh, name, sent);
    }
  }

  /// The water's answer; with the volume law, less what would work on the carried modes.
  void read() {
    p->readData(in.mesh, "force", received);
    if (volumeLaw) projectForce(received);
  }

  // ------------------------------------------------------------------ the protocol, per window
  // (tq/coupling/fluid_coupling.hpp; docs/coupler.md "Solid adapter", "Windows of several steps")

  /// One solid step of the window, k = in.windowSteps steps and one water step: the plan at its
  /// first step, the plan's force at steps j < k, the exchange at step k and the decision —
  /// accepted: the next window; not accepted: the window stepped again from its start with the
  /// water's answer as F̃ (a one-step window at once: its step is, at the interface, the local
  /// update from `st`, which the next exchange() predicts again; a window of k steps by the time
  /// loop, which restores the solver's state saved at its start: takeRepeat(), WindowedStepper).
  /// True at the end of an accepted window.
  bool windowStep(Real dt, const NodalState& st) {
    if (++stepInWindow == 1) startWindow(st);
    if (stepInWindow < in.windowSteps) {
      stepForce();
      p->advance(dt);
      return false;
    }
    stepInWindow = 0;
    while (!exchange(dt, st)) {
      trial = received;  // the next pass steps the window again with the water's answer
      if (repeats) {     // a window of k steps: the time loop restores its start (takeRepeat())
        repeat = true;
        return false;
      }
    }
    acceptWindow(st);
    return true;
  }

  /// The window's first step (of every pass): the interface's motion at the start (windows of
  /// k > 1 steps send the window's mean velocity); on pass 0 the plan: the window-end force
  /// `trial` of the first pass — implicit: the predictor's (implicitPassZeroForce()); paper and
  /// explicit: none, the water answers the motion the other forces make — and, for windows stepped
  /// again whole, the force at the window's start F_w (the last window's, the initial force before
  /// the first).
  void startWindow(const NodalState& st) {
    if (in.windowSteps > 1) markWindowStart(st);
    repeat = false;
    if (pass > 0) return;  // stepped again: `trial` is the water's last answer
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
  /// being iterated). True when the water accepted the window.
  bool exchange(Real dt, const NodalState& st) {
    ++pass;
    predictWithLaw(dt, st, trial);
    if (in.windowSteps > 1) windowMeanVelocity();
    write();
    p->advance(dt);
    read();
    force = scheme == cp::SchemeKind::Explicit ? received : trial;
    return !p->requiresReadingCheckpoint();
  }

  /// The window accepted: the water's work booked (windows stepped again whole pair it as the
  /// solver pairs its own steps), the counters, pass 0 of the next window.
  void acceptWindow(const NodalState& st) {
    if (repeats)
      bookReceivedWorkWindow(st);
    else
      bookReceivedWork();
    ++stats.windows;
    stats.passes += pass;
    stats.maxPasses = std::max(stats.maxPasses, pass);
    pass = 0;
  }

  /// The cost split's tallies for the coupler part of a step that began at t0 (wall) and c0 (CPU).
  void timeCoupler(std::chrono::steady_clock::time_point t0, double c0) {
    const auto t1 = std::chrono::steady_clock::now();
    const double inCoupler = std::chrono::duration<double>(t1 - t0).count();
    stats.secondsExchanging += inCoupler;
    stats.secondsInCoupler += inCoupler;
    stats.secondsCoupled = std::chrono::duration<double>(t1 - steppingStart).count();
    const double c1 = threadCpu();
    stats.cpuInCoupler += c1 - c0;
    stats.cpuCoupled = c1 - cpuStart;
  }

  /// Adds this step's force and the carried laws' pressure (p_v and the translation's λ for the
  /// force this step applies, implicit in this step's motion) to f_ext, and books the work of each
  /// over u^{n−1} → u^n exactly as the solver books f_ext (trapezoid).
  void addToSolid(Real dt, NodalState& st) {
    if (volumeLaw) {
      predict(dt, st, force, scratchU, scratchV);
      applyCarriedLaws(dt, st.vData(), scratchU, scratchV, ps.data(), lam.data());
      advanceAxialFlow(dt);
    }
    Real* fe = st.fExtData();
    const Real* v = st.vData();
    Real w = 0, wv = 0;
    for (size_t k = 0; k < nodes.size(); ++k)
      for (int d = 0; d < 3; ++d) {
        const size_t i = 3 * size_t(nodes[k]) + size_t(d), j = 3 * k + size_t(d);
        total[j] = force[j];
        if (!(st.mass(nodes[k]) > 0)) continue;
        fe[i] += force[j];
        w += 0.5 * (force[j] + prev[j]) * dtPrev * v[i];
        if (volumeLaw) {
          const Real pc = carried(k, ps.data(), lam.data());
          const Real pcPrev = carried(k, psPrev.data(), lamPrev.data());
          fe[i] += pc * g[j];
          total[j] += pc * g[j];
          wv += 0.5 * (pc + pcPrev) * g[j] * dtPrev * v[i];
        }
      }
    work += w;
    volumeWork += wv;
    prev = force;
    psPrev = ps;
    lamPrev = lam;
    dtPrev = dt;
  }
};

FluidCoupling::FluidCoupling(Solver& solver, const CouplingInput& in, Real tEnd)
    : impl_(std::make_unique<Impl>(solver)) {
  Impl& I = *impl_;
  I.in = in;
  const Mesh& mesh = solver.mesh();
  I.nodes = mesh.faceNodes(in.face);  // throws InputError naming the missing group
  std::sort(I.nodes.begin(), I.nodes.end());
  I.nodes.erase(std::unique(I.nodes.begin(), I.nodes.end()), I.nodes.end());
  if (I.nodes.empty()) throw InputError("/coupling: face group '" + in.face + "' has no nodes");
  const size_t n3 = 3 * I.nodes.size();
  I.u0.resize(n3);
  I.force.assign(n3, 0.0);
  I.prev.assign(n3, 0.0);
  I.received.assign(n3, 0.0);
  I.trial.assign(n3, 0.0);
  I.receivedPrev.assign(n3, 0.0);
  I.disp.assign(n3, 0.0);
  I.vel.assign(n3, 0.0);
  I.dispStart.assign(n3, 0.0);
  I.forceStart.assign(n3, 0.0);
  I.sent1.assign(n3, 0.0);
  I.sent2.assign(n3, 0.0);
  I.recvPrev.assign(n3, 0.0);
  I.lagPrev.assign(n3, 0.0);
  for (size_t k = 0; k < I.nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) I.u0[3 * k + d] = solver.state().u(I.nodes[k], d);
  I.total.assign(n3, 0.0);
  I.planar = mesh.slice;
  I.volumeLaw = in.volumeLaw != "none";
  I.incompressible = in.volumeLaw == "incompressible";
  I.openEnds = in.waterEnds == "open";
  if (I.volumeLaw) I.buildVolumeLaw(mesh);

  // The energy guard's floor: the work of the scale forces on the scale motion of one window over
  // every wetted node (coupling_scales.py: force ρ a r A, displacement a window², the absolute
  // tolerances divided by the relative one); 26 J on the 3D paper case. Below it E_c is round-off
  // against round-off (at rest, before the wave arrives).
  if (in.energyFloor > 0)
    I.energyFloor = in.energyFloor;
  else if (in.absoluteTolForce > 0 && in.absoluteTolDisplacement > 0 && in.tolerance > 0)
    I.energyFloor =
        Real(I.nodes.size()) * (in.absoluteTolForce / in.tolerance) * (in.absoluteTolDisplacement / in.tolerance);

  // Step and window: window = k solid steps.
  if (in.windowSize > 0) solver.setTimeStep(in.windowSize / Real(in.windowSteps));  // InputError if unstable
  I.window = in.windowSize > 0 ? in.windowSize : Real(in.windowSteps) * solver.dt();
  I.windows = in.windows > 0 ? in.windows : (long long)std::ceil(tEnd / I.window - 1e-9);
  if (I.windows < 1) I.windows = 1;

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
  I.repeats = in.windowSteps > 1 && c.scheme == cp::SchemeKind::Implicit;
  if (in.windowSteps > 1 && c.scheme == cp::SchemeKind::Paper)
    throw InputError("/coupling: a window of " + std::to_string(in.windowSteps) +
                     " solid steps needs scheme explicit or implicit (the paper scheme's two passes are "
                     "made for one-step windows); use window 1");
  t.kind = in.transport == "mpi" ? cp::TransportKind::Mpi : cp::TransportKind::Tcp;
  t.addressFile = in.addressFile;
  t.receiveTimeout = in.timeout;
  t.connectTimeout = in.connectTimeout > 0 ? in.connectTimeout : in.timeout;

  // Interface vertices: mesh node index as id, reference coordinates, the face's quads as triangles.
  std::vector<std::int64_t> ids(I.nodes.begin(), I.nodes.end());
  std::vector<double> xyz(n3);
  for (size_t k = 0; k < I.nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) xyz[3 * k + d] = mesh.coords[3 * size_t(I.nodes[k]) + d];
  std::vector<std::int32_t> tri;
  const auto& quads = mesh.faces.at(in.face);
  auto local = [&](Index n) {
    return std::int32_t(std::lower_bound(I.nodes.begin(), I.nodes.end(), n) - I.nodes.begin());
  };
  for (size_t q = 0; q + 3 < quads.size(); q += 4) {
    const std::int32_t a = local(quads[q]), b = local(quads[q + 1]), cc = local(quads[q + 2]), d = local(quads[q + 3]);
    tri.insert(tri.end(), {a, b, cc, a, cc, d});
  }
  try {
    I.p = std::make_unique<cp::Participant>(in.participant, c, t, in.token);
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
    I.receivedPrev = I.received;  // R_{−1} of the linear predictor: window 0 starts from the initial force
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
                               &I.forceStart, &I.sent1, &I.sent2, &I.recvPrev, &I.lagPrev})
    a.io(*v);
  // The volume law's state across steps: the stations' pressures and the water's resultants of the
  // last two steps, the work they did, and with open ends the axial flux and the volume that left
  // each station (the plug flow's integrators).
  for (std::vector<Real>* v : {&I.ps, &I.psPrev, &I.lam, &I.lamPrev, &I.Q, &I.W}) a.io(*v);
  a.io(I.volumeWork);
  a.io(I.pass);
  a.io(I.repeat);
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

void FluidCoupling::abort(const std::string& reason) noexcept {
  if (impl_->p && !impl_->finalized) impl_->p->abort(reason);
  impl_->finalized = true;
}

std::string FluidCoupling::name() const { return "water coupling on '" + impl_->in.face + "'"; }

// One solid step of the coupling (the protocol: Impl::windowStep), then the force added to the solid.
void FluidCoupling::addForces(Real /*t*/, Real dt, NodalState& st) {
  Impl& I = *impl_;
  if (!I.initialized) throw CouplingError("water coupling: addForces before initialize()");
  if (!I.p->isCouplingOngoing())  // past the last window (never in tq-solid: its loop stops there)
    throw CouplingError("water coupling: the solid stepped past the last coupling window (t_end = " +
                        std::to_string(endTime()) + " s); stop the time loop when ongoing() is false");
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = threadCpu();
  bool windowEnded = false;  // the guard then looks at the energy once this step's work is booked
  try {
    windowEnded = I.windowStep(dt, st);
  } catch (const cp::CouplerError& e) {
    I.fail("exchange with '" + I.in.partner + "' failed", e);
  }
  I.timeCoupler(t0, c0);
  I.addToSolid(dt, st);
  if (windowEnded) I.guardEnergy();
}

void FluidCoupling::checkpoint(StateArchive& a) {
  Impl& I = *impl_;
  a.io(I.force);
  a.io(I.prev);
  a.io(I.work);
  a.io(I.dtPrev);
  a.io(I.stepInWindow);
  a.io(I.ps);
  a.io(I.psPrev);
  a.io(I.lam);
  a.io(I.lamPrev);
  a.io(I.Q);
  a.io(I.W);
  a.io(I.volumeWork);
  a.io(I.total);
}

bool FluidCoupling::repeatsWindows() const { return impl_->repeats; }
bool FluidCoupling::windowOpen() const { return impl_->stepInWindow != 0; }
bool FluidCoupling::takeRepeat() {
  const bool r = impl_->repeat;
  impl_->repeat = false;
  return r;
}

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
const std::vector<Real>& FluidCoupling::force() const { return impl_->total; }
bool FluidCoupling::hasVolumeLaw() const { return impl_->volumeLaw; }
Real FluidCoupling::volumePressure() const {
  const Impl& I = *impl_;
  if (I.S == 1) return I.ps.empty() ? 0.0 : I.ps[0];
  Real pV = 0;
  for (size_t j = 0; j < I.S; ++j) pV += I.ps[j] * I.Vs[j];
  return pV / I.volume;
}
std::vector<Real> FluidCoupling::stationPressures() const { return impl_->ps; }
Real FluidCoupling::volumeLawWork() const { return impl_->volumeWork; }
Real FluidCoupling::enclosedVolume() const { return impl_->volume; }

bool FluidCoupling::partnerReleased() const { return impl_->linked && !impl_->silent; }

std::string FluidCoupling::describe() const {
  const Impl& I = *impl_;
  std::ostringstream os;
  os.precision(6);
  os << "water coupling: scheme " << I.in.scheme << ", window " << I.window << " s (" << I.in.windowSteps
     << " solid step(s)) x " << I.windows << ", " << I.nodes.size() << " nodes of '" << I.in.face << "' as mesh '"
     << I.in.mesh << "', writes";
  for (const auto& f : I.in.writeFields) os << " " << f;
  os << ", reads force; " << I.in.transport;
  if (I.in.transport == "tcp") os << " (address file " << I.in.addressFile << ")";
  os << ", timeout " << I.in.timeout << " s";
  if (I.scheme == cp::SchemeKind::Implicit)
    os << ", tolerance " << I.in.tolerance << ", at most " << I.in.maxIterations << " passes, " << I.in.acceleration
       << ", predictor " << I.in.predictor;
  if (I.volumeLaw) {
    os << "; volume law in the solid: " << I.in.volumeLaw << " water, enclosed volume " << I.volume << " m³";
    if (I.openEnds) os << ", open ends: " << I.S << " stations along the axis joined by the water's axial flow";
    if (!I.incompressible) os << ", K " << I.in.bulkModulus << " Pa";
    if (I.translation) os << ", the water's in-plane translation (" << I.rhoW * I.volume << " kg)";
  }
  return os.str();
}

// ------------------------------------------------------------------ tq-solid under mpirun
CouplingMpi::CouplingMpi(const CouplingInput& in) : partner_(in.partner) {
  cp::mpi::initialize(nullptr, nullptr);
  cp::mpi::stopOnTerminationSignals();
  const std::string n = launchedByMpirun();
  worldSize_ = n.empty() ? 1 : std::atoi(n.c_str());
  try {
    cp::mpi::splitWorld(in.participant, in.partner);
  } catch (const cp::CouplerError& e) {
    problem_ = std::string("water coupling over MPI (/coupling transport mpi): ") + e.what() +
               ". Fix: start tq-solid and the fluid under one mpirun, e.g. mpirun -np 1 tq-solid solid_input.h5 : "
               "-np 1 <fluid> (docs/coupler.md \"tq-solid under mpirun\"), or set /coupling transport tcp to run "
               "the two as separate processes.";
    return;
  }
  partnerInJob_ = true;
  if (const int k = cp::mpi::appSize(); k > 1)
    problem_ = "water coupling over MPI: " + std::to_string(k) +
               " processes of tq-solid in the job; tq-solid runs "
               "as one MPI process (it is threaded with OpenMP: --threads). Fix: mpirun -np 1 tq-solid ... : "
               "-np N <fluid> ... (docs/coupler.md \"tq-solid under mpirun\")";
}

CouplingMpi::~CouplingMpi() {
  if (!finished_) {
    std::ostringstream sink;
    finish(1, sink);
  }
}

std::string CouplingMpi::launchedByMpirun() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(var); v && *v) return std::string(v) + " processes";
  return "";
}

std::string CouplingMpi::describe() const {
  std::ostringstream os;
  os << "MPI: one application of an MPMD job of " << worldSize_ << " process(es), coupled with '" << partner_
     << "' over MPI; " << omp_get_max_threads() << " OpenMP thread(s)";
  return os.str();
}

std::string CouplingMpi::bindingWarning() const {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return "";
  const unsigned mine = unsigned(CPU_COUNT(&set)), all = std::thread::hardware_concurrency();
  if (all == 0 || mine >= all) return "";
  std::ostringstream os;
  os << "this process is bound to " << mine << " of the machine's " << all << " cores (mpirun binds each process "
     << "to a core by default), so its " << omp_get_max_threads() << " OpenMP thread(s) share "
     << (mine == 1 ? "it" : "them") << ". Fix: mpirun --bind-to none -np 1 tq-solid ... (docs/coupler.md \"tq-solid "
     << "under mpirun\")";
  return os.str();
}

void CouplingMpi::note(const FluidCoupling& c) {
  noted_ = true;
  released_ = c.partnerReleased();
}

int CouplingMpi::finish(int exitCode, std::ostream& err) {
  if (finished_) return exitCode;
  finished_ = true;
  if (cp::mpi::terminationSignal() != 0) return exitCode;  // mpirun is ending the job (a process died)
  if (exitCode == 0 || !partnerInJob_ || (noted_ && released_)) {
    cp::mpi::finalize();
    return exitCode;
  }
  err << "tq-solid: ending the MPI job (MPI_Abort, code " << exitCode << "): '" << partner_ << "' "
      << (noted_ && !released_ && partnerInJob_ ? "does not answer" : "was never reached")
      << ", so it would not end by itself" << std::endl;
  cp::mpi::abortJob(exitCode);
}

}  // namespace tq
