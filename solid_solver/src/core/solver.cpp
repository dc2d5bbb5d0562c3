#include "tq/core/solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>

// The node update's vector helpers are always inlined: the AVX ABI note does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

#include "simd_util.hpp"

namespace tq {

namespace {
constexpr Index kNodeChunk = 1024;
constexpr int kSums = 6;  // kinetic, external, damping, boundary, first bad dof (as Real), internal work

struct LeapfrogArgs {
  Real *u, *v, *a;
  const Real *fi, *fe, *cb;  // cb: dashpots (null when the model has none)
  const std::uint8_t* fr;    // 1 free, 0 fixed
  const Real* fprev;         // f_ext of the previous step
  const Real* m;             // mass per node (the chunk's first node)
  Index nn;                  // nodes in the chunk
  Real dt, dtl, alpha, vlim;
  bool kin;  // sum the kinetic energy (Solver::setKineticEnergyWanted)
};
struct LeapfrogSums {
  Real ke = 0, ext = 0, damp = 0, bdry = 0;
  Real wint = 0;  // subcycled: the internal forces' work booked at the node updates
  Index nBad = 0;
};

// First dof in [i0, i1) whose |v| is above the limit or not finite (-1 if none): where a node
// loop that counted a bad lane reports it.
inline Index firstBadDof(const Real* v, size_t i0, size_t i1, Real vlim) {
  for (size_t j = i0; j < i1; ++j)
    if (!(std::abs(v[j]) <= vlim)) return Index(j);
  return -1;
}

inline void storeChunkSums(Real* s, Real ke, Real ext, Real damp, Real bdry, Index bad, Real wint = 0) {
  s[0] = ke;
  s[1] = ext;
  s[2] = damp;
  s[3] = bdry;
  s[4] = Real(bad);
  s[5] = wint;
}

typedef long long LI2 __attribute__((vector_size(16)));
typedef long long LI4 __attribute__((vector_size(32)));

// 4 node values spread over their 12 dofs (node-major: m0 m0 m0 m1 | m1 m1 m2 m2 | ...), from a
// register (values built lane by lane: stored to memory one at a time and read back as a vector,
// they stall the load on its store forwarding) or from memory (dofMasses: the masses).
inline __attribute__((always_inline)) void dofSpread(V4 mv, V4 out[3]) {
  out[0] = __builtin_shuffle(mv, LI4{0, 0, 0, 1});
  out[1] = __builtin_shuffle(mv, LI4{1, 1, 2, 2});
  out[2] = __builtin_shuffle(mv, LI4{2, 3, 3, 3});
}
inline __attribute__((always_inline)) void dofSpread(V2 a, V2 b, V2 out[6]) {
  out[0] = __builtin_shuffle(a, LI2{0, 0});
  out[1] = a;
  out[2] = __builtin_shuffle(a, LI2{1, 1});
  out[3] = __builtin_shuffle(b, LI2{0, 0});
  out[4] = b;
  out[5] = __builtin_shuffle(b, LI2{1, 1});
}
inline __attribute__((always_inline)) void dofSpread(V4 mv, V2 out[6]) {
  dofSpread(V2{mv[0], mv[1]}, V2{mv[2], mv[3]}, out);
}
inline __attribute__((always_inline)) void dofMasses(const Real* m, V4 out[3]) { dofSpread(loadv<V4>(m), out); }
inline __attribute__((always_inline)) void dofMasses(const Real* m, V2 out[6]) {
  dofSpread(loadv<V2>(m), loadv<V2>(m + 2), out);
}
// The free mask (bytes 0/1) of 4 or 2 dofs as 0.0/1.0 lanes, through a table indexed by the bits
// (GCC 12 converts byte vectors to doubles one lane at a time).
struct FreeLut {
  V4 v4[16];
  V2 v2[4];
  FreeLut() {
    for (int i = 0; i < 16; ++i)
      for (int l = 0; l < 4; ++l) v4[i][l] = Real((i >> l) & 1);
    for (int i = 0; i < 4; ++i)
      for (int l = 0; l < 2; ++l) v2[i][l] = Real((i >> l) & 1);
  }
};
const FreeLut kFreeLut;
inline __attribute__((always_inline)) V4 freeLanes(const std::uint8_t* fr, V4) {
  std::uint32_t w;
  std::memcpy(&w, fr, 4);
  return kFreeLut.v4[((w * 0x01020408u) >> 24) & 15];  // byte k (0 or 1) -> bit k
}
inline __attribute__((always_inline)) V2 freeLanes(const std::uint8_t* fr, V2) {
  std::uint16_t w;
  std::memcpy(&w, fr, 2);
  return kFreeLut.v2[((std::uint32_t(w) * 0x0102u) >> 8) & 3];
}

// Central-difference update of one dof or one vector of dofs T (Real or a vector type): every
// value is computed unconditionally (selects, no branches). A dof of a node of no active element
// (excavated, not yet installed; m = 0) stays at rest. kKin: sum the kinetic energy (a state, read
// only at some steps); the works are accumulated at every step.
template <class T, bool kKin>
inline __attribute__((always_inline)) void leapfrogDofs(T mn, T fri, T cd, Real* __restrict u, Real* __restrict v,
                                                        Real* __restrict a, const Real* __restrict fi,
                                                        const Real* __restrict fe, const Real* __restrict fprev,
                                                        const LeapfrogArgs& q, T& ke, T& ext, T& damp, T& bdry,
                                                        T& bad) {
  const T zero = T{} * 0.0, one = zero + 1.0;
  const T vo = loadv<T>(v), fei = loadv<T>(fe), fii = loadv<T>(fi), fpi = loadv<T>(fprev);
  const Real dt = q.dt, rdt = 1 / q.dt;
  const auto has = mn > 0;
  const T f = fei - fii;
  const T cm = q.alpha * mn;
  // Dashpots (α M and boundary) with the mean of the half-step velocities:
  // v^{n+½} = [(m/Δt - c/2) v^{n-½} + f] / (m/Δt + c/2): stable for any c.
  const T mdt = mn * rdt, ch = 0.5 * (cm + cd);
  const T den = has ? mdt + ch : one;
  const T vfree = fri * ((mdt - ch) * vo + f) / den;
  const T vn = has ? vfree : zero;
  const T vb = 0.5 * (vo + vn);
  // Work of the external force over u^{n-1} -> u^n (trapezoid; exact balance).
  const T wExt = 0.5 * (fei + fpi) * q.dtl * vo, wKin = 0.5 * mn * vo * vn;
  const T wDamp = cm * vb * vb * dt, wBdry = cd * vb * vb * dt;
  ext += has ? wExt : zero;
  if (kKin) ke += has ? wKin : zero;
  damp += has ? wDamp : zero;
  bdry += has ? wBdry : zero;
  const T acc = (vn - vo) * rdt, du = dt * vn;
  storev(a, has ? acc : zero);
  storev(u, loadv<T>(u) + (has ? du : zero));
  storev(v, vn);
  const T av = vn < 0 ? -vn : vn;
  bad += av <= q.vlim ? zero : one;  // also catches NaN
}

// The lanes' sums of the node loops, in lane order (fixed: independent of the vector width).
template <class V>
inline __attribute__((always_inline)) LeapfrogSums laneSums(V ke, V ext, V damp, V bdry, V bad, Real& bads) {
  constexpr int L = sizeof(V) / sizeof(Real);
  LeapfrogSums r;
  for (int l = 0; l < L; ++l) {
    r.ke += ke[l];
    r.ext += ext[l];
    r.damp += damp[l];
    r.bdry += bdry[l];
    bads += bad[l];
  }
  return r;
}

// One SIMD loop over a node chunk, 4 nodes (12 dofs) at a time: V = 2 lanes (generic x86-64) or
// 4 lanes (AVX2 + FMA), chosen like the element kernel (ElementBlock::defaultUseAvx2; the results
// of the two differ in the last bits, never with the thread count). kDash: the model has dashpots.
template <class V, bool kDash, bool kKin>
inline __attribute__((always_inline)) LeapfrogSums leapfrogBody(const LeapfrogArgs& q) {
  constexpr int L = sizeof(V) / sizeof(Real), K = 12 / L;
  Real* __restrict u = q.u;
  Real* __restrict v = q.v;
  Real* __restrict a = q.a;
  const Real* __restrict fi = q.fi;
  const Real* __restrict fe = q.fe;
  const Real* __restrict cb = q.cb;
  const Real* __restrict fp = q.fprev;
  const std::uint8_t* __restrict fr = q.fr;
  V ke{}, ext{}, damp{}, bdry{}, bad{};
  const Index n4 = q.nn / 4 * 4;
  for (Index n = 0; n < n4; n += 4) {
    V mv[K];
    dofMasses(q.m + n, mv);
#pragma GCC unroll 6
    for (int k = 0; k < K; ++k) {
      const size_t i = 3 * size_t(n) + size_t(k) * L;
      const V cd = kDash ? loadv<V>(cb + i) : V{};
      leapfrogDofs<V, kKin>(mv[k], freeLanes(fr + i, V{}), cd, u + i, v + i, a + i, fi + i, fe + i, fp + i, q, ke, ext,
                            damp, bdry, bad);
    }
  }
  Real bads = 0;
  LeapfrogSums r = laneSums(ke, ext, damp, bdry, bad, bads);
  // The last few nodes, scalar, sum the kinetic energy whatever is asked (left unread then): the
  // same code as the steps that sum it. Compiled without it this loop moved its nodes differently
  // in the last bits: a tunnel with contact on 3 ranks (a rank's last few nodes frontier nodes that
  // another rank updates in the vector loop) differed from its run summing the kinetic energy at
  // every step (ring forces by 3e-13 of their largest value), its frontier nodes' copies from each
  // other.
  for (size_t i = 3 * size_t(n4); i < 3 * size_t(q.nn); ++i) {
    const Real cd = kDash ? cb[i] : 0.0;
    leapfrogDofs<Real, true>(q.m[i / 3], Real(fr[i]), cd, u + i, v + i, a + i, fi + i, fe + i, fp + i, q, r.ke, r.ext,
                             r.damp, r.bdry, bads);
  }
  r.nBad = Index(bads);
  return r;
}
struct SubcycleArgs {
  Real *u, *v, *a, *fs, *dtp;  // fs: f_ext at each node's last update; dtp: its last step
  Real* fis;                   // f_int at each node's last update
  const Real *fi, *fe, *cb, *m;
  const std::uint8_t *fr, *lev;
  Index nn;  // nodes in the chunk
  Real dt, alpha, vlim;
  int active;
  bool kin;     // sum the kinetic energy (Solver::setKineticEnergyWanted)
  Real rdt[9];  // 1 / (2^level Δt), level 0..8
};

// Subcycled update of one dof or one vector of dofs (see Solver::updateNodesSubcycled): a due
// node (upd) takes the central-difference step dtn = 2^level Δt; every node of an active element
// moves by Δt v. Branch-free like leapfrogDofs. The works of the external and of the internal
// forces are both booked at the node's updates, over its previous step (trapezoid): the node's
// own update then balances kinetic + internal + damping - external exactly, at every fine step
// (the elements' own stress work, booked when they are evaluated, would count a coarse node's
// motion on the fine elements next to it before its external work and kinetic energy are).
// kKin: sum the kinetic energy, as leapfrogDofs.
template <class T, bool kKin>
inline __attribute__((always_inline)) void subcycleDofs(T mn, T due, T dtn, T rdt, T dtl, T fri, T cd, size_t i,
                                                        const SubcycleArgs& q, T& ke, T& ext, T& damp, T& bdry, T& wint,
                                                        T& bad) {
  const T zero = T{} * 0.0, one = zero + 1.0;
  const T vo = loadv<T>(q.v + i), fei = loadv<T>(q.fe + i), fii = loadv<T>(q.fi + i), fsi = loadv<T>(q.fs + i);
  const T fisi = loadv<T>(q.fis + i), ao = loadv<T>(q.a + i);
  const auto has = mn > 0;
  const auto upd = has & (due > 0);
  const T cm = q.alpha * mn, mdt = mn * rdt, ch = 0.5 * (cm + cd);
  const T den = has ? mdt + ch : one;
  const T vnew = fri * ((mdt - ch) * vo + fei - fii) / den;
  const T vn = upd ? vnew : has ? vo : zero;
  const T vb = 0.5 * (vo + vn);
  ext += upd ? 0.5 * (fei + fsi) * dtl * vo : zero;  // over this node's previous step
  wint += upd ? 0.5 * (fii + fisi) * dtl * vo : zero;
  // ½ m v^{k-½}·v^{k+½} of the node's own step k, also between its updates (v^{k-½} = v - a dtn):
  // the kinetic energy changes only where the works are booked.
  if (kKin) ke += has ? 0.5 * mn * vo * (upd ? vn : vo - dtn * ao) : zero;
  // The dashpots' work over the node's previous step, ½ v^{k+½}·(c v̄^{k+1} dtn + c v̄^k dtl) with
  // v̄^k = v^{k+½} − ½ a dtl: what the product form of the kinetic energy loses to them from one
  // update to the next (booked as c v̄² dtn at each update, as single-rate books it, the preloaded
  // box of test_subcycling.cpp drifted by 4.5e-6 of its external work; now 1e-15).
  const T wdash = 0.5 * vo * (dtn * vb + dtl * (vo - 0.5 * dtl * ao));
  damp += upd ? cm * wdash : zero;
  bdry += upd ? cd * wdash : zero;
  storev(q.fs + i, upd ? fei : fsi);
  storev(q.fis + i, upd ? fii : fisi);
  storev(q.a + i, upd ? (vn - vo) * rdt : has ? ao : zero);
  storev(q.v + i, vn);
  storev(q.u + i, loadv<T>(q.u + i) + q.dt * vn);  // + 0 for a node of no active element
  const T av = vn < 0 ? -vn : vn;
  bad += av <= q.vlim ? zero : one;  // also catches NaN
}

// One chunk of the subcycled update, 4 nodes (12 dofs) at a time, the node values spread over
// their dofs as the masses are (dofMasses).
template <class V, bool kDash, bool kKin>
inline __attribute__((always_inline)) LeapfrogSums subcycleBody(const SubcycleArgs& q) {
  constexpr int L = sizeof(V) / sizeof(Real), K = 12 / L;
  V ke{}, ext{}, damp{}, bdry{}, wint{}, bad{};
  const Index n4 = q.nn / 4 * 4;
  for (Index n = 0; n < n4; n += 4) {
    V mv[K];
    dofMasses(q.m + n, mv);
    bool quiet = true;  // none of the 4 due, all of active elements: most groups at most fine steps
    for (int j = 0; j < 4; ++j) quiet = quiet && q.lev[n + j] > q.active && q.m[n + j] > 0;
    if (quiet) {  // move on with v (what subcycleDofs does for them, without its division)
      if (!kKin) {
#pragma GCC unroll 6
        for (int k = 0; k < K; ++k) {
          const size_t i = 3 * size_t(n) + size_t(k) * L;
          storev(q.u + i, loadv<V>(q.u + i) + q.dt * loadv<V>(q.v + i));
        }
        continue;
      }
      V tq[K];
      dofSpread(V4{q.dt * Real(1u << q.lev[n]), q.dt * Real(1u << q.lev[n + 1]), q.dt * Real(1u << q.lev[n + 2]),
                   q.dt * Real(1u << q.lev[n + 3])},
                tq);
#pragma GCC unroll 6
      for (int k = 0; k < K; ++k) {
        const size_t i = 3 * size_t(n) + size_t(k) * L;
        const V vo = loadv<V>(q.v + i);
        ke += 0.5 * mv[k] * vo * (vo - tq[k] * loadv<V>(q.a + i));
        storev(q.u + i, loadv<V>(q.u + i) + q.dt * vo);
      }
      continue;
    }
    const int l0 = q.lev[n], l1 = q.lev[n + 1], l2 = q.lev[n + 2], l3 = q.lev[n + 3];
    const V4 due4 = {l0 <= q.active ? 1.0 : 0.0, l1 <= q.active ? 1.0 : 0.0, l2 <= q.active ? 1.0 : 0.0,
                     l3 <= q.active ? 1.0 : 0.0};
    const V4 dtn4 = {q.dt * Real(1u << l0), q.dt * Real(1u << l1), q.dt * Real(1u << l2), q.dt * Real(1u << l3)};
    V dv[K], tv[K], rv[K], lv[K];
    dofSpread(due4, dv);
    dofSpread(dtn4, tv);
    dofSpread(V4{q.rdt[l0], q.rdt[l1], q.rdt[l2], q.rdt[l3]}, rv);
    dofMasses(q.dtp + n, lv);
#pragma GCC unroll 6
    for (int k = 0; k < K; ++k) {
      const size_t i = 3 * size_t(n) + size_t(k) * L;
      const V cd = kDash ? loadv<V>(q.cb + i) : V{};
      subcycleDofs<V, kKin>(mv[k], dv[k], tv[k], rv[k], lv[k], freeLanes(q.fr + i, V{}), cd, i, q, ke, ext, damp, bdry,
                            wint, bad);
    }
    for (int j = 0; j < 4; ++j)
      if (q.m[n + j] > 0 && due4[j] > 0) q.dtp[n + j] = dtn4[j];
  }
  Real bads = 0;
  LeapfrogSums r = laneSums(ke, ext, damp, bdry, bad, bads);
  for (int l = 0; l < L; ++l) r.wint += wint[l];
  for (Index n = n4; n < q.nn; ++n) {  // the last few nodes, with the kinetic energy (as leapfrogBody's)
    const bool d = q.lev[n] <= q.active;
    const Real dtn = q.dt * Real(1u << q.lev[n]);
    for (int c = 0; c < 3; ++c) {
      const size_t i = dofIndex(n, c);
      subcycleDofs<Real, true>(q.m[n], d ? 1.0 : 0.0, dtn, q.rdt[q.lev[n]], q.dtp[n], Real(q.fr[i]),
                               kDash ? q.cb[i] : 0.0, i, q, r.ke, r.ext, r.damp, r.bdry, r.wint, bads);
    }
    if (q.m[n] > 0 && d) q.dtp[n] = dtn;
  }
  r.nBad = Index(bads);
  return r;
}
// Each body with or without dashpots, with or without the kinetic energy.
LeapfrogSums subcycleGeneric(const SubcycleArgs& q) {
  if (q.kin) return q.cb ? subcycleBody<V2, true, true>(q) : subcycleBody<V2, false, true>(q);
  return q.cb ? subcycleBody<V2, true, false>(q) : subcycleBody<V2, false, false>(q);
}
__attribute__((target("avx2,fma"))) LeapfrogSums subcycleAvx2(const SubcycleArgs& q) {
  if (q.kin) return q.cb ? subcycleBody<V4, true, true>(q) : subcycleBody<V4, false, true>(q);
  return q.cb ? subcycleBody<V4, true, false>(q) : subcycleBody<V4, false, false>(q);
}

LeapfrogSums leapfrogGeneric(const LeapfrogArgs& q) {
  if (q.kin) return q.cb ? leapfrogBody<V2, true, true>(q) : leapfrogBody<V2, false, true>(q);
  return q.cb ? leapfrogBody<V2, true, false>(q) : leapfrogBody<V2, false, false>(q);
}
__attribute__((target("avx2,fma"))) LeapfrogSums leapfrogAvx2(const LeapfrogArgs& q) {
  if (q.kin) return q.cb ? leapfrogBody<V4, true, true>(q) : leapfrogBody<V4, false, true>(q);
  return q.cb ? leapfrogBody<V4, true, false>(q) : leapfrogBody<V4, false, false>(q);
}
}  // namespace

Integrator parseIntegrator(const std::string& n) {
  if (n == "central_difference") return Integrator::CentralDifference;
  if (n == "paper_eq3_4") return Integrator::PaperEq34;
  throw InputError("unknown integrator '" + n +
                   "'; use central_difference (default) or paper_eq3_4 (the paper's eqs. 3-4 taken "
                   "literally, unstable without damping: for study only)");
}

std::string integratorName(Integrator i) {
  return i == Integrator::CentralDifference ? "central_difference" : "paper_eq3_4";
}

RayleighDamping RayleighDamping::fromRatio(Real xi, Real f1, Real f2) {
  if (!(xi >= 0 && xi < 1))
    throw InputError("damping ratio " + std::to_string(xi) + " is outside [0, 1); give e.g. 0.05 for 5 %");
  if (xi == 0) return {};
  if (!(f1 > 0 && f2 > 0))
    throw InputError("Rayleigh damping needs two frequencies f1, f2 > 0 Hz (got " + std::to_string(f1) + ", " +
                     std::to_string(f2) + ")");
  const Real w1 = 2 * M_PI * f1, w2 = 2 * M_PI * f2;
  return {2 * xi * w1 * w2 / (w1 + w2), 2 * xi / (w1 + w2)};
}

Real TimeFunction::operator()(Real time) const {
  if (t.empty()) return 0;
  if (time <= t.front()) return value.front();
  if (time >= t.back()) return value.back();
  const auto it = std::upper_bound(t.begin(), t.end(), time);
  const size_t i = size_t(it - t.begin());
  const Real w = (time - t[i - 1]) / (t[i] - t[i - 1]);
  return value[i - 1] + w * (value[i] - value[i - 1]);
}

std::vector<Index> materialRegions(const Mesh& mesh, const std::vector<std::string>& names) {
  std::vector<Index> regions;
  std::vector<bool> covered(mesh.regionNames.size(), false);
  for (const std::string& name : names) {
    const Index r = mesh.regionIndex(name);
    if (r < 0) {
      std::string have;
      for (auto& n : mesh.regionNames) have += " '" + n + "'";
      throw InputError("material for region '" + name + "' but the mesh " + mesh.source +
                       " has no such region (it has:" + have + ")");
    }
    covered[size_t(r)] = true;
    regions.push_back(r);
  }
  for (size_t r = 0; r < covered.size(); ++r)
    if (!covered[r])
      for (Index e = 0; e < mesh.numElems(); ++e)
        if (mesh.region[e] == Index(r))
          throw InputError("region '" + mesh.regionNames[r] + "' of mesh " + mesh.source +
                           " has elements but no material; add /materials/" + mesh.regionNames[r]);
  return regions;
}

std::vector<std::unique_ptr<ElementBlock>> makeBlocksByRegion(
    const Mesh& mesh, const std::vector<std::pair<std::string, std::shared_ptr<const Material>>>& materials,
    Hex8Formulation formulation) {
  std::vector<std::string> names;
  for (const auto& m : materials) names.push_back(m.first);
  const std::vector<Index> regions = materialRegions(mesh, names);
  std::vector<std::unique_ptr<ElementBlock>> blocks;
  for (size_t m = 0; m < materials.size(); ++m) {
    std::vector<Index> elems;
    for (Index e = 0; e < mesh.numElems(); ++e)
      if (mesh.region[e] == regions[m]) elems.push_back(e);
    if (!elems.empty())
      blocks.push_back(
          std::make_unique<ElementBlock>(materials[m].first, materials[m].second, formulation, mesh, std::move(elems)));
  }
  return blocks;
}

Solver::Solver(const Mesh& mesh, std::vector<std::unique_ptr<ElementBlock>> blocks, SolverOptions opt)
    : mesh_(mesh), blocks_(std::move(blocks)), opt_(opt) {
  avx2_ = ElementBlock::defaultUseAvx2();
  if (!(opt_.safety > 0 && opt_.safety <= 1))
    throw InputError("time step safety factor " + std::to_string(opt_.safety) + " must lie in (0, 1]");
  const Index N = mesh.numNodes();
  state_.resize(N);
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) state_.setX0(n, d, mesh.coords[dofIndex(n, d)]);
  free_.assign(3 * size_t(N), 1);
  fExtPrev_.assign(3 * size_t(N), 0.0);
  nodeChunkSums_.assign(kSums * size_t((N + kNodeChunk - 1) / kNodeChunk), 0.0);
  if (mesh.slice)  // plane strain along y: u_y = 0 everywhere
    for (Index n = 0; n < N; ++n) fix(n, 1);
  // Blocks that share no node (the rock and a lining tied to it by contact pairs) may have their
  // slabs in one parallel loop: a node's force then still comes from its own block's slabs alone.
  std::vector<int> owner(size_t(N), -1);
  blocksDisjoint_ = blocks_.size() >= 2;
  for (size_t bi = 0; bi < blocks_.size() && blocksDisjoint_; ++bi)
    for (Index e = 0; e < blocks_[bi]->numElems() && blocksDisjoint_; ++e)
      for (int k = 0; k < 8; ++k) {
        int& o = owner[size_t(blocks_[bi]->node(e, k))];
        if (o >= 0 && o != int(bi)) blocksDisjoint_ = false;
        o = int(bi);
      }
  rebuild();
  setTimeStep(opt_.dt);
}

void Solver::fix(Index node, int d) { free_[dofIndex(node, d)] = 0; }

void Solver::fixFaceGroup(const std::string& group, const std::string& dirs) {
  const auto nodes = mesh_.faceNodes(group);
  for (char c : dirs) {
    const int d = c == 'x' ? 0 : c == 'y' ? 1 : c == 'z' ? 2 : -1;
    if (d < 0)
      throw InputError("fixed directions '" + dirs + "' for face group '" + group +
                       "': use letters x, y, z (e.g. \"xyz\" or \"z\")");
    for (Index n : nodes) fix(n, d);
  }
}

void Solver::rebuild() {
  const Index N = state_.numNodes();
  // Lumped masses: re-sum from active elements.
  std::vector<Real> m(static_cast<size_t>(N));
  if (rx_) {  // on ranks: every element's share, summed as one process sums it, over every rank
    std::vector<std::vector<Real>> share(blocks_.size());
    for (size_t bi = 0; bi < blocks_.size(); ++bi) {
      const ElementBlock& b = *blocks_[bi];
      for (Index e = 0; e < b.numElems(); ++e)
        share[bi].push_back(b.active(e) ? b.material().density() * b.volume(e) / 8 : 0.0);
    }
    rx_->sumElementShares(share, m.data());
  } else {
    NodalState fresh(N);
    for (auto& b : blocks_) b->lumpMassInto(fresh);
    for (Index n = 0; n < N; ++n) m[size_t(n)] = fresh.mass(n);
  }
  for (Index n = 0; n < N; ++n) state_.addMass(n, m[size_t(n)] - state_.mass(n));
}

StableStep Solver::stableStep() const {
  StableStep s;
  for (const auto& b : blocks_) {
    Index e = -1;
    const Real w = b->maxFrequency(&e);
    if (w > s.omegaMax) {
      s.omegaMax = w;
      s.block = b->name();
      s.element = e >= 0 ? b->meshElem(e) : -1;
      s.charLength = e >= 0 ? b->charLength(e) : 0;
      s.waveSpeed = 0.5 * w * s.charLength;
    }
  }
  if (s.omegaMax <= 0 && !rx_) throw InputError("no active elements: nothing to integrate");
  // Stiffness-proportional damping with the lagged velocity (Belytschko et al., Nonlinear FE,
  // §6.3): Δt ≤ (2/ω_max)(√(1+ξ²) - ξ), ξ = β ω_max / 2. The central difference treats α M with
  // the mean of the half-step velocities (unconditionally stable); the literal paper form treats it
  // explicitly, so α/(2ω_max) is added there.
  s.xiMax = 0.5 * opt_.damping.beta * s.omegaMax;
  if (opt_.integrator == Integrator::PaperEq34) s.xiMax += opt_.damping.alpha / (2 * s.omegaMax);
  s.dtCritical = (2 / s.omegaMax) * (std::sqrt(1 + s.xiMax * s.xiMax) - s.xiMax);
  s.omegaLimit = s.omegaMax;
  // A viscous material (Kelvin–Voigt, retardation time τ) damps its block like β = τ more: the same
  // bound with ξ = (β + τ) ω_b / 2 at the block's own ω_b, which can limit below ω_max's block.
  for (const auto& b : blocks_) {
    const Real tau = b->material().viscousTime();
    if (!(tau > 0)) continue;
    Index e = -1;
    const Real w = b->maxFrequency(&e);
    if (!(w > 0)) continue;
    Real xi = 0.5 * (opt_.damping.beta + tau) * w;
    if (opt_.integrator == Integrator::PaperEq34) xi += opt_.damping.alpha / (2 * w);
    const Real dt = (2 / w) * (std::sqrt(1 + xi * xi) - xi);
    if (dt < s.dtCritical) {
      s.dtCritical = dt;
      s.omegaLimit = w;
      s.xiMax = xi;
      s.block = b->name();
      s.element = e >= 0 ? b->meshElem(e) : -1;
      s.charLength = e >= 0 ? b->charLength(e) : 0;
      s.waveSpeed = 0.5 * w * s.charLength;
    }
  }
  if (rx_) {  // on ranks: the whole model's step (the limiting element's details are this rank's)
    s.omegaMax = rx_->maxAll(s.omegaMax);
    if (s.omegaMax <= 0) throw InputError("no active elements: nothing to integrate");
    s.dtCritical = rx_->minAll(s.dtCritical);
  }
  s.dtSafe = opt_.safety * s.dtCritical;
  return s;
}

void Solver::setTimeStep(Real dt) {
  const StableStep s = stableStep();
  if (dt == 0) {
    dt_ = s.dtSafe;
    return;
  }
  if (!(dt > 0) || !std::isfinite(dt))
    throw InputError("time step dt = " + std::to_string(dt) + " s is invalid; give dt > 0 or 0 for automatic");
  if (dt > s.dtSafe && !opt_.allowUnstableStep) {
    std::ostringstream os;
    os.precision(4);
    os << "time step dt = " << dt << " s is above the stable limit " << s.dtSafe << " s (= safety " << opt_.safety
       << " x critical " << s.dtCritical << " s). The limit comes from element " << s.element << " of block '"
       << s.block << "': characteristic length " << s.charLength << " m, P-wave speed " << s.waveSpeed
       << " m/s, ω = 2 c_p / L = " << s.omegaLimit << " rad/s, damping ratio at ω ξ = " << s.xiMax
       << " (Δt ≤ (2/ω)(√(1+ξ²) - ξ)). Fix: use dt ≤ " << s.dtSafe
       << " s or dt = 0 for automatic; or coarsen/regularise the smallest elements; or lower the "
          "stiffness-proportional damping (its β, and a Kelvin–Voigt material's retardation time τ, shorten "
          "the step).";
    throw InputError(os.str());
  }
  dt_ = dt;
}

void Solver::computeInternalForces(int activeLevel) {
  ElementStepParams p;
  p.dt = dt_;
  p.dtLast = dtLast_;
  p.activeLevel = activeLevel;
  p.beta = alphaRelax_ >= 0 ? 0.0 : opt_.damping.beta;
  Real work = 0, stored = 0, damp = 0;
  const Index N = state_.numNodes();
  Real* __restrict f = state_.fIntData();
  if (everyChunkDue(activeLevel) && !leavesNodeChunks(2)) {  // a re-pass: the chunks it leaves alone keep theirs
#pragma omp parallel for schedule(static) if (N >= 8 * kNodeChunk)
    for (Index i = 0; i < 3 * N; ++i) f[i] = 0;
  } else {  // subcycling: the due nodes' chunks only (the others' f_int is not read before they are due)
    const Index nChunks = Index(nodeChunkLevel_.size());
#pragma omp parallel for schedule(static) if (N >= 8 * kNodeChunk)
    for (Index c = 0; c < nChunks; ++c)
      if (chunkDue(c, activeLevel) && !frozenChunk(c))
        std::fill(f + 3 * size_t(c * kNodeChunk), f + 3 * size_t(std::min(N, (c + 1) * kNodeChunk)), Real(0));
  }
  const bool oneLoop = blockSlabsInOneLoop();
  if (oneLoop) {
    // The blocks' slabs of each parity in one loop, the widest first: a thread that finishes a
    // slab takes the next, so a wide slab of one block runs beside the narrow ones of another
    // instead of ending its block's loop alone (the same bits: no node is in two blocks).
    for (auto& b : blocks_) b->beginForces(p);
    // The lists depend on the step's level only (kept until the levels change: enableSubcycling).
    const size_t key = size_t(std::min(activeLevel, kSlabTaskLevels - 1));
    if (slabTasks_.size() < kSlabTaskLevels) slabTasks_.resize(kSlabTaskLevels);
    std::array<std::vector<SlabTask>, 2>& lists = slabTasks_[key];
    if (lists[0].empty() && lists[1].empty())
      for (int parity = 0; parity < 2; ++parity) {
        for (size_t bi = 0; bi < blocks_.size(); ++bi) {
          const Index nS = blocks_[bi]->numSlabs(p);
          for (Index s = parity; s < nS; s += 2) lists[size_t(parity)].push_back({bi, s, blocks_[bi]->slabWidth(p, s)});
        }
        std::stable_sort(lists[size_t(parity)].begin(), lists[size_t(parity)].end(),
                         [](const SlabTask& a, const SlabTask& b) { return a.width > b.width; });
      }
    for (const std::vector<SlabTask>& tasks : lists) {
      const Index nT = Index(tasks.size());
#pragma omp parallel for schedule(dynamic, 1) if (nT >= 2)
      for (Index i = 0; i < nT; ++i) blocks_[tasks[size_t(i)].block]->runSlab(state_, p, tasks[size_t(i)].slab, f);
    }
    if (rp_.mode) repassEnergies(activeLevel);  // before the blocks sum their chunks' terms
  }
  for (size_t bi = 0; bi < blocks_.size(); ++bi) {  // blocks in order: a fixed sum order per node
    if (oneLoop) {
      const BlockEnergy en = blocks_[bi]->endForces(p);
      work += en.stressWork;
      stored += en.storedEnergy;
      damp += en.dampingWork;
      continue;
    }
    if (rx_ && bi == rx_->frontierBlocks()) rx_->beginForceSum(f);  // on ranks: sent while the rest is computed
    const BlockEnergy en = blocks_[bi]->computeForcesForElems(state_, p, f);
    work += en.stressWork;
    stored += en.storedEnergy;
    damp += en.dampingWork;
  }
  if (rx_) {
    if (rx_->frontierBlocks() >= blocks_.size()) rx_->beginForceSum(f);
    rx_->finishForceSum(f, activeLevel);
  }
  if (rp_.mode) repassForces(activeLevel);
  stressWork_ += work;
  storedEnergy_ = stored;
  dampWork_ += damp;
}

Index Solver::numNodeChunks() const { return Index((state_.numNodes() + kNodeChunk - 1) / kNodeChunk); }

Index Solver::nodeChunksSet(int activeLevel) const {
  if (everyChunkDue(activeLevel)) return numNodeChunks();
  Index n = 0;
  for (Index c = 0; c < Index(nodeChunkLevel_.size()); ++c) n += chunkDue(c, activeLevel);
  return n;
}

void Solver::addContributor(ForcePhase phase, std::shared_ptr<NodalForceContributor> c) {
  // The fast path of constant loads (held reactions, static pressures): decided here, once.
  int folded = 0;
  for (const auto& e : contributors_) folded += e.foldedIntoGravity;
  const std::vector<Real>* f = c->constantForces();
  const bool fold =
      phase == ForcePhase::Loads && folded < kMaxFoldedLoads && f && f->size() == 3 * size_t(state_.numNodes());
  contributors_.push_back({phase, fold, std::move(c)});
}

// The step's external force, phase by phase (ForcePhase): the Loads phase starts with gravity and
// the constant loads folded into its pass, then the NodalLoads, then the phase's other
// contributors; then Boundaries, Interface, Water, Ties.
void Solver::computeExternalForces() {
  addGravityAndLoads();
  addPhaseForces(ForcePhase::Loads, ForcePhase::Ties);
}

void Solver::addGravityAndLoads(int activeLevel) {
  addGravityAndFoldedLoads(activeLevel);
  Real* fe = state_.fExtData();
  for (const auto& l : loads_) {
    const Real f = l.forcePerNode * l.function(t_);
    for (Index n : l.nodes) fe[dofIndex(n, l.direction)] += f;
  }
}

void Solver::addPhaseForces(ForcePhase first, ForcePhase last) {
  for (const ForcePhase phase : kForcePhases)
    if (phase >= first && phase <= last)
      for (auto& e : contributors_)
        if (e.phase == phase && !e.foldedIntoGravity) e.contributor->addForces(t_, dt_, state_);
}

void Solver::addGravityAndFoldedLoads(int activeLevel) {
  const Index N = state_.numNodes();
  Real* fe = state_.fExtData();
  // Gravity acts on the true masses, also while relax() runs with scaled ones.
  const bool trueMass = gravityMass_.empty();
  const Real* m = trueMass ? state_.massData() : gravityMass_.data();
  const Real g[3] = {opt_.gravity[0], opt_.gravity[1], opt_.gravity[2]};
  // The folded constant loads, added in the order they were added.
  const Real* cf[kMaxFoldedLoads] = {};
  int nc = 0;
  for (const auto& e : contributors_)
    if (e.foldedIntoGravity) cf[nc++] = e.contributor->constantForces()->data();
  // Their sum is the same at every step between changes of the masses or the folded loads: summed once then, and copied
  // at each step (the sum at every step cost about 5 % of a subcycled slice's step).
  ConstantLoads& c = constantLoads_;
  const std::uint64_t mv = trueMass ? state_.massVersion() : ~std::uint64_t(0);
  const bool current = c.f.size() == 3 * size_t(N) && c.massVersion == mv &&
                       c.gravityMassVersion == gravityMassVersion_ && c.nFolded == nc &&
                       std::equal(cf, cf + nc, c.folded);
  if (!current) {
    c.f.resize(3 * size_t(N));
    for (Index n = 0; n < N; ++n) {
      const size_t i = 3 * size_t(n);
      Real f[3] = {m[n] * g[0], m[n] * g[1], m[n] * g[2]};
      for (int k = 0; k < nc; ++k)
        for (int d = 0; d < 3; ++d) f[d] += cf[k][i + size_t(d)];
      c.f[i] = f[0];
      c.f[i + 1] = f[1];
      c.f[i + 2] = f[2];
    }
    c.massVersion = mv;
    c.gravityMassVersion = gravityMassVersion_;
    std::copy_n(cf, kMaxFoldedLoads, c.folded);
    c.nFolded = nc;
  }
  const Index nChunks = Index((N + kNodeChunk - 1) / kNodeChunk);
  const Real* src = c.f.data();
  // Subcycling: the due nodes' chunks only. The contributors then add to every node they act on,
  // but a node not due at this step has its f_ext set again, from these loads, before it is read.
  const bool all = everyChunkDue(activeLevel);
#pragma omp parallel for schedule(static) if (nChunks >= 4)
  for (Index k = 0; k < nChunks; ++k) {
    if (!all && !chunkDue(k, activeLevel)) continue;
    const size_t i0 = 3 * size_t(k * kNodeChunk), i1 = 3 * size_t(std::min(N, (k + 1) * kNodeChunk));
    std::copy(src + i0, src + i1, fe + i0);
  }
}

void Solver::updateNodes() {
  const Index N = state_.numNodes();
  const Index nChunks = Index((N + kNodeChunk - 1) / kNodeChunk);
  Real* __restrict u = state_.uData();
  Real* __restrict v = state_.vData();
  Real* __restrict a = state_.aData();
  const Real* __restrict fi = state_.fIntData();
  const Real* __restrict fe = state_.fExtData();
  const Real* __restrict m = state_.massData();
  const Real* __restrict cb = state_.hasDashpots() ? state_.dashpotData() : nullptr;
  const std::uint8_t* __restrict fr = free_.data();
  const Real* __restrict fprev = fExtPrev_.data();
  const Real dt = dt_, dtl = dtLast_;
  const Real alpha = alphaRelax_ >= 0 ? alphaRelax_ : opt_.damping.alpha;
  const Real vlim = opt_.velocityLimit;
  const bool leapfrog = opt_.integrator == Integrator::CentralDifference;
  const bool kin = kineticStep_ = kineticWanted_ || !balanceSet_;
  Real* sums = nodeChunkSums_.data();
  if (rx_) {  // on ranks: the ghosts' v^{n-1/2}, to take their share out of the sums (subtractGhostSums)
    ghostV_.clear();
    for (Index n : rx_->ghosts())
      for (int d = 0; d < 3; ++d) ghostV_.push_back(v[dofIndex(n, d)]);
  }
#pragma omp parallel for schedule(static) if (nChunks >= 2)
  for (Index c = 0; c < nChunks; ++c) {
    const Index n0 = c * kNodeChunk, n1 = std::min(N, n0 + kNodeChunk);
    const Index i0 = 3 * n0, nd = 3 * (n1 - n0);
    Real ke = 0, ext = 0, damp = 0, bdry = 0;
    Index bad = -1;
    if (leapfrog) {
      LeapfrogArgs la{u + i0,  v + i0,     a + i0, fi + i0, fe + i0, cb ? cb + i0 : nullptr,
                      fr + i0, fprev + i0, m + n0, n1 - n0, dt,      dtl,
                      alpha,   vlim,       kin};
      const LeapfrogSums ls = avx2_ ? leapfrogAvx2(la) : leapfrogGeneric(la);
      ke = ls.ke;
      ext = ls.ext;
      damp = ls.damp;
      bdry = ls.bdry;
      if (ls.nBad > 0) bad = firstBadDof(v, size_t(i0), size_t(i0 + nd), vlim);
    } else {
      for (Index n = n0; n < n1; ++n) {
        const Real mn = m[n];
        for (int d = 0; d < 3; ++d) {
          const size_t i = dofIndex(n, d);
          if (!(mn > 0)) {  // node of no active element: at rest
            v[i] = a[i] = 0;
            continue;
          }
          // Paper eqs. (3)-(4): explicit damping with the full-step velocity.
          const Real f = fe[i] - fi[i];
          const Real vo = v[i];
          const Real cm = alpha * mn, cd = cb ? cb[i] : 0.0;
          const Real acc = Real(fr[i]) * (f - (cm + cd) * vo) / mn;
          const Real du = dt * vo + 0.5 * dt * dt * acc;
          const Real vn = Real(fr[i]) * (2 * du / dt - vo);
          a[i] = acc;
          if (kin) ke += 0.5 * mn * vo * vo;
          ext += fe[i] * du;
          damp += cm * vo * vo * dt;
          bdry += cd * vo * vo * dt;
          v[i] = vn;
          u[i] += du;
          if (!(std::abs(vn) <= vlim) && bad < 0) bad = Index(i);
        }
      }
    }
    storeChunkSums(sums + kSums * size_t(c), ke, ext, damp, bdry, bad);
  }
  bookNodeChunks(nChunks);
}

void Solver::bookNodeChunks(Index nChunks) {
  // The node chunks' sums in a fixed order (any thread count), the first bad dof, the balance.
  Real ke = 0, ext = 0, damp = 0, bdry = 0;
  Index bad = -1;
  for (Index c = 0; c < nChunks; ++c) {
    const Real* s = nodeChunkSums_.data() + kSums * size_t(c);
    ke += s[0];
    ext += s[1];
    damp += s[2];
    bdry += s[3];
    if (bad < 0 && s[4] >= 0) bad = Index(s[4]);
  }
  Real wint = 0;
  for (Index c = 0; c < nChunks; ++c) wint += nodeChunkSums_[kSums * size_t(c) + 5];
  if (rx_) subtractGhostSums(ke, ext, damp, bdry, wint);
  nodalIntWork_ += wint;
  if (bad >= 0 && !rx_) reportInstability(bad, state_.vData()[bad]);  // on ranks: finishEnergy, on every rank
  extWork_ += ext;
  dampWork_ += damp;
  bdryWork_ += bdry;
  energy_.kinetic = kineticStep_ ? ke : std::numeric_limits<Real>::quiet_NaN();
  finishEnergy(bad);
}

void Solver::subtractGhostSums(Real& ke, Real& ext, Real& damp, Real& bdry, Real& wint) const {
  // The leapfrog update's terms (leapfrogDofs) of each ghost dof, from its velocity before and after.
  const Real* v = state_.vData();
  const Real* fe = state_.fExtData();
  const Real* cb = state_.hasDashpots() ? state_.dashpotData() : nullptr;
  const Real alpha = alphaRelax_ >= 0 ? alphaRelax_ : opt_.damping.alpha;
  const auto& ghosts = rx_->ghosts();
  if (!nodeLevel_.empty()) {  // subcycling: subcycleDofs' terms, from the ghost's values before the update
    const Real* fi = state_.fIntData();
    for (size_t k = 0; k < ghosts.size(); ++k) {
      const Index n = ghosts[k];
      const Real mn = state_.mass(n);
      if (!(mn > 0)) continue;
      const int l = nodeLevel_[size_t(n)];
      const bool due = l <= activeLevel_;
      const Real dtn = dt_ * Real(1u << l), dtl = ghostDtp_[k];
      for (int d = 0; d < 3; ++d) {
        const size_t i = dofIndex(n, d), j = 3 * k + size_t(d);
        const Real vo = ghostV_[j], vn = v[i], vb = 0.5 * (vo + vn), ao = ghostA_[j];
        const Real cm = alpha * mn, cd = cb ? cb[i] : 0.0;
        if (kineticStep_) ke -= 0.5 * mn * vo * (due ? vn : vo - dtn * ao);
        if (!due) continue;
        ext -= 0.5 * (fe[i] + ghostFs_[j]) * dtl * vo;
        wint -= 0.5 * (fi[i] + ghostFis_[j]) * dtl * vo;
        const Real wdash = 0.5 * vo * (dtn * vb + dtl * (vo - 0.5 * dtl * ao));
        damp -= cm * wdash;
        bdry -= cd * wdash;
      }
    }
    return;
  }
  for (size_t k = 0; k < ghosts.size(); ++k) {
    const Index n = ghosts[k];
    const Real mn = state_.mass(n);
    if (!(mn > 0)) continue;
    for (int d = 0; d < 3; ++d) {
      const size_t i = dofIndex(n, d);
      const Real vo = ghostV_[3 * k + size_t(d)], vn = v[i], vb = 0.5 * (vo + vn);
      const Real cm = alpha * mn, cd = cb ? cb[i] : 0.0;
      ext -= 0.5 * (fe[i] + fExtPrev_[i]) * dtLast_ * vo;
      if (kineticStep_) ke -= 0.5 * mn * vo * vn;
      damp -= cm * vb * vb * dt_;
      bdry -= cd * vb * vb * dt_;
    }
  }
}

const EnergyBalance& Solver::energy() const {
  if (plasticStale_) {
    Real plastic = 0;
    for (const auto& b : blocks_) plastic += b->dissipatedEnergy();
    energy_.plastic = plastic - plastic0_;
    plasticStale_ = false;
  }
  return energy_;
}

void Solver::finishEnergy(Index bad) {
  // Contributors that dissipate (interface friction) or store/absorb (boundary springs) book their
  // own work W_c = -E_c; the solver's external work includes it, so it is moved out of `external`
  // into `interface` / `boundary`: balance = interface + kinetic + internal + damping + boundary
  // - external stays constant.
  Real dissContrib = 0, bdryContrib = 0;
  for (const auto& e : contributors_) dissContrib += e.contributor->dissipatedEnergy();
  for (const auto& e : contributors_) bdryContrib += e.contributor->boundaryEnergy();
  Real diss = dissContrib - interface0_, bE = bdryContrib - boundary0_;
  // Subcycled: the internal forces' work booked at the node updates (updateNodesSubcycled) from
  // the elements' internal energy when subcycling started.
  Real internal = nodeLevel_.empty() ? stressWork_ + storedEnergy_ : intBase_ + nodalIntWork_, damping = dampWork_,
       boundary = bdryWork_, external = extWork_;
  if (rx_) {  // on ranks: the whole model's terms, and a stop on every rank when one went unstable
    Real sums[8] = {
        internal, damping, boundary, external, kineticStep_ ? energy_.kinetic : 0.0, diss, bE, bad >= 0 ? 1.0 : 0.0};
    rx_->sumAll(sums, 8);
    internal = sums[0], damping = sums[1], boundary = sums[2], external = sums[3];
    if (kineticStep_) energy_.kinetic = sums[4];
    diss = sums[5], bE = sums[6];
    if (sums[7] > 0) {
      if (bad >= 0) reportInstability(bad, state_.vData()[bad]);
      throw InstabilityError("run stopped at step " + std::to_string(step_) + ", t = " + std::to_string(t_) +
                             " s: another rank's part of the model went unstable (its message is above)");
    }
  }
  energy_.internal = internal;
  energy_.damping = damping;
  energy_.boundary = boundary + bE;
  energy_.interface = diss;
  plasticStale_ = true;  // energy_.plastic: by energy() when asked (not in the balance)
  energy_.external = external + diss + bE;
  if (!kineticStep_) {  // a step that did not sum the kinetic energy: no balance
    energy_.error = std::numeric_limits<Real>::quiet_NaN();
    return;
  }
  const Real bal =
      energy_.interface + energy_.kinetic + energy_.internal + energy_.damping + energy_.boundary - energy_.external;
  if (!balanceSet_) {
    balance0_ = bal;
    balanceSet_ = true;
  }
  const Real scale = std::max({std::abs(energy_.kinetic) + std::abs(energy_.internal), std::abs(energy_.external),
                               std::abs(energy_.damping) + std::abs(energy_.boundary) + std::abs(energy_.interface),
                               std::numeric_limits<Real>::min()});
  energy_.error = std::abs(bal - balance0_) / scale;
  checkedError_ = energy_.error;
  checkedTime_ = t_ + dt_;  // the time this step ends at (the clock advances after the node update)
}

void Solver::updateNodesSubcycled(int active) {
  // Nodes due at this fine step (level <= active) take a central-difference velocity update with
  // their own step 2^level Δt; every node then moves by Δt v, so a coarse node's displacement is
  // linear in time between its updates (the fine elements next to it see it interpolated).
  const Index N = state_.numNodes();
  const Index nChunks = Index((N + kNodeChunk - 1) / kNodeChunk);
  Real* __restrict u = state_.uData();
  Real* __restrict v = state_.vData();
  Real* __restrict a = state_.aData();
  const Real* __restrict fi = state_.fIntData();
  const Real* __restrict fe = state_.fExtData();
  const Real* __restrict m = state_.massData();
  const Real* __restrict cb = state_.hasDashpots() ? state_.dashpotData() : nullptr;
  const std::uint8_t* __restrict fr = free_.data();
  const std::uint8_t* __restrict lev = nodeLevel_.data();
  Real* __restrict fs = fSync_.data();
  Real* __restrict fis = fIntSync_.data();
  Real* __restrict dtp = dtPrevNode_.data();
  const Real dt = dt_, alpha = opt_.damping.alpha, vlim = opt_.velocityLimit;
  Real rdt[9];  // 1 / (2^level Δt)
  for (int l = 0; l < 9; ++l) rdt[l] = 1 / (dt * Real(1u << l));
  const bool kin = kineticStep_ = kineticWanted_ || !balanceSet_;
  Real* sums = nodeChunkSums_.data();
  // A window's first pass records the sums of the chunks its re-passes leave alone; a re-pass takes
  // them, step by step, instead of updating those chunks (Solver::planRepasses).
  const bool record = leavesNodeChunks(1), replay = leavesNodeChunks(2);
  const size_t stepSums = kSums * size_t(rp_.nFrozen);
  Real* kept = nullptr;
  if (record) {
    rp_.sums.resize(rp_.sums.size() + stepSums);
    kept = rp_.sums.data() + rp_.sums.size() - stepSums;
  } else if (replay) {
    if (rp_.sAt + stepSums > rp_.sums.size()) throw std::logic_error("re-pass: more node updates than the first pass");
    kept = rp_.sums.data() + rp_.sAt;
    rp_.sAt += stepSums;
  }
  if (rx_) {  // on ranks: the ghosts' values before the update, to take their share out of the sums
    ghostV_.clear();
    ghostFs_.clear();
    ghostFis_.clear();
    ghostA_.clear();
    ghostDtp_.clear();
    for (Index n : rx_->ghosts()) {
      for (int d = 0; d < 3; ++d) {
        ghostV_.push_back(v[dofIndex(n, d)]);
        ghostFs_.push_back(fs[dofIndex(n, d)]);
        ghostFis_.push_back(fis[dofIndex(n, d)]);
        ghostA_.push_back(a[dofIndex(n, d)]);
      }
      ghostDtp_.push_back(dtp[n]);
    }
  }
#pragma omp parallel for schedule(dynamic, 2) if (nChunks >= 2)
  for (Index c = 0; c < nChunks; ++c) {
    Real* kc = kept && rp_.frozen[size_t(c)] ? kept + kSums * size_t(rp_.frozenAt[size_t(c)]) : nullptr;
    if (replay && kc) {
      std::copy_n(kc, kSums, sums + kSums * size_t(c));
      continue;
    }
    const Index n0 = c * kNodeChunk, n1 = std::min(N, n0 + kNodeChunk);
    const size_t i0 = 3 * size_t(n0);
    SubcycleArgs q{u + i0, v + i0,  a + i0,   fs + i0, dtp + n0, fis + i0, fi + i0, fe + i0, cb ? cb + i0 : nullptr,
                   m + n0, fr + i0, lev + n0, n1 - n0, dt,       alpha,    vlim,    active,  kin,
                   {}};
    std::copy(rdt, rdt + 9, q.rdt);
    const LeapfrogSums ls = avx2_ ? subcycleAvx2(q) : subcycleGeneric(q);
    const Index bad = ls.nBad > 0 ? firstBadDof(v, i0, 3 * size_t(n1), vlim) : -1;
    storeChunkSums(sums + kSums * size_t(c), ls.ke, ls.ext, ls.damp, ls.bdry, bad, ls.wint);
    if (kc) std::copy_n(sums + kSums * size_t(c), kSums, kc);
  }
  bookNodeChunks(nChunks);
}

void Solver::checkSubcycling(int maxLevel) const {
  if (maxLevel <= 0) return;
  if (maxLevel > 8)
    throw InputError("subcycling levels = " + std::to_string(maxLevel) +
                     ": at most 8 (steps up to 256 times the finest); 3 or 4 is usual");
  if (opt_.integrator != Integrator::CentralDifference)
    throw InputError("subcycling needs the central-difference integrator (integrator " +
                     integratorName(opt_.integrator) + " given); set subcycling levels to 0");
  if (opt_.damping.beta > 0)
    throw InputError("subcycling needs damping without the stiffness term (β = " + std::to_string(opt_.damping.beta) +
                     " s given): use mass-proportional damping, or set subcycling levels to 0");
  for (const auto& b : blocks_)
    if (b->material().viscousTime() > 0)
      throw InputError("subcycling needs materials without viscosity (block '" + b->name() + "' is " +
                       b->material().typeName() + " with retardation time " +
                       std::to_string(b->material().viscousTime()) +
                       " s): use a material without viscosity there, or set subcycling levels to 0");
}

SubcyclingInfo Solver::enableSubcycling(int maxLevel) {
  SubcyclingInfo info;
  nodeLevel_.clear();
  nodeChunkLevel_.clear();
  maxChunkLevel_ = 0;
  fSync_.clear();
  fIntSync_.clear();
  dtPrevNode_.clear();
  slabTasks_.clear();  // the slabs of the new levels
  for (auto& b : blocks_) b->setChunkLevels({});
  if (maxLevel <= 0) return info;
  checkSubcycling(maxLevel);
  if (!(dt_ > 0)) throw InputError("subcycling: set the time step first");
  const Index N = state_.numNodes();
  // Each node: the coarsest level all its active elements allow (their own safety × critical step).
  std::vector<std::uint8_t> level(size_t(N), static_cast<std::uint8_t>(maxLevel));
  for (const auto& b : blocks_)
    for (Index e = 0; e < b->numElems(); ++e) {
      if (!b->active(e)) continue;
      const Real dte = opt_.safety * 2 / b->frequency(e);
      int l = 0;
      while (l < maxLevel && dte >= dt_ * Real(2u << l)) ++l;
      for (int k = 0; k < 8; ++k) {
        std::uint8_t& nl = level[size_t(b->node(e, k))];
        nl = std::min(nl, std::uint8_t(l));
      }
    }
  // The contributors' constraints and the grading (the nodes of one element differ by at most
  // one level: a fine element next to nodes stepping 8 times its step made the lining's stresses
  // oscillate and grow on the paper slice within 3 s; graded, the run stays within the reference's
  // energy error), until neither lowers a level.
  // On ranks the same levels as one process: each rank lowers its nodes' levels as one process
  // does, the copies of a frontier node take the lowest, until no rank lowers one (the levels only
  // go down, to the largest ones that meet every constraint: one answer, whatever the order).
  std::vector<Real> copies;
  if (rx_) {
    copies.assign(level.begin(), level.end());
    rx_->minFrontier(copies.data(), 1);
    for (Index n = 0; n < N; ++n) level[size_t(n)] = std::uint8_t(copies[size_t(n)]);
  }
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& e : contributors_) changed = e.contributor->constrainLevels(level) || changed;
    for (const auto& b : blocks_)
      for (Index e = 0; e < b->numElems(); ++e) {
        if (!b->active(e)) continue;
        std::uint8_t lo = 255;
        for (int k = 0; k < 8; ++k) lo = std::min(lo, level[size_t(b->node(e, k))]);
        for (int k = 0; k < 8; ++k) {
          std::uint8_t& nl = level[size_t(b->node(e, k))];
          if (nl > lo + 1) {
            nl = std::uint8_t(lo + 1);
            changed = true;
          }
        }
      }
    if (rx_) {
      copies.assign(level.begin(), level.end());
      rx_->minFrontier(copies.data(), 1);
      for (Index n = 0; n < N; ++n)
        if (std::uint8_t(copies[size_t(n)]) != level[size_t(n)]) {
          level[size_t(n)] = std::uint8_t(copies[size_t(n)]);
          changed = true;
        }
      Real any = changed ? 1.0 : 0.0;
      rx_->sumAll(&any, 1);
      changed = any > 0;
    }
  }
  nodeLevel_ = std::move(level);
  if (!rx_) {  // on ranks every chunk stays due (the frontier's sums take every node's forces)
    nodeChunkLevel_.assign(size_t(numNodeChunks()), 255);
    for (Index n = 0; n < N; ++n) {
      std::uint8_t& cl = nodeChunkLevel_[size_t(n / kNodeChunk)];
      cl = std::min(cl, nodeLevel_[size_t(n)]);
    }
    for (std::uint8_t l : nodeChunkLevel_) maxChunkLevel_ = std::max(maxChunkLevel_, int(l));
  }
  fSync_.assign(state_.fExtData(), state_.fExtData() + 3 * size_t(N));     // f_ext of the step just taken
  fIntSync_.assign(state_.fIntData(), state_.fIntData() + 3 * size_t(N));  // and its f_int
  dtPrevNode_.assign(size_t(N), dtLast_);
  intBase_ = stressWork_ + storedEnergy_;  // the elements' internal energy to the step just taken
  nodalIntWork_ = 0;
  cycle_ = 0;
  info.nodes.assign(size_t(maxLevel) + 1, 0);
  info.elements.assign(size_t(maxLevel) + 1, 0);
  for (Index n = 0; n < N; ++n)
    if (state_.mass(n) > 0 && (!rx_ || rx_->owned()[n])) ++info.nodes[nodeLevel_[size_t(n)]];
  // On ranks each chunk takes the level of the one-process chunk its elements belong to.
  const std::vector<std::vector<std::uint8_t>> given =
      rx_ ? rx_->subcycle(nodeLevel_, maxLevel, blocks_) : std::vector<std::vector<std::uint8_t>>{};
  Real evals = 0, active = 0;
  for (size_t bi = 0; bi < blocks_.size(); ++bi) {
    auto& b = blocks_[bi];
    b->setChunkLevels(nodeLevel_, rx_ ? &given[bi] : nullptr);
    for (Index e = 0; e < b->numElems(); ++e) {
      if (!b->active(e)) continue;
      const int l = b->chunkLevel(e / ElementBlock::kChunk);
      ++info.elements[size_t(l)];
      evals += 1.0 / Real(1u << l);
      active += 1;
    }
  }
  if (rx_) {  // the whole model's counts (whole numbers and sums of powers of 2: exact in any order)
    std::vector<Real> counts(info.nodes.begin(), info.nodes.end());
    counts.insert(counts.end(), info.elements.begin(), info.elements.end());
    counts.push_back(evals);
    counts.push_back(active);
    rx_->sumAll(counts.data(), int(counts.size()));
    for (size_t l = 0; l <= size_t(maxLevel); ++l) {
      info.nodes[l] = decltype(info.nodes)::value_type(counts[l]);
      info.elements[l] = decltype(info.elements)::value_type(counts[size_t(maxLevel) + 1 + l]);
    }
    evals = counts[2 * (size_t(maxLevel) + 1)];
    active = counts[2 * (size_t(maxLevel) + 1) + 1];
  }
  for (size_t l = 0; l < info.nodes.size(); ++l)
    if (info.nodes[l] > 0) info.levels = std::max<int>(info.levels, int(l));
  info.elements.resize(size_t(info.levels) + 1);
  info.nodes.resize(size_t(info.levels) + 1);
  info.costFraction = active > 0 ? evals / active : 1;
  return info;
}

void Solver::reportInstability(Index dof, Real value) {
  const Index node = dof / 3;
  const int d = int(dof % 3);
  RankExchange* const rx = rx_;
  rx_ = nullptr;  // on ranks: this rank's own step for the message (the others are not asking)
  const StableStep s = stableStep();
  rx_ = rx;
  std::ostringstream os;
  os.precision(6);
  os << "run stopped at step " << step_ << ", t = " << t_ << " s: velocity v_"
     << "xyz"[d] << " = " << value << " m/s at node " << node << " (x, y, z = " << state_.x0(node, 0) << ", "
     << state_.x0(node, 1) << ", " << state_.x0(node, 2) << " m) is "
     << (std::isfinite(value) ? "exploding (|v| above the limit " : "not finite (limit ") << opt_.velocityLimit
     << " m/s)"
     << ". Likely cause: ";
  Index badElem = -1;
  std::string badBlock;
  for (const auto& b : blocks_) {
    const Index e = b->findBadStress(1e300);
    if (e >= 0) {
      badElem = b->meshElem(e);
      badBlock = b->name();
      break;
    }
  }
  if (dt_ > s.dtCritical)
    os << "the time step " << dt_ << " s is above the critical step " << s.dtCritical << " s (limited by element "
       << s.element << " of block '" << s.block << "'); use dt = 0 (automatic) or dt <= " << s.dtSafe << " s.";
  else if (opt_.integrator == Integrator::PaperEq34)
    os << "integrator paper_eq3_4 is unstable for any step without enough damping (growth "
          "factor √(1+(ωΔt)²/2) per step); use central_difference.";
  else if (badElem >= 0)
    os << "element " << badElem << " of block '" << badBlock
       << "' has a non-finite stress; check its material parameters.";
  else
    os << "the motion grows without bound: check loads, boundary conditions (an unsupported model "
          "under gravity accelerates freely), and material parameters.";
  throw InstabilityError(os.str());
}

void Solver::step() {
  beginStep();
  finishStep();
}

void Solver::beginStep() {
  // Subcycling: the chunks and nodes due at this fine step are those of level <= the number of
  // trailing zero bits of the fine-step count (all of them at count 0).
  activeLevel_ = nodeLevel_.empty() ? 255 : cycle_ == 0 ? 255 : __builtin_ctzll((unsigned long long)cycle_);
  computeInternalForces(activeLevel_);
  state_.swapFExt(fExtPrev_);  // f_ext of the step just taken becomes the previous one
  addGravityAndLoads(activeLevel_);
  addPhaseForces(ForcePhase::Loads, ForcePhase::Interface);
  stepOpen_ = true;
}

void Solver::finishStep() {
  addPhaseForces(ForcePhase::Water, ForcePhase::Ties);
  stepOpen_ = false;
  if (nodeLevel_.empty()) {
    updateNodes();
  } else {
    updateNodesSubcycled(activeLevel_);
    ++cycle_;
  }
  dtLast_ = dt_;
  t_ += dt_;
  ++step_;
}

// ---- a coupling window's re-passes (planRepasses) --------------------------------------------

Solver::RepassPlan Solver::planRepasses(const std::vector<Index>& wet, Index windowSteps) {
  RepassPlan plan;
  rp_ = Repasses{};
  for (auto& b : blocks_) b->setRepassSkip({});
  for (const auto& b : blocks_) {
    plan.chunks += b->numChunks();
    for (Index e = 0; e < b->numElems(); ++e) plan.elements += b->active(e);
  }
  std::vector<std::vector<Index>> groups;
  if (rx_)
    plan.why = "the solid is on MPI ranks";
  else if (!blockSlabsInOneLoop())
    plan.why = "the element blocks share nodes";
  for (const auto& b : blocks_)
    if (plan.why.empty() && b->hasBlockPass()) plan.why = "block '" + b->name() + "' has a material with a block pass";
  for (const auto& e : contributors_)
    if (plan.why.empty() && !e.contributor->forceGroups(groups))
      plan.why = "'" + e.contributor->name() + "' does not say which nodes its forces join";
  const Index N = state_.numNodes();
  int top = 0;
  for (std::uint8_t l : nodeLevel_) top = std::max(top, int(l));
  const Index period = Index(1) << top;
  if (plan.why.empty() && windowSteps % period != 0)
    plan.why = "windows of " + std::to_string(windowSteps) + " steps are not a multiple of the coarsest level's " +
               std::to_string(period);
  if (!plan.why.empty()) return plan;
  // The window's steps from its start (a multiple of `period` fine steps: every level due at the
  // first): a node changes at an update whose force may differ (the wet nodes' from the first step,
  // a node's with an element changed before, or with a group partner changed before or loaded
  // differently at this step); an element from its first evaluation that reads a changed node.
  const auto levelOf = [&](Index n) { return nodeLevel_.empty() ? 0 : int(nodeLevel_[size_t(n)]); };
  std::vector<std::uint8_t> changed(size_t(N), 0), force(size_t(N), 0);
  std::vector<std::vector<std::uint8_t>> elemChanged(blocks_.size());
  for (size_t bi = 0; bi < blocks_.size(); ++bi) elemChanged[bi].assign(size_t(blocks_[bi]->numElems()), 0);
  for (Index j = 0; j < windowSteps; ++j) {
    const int active = j % period == 0 ? 255 : __builtin_ctzll((unsigned long long)j);
    std::fill(force.begin(), force.end(), std::uint8_t(0));
    for (size_t bi = 0; bi < blocks_.size(); ++bi) {
      const ElementBlock& b = *blocks_[bi];
      for (Index e = 0; e < b.numElems(); ++e) {
        if (!b.active(e) || b.chunkLevel(e / ElementBlock::kChunk) > active) continue;
        std::uint8_t& ec = elemChanged[bi][size_t(e)];
        for (int k = 0; k < 8 && !ec; ++k) ec = changed[size_t(b.node(e, k))];
        if (ec)
          for (int k = 0; k < 8; ++k) force[size_t(b.node(e, k))] = 1;
      }
    }
    for (Index n : wet) force[size_t(n)] = 1;
    // a group's forces come from its members' motion, or from their forces of this step (the
    // contact predicts a pair's motion from both nodes' whole force): until no group adds one
    for (bool added = true; added;) {
      added = false;
      for (const auto& g : groups)
        if (std::any_of(g.begin(), g.end(), [&](Index n) { return changed[size_t(n)] || force[size_t(n)]; }))
          for (Index n : g) added = added || !force[size_t(n)], force[size_t(n)] = 1;
    }
    for (Index n = 0; n < N; ++n)
      if (force[size_t(n)] && levelOf(n) <= active) changed[size_t(n)] = 1;
  }
  // A re-pass steps every element on a changed node (a node's update sums all its elements), by
  // chunks; the nodes of the active elements of the chunks it skips take f_int from the first pass.
  // Subcycled, it steps the node chunks with a node that is read: on an element it evaluates,
  // reached by the change, or read by a contributor (its groups' members, motionReadNodes).
  std::vector<std::uint8_t> replay(size_t(N), 0), read(size_t(N), 0);
  std::vector<Index> readNodes;
  if (nodeLevel_.empty()) plan.whyNodes = "the solid steps single-rate";
  for (const auto& e : contributors_)
    if (plan.whyNodes.empty() && !e.contributor->motionReadNodes(readNodes))
      plan.whyNodes = "'" + e.contributor->name() + "' does not say which nodes' motion it reads";
  for (Index n : readNodes) read[size_t(n)] = 1;
  for (const auto& g : groups)
    for (Index n : g) read[size_t(n)] = 1;
  for (Index n : wet) read[size_t(n)] = 1;
  for (Index n = 0; n < N; ++n) read[size_t(n)] |= changed[size_t(n)];
  for (size_t bi = 0; bi < blocks_.size(); ++bi) {
    ElementBlock& b = *blocks_[bi];
    std::vector<std::uint8_t> skip(size_t(b.numChunks()), 1);
    for (Index e = 0; e < b.numElems(); ++e)
      for (int k = 0; k < 8; ++k)
        if (changed[size_t(b.node(e, k))]) skip[size_t(e / ElementBlock::kChunk)] = 0;
    for (Index e = 0; e < b.numElems(); ++e)
      if (b.active(e) && !skip[size_t(e / ElementBlock::kChunk)])
        for (int k = 0; k < 8; ++k) read[size_t(b.node(e, k))] = 1;
    for (Index c = 0; c < b.numChunks(); ++c) {
      if (!skip[size_t(c)]) continue;
      ++plan.skippedChunks;
      rp_.chunks.push_back({Index(bi), c, Index(b.chunkLevel(c))});
      for (Index e = c * ElementBlock::kChunk; e < std::min(b.numElems(), (c + 1) * ElementBlock::kChunk); ++e) {
        if (!b.active(e)) continue;
        ++plan.skippedElements;
        for (int k = 0; k < 8; ++k) replay[size_t(b.node(e, k))] = 1;
      }
    }
    b.setRepassSkip(std::move(skip));
  }
  plan.nodeChunks = numNodeChunks();
  rp_.frozen.assign(size_t(plan.nodeChunks), 0);
  rp_.frozenAt.assign(size_t(plan.nodeChunks), -1);
  for (Index c = 0; c < plan.nodeChunks && plan.whyNodes.empty(); ++c) {
    const Index n0 = c * kNodeChunk, n1 = std::min(N, n0 + kNodeChunk);
    if (std::any_of(read.begin() + n0, read.begin() + n1, [](std::uint8_t r) { return r != 0; })) continue;
    rp_.frozen[size_t(c)] = 1;
    rp_.frozenAt[size_t(c)] = plan.frozenNodeChunks++;
    plan.frozenNodes += n1 - n0;
  }
  rp_.nFrozen = plan.frozenNodeChunks;
  for (Index c = 0; c < plan.nodeChunks;) {  // the other chunks, in runs: what a re-pass restores
    if (rp_.frozen[size_t(c)]) {
      ++c;
      continue;
    }
    Index c1 = c;
    while (c1 < plan.nodeChunks && !rp_.frozen[size_t(c1)]) ++c1;
    const size_t n0 = size_t(c * kNodeChunk), n1 = size_t(std::min(N, c1 * kNodeChunk));
    rp_.nodeRanges.push_back({n0, n1});
    rp_.dofRanges.push_back({3 * n0, 3 * n1});
    c = c1;
  }
  if (plan.whyNodes.empty() && rp_.nFrozen == 0) plan.whyNodes = "every node chunk has a node that a re-pass reads";
  rp_.nodesByLevel.assign(size_t(top) + 1, {});
  for (Index n = 0; n < N; ++n)
    if (replay[size_t(n)] && !rp_.frozen[size_t(n / kNodeChunk)]) {  // a frozen node's f_int is not read
      if (changed[size_t(n)]) throw std::logic_error("planRepasses: a replayed node changes within the window");
      rp_.nodesByLevel[size_t(levelOf(n))].push_back(n);
      ++plan.replayNodes;
    }
  rp_.planned = plan.skippedChunks > 0;
  rp_.period = period;
  if (!rp_.planned) {
    for (auto& b : blocks_) b->setRepassSkip({});
    rp_ = Repasses{};
    plan.why = "every element chunk is within reach of the water's force within a window";
    plan.frozenNodeChunks = plan.frozenNodes = 0;
    plan.whyNodes.clear();
  }
  return plan;
}

void Solver::beginPass(bool repass) {
  if (!rp_.planned) return;
  if (!repass) {  // the first pass records, when the window starts where the plan's steps do
    rp_.mode = cycle_ % rp_.period == 0 || nodeLevel_.empty() ? 1 : 0;
    rp_.fInt.clear();
    rp_.energy.clear();
    rp_.sums.clear();
  } else if (rp_.mode) {
    rp_.mode = 2;
    rp_.fAt = rp_.eAt = rp_.sAt = 0;
  }
  for (auto& b : blocks_) {
    b->setRepass(rp_.mode == 2);
    b->setRepassSave(rp_.mode == 1);
  }
}

void Solver::endPasses() {
  if (!rp_.planned) return;
  rp_.mode = 0;
  for (auto& b : blocks_) {
    b->setRepass(false);
    b->setRepassSave(false);
  }
}

void Solver::repassEnergies(int activeLevel) {
  for (const auto& [bi, c, level] : rp_.chunks) {
    if (level > activeLevel) continue;  // not evaluated at this step in the first pass either
    BlockEnergy& en = blocks_[size_t(bi)]->chunkEnergy(c);
    if (rp_.mode == 1) {
      rp_.energy.push_back(en);
    } else {
      if (rp_.eAt >= rp_.energy.size()) throw std::logic_error("re-pass: more chunk steps than the first pass");
      en = rp_.energy[rp_.eAt++];
    }
  }
}

void Solver::repassForces(int activeLevel) {
  Real* f = state_.fIntData();
  for (size_t L = 0; L < rp_.nodesByLevel.size() && int(L) <= activeLevel; ++L) {
    const std::vector<Index>& nodes = rp_.nodesByLevel[L];
    const Index n = Index(nodes.size());
    const size_t at = rp_.mode == 1 ? rp_.fInt.size() : rp_.fAt;
    if (rp_.mode == 1) {
      rp_.fInt.resize(at + 3 * size_t(n));
    } else {
      if (at + 3 * size_t(n) > rp_.fInt.size()) throw std::logic_error("re-pass: more node steps than the first pass");
      rp_.fAt = at + 3 * size_t(n);
    }
    Real* r = rp_.fInt.data() + at;
    const bool record = rp_.mode == 1;
#pragma omp parallel for schedule(static) if (n >= 8192)
    for (Index i = 0; i < n; ++i) {
      Real* x = f + 3 * size_t(nodes[size_t(i)]);
      Real* y = r + 3 * size_t(i);
      if (record)
        y[0] = x[0], y[1] = x[1], y[2] = x[2];
      else
        x[0] = y[0], x[1] = y[1], x[2] = y[2];
    }
  }
}

void Solver::checkpoint(StateArchive& a) {
  // Subcycled, with a re-pass plan: a window's save (its first pass, mode 1) and a re-pass's restore
  // (mode 2) hold the node chunks a re-pass steps only (the others end as the first pass ends them).
  const bool part = a.windowStart() && (leavesNodeChunks(1) || leavesNodeChunks(2));
  if (a.windowStart()) {
    // What the window's steps read before they write it: f_int is summed again at every step, and
    // so is f_ext: at every node single-rate, whose next step reads the last one's f_ext as its
    // previous one (swapFExt; fExtPrev_ is then written), at the due nodes subcycled, whose last
    // update's f_ext and f_int are fSync_ and fIntSync_ (fExtPrev_ unread).
    state_.checkpointMotion(a, nodeLevel_.empty(), part ? &rp_.dofRanges : nullptr);
  } else {
    state_.checkpoint(a);
    a.io(fExtPrev_);
  }
  a.io(t_);
  a.io(dtLast_);
  a.io(step_);
  a.io(energy_);
  plasticStale_ = true;  // a restored history: sum again when asked
  a.io(stressWork_);
  a.io(storedEnergy_);
  a.io(dampWork_);
  a.io(bdryWork_);
  a.io(extWork_);
  a.io(balance0_);
  a.io(balanceSet_);
  a.io(interface0_);
  a.io(plastic0_);
  a.io(boundary0_);
  a.io(alphaRelax_);
  a.io(fSync_, part ? &rp_.dofRanges : nullptr);
  a.io(fIntSync_, part ? &rp_.dofRanges : nullptr);
  a.io(dtPrevNode_, part ? &rp_.nodeRanges : nullptr);
  a.io(intBase_);
  a.io(nodalIntWork_);
  a.io(cycle_);
  if (!a.saving()) stepOpen_ = false;  // a restored state abandons an open step
  if (!a.saving() && std::isnan(checkedTime_) && !std::isnan(energy_.error)) {  // resumed: its balance
    checkedError_ = energy_.error;
    checkedTime_ = t_;
  }
  for (auto& b : blocks_) b->checkpoint(a);
  for (auto& e : contributors_) e.contributor->checkpoint(a);
}

void Solver::runUntil(Real tEnd, const std::function<void()>& each) {
  while (t_ < tEnd - 1e-9 * dt_) {
    step();
    if (each) each();
  }
}

Real Solver::velocityAt(Index node, int d) const { return state_.vData()[dofIndex(node, d)]; }

Real Solver::unbalancedRatio() const { return unbalancedRatio(false); }

Real Solver::unbalancedRatio(bool allDofsReference) const {
  const Index N = state_.numNodes();
  Real r2 = 0, fe2 = 0, fi2 = 0;
  std::vector<Real> terms(rx_ ? 9 * size_t(N) : 0);  // on ranks: summed in the one-process order
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) {
      const size_t i = dofIndex(n, d);
      const Real fe = state_.fExtData()[i], fi = state_.fIntData()[i];
      const bool isFree = free_[i] != 0, ref = isFree || allDofsReference;
      if (rx_) {
        terms[9 * size_t(n) + size_t(d)] = isFree ? (fe - fi) * (fe - fi) : 0.0;
        terms[9 * size_t(n) + 3 + size_t(d)] = ref ? fe * fe : 0.0;
        terms[9 * size_t(n) + 6 + size_t(d)] = ref ? fi * fi : 0.0;
        continue;
      }
      if (isFree) r2 += (fe - fi) * (fe - fi);
      if (ref) {
        fe2 += fe * fe;
        fi2 += fi * fi;
      }
    }
  if (rx_) {
    Real sums[3] = {0, 0, 0};
    rx_->sumInNodeOrder(terms.data(), 3, 3, sums);
    r2 = sums[0], fe2 = sums[1], fi2 = sums[2];
  }
  const Real ref = std::sqrt(std::max(fe2, fi2));
  return ref > 0 ? std::sqrt(r2) / ref : 0;
}

Real Solver::residualNorm() const {
  const Index N = state_.numNodes();
  Real r2 = 0;
  std::vector<Real> terms(rx_ ? 3 * size_t(N) : 0);  // on ranks: summed in the one-process order
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) {
      const size_t i = dofIndex(n, d);
      if (free_[i] == 0) continue;
      const Real r = state_.fExtData()[i] - state_.fIntData()[i];
      if (rx_)
        terms[i] = r * r;
      else
        r2 += r * r;
    }
  if (rx_) rx_->sumInNodeOrder(terms.data(), 1, 3, &r2);
  return std::sqrt(r2);
}

void Solver::computeForces(bool withContributors) {
  const Real saved = alphaRelax_;
  alphaRelax_ = 0;  // no stiffness-proportional damping force: the state is taken at rest
  computeInternalForces();
  std::vector<AddedContributor> none;
  if (!withContributors) none.swap(contributors_);
  computeExternalForces();
  if (!withContributors) none.swap(contributors_);
  alphaRelax_ = saved;
}

RelaxResult Solver::relax(const RelaxParams& p) {
  RelaxResult r;
  const Index N = state_.numNodes();
  std::vector<Real> fPrev(3 * size_t(N), 0.0);
  Real wmax = stableStep().omegaMax;
  const Real dtDynamic = dt_;
  if (p.massScaling) {
    // Statics only: every element's mass is scaled by (ω_e / ω_ref)² so that its frequency
    // 2 c_p / L_e becomes the lowest one, ω_ref; the step grows to safety × 2 / ω_ref. Gravity
    // keeps the true masses (gravityMass_).
    Real wref = std::numeric_limits<Real>::max();
    for (const auto& b : blocks_) {
      const Real cp = std::sqrt(b->material().elasticModuli().pModulus() / b->material().density());
      for (Index e = 0; e < b->numElems(); ++e)
        if (b->active(e)) wref = std::min(wref, 2 * cp / b->charLength(e));
    }
    if (rx_) wref = rx_->minAll(wref);
    gravityMass_.assign(state_.massData(), state_.massData() + N);
    ++gravityMassVersion_;
    std::vector<Real> scaled(size_t(N), 0.0);
    std::vector<std::vector<Real>> share(rx_ ? blocks_.size() : 0);  // on ranks: summed as one process sums them
    for (size_t bi = 0; bi < blocks_.size(); ++bi) {
      const ElementBlock* b = blocks_[bi].get();
      const Real rho = b->material().density();
      const Real cp = std::sqrt(b->material().elasticModuli().pModulus() / rho);
      for (Index e = 0; e < b->numElems(); ++e) {
        if (!b->active(e)) {
          if (rx_) share[bi].push_back(0.0);
          continue;
        }
        const Real we = 2 * cp / b->charLength(e), f = (we / wref) * (we / wref);
        const Real m = f * rho * b->volume(e) / 8;
        if (rx_)
          share[bi].push_back(m);
        else
          for (int k = 0; k < 8; ++k) scaled[size_t(b->node(e, k))] += m;
      }
    }
    if (rx_) rx_->sumElementShares(share, scaled.data());
    for (Index n = 0; n < N; ++n) state_.addMass(n, scaled[size_t(n)] - state_.mass(n));
    wmax = wref;
    dt_ = opt_.safety * 2 / wref;
  }
  Real omega = 0;
  alphaRelax_ = 0;
  for (Index s = 0; s < p.maxSteps; ++s) {
    // Underwood (1983): lowest active frequency from the Rayleigh quotient of the last
    // increment, ω² = Δu·Δf_int / Δu·M·Δu; critical mass damping c = 2ω.
    computeInternalForces();
    if (s > 0) {
      Real num = 0, den = 0;
      const Real* f = state_.fIntData();
      const Real* v = state_.vData();
      if (rx_) {  // on ranks: the whole model's Rayleigh quotient, summed in the one-process order
        rankTerms_.resize(6 * size_t(N));
        for (Index n = 0; n < N; ++n)
          for (int d = 0; d < 3; ++d) {
            const size_t i = dofIndex(n, d);
            const Real du = dtLast_ * v[i];
            rankTerms_[6 * size_t(n) + size_t(d)] = du * (f[i] - fPrev[i]);
            rankTerms_[6 * size_t(n) + 3 + size_t(d)] = du * du * state_.mass(n);
          }
        Real q[2] = {0, 0};
        rx_->sumInNodeOrder(rankTerms_.data(), 2, 3, q);
        num = q[0], den = q[1];
      } else {
        for (Index n = 0; n < N; ++n)
          for (int d = 0; d < 3; ++d) {
            const size_t i = dofIndex(n, d);
            const Real du = dtLast_ * v[i];
            num += du * (f[i] - fPrev[i]);
            den += du * du * state_.mass(n);
          }
      }
      if (den > 0 && num > 0) omega = std::min(std::sqrt(num / den), wmax);
    }
    std::copy(state_.fIntData(), state_.fIntData() + 3 * size_t(N), fPrev.begin());
    alphaRelax_ = 2 * omega;
    state_.swapFExt(fExtPrev_);
    computeExternalForces();
    updateNodes();
    dtLast_ = dt_;
    t_ += dt_;
    ++step_;
    r.steps = s + 1;
    if ((s + 1) % p.checkEvery == 0) {
      r.ratio = p.referenceForce > 0 ? residualNorm() / p.referenceForce : unbalancedRatio();
      if (r.ratio < p.tolerance) r.converged = true;
      if (p.onCheck) p.onCheck(r);
      if (r.converged) break;
    }
  }
  alphaRelax_ = -1;
  if (p.massScaling) {  // back to the true masses and the dynamic step
    for (Index n = 0; n < N; ++n) state_.addMass(n, gravityMass_[size_t(n)] - state_.mass(n));
    gravityMass_.clear();
    ++gravityMassVersion_;
    dt_ = dtDynamic;
  }
  return r;
}

void Solver::resetMotion() {
  // The displacement itself is kept (the hourglass forces and strains are functions of the total
  // displacement, so zeroing it would make the model jump); results are reported relative to it.
  const Index N = state_.numNodes();
  uRef_.assign(state_.uData(), state_.uData() + 3 * size_t(N));
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) {
      state_.v(n, d) = 0;
      state_.a(n, d) = 0;
    }
  stressWork_ = dampWork_ = bdryWork_ = extWork_ = 0;
  stressWork_ = -storedEnergy_;  // internal energy restarts at 0 from the current state
  intBase_ = nodalIntWork_ = 0;  // subcycled: likewise
  interface0_ = plastic0_ = boundary0_ = 0;
  for (const auto& e : contributors_) interface0_ += e.contributor->dissipatedEnergy();
  for (const auto& b : blocks_) plastic0_ += b->dissipatedEnergy();
  plasticStale_ = true;
  for (const auto& e : contributors_) boundary0_ += e.contributor->boundaryEnergy();
  balanceSet_ = false;
}

Real Solver::relativeDisplacement(Index node, int d) const {
  const size_t i = dofIndex(node, d);
  return state_.uData()[i] - (uRef_.empty() ? 0.0 : uRef_[i]);
}

}  // namespace tq
