// The water's laws tq-solid carries in its own step (tq/water/carried_water.hpp; docs/coupler.md
// "Volume law in the solid", "Open ends").
#include "tq/water/carried_water.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "tq/io/mesh.hpp"

namespace tq {

struct CarriedWater::Impl {
  const Solver& solver;
  CouplingInput in;
  WallPrediction wall;  // the wet nodes (mesh indices, ascending) and u0
  const std::vector<Index>& nodes;
  // On MPI ranks: this rank's part of the wetted face (its nodes `nodes`, the solver's indices), its
  // sums taken in the one-process order on every part (tq/water/wet_part.hpp); null in one process.
  const WetPart* part = nullptr;
  // The whole wetted face's nodes in the mesh the geometry is built on (one process: `nodes`).
  std::vector<Index> geo;
  // The water's volume law (docs/coupler.md "Volume law in the solid"): the pressure
  // p_j of station j acts on its wet nodes as p_j g_i, g the nodes' area vectors out of the water, and
  // is set implicitly each step from the volume change the step makes, s_j^{n+1} = Σ_{i∈j} g_i·(u_i^{n+1}
  // − u0_i). A closed section is one station: p = −κ s^{n+1} (κ = K/V), or s^{n+1} = 0
  // (incompressible). With open ends each plane of wet nodes normal to the axis y is a station, the
  // volume W_j that left it flows along the axis as a plug (docs/coupler.md "Open ends"):
  // p_j = −κ_j (s_j + W_j), or s_j + W_j = 0. An end plane at a reservoir holds p = 0; at a valve it
  // is a station whose only flow is to its neighbour; at a surge tank the same, its compliance V_j/K
  // plus the tank's A_s/(ρ g) (the water that left into the tank raised its level by p/(ρ g)).
  bool incompressible = false;
  Real volume = 0;      // m³: all the enclosed water
  std::vector<Real> g;  // [3n] m²
  // [3n] m²: the volume mode's column of the projection (B): g, twice g on the nodes of a plane of
  // symmetry (/coupling symmetry_ymax), whose area vectors on the whole face are twice the half's
  std::vector<Real> gB;
  WallMotion scratch;       // the step's prediction (addForces)
  std::vector<Real> force;  // [3n] N: the carried pressure's force added this step
  Real volumeWork = 0, dtPrev = 0;
  bool openEnds = false;
  size_t jFirst = 0, jLast = 0;  // open ends: the stations whose pressure the law sets (not at a reservoir)
  size_t S = 1;                  // stations
  std::vector<size_t> station;   // [n] the station of each wet node
  // The whole face's stations, area vectors and in-section positions (one process: station, g, r):
  // what a sum's add() and a frontier copy's carried force read, on every part.
  std::vector<size_t> stationW;
  std::vector<Real> gW, rW;
  std::vector<Real> Vs, compliance;  // [S] m³, and V_j/K (0: incompressible) in m³/Pa
  // Open ends: segment j joins stations j and j+1, Q̇_j = cAx_j (p_j − p_{j+1}) with cAx = A/(ρ h);
  // Q [S−1] the axial flux at t^{n−½} (m³/s), W [S] the volume that has left each station (m³).
  std::vector<Real> cAx, Q, W;
  std::vector<Real> ps, psPrev;  // [S] Pa: the stations' pressure this step and the last
  std::vector<Real> planes;      // [S] m: the stations' y with open ends (empty for a closed section)
  // The water's rigid translation in the section's plane (x, z), carried when /coupling
  // water_density is given: a station's mean displacement is ū_j = T_j u = (1/V_j) Σ_{i∈j}
  // r_i (g_i·u_i) (r_i = x_i − c_j, c_j the station's water centroid; exact for incompressible water,
  // ∫u dV = ∮ (x − c) u·n dA), and its force on the wall is the pressure p = r·λ_j/V_j with resultant
  // λ_j = −ρ_w V_j ā_j, ā_j = T_j a, implicit in the step like p_j. The exchange then carries neither
  // the volume change nor the translation.
  bool translation = false;
  Real rhoW = 0;
  std::vector<Real> r;             // [2n] (x − c_j, z − c_j) of each wet node
  std::vector<Real> lam, lamPrev;  // [2S] N: the water's in-plane resultant −ρ V_j ā_j this step
  // The oblique projection the exchange sees, station by station: P u = u − B C⁻¹ Aᵀu removes the
  // carried modes from a motion (B: gB and the uniform x, z translations; Aᵀ: the volume change g·u
  // and T u), Pᵀ F = F − A C⁻ᵀ BᵀF from a force; m = 1 (volume) or 3 (volume, translation) modes.
  int modes = 0;
  std::vector<Real> Cinv;  // [9 S] row-major 3 × 3 per station
  // Work space of the laws (per station).
  mutable std::vector<Real> sums, alpha, beta, sPrime, suPrime, pScratch, lamScratch, tri, moments, motionMoments;
  PendingWetWork pending;  // on a part: each step's work terms, booked in step order by flushWetWork()

  Impl(const Solver& s, const CouplingInput& ci, std::vector<Index> wet)
      : solver(s), in(ci), wall(s, std::move(wet)), nodes(wall.nodes()) {}

  /// The stations: one for a closed section; with open ends, the planes of wet nodes along y, whose
  /// positions (ascending) it returns.
  std::vector<Real> buildStations(const Mesh& mesh) {
    const size_t n = geo.size();
    station.assign(n, 0);
    S = 1;
    if (!openEnds) return {};
    std::vector<Real> ys(n);
    for (size_t k = 0; k < n; ++k) ys[k] = mesh.coords[dofIndex(geo[k], 1)];
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
    const size_t n = geo.size();
    g.assign(3 * n, 0.0);
    auto x = [&](Index node, int d) { return mesh.coords[dofIndex(node, d)]; };
    Real c[3] = {0, 0, 0};
    for (Index node : geo)
      for (int d = 0; d < 3; ++d) c[d] += x(node, d) / Real(n);
    planes = buildStations(mesh);
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
        const size_t i = size_t(std::lower_bound(geo.begin(), geo.end(), quads[q + size_t(k)]) - geo.begin());
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
    jFirst = 0, jLast = S - 1;
    if (openEnds) {
      // the surge tank's free surface: dV_tank = (A_s/(ρ g)) dp in parallel with the end station's water
      constexpr Real g0 = 9.80665;
      if (in.endYmin == "surge_tank") compliance[0] += in.surgeTankAreaYmin / (in.axialDensity * g0);
      if (in.endYmax == "surge_tank") compliance[S - 1] += in.surgeTankAreaYmax / (in.axialDensity * g0);
      jFirst = in.endYmin == "reservoir" ? 1 : 0;
      jLast = in.endYmax == "reservoir" ? S - 2 : S - 1;
    }
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
      r[2 * k] = x(geo[k], 0) - (c[0] + cw[2 * j] / Vs[j]);
      r[2 * k + 1] = x(geo[k], 2) - (c[2] + cw[2 * j + 1] / Vs[j]);
    }
    gB = g;
    if (in.symmetryYmax) {
      Real yPlane = -std::numeric_limits<Real>::infinity(), yLow = std::numeric_limits<Real>::infinity();
      for (Index node : geo) yPlane = std::max(yPlane, x(node, 1)), yLow = std::min(yLow, x(node, 1));
      const Real tol = 1e-9 * std::max<Real>(1, yPlane - yLow);
      for (size_t k = 0; k < n; ++k)
        if (x(geo[k], 1) >= yPlane - tol)
          for (int d = 0; d < 3; ++d) gB[3 * k + size_t(d)] *= 2;
    }
    buildProjection();
    stationW = station;
    if (part) gW = g, rW = r;
    if (part) {  // the geometry of this part's nodes only
      std::vector<Real> gp, rp, gbp;
      std::vector<size_t> sp;
      for (size_t k : part->places) {
        gp.insert(gp.end(), g.begin() + long(3 * k), g.begin() + long(3 * k + 3));
        gbp.insert(gbp.end(), gB.begin() + long(3 * k), gB.begin() + long(3 * k + 3));
        rp.insert(rp.end(), r.begin() + long(2 * k), r.begin() + long(2 * k + 2));
        sp.push_back(station[k]);
      }
      g.swap(gp), gB.swap(gbp), r.swap(rp), station.swap(sp);
    }
    scratch.resize(3 * nodes.size());
    force.assign(3 * nodes.size(), 0.0);
    sums.assign(12 * S + 1, 0.0);  // the last: the response of every station together
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
  ///                 p = 0 at a reservoir's end plane (a valve's or a surge tank's is a station);
  ///   translation:  λ_j = −ρ V_j ā_j,  ā_j = T_j (v^{n+½} − v^{n−½})/Δt after the correction.
  /// Each station's translation is eliminated first (λ_j = α_j + β_j p_j), which leaves one equation in
  /// p for a closed section, and a tridiagonal system in the interior stations' p for open ends.
  /// Writes p [S] and λ [2S] (the work space when null).
  /// On a part with feAlong (the f_ext of this process's nodes) every node's f_ext travels with the
  /// sums' terms (sumOverWetNodes: WetPart::whole holds them after).
  void applyCarriedLaws(Real dt, const Real* v, WallMotion& m, Real* pOut, Real* lamOut,
                        const Real* feAlong = nullptr) const {
    std::vector<Real>&du = m.disp, &dv = m.vel;
    const std::vector<Real>&respU = m.respU, &respV = m.respV;
    if (!pOut) pOut = pScratch.data();
    if (!lamOut) lamOut = lamScratch.data();
    std::fill(sums.begin(), sums.end(), 0.0);
    // per station: 0 s*, 1 SU, 2–3 SUr, 4–5 SVr, 6–9 SVrr, 10–11 a0; then SU of all stations. A node's
    // terms: g·du by dof (3), qU, then with the translation qU r (2), qV r (2), r g·Δv (2), qV r r (4);
    // then, with feAlong, the node's f_ext (3: the frontier's copies take it, addForces).
    const size_t width = (translation ? 14 : 4) + (feAlong ? 3 : 0);
    sumOverWetNodes(
        part, nodes.size(), width,
        [&](size_t k, Real* t) {
          Real qU = 0, qV = 0, gdv = 0;
          for (int d = 0; d < 3; ++d) {
            const size_t j = 3 * k + size_t(d);
            t[d] = g[j] * du[j];
            qU += g[j] * g[j] * respU[j];
            qV += g[j] * g[j] * respV[j];
            gdv += g[j] * (dv[j] - v[dofIndex(nodes[k], d)]);
          }
          t[3] = qU;
          Real* e = t + 4;
          if (translation) {
            for (int a = 0; a < 2; ++a) {
              const Real ra = r[2 * k + size_t(a)];
              t[4 + a] = qU * ra;
              t[6 + a] = qV * ra;
              t[8 + a] = ra * gdv;
              for (int b = 0; b < 2; ++b) t[10 + 2 * a + b] = qV * ra * r[2 * k + size_t(b)];
            }
            e = t + 14;
          }
          if (feAlong)
            for (int d = 0; d < 3; ++d) e[d] = feAlong[dofIndex(nodes[k], d)];
        },
        [&](size_t k, const Real* t) {
          Real* s = &sums[12 * stationW[k]];
          s[0] += t[0];
          s[0] += t[1];
          s[0] += t[2];
          s[1] += t[3];
          sums[12 * S] += t[3];
          if (!translation) return;
          for (int a = 0; a < 2; ++a) {
            s[2 + a] += t[4 + a];
            s[4 + a] += t[6 + a];
            s[10 + a] += t[8 + a];
            for (int b = 0; b < 2; ++b) s[6 + 2 * a + b] += t[10 + 2 * a + b];
          }
        });
    if (!(sums[12 * S] > 0)) {
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
      // the stations jFirst … jLast (Thomas): −dt² c_{j−1} p_{j−1} + D_j p_j − dt² c_j p_{j+1} = rhs_j;
      // segment j joins stations j and j+1, a reservoir's end station holds p = 0
      pOut[0] = pOut[S - 1] = 0;
      const Real dt2 = dt * dt;
      Real* cp = tri.data();  // modified super-diagonal
      Real* dp = cp + S;      // modified right-hand side
      for (size_t j = jFirst; j <= jLast; ++j) {
        const bool left = j > 0, right = j + 1 < S;  // the segments j−1 and j exist
        const Real cl = left ? cAx[j - 1] : 0.0, cr = right ? cAx[j] : 0.0;
        const Real sub = j > jFirst ? -dt2 * cl : 0.0, sup = j < jLast ? -dt2 * cr : 0.0;
        const Real D = suPrime[j] + compliance[j] + dt2 * (cl + cr);
        const Real rhs = -(sPrime[j] + W[j] + dt * ((right ? Q[j] : 0.0) - (left ? Q[j - 1] : 0.0)));
        const Real den = D - (j > jFirst ? sub * cp[j - 1] : 0.0);
        cp[j] = sup / den;
        dp[j] = (rhs - (j > jFirst ? sub * dp[j - 1] : 0.0)) / den;
      }
      for (size_t j = jLast + 1; j-- > jFirst;) pOut[j] = dp[j] - (j < jLast ? cp[j] * pOut[j + 1] : 0.0);
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
  Real carried(size_t k, const Real* p, const Real* l) const { return carriedAt(station, r, k, p, l); }
  /// The same at node k of a face whose stations and in-section positions are st, rr.
  Real carriedAt(const std::vector<size_t>& st, const std::vector<Real>& rr, size_t k, const Real* p,
                 const Real* l) const {
    const size_t j = st[k];
    return translation ? p[j] + (rr[2 * k] * l[2 * j] + rr[2 * k + 1] * l[2 * j + 1]) / Vs[j] : p[j];
  }

  /// A part's frontier copies of wet nodes owned by other parts, after the step's sums (with feAlong):
  /// each copy's f_ext is its owner's when the sums' terms were taken, plus, where the node moves, the
  /// carried force the owner adds, computed alike; so the copies stay bitwise their owner's without a
  /// message of their own.
  void setCopies(NodalState& st) const {
    const size_t width = (translation ? 14 : 4) + 3;
    Real* fe = st.fExtData();
    for (const auto& [l, k] : part->copies) {
      const Real* owner = part->whole.data() + width * k + (width - 3);
      const bool moves = st.mass(l) > 0;
      const Real pc = moves ? carriedAt(stationW, rW, k, ps.data(), lam.data()) : 0.0;
      for (int d = 0; d < 3; ++d) {
        const size_t i = dofIndex(l, d);
        fe[i] = owner[d];
        if (moves) fe[i] += pc * gW[3 * k + size_t(d)];
      }
    }
  }

  /// Open ends: the axial plug flow moves on with this step's station pressures.
  void advanceAxialFlow(Real dt) {
    if (!openEnds) return;
    for (size_t j = 0; j + 1 < S; ++j) Q[j] += dt * cAx[j] * (ps[j] - ps[j + 1]);
    for (size_t j = jFirst; j <= jLast; ++j) W[j] += dt * ((j + 1 < S ? Q[j] : 0.0) - (j > 0 ? Q[j - 1] : 0.0));
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
    // columns of B: gB, the uniform x and z translations; rows of Aᵀ: g·, T_x, T_z (on the station's nodes)
    auto Bcol = [&](int m, size_t k, int d) -> Real {
      if (m == 0) return gB[3 * k + size_t(d)];
      return (m == 1 && d == 0) || (m == 2 && d == 2) ? 1.0 : 0.0;
    };
    auto Arow = [&](int m, size_t k, int d) -> Real {
      if (m == 0) return g[3 * k + size_t(d)];
      return r[2 * k + size_t(m - 1)] * g[3 * k + size_t(d)] / Vs[station[k]];
    };
    std::vector<Real> C(9 * S, 0.0);
    for (size_t k = 0; k < geo.size(); ++k)
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

  /// With the volume law the exchange leaves the carried modes to the solid: a motion sent loses them
  /// (P u: no volume change, and no translation of the water), a force read loses what would work on
  /// them (Pᵀ F: no work on a volume change or a rigid translation; its resultant goes to the solid).
  /// Several motions at once (the fields written): their sums in one gather, each projected as alone.
  void projectMotions(const std::vector<std::vector<Real>*>& xs) const {
    // a motion's terms at a node, by dof: g·x, and with the translation r g·x / V (2)
    const size_t w = size_t(modes), nf = xs.size();
    motionMoments.assign(nf * 3 * S, 0.0);
    sumOverWetNodes(
        part, nodes.size(), 3 * w * nf,
        [&](size_t k, Real* t) {
          for (const std::vector<Real>* xp : xs) {
            const std::vector<Real>& x = *xp;
            for (int d = 0; d < 3; ++d) {
              const Real xv = x[3 * k + size_t(d)], gv = g[3 * k + size_t(d)];
              Real* td = t + w * size_t(d);
              td[0] = gv * xv;
              if (modes == 3)
                td[1] = r[2 * k] * gv * xv / Vs[station[k]], td[2] = r[2 * k + 1] * gv * xv / Vs[station[k]];
            }
            t += 3 * w;
          }
        },
        [&](size_t k, const Real* t) {
          for (size_t f = 0; f < nf; ++f, t += 3 * w) {
            Real* m = &motionMoments[3 * S * f + 3 * stationW[k]];
            for (int d = 0; d < 3; ++d)
              for (size_t a = 0; a < w; ++a) m[a] += t[w * size_t(d) + a];
          }
        });
    for (size_t f = 0; f < nf; ++f) {
      std::vector<Real>& x = *xs[f];
      std::fill(sums.begin(), sums.begin() + 6 * long(S), 0.0);  // m [3S], then c [3S]
      std::copy_n(motionMoments.begin() + long(3 * S * f), 3 * S, sums.begin());
      for (size_t j = 0; j < S; ++j)
        for (int a = 0; a < modes; ++a)
          for (int b = 0; b < modes; ++b)
            sums[3 * (S + j) + size_t(a)] += Cinv[9 * j + size_t(3 * a + b)] * sums[3 * j + size_t(b)];
      for (size_t k = 0; k < nodes.size(); ++k) {
        const Real* c = &sums[3 * (S + station[k])];
        for (int d = 0; d < 3; ++d) x[3 * k + size_t(d)] -= c[0] * gB[3 * k + size_t(d)];
        if (modes == 3) x[3 * k] -= c[1], x[3 * k + 2] -= c[2];
      }
    }
  }
  void projectForce(std::vector<Real>& f) const {
    std::fill(sums.begin(), sums.begin() + 6 * long(S), 0.0);
    moments.assign(3 * S, 0.0);
    // a node's terms: B's columns on f: gB·f by dof (3), and with the translation f_x, f_z
    sumOverWetNodes(
        part, nodes.size(), modes == 3 ? 5 : 3,
        [&](size_t k, Real* t) {
          for (int d = 0; d < 3; ++d) t[d] = gB[3 * k + size_t(d)] * f[3 * k + size_t(d)];
          if (modes == 3) t[3] = f[3 * k], t[4] = f[3 * k + 2];
        },
        [&](size_t k, const Real* t) {
          Real* m = &moments[3 * stationW[k]];
          m[0] += t[0];
          m[0] += t[1];
          m[0] += t[2];
          if (modes == 3) m[1] += t[3], m[2] += t[4];
        });
    std::copy(moments.begin(), moments.end(), sums.begin());
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
};

std::shared_ptr<CarriedWater> CarriedWater::fromCoupling(const Solver& solver, const CouplingInput& in) {
  if (in.volumeLaw == "none") return nullptr;
  return std::make_shared<CarriedWater>(solver, in);
}

CarriedWater::CarriedWater(const Solver& solver, const CouplingInput& in)
    : impl_(std::make_unique<Impl>(solver, in, wallNodes(solver.mesh(), in.face))) {
  impl_->geo = impl_->nodes;
  impl_->incompressible = in.volumeLaw == "incompressible";
  impl_->openEnds = in.waterEnds == "open";
  impl_->buildVolumeLaw(solver.mesh());
}

CarriedWater::CarriedWater(const Solver& solver, const CouplingInput& in, const Mesh& whole, const WetPart& part,
                           std::vector<Index> nodes)
    : impl_(std::make_unique<Impl>(solver, in, std::move(nodes))) {
  impl_->part = &part;
  impl_->geo = wallNodes(whole, in.face);
  impl_->incompressible = in.volumeLaw == "incompressible";
  impl_->openEnds = in.waterEnds == "open";
  impl_->buildVolumeLaw(whole);
}

CarriedWater::~CarriedWater() = default;

std::string CarriedWater::name() const { return "water carried by the solid on '" + impl_->in.face + "'"; }

// The pressure p_j and the resultants λ_j implicit in this step's motion (the prediction holds every
// force before this one, the exchanged water force included), then added and booked like f_ext.
void CarriedWater::addForces(Real /*t*/, Real dt, NodalState& st) {
  Impl& I = *impl_;
  I.wall.predict(dt, st, nullptr, I.scratch, true);
  // With frontier copies of wet nodes, each node's f_ext (the exchanged force added) goes with the sums'
  // terms, and a copy's f_ext is set from its owner's.
  const bool along = I.part && I.part->copiesAnywhere;
  I.applyCarriedLaws(dt, st.vData(), I.scratch, I.ps.data(), I.lam.data(), along ? st.fExtData() : nullptr);
  I.advanceAxialFlow(dt);
  Real* fe = st.fExtData();
  if (along) I.setCopies(st);
  const Real* v = st.vData();
  std::fill(I.force.begin(), I.force.end(), 0.0);
  // The work of the moving dofs, in the order of the wet nodes (on a part: kept for flushWetWork()).
  Real pc = 0, pcPrev = 0;  // the node's carried pressure now and a step before
  I.pending.bookStep(
      I.part, I.nodes.size(), [&](size_t k) { return st.mass(I.nodes[k]) > 0; },
      [&](size_t k, int d, size_t j) {
        if (d == 0) {
          pc = I.carried(k, I.ps.data(), I.lam.data());
          pcPrev = I.carried(k, I.psPrev.data(), I.lamPrev.data());
        }
        const size_t i = dofIndex(I.nodes[k], d);
        I.force[j] = pc * I.g[j];
        fe[i] += I.force[j];
        return 0.5 * (pc + pcPrev) * I.g[j] * I.dtPrev * v[i];
      },
      I.volumeWork);
  I.psPrev = I.ps;
  I.lamPrev = I.lam;
  I.dtPrev = dt;
}

void CarriedWater::checkpoint(StateArchive& a) {
  Impl& I = *impl_;
  for (std::vector<Real>* v : {&I.ps, &I.psPrev, &I.lam, &I.lamPrev, &I.Q, &I.W, &I.force, &I.wall.reference()})
    a.io(*v);
  a.io(I.volumeWork);
  a.io(I.dtPrev);
  if (I.part) I.pending.checkpoint(a);  // the steps whose work is not booked yet
}

WetWorkBook CarriedWater::workBook() { return {&impl_->pending, &impl_->volumeWork}; }

bool CarriedWater::constrainLevels(std::vector<std::uint8_t>& level) const {
  return lowerToFinestLevel(level, impl_->nodes);
}

bool CarriedWater::forceGroups(std::vector<std::vector<Index>>& groups) const {
  groups.push_back(impl_->nodes);
  return true;
}

void CarriedWater::correct(Real dt, const NodalState& st, WallMotion& m) const {
  impl_->applyCarriedLaws(dt, st.vData(), m, nullptr, nullptr);
}
void CarriedWater::projectMotion(std::vector<Real>& x) const { impl_->projectMotions({&x}); }
void CarriedWater::projectMotions(const std::vector<std::vector<Real>*>& xs) const { impl_->projectMotions(xs); }
void CarriedWater::projectForce(std::vector<Real>& f) const { impl_->projectForce(f); }

const std::vector<Index>& CarriedWater::nodes() const { return impl_->nodes; }
const std::vector<Real>& CarriedWater::force() const { return impl_->force; }
Real CarriedWater::volumePressure() const {
  const Impl& I = *impl_;
  if (I.S == 1) return I.ps.empty() ? 0.0 : I.ps[0];
  Real pV = 0;
  for (size_t j = 0; j < I.S; ++j) pV += I.ps[j] * I.Vs[j];
  return pV / I.volume;
}
std::vector<Real> CarriedWater::stationPressures() const { return impl_->ps; }
Real CarriedWater::stationPressure(size_t j) const { return j < impl_->ps.size() ? impl_->ps[j] : 0.0; }
const std::vector<Real>& CarriedWater::stationPositions() const { return impl_->planes; }
bool CarriedWater::hasSurgeTank(int end) const {
  const Impl& I = *impl_;
  return I.openEnds && (end == 0 ? I.in.endYmin : I.in.endYmax) == "surge_tank";
}
// The tank's compliance A_s/(ρ g) holds the volume A_s p/(ρ g) at its end station's pressure p, so its
// level stands p/(ρ g) above its rest.
Real CarriedWater::surgeLevel(int end) const {
  const Impl& I = *impl_;
  if (!hasSurgeTank(end) || I.ps.empty()) return 0.0;
  constexpr Real g0 = 9.80665;
  return (end == 0 ? I.ps.front() : I.ps.back()) / (I.in.axialDensity * g0);
}
Real CarriedWater::work() const { return impl_->volumeWork; }
Real CarriedWater::enclosedVolume() const { return impl_->volume; }

std::string CarriedWater::describe() const {
  const Impl& I = *impl_;
  std::ostringstream os;
  os.precision(6);
  os << "volume law in the solid: " << I.in.volumeLaw << " water, enclosed volume " << I.volume << " m³";
  if (I.openEnds) {
    os << ", open ends: " << I.S << " stations along the axis joined by the water's axial flow, ends " << I.in.endYmin;
    if (I.in.endYmin == "surge_tank") os << " (" << I.in.surgeTankAreaYmin << " m²)";
    os << " / " << I.in.endYmax;
    if (I.in.endYmax == "surge_tank") os << " (" << I.in.surgeTankAreaYmax << " m²)";
  }
  if (!I.incompressible) os << ", K " << I.in.bulkModulus << " Pa";
  if (I.translation) os << ", the water's in-plane translation (" << I.rhoW * I.volume << " kg)";
  if (I.in.subtractMeanPressure) os << "; the water sends its wall pressure less its mean";
  return os.str();
}

}  // namespace tq
