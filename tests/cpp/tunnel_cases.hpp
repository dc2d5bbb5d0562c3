// The tunnel's static verification cases as functions, shared by
// test_tunnel_statics.cpp and the convergence ladders of `tunnelquake bench` (tq-verification-ladder):
// the quarter plate with a hole (and lining), polar stresses, the Kirsch excavation and
// the lined tunnel under internal water pressure.
#pragma once

#include <cmath>
#include <cstdio>
#include <sstream>

#include "staged_helpers.hpp"
#include "tq/elements/hex8.hpp"

namespace tqcases {

using namespace tq;

struct QuarterSpec {
  Real b = 5.25;      // hole radius (m)
  Real L = 105;       // outer square half-side (m)
  Index nTheta = 12;  // elements around the quarter
  Real liningT = 0;   // lining thickness (m); 0: no lining
  Index nLining = 3;  // elements through the lining
  Real width = 0.5;   // slice thickness along y (m)
};

/// Quarter plate with a hole (and optionally a lining ring with duplicated interface nodes).
/// Faces: bottom (z = 0), xmin (x = 0), xmax (x = L), top (z = L), ymin, ymax, rock_hole,
/// lining_inner, lining_outer; regions rock (0), lining (1).
inline Mesh quarterPlate(const QuarterSpec& q) {
  Mesh m;
  m.slice = true;
  m.source = "<quarter plate>";
  m.regionNames = {"rock", "lining"};
  const Index nt = q.nTheta;
  const Real dth = M_PI / 2 / nt;
  const Index nr = std::max<Index>(1, Index(std::lround(std::log(q.L / q.b) / dth)));
  auto addNode = [&](Real x, Real y, Real z) {
    m.coords.insert(m.coords.end(), {x, y, z});
    return m.numNodes() - 1;
  };
  // Node grids id[i][j][k]: i hoop, j radial, k = 0, 1 along y.
  auto grid = [&](Index nj, auto radius) {
    std::vector<Index> id(size_t((nt + 1) * (nj + 1) * 2));
    for (Index k = 0; k < 2; ++k)
      for (Index j = 0; j <= nj; ++j)
        for (Index i = 0; i <= nt; ++i) {
          const Real th = i * dth, r = radius(th, j);
          id[size_t((k * (nj + 1) + j) * (nt + 1) + i)] = addNode(r * std::cos(th), k * q.width, r * std::sin(th));
        }
    return id;
  };
  auto at = [&](const std::vector<Index>& id, Index nj, Index i, Index j, Index k) {
    return id[size_t((k * (nj + 1) + j) * (nt + 1) + i)];
  };
  auto addBlock = [&](const std::vector<Index>& id, Index nj, Index region, const std::string& inner,
                      const std::string& outer, bool splitOuter) {
    for (Index j = 0; j < nj; ++j)
      for (Index i = 0; i < nt; ++i) {
        const Index c[8] = {at(id, nj, i, j, 0),         at(id, nj, i + 1, j, 0), at(id, nj, i + 1, j + 1, 0),
                            at(id, nj, i, j + 1, 0),     at(id, nj, i, j, 1),     at(id, nj, i + 1, j, 1),
                            at(id, nj, i + 1, j + 1, 1), at(id, nj, i, j + 1, 1)};
        m.connectivity.insert(m.connectivity.end(), c, c + 8);
        m.region.push_back(region);
        auto face = [&](const std::string& name, int f) {
          for (int v = 0; v < 4; ++v) m.faces[name].push_back(c[hex8::kFaces[f][v]]);
        };
        face("ymin", 0);
        face("ymax", 1);
        if (j == 0) face(inner, 2);
        if (j == nj - 1) face(splitOuter ? ((i + 0.5) * dth < M_PI / 4 ? "xmax" : "top") : outer, 4);
        if (i == 0) face("bottom", 5);
        if (i == nt - 1) face("xmin", 3);
      }
  };
  const Real b = q.b, L = q.L;
  const auto rock = grid(nr, [&](Real th, Index j) {
    const Real rsq = L / std::max(std::cos(th), std::sin(th));
    return b * std::pow(rsq / b, Real(j) / nr);
  });
  addBlock(rock, nr, 0, "rock_hole", "", true);
  if (q.liningT > 0) {
    const Real a = b - q.liningT;
    const auto lin = grid(q.nLining, [&](Real, Index j) { return a + (b - a) * Real(j) / q.nLining; });
    addBlock(lin, q.nLining, 1, "lining_inner", "lining_outer", false);
    for (Index k = 0; k < 2; ++k)
      for (Index i = 0; i <= nt; ++i) {
        m.rockLiningPairs.push_back(at(rock, nr, i, 0, k));
        m.rockLiningPairs.push_back(at(lin, q.nLining, i, q.nLining, k));
      }
  }
  checkMesh(m);
  return m;
}

/// Hoop and radial stress (tension positive) of an element from its Cartesian stress, at the
/// centroid angle; returns the centroid radius.
inline Real polarStress(const Mesh& m, const ElementBlock& blk, Index e, Real* hoop, Real* radial, Real* theta) {
  Real x = 0, z = 0;
  for (int k = 0; k < 8; ++k) {
    x += 0.125 * m.coords[3 * size_t(blk.node(e, k))];
    z += 0.125 * m.coords[3 * size_t(blk.node(e, k)) + 2];
  }
  const Real th = std::atan2(z, x), c = std::cos(th), s = std::sin(th);
  const Real sxx = blk.stress(e, XX), szz = blk.stress(e, ZZ), sxz = blk.stress(e, ZX);
  *hoop = sxx * s * s + szz * c * c - 2 * sxz * s * c;
  *radial = sxx * c * c + szz * s * s + 2 * sxz * s * c;
  *theta = th;
  return std::hypot(x, z);
}

constexpr Real kEr = 8e9, kNur = 0.27, kRhor = 2700;   // rock (paper Table 1)
constexpr Real kEl = 28e9, kNul = 0.17, kRhol = 2500;  // lining, C25

struct KirschResult {
  Real errSide = 0, errCrown = 0;  // relative errors of the wall hoop stress
  Index steps = 0, elems = 0;
};

inline KirschResult kirsch(Index nTheta, Real p, Real k, Real Lfactor = 20) {
  tqtest::StagedRun run;
  QuarterSpec qs;
  qs.nTheta = nTheta;
  qs.L = Lfactor * qs.b;
  run.mesh = quarterPlate(qs);
  run.in.materials = {{"rock", elasticValues({kEr, kNur, kRhor})}};
  run.in.fixed = {{"bottom", "z"}, {"xmin", "x"}, {"xmax", "x"}, {"top", "z"}};
  StagedInput& S = run.in.staged;
  S.present = true;
  S.stages.sequence = {"in_situ", "excavation"};
  S.stages.tolerance = 1e-4;  // of the released tractions: far below the discretisation error
  S.stages.maxSteps = 200000;
  S.inSitu.present = true;
  S.inSitu.kx = k;
  S.inSitu.ky = 0.5 * (1 + k);
  S.inSitu.kz = 1;
  S.inSitu.surcharge = p;  // uniform σv = −p (gravity off)
  run.build();
  std::ostringstream log;
  run.stages->runStatics(log);
  const ElementBlock& blk = *run.solver->blocks()[0];
  // Wall hoop stress at the first and last element columns (θ_c = Δθ/2 and π/2 − Δθ/2): linear
  // extrapolation in r of the two innermost elements to r = b, against Kirsch at (b, θ_c).
  const Real dth = M_PI / 2 / nTheta;
  auto wall = [&](Index column) {
    Real r[2], h[2], th = 0;
    for (Index j = 0; j < 2; ++j) {
      Real rad;
      r[j] = polarStress(run.mesh, blk, j * nTheta + column, &h[j], &rad, &th);
    }
    const Real hw = h[0] + (h[1] - h[0]) * (qs.b - r[0]) / (r[1] - r[0]);
    const Real ref = -p * ((1 + k) + 2 * (1 - k) * std::cos(2 * th));  // tension positive
    return hw / ref - 1;
  };
  KirschResult res;
  res.errSide = wall(0);
  res.errCrown = wall(nTheta - 1);
  res.steps = run.stages->reports().back().steps;
  res.elems = run.mesh.numElems();
  std::printf(
      "Kirsch k = %.2f, %d around the quarter (%d elements): sidewall %+.2f %%, crown %+.2f %% (θ_c = "
      "%.2f°), %d relaxation steps\n",
      k, nTheta, res.elems, 100 * res.errSide, 100 * res.errCrown, 90 - 0.5 * dth * 180 / M_PI, res.steps);
  (void)dth;
  return res;
}

// Lined tunnel (tests/verification/solid_lined_tunnel): the paper's lining
// a = 4.5 m to b = 5.25 m installed stress-free after the excavation, bonded to the rock, then a
// uniform internal pressure p_i. Closed form of a lining bonded in an infinite elastic medium
// (VERIFICATION.md; tunnelquake.references.lined_tunnel_internal_pressure).
constexpr Real kLinedPi = 1000 * 9.81 * 123;  // 123 m of water (Pa)

struct LinedReference {
  Real pc = 0, hoopIn = 0, hoopOut = 0;  // contact pressure, inner and outer hoop stress (tension +)
};

inline LinedReference linedReference(Real pi, Real a = 4.5, Real b = 5.25) {
  const Real Gl = kEl / (2 * (1 + kNul)), Gm = kEr / (2 * (1 + kNur));
  const Real den = Gl * (b * b - a * a) + Gm * ((1 - 2 * kNul) * b * b + a * a);
  LinedReference r;
  r.pc = pi * 2 * Gm * (1 - kNul) * a * a / den;
  r.hoopIn = pi * (Gl * (a * a + b * b) + Gm * ((1 - 2 * kNul) * b * b - a * a)) / den;
  r.hoopOut = pi * 2 * a * a * (Gl - Gm * kNul) / den;
  return r;
}

/// The lining ring's stresses in Lamé form, σθθ = A + B/r², σrr = A − B/r² (exact for an
/// axisymmetric ring), fitted by least squares over every element of the block (rows [1, 1/r²] → hoop,
/// [1, −1/r²] → radial: the normal equations are diagonal).
struct LameFit {
  Real A = 0, B = 0;
  Real hoop(Real r) const { return A + B / (r * r); }
  /// −σrr at radius r: the contact pressure at the ring's outer face, compression positive.
  Real contactPressure(Real r) const { return -(A - B / (r * r)); }
};
inline LameFit lameFit(const Mesh& m, const ElementBlock& lin) {
  Real s11 = 0, s22 = 0, r1 = 0, r2 = 0;
  for (Index e = 0; e < lin.numElems(); ++e) {
    Real h, rad, th;
    const Real r = polarStress(m, lin, e, &h, &rad, &th);
    const Real q = 1 / (r * r);
    s11 += 2;
    s22 += 2 * q * q;
    r1 += h + rad;
    r2 += q * h - q * rad;
  }
  return {r1 / s11, r2 / s22};
}

/// The contact pressure from the tie's forces on the lining's nodes (rock → lining) of a quarter
/// model with nTheta elements around, over the polygonal interface's area (compression positive).
template <class Run, class Spec>
Real tieContactPressure(const Run& run, const Spec& qs, Index nTheta) {
  const auto* tie = dynamic_cast<const TiedNodeGroups*>(run.stages->rockLiningInterface().get());
  Real fr = 0;
  for (Index g = 0; g < tie->numGroups(); ++g) {
    const Index ln = tie->begin(g)[1];
    const Real* f = tie->force(tie->memberIndex(g, 1));
    const Real x = run.mesh.coords[3 * size_t(ln)], z = run.mesh.coords[3 * size_t(ln) + 2], r = std::hypot(x, z);
    fr += (f[0] * x + f[2] * z) / r;
  }
  const Real dth = M_PI / 2 / nTheta;
  return -fr / (nTheta * 2 * qs.b * std::sin(dth / 2) * qs.width);
}

/// The lining's excavation load in closed form (tension positive): hydrostatic in-situ stress p0
/// (compression), release fraction λ before the lining a ≤ r ≤ b is bonded in the rock; the lining
/// takes the release of the remaining (1 − λ) p0 at r = b on the composite (plane strain).
struct ReleaseReference {
  Real pc = 0, hoopIn = 0, hoopOut = 0;  // contact pressure (compression +), hoop at r = a and r = b
};

inline ReleaseReference releaseReference(Real p0, Real lambda, Real a, Real b) {
  const Real Gl = kEl / (2 * (1 + kNul)), Gr = kEr / (2 * (1 + kNur));
  const Real d = b * b - a * a;
  ReleaseReference r;
  r.pc = (1 - lambda) * p0 * Gl * d / (Gl * d + Gr * ((1 - 2 * kNul) * b * b + a * a));
  r.hoopIn = -2 * r.pc * b * b / d;
  r.hoopOut = -r.pc * (a * a + b * b) / d;
  return r;
}

struct LinedResult {
  Real hoopIn = 0, hoopOut = 0, pc = 0, pcTie = 0;  // lining stresses (tension positive), contact pressure
  Index steps = 0, elems = 0;                       // relaxation steps of all four stages, elements
};

/// The lined tunnel's quarter model (lining a = 4.5 m to b = 5.25 m, bonded) in `run`, relaxed
/// through in_situ → excavation → lining → hydrostatic (uniform internal pressure pi).
inline void runLinedTunnel(tqtest::StagedRun& run, QuarterSpec& qs, Index nTheta, Index nThrough, Real pi, Real p0,
                           Real Lfactor = 20) {
  qs.nTheta = nTheta;
  qs.liningT = 0.75;
  qs.L = Lfactor * qs.b;
  qs.nLining = nThrough;
  run.mesh = quarterPlate(qs);
  run.in.materials = {{"rock", elasticValues({kEr, kNur, kRhor})}, {"lining", elasticValues({kEl, kNul, kRhol})}};
  run.in.fixed = {{"bottom", "z"}, {"xmin", "x"}, {"xmax", "x"}, {"top", "z"}};
  StagedInput& S = run.in.staged;
  S.present = true;
  S.stages.sequence = {"in_situ", "excavation", "lining", "hydrostatic"};
  S.stages.tolerance = 1e-6;
  S.stages.maxSteps = 200000;
  S.inSitu.present = true;
  S.inSitu.kx = 1.1;  // paper
  S.inSitu.ky = 0.8;
  S.inSitu.kz = 1.0;
  S.inSitu.surcharge = p0;  // the rock's prestress: the lining, installed after, must not feel it
  S.hydrostatic.present = true;
  S.hydrostatic.pressureAtAxis = pi;
  S.hydrostatic.unitWeight = 0;  // uniform: the closed form is for a uniform internal pressure
  run.build();
  std::ostringstream log;
  run.stages->runStatics(log);
}

inline LinedResult linedTunnel(Index nTheta, Index nThrough, Real pi, Real p0, Real Lfactor = 20) {
  tqtest::StagedRun run;
  QuarterSpec qs;
  runLinedTunnel(run, qs, nTheta, nThrough, pi, p0, Lfactor);
  const ElementBlock* lin = nullptr;
  for (const auto& b : run.solver->blocks())
    if (b->name() == "lining") lin = b.get();
  const LameFit L = lameFit(run.mesh, *lin);
  const Real a = qs.b - qs.liningT, b = qs.b;
  LinedResult res;
  for (const auto& rep : run.stages->reports()) res.steps += rep.steps;
  res.elems = run.mesh.numElems();
  res.hoopIn = L.hoop(a);
  res.hoopOut = L.hoop(b);
  res.pc = L.contactPressure(b);
  res.pcTie = tieContactPressure(run, qs, nTheta);
  return res;
}

}  // namespace tqcases
