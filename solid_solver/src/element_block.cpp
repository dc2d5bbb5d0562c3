#include "tq/element_block.hpp"

#include <algorithm>
#include <cmath>

#include "tq/hex8.hpp"

namespace tq {

Hex8Formulation parseFormulation(const std::string& n) {
  if (n == "one_point_assumed_strain") return Hex8Formulation::OnePointAssumedStrain;
  if (n == "one_point_assumed_strain_no_poisson") return Hex8Formulation::OnePointAssumedStrainNoPoisson;
  if (n == "full_integration") return Hex8Formulation::FullIntegration;
  throw InputError("unknown element formulation '" + n +
                   "'; use one_point_assumed_strain (default), one_point_assumed_strain_no_poisson "
                   "or full_integration");
}

std::string formulationName(Hex8Formulation f) {
  switch (f) {
    case Hex8Formulation::OnePointAssumedStrain: return "one_point_assumed_strain";
    case Hex8Formulation::OnePointAssumedStrainNoPoisson: return "one_point_assumed_strain_no_poisson";
    case Hex8Formulation::FullIntegration: return "full_integration";
  }
  return "?";
}

ElementBlock::ElementBlock(std::string name, std::shared_ptr<const Material> material,
                           Hex8Formulation formulation, const Mesh& mesh,
                           std::vector<Index> meshElems, Real hourglassScale)
    : name_(std::move(name)), material_(std::move(material)), formulation_(formulation),
      nElems_(static_cast<Index>(meshElems.size())), meshElems_(std::move(meshElems)),
      hgScale_(hourglassScale) {
  if (formulation_ == Hex8Formulation::FullIntegration && !material_->isLinearElastic())
    throw InputError("block '" + name_ + "': full_integration is a linear elastic reference "
                     "formulation; material '" + material_->typeName() + "' needs one_point_assumed_strain");
  mod_ = material_->elasticModuli();
  nuBar_ = formulation_ == Hex8Formulation::OnePointAssumedStrain ? mod_.lambda / mod_.pModulus() : 0.0;
  const size_t E = size_t(nElems_);
  conn_.resize(8 * E);
  active_.assign(E, 1);
  vol_.resize(E);
  charLen_.resize(E);
  const bool full = formulation_ == Hex8Formulation::FullIntegration;
  if (full) {
    bg_.resize(8 * 24 * E);
    wdet_.resize(8 * E);
  } else {
    b_.resize(24 * E);
    gamma_.resize(32 * E);
    rot_.resize(9 * E);
    invHalf_.resize(3 * E);
  }
  for (auto& s : stress_) s.assign(E, 0.0);
  for (auto& s : strain_) s.assign(E, 0.0);
  for (size_t h = 0; h < material_->historyNames().size(); ++h) history_.emplace_back(E, 0.0);
  for (auto& h : history_) historyPtr_.push_back(h.data());
  for (size_t e = 0; e < E; ++e) {
    const Index me = meshElems_[e];
    Real x[3][8];
    for (int k = 0; k < 8; ++k) {
      conn_[8 * e + k] = mesh.connectivity[8 * size_t(me) + k];
      for (int i = 0; i < 3; ++i) x[i][k] = mesh.coords[3 * size_t(conn_[8 * e + k]) + i];
    }
    const hex8::Geometry g = hex8::computeGeometry(x);
    vol_[e] = g.volume;
    charLen_[e] = g.charLength;
    if (full) {
      Real bg[8][3][8], wd[8];
      hex8::gaussGradients(x, bg, wd);
      std::copy(&bg[0][0][0], &bg[0][0][0] + 192, &bg_[192 * e]);
      std::copy(wd, wd + 8, &wdet_[8 * e]);
    } else {
      std::copy(&g.b[0][0], &g.b[0][0] + 24, &b_[24 * e]);
      std::copy(&g.gamma[0][0], &g.gamma[0][0] + 32, &gamma_[32 * e]);
      std::copy(&g.rot[0][0], &g.rot[0][0] + 9, &rot_[9 * e]);
      std::copy(g.invHalf, g.invHalf + 3, &invHalf_[3 * e]);
    }
  }
  chunkEnergy_.resize(size_t((nElems_ + kChunk - 1) / kChunk));
}

void ElementBlock::setActive(Index e, bool on, const NodalState& state) {
  active_[e] = on ? 1 : 0;
  for (int c = 0; c < 6; ++c) stress_[c][e] = 0;
  for (auto& h : history_) h[e] = 0;
  // Restart strain-free from the current displacement (the next strain increment is measured
  // from here, so an element installed into a deformed mesh carries no stress).
  strainFromDisplacement(e, state);
}

void ElementBlock::rebaseStrain(const NodalState& state) {
  for (Index e = 0; e < nElems_; ++e) strainFromDisplacement(e, state);
}

void ElementBlock::strainFromDisplacement(Index e, const NodalState& state) {
  if (b_.empty()) return;
  const Real* b = &b_[24 * size_t(e)];
  Real L[3][3] = {};
  for (int k = 0; k < 8; ++k) {
    const Index n = conn_[8 * size_t(e) + k];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) L[i][j] += state.u(n, i) * b[8 * j + k];
  }
  strain_[XX][e] = L[0][0];
  strain_[YY][e] = L[1][1];
  strain_[ZZ][e] = L[2][2];
  strain_[XY][e] = L[0][1] + L[1][0];
  strain_[YZ][e] = L[1][2] + L[2][1];
  strain_[ZX][e] = L[2][0] + L[0][2];
}

void ElementBlock::lumpMassInto(NodalState& state) const {
  const Real rho = material_->density();
  for (Index e = 0; e < nElems_; ++e) {
    if (!active_[e]) continue;
    const Real m = rho * vol_[e] / 8;
    for (int k = 0; k < 8; ++k) state.addMass(conn_[8 * size_t(e) + k], m);
  }
}

Real ElementBlock::dissipatedEnergy() const {
  const int h = material_->dissipationHistory();
  if (h < 0 || size_t(h) >= history_.size()) return 0;
  Real sum = 0;  // serial, fixed order: the same for any thread count
  for (Index e = 0; e < nElems_; ++e) sum += vol_[e] * history_[size_t(h)][e];
  return sum;
}

Real ElementBlock::maxFrequency(Index* where) const {
  const Real cp = std::sqrt(mod_.pModulus() / material_->density());
  Real wmax = 0;
  Index at = -1;
  for (Index e = 0; e < nElems_; ++e) {
    if (!active_[e]) continue;
    const Real w = 2 * cp / charLen_[e];
    if (w > wmax) { wmax = w; at = e; }
  }
  if (where) *where = at;
  return wmax;
}

Index ElementBlock::findBadStress(Real limit) const {
  for (Index e = 0; e < nElems_; ++e)
    for (int c = 0; c < 6; ++c)
      if (!(std::abs(stress_[c][e]) <= limit)) return e;
  return -1;
}

// Assumed-strain hourglass stiffness in the element's local frame (derivation in
// docs/solid_solver.md). qh[k][α]: local component k of hourglass mode α (H_0 = ηζ, H_1 = ζξ,
// H_2 = ξη, H_3 = ξηζ); Qh: generalised hourglass forces, U = ½ Σ Qh·qh.
inline __attribute__((always_inline)) void ElementBlock::hourglassStiffness(Index e, const Real qh[3][4], Real Qh[3][4]) const {
  const Real* ia = &invHalf_[3 * size_t(e)];
  const Real lam = mod_.lambda, mu = mod_.mu, lp2m = mod_.pModulus();
  const Real V3 = hgScale_ * vol_[e] / 3, V9 = hgScale_ * vol_[e] / 9;
  // Twist/warping modes (component k of mode k): shear strains 2ε_12 ∝ ξ0, 2ε_20 ∝ ξ1, 2ε_01 ∝ ξ2.
  const Real t0 = qh[1][1] * ia[2] + qh[2][2] * ia[1];
  const Real t1 = qh[2][2] * ia[0] + qh[0][0] * ia[2];
  const Real t2 = qh[0][0] * ia[1] + qh[1][1] * ia[0];
  Qh[0][0] = mu * V3 * (t1 * ia[2] + t2 * ia[1]);
  Qh[1][1] = mu * V3 * (t0 * ia[2] + t2 * ia[0]);
  Qh[2][2] = mu * V3 * (t0 * ia[1] + t1 * ia[0]);
  // Bending modes: component k ≠ α of mode α is fibre k bending with curvature along
  // m = 3 - α - k; its normal strain ε_kk = s ξ_m with s = qh[k][α]/a_k. For each m the two
  // bending strains (k ≠ m) share the transverse strain ε_mm = -ν̄ Σ s.
  for (int m = 0; m < 3; ++m) {
    const int k1 = (m + 1) % 3, k2 = (m + 2) % 3;
    const int a1 = 3 - m - k1, a2 = 3 - m - k2;  // modes: α = third index of (k, m)
    const Real s1 = qh[k1][a1] * ia[k1], s2 = qh[k2][a2] * ia[k2];
    const Real em = -nuBar_ * (s1 + s2);
    const Real tr = s1 + s2 + em;
    const Real sg1 = lam * tr + 2 * mu * s1, sg2 = lam * tr + 2 * mu * s2, sgm = lam * tr + 2 * mu * em;
    Qh[k1][a1] = V3 * ia[k1] * (sg1 - nuBar_ * sgm);
    Qh[k2][a2] = V3 * ia[k2] * (sg2 - nuBar_ * sgm);
  }
  // ξηζ mode: compatible bilinear strains (orthogonal to everything else).
  const Real s0 = ia[0] * ia[0], s1 = ia[1] * ia[1], s2 = ia[2] * ia[2];
  Qh[0][3] = V9 * (lp2m * s0 + mu * (s1 + s2)) * qh[0][3];
  Qh[1][3] = V9 * (lp2m * s1 + mu * (s2 + s0)) * qh[1][3];
  Qh[2][3] = V9 * (lp2m * s2 + mu * (s0 + s1)) * qh[2][3];
}

template <bool kDamp>
void ElementBlock::onePointChunk(Index c, const Real* __restrict u, const Real* __restrict v,
                                 const ElementStepParams& p, Real* __restrict corner,
                                 BlockEnergy& en) {
  const Index e0 = c * kChunk, n = std::min(kChunk, nElems_ - e0);
  alignas(64) Real de[6][kChunk];
  alignas(64) Real w1[kChunk];
  Real wStress = 0, eHg = 0, wDamp = 0;
  // 1. Gather, total strain and its increment, hourglass forces into the corner buffer.
  for (Index l = 0; l < n; ++l) {
    const size_t e = size_t(e0 + l);
    Real* __restrict fe = corner + 24 * e;
    if (!active_[e]) {
      for (int k = 0; k < 6; ++k) de[k][l] = 0;
      w1[l] = 0;
      continue;
    }
    const Index* cn = &conn_[8 * e];
    Real ux[8], uy[8], uz[8];
    for (int k = 0; k < 8; ++k) {
      const Real* un = u + 3 * size_t(cn[k]);
      ux[k] = un[0];
      uy[k] = un[1];
      uz[k] = un[2];
    }
    const Real* __restrict b = &b_[24 * e];
    Real L[3][3];
    for (int j = 0; j < 3; ++j) {
      Real sx = 0, sy = 0, sz = 0;
      for (int k = 0; k < 8; ++k) {
        sx += ux[k] * b[8 * j + k];
        sy += uy[k] * b[8 * j + k];
        sz += uz[k] * b[8 * j + k];
      }
      L[0][j] = sx;
      L[1][j] = sy;
      L[2][j] = sz;
    }
    const Real eps[6] = {L[0][0], L[1][1], L[2][2], L[0][1] + L[1][0], L[1][2] + L[2][1],
                         L[2][0] + L[0][2]};
    Real w = 0;
    for (int k = 0; k < 6; ++k) {
      de[k][l] = eps[k] - strain_[k][e];
      strain_[k][e] = eps[k];
      w += stress_[k][e] * de[k][l];
    }
    w1[l] = w;
    // Hourglass: generalised displacements q_iα = γ_α · u_i, rotated to the local frame.
    const Real* __restrict g = &gamma_[32 * e];
    const Real* __restrict R = &rot_[9 * e];
    Real q[3][4];
    for (int a = 0; a < 4; ++a) {
      Real sx = 0, sy = 0, sz = 0;
      for (int k = 0; k < 8; ++k) {
        sx += g[8 * a + k] * ux[k];
        sy += g[8 * a + k] * uy[k];
        sz += g[8 * a + k] * uz[k];
      }
      q[0][a] = sx;
      q[1][a] = sy;
      q[2][a] = sz;
    }
    Real qh[3][4], Qh[3][4];
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 4; ++a) qh[k][a] = R[k] * q[0][a] + R[3 + k] * q[1][a] + R[6 + k] * q[2][a];
    hourglassStiffness(Index(e), qh, Qh);
    Real ehg = 0;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 4; ++a) ehg += qh[k][a] * Qh[k][a];
    eHg += 0.5 * ehg;
    if constexpr (kDamp) {
      // Stiffness-proportional damping on the hourglass modes: β K_hg q̇ with the lagged
      // velocity v^{n-1/2}.
      Real vx[8], vy[8], vz[8];
      for (int k = 0; k < 8; ++k) {
        const Real* vn = v + 3 * size_t(cn[k]);
        vx[k] = vn[0];
        vy[k] = vn[1];
        vz[k] = vn[2];
      }
      Real qd[3][4], qdh[3][4], Qdh[3][4];
      for (int a = 0; a < 4; ++a) {
        Real sx = 0, sy = 0, sz = 0;
        for (int k = 0; k < 8; ++k) {
          sx += g[8 * a + k] * vx[k];
          sy += g[8 * a + k] * vy[k];
          sz += g[8 * a + k] * vz[k];
        }
        qd[0][a] = sx;
        qd[1][a] = sy;
        qd[2][a] = sz;
      }
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 4; ++a)
          qdh[k][a] = R[k] * qd[0][a] + R[3 + k] * qd[1][a] + R[6 + k] * qd[2][a];
      hourglassStiffness(Index(e), qdh, Qdh);
      Real pd = 0;
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 4; ++a) {
          pd += qdh[k][a] * Qdh[k][a];
          Qh[k][a] += p.beta * Qdh[k][a];
        }
      wDamp += p.beta * pd * p.dt;
    }
    Real Q[3][4];
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 4; ++a) Q[i][a] = R[3 * i] * Qh[0][a] + R[3 * i + 1] * Qh[1][a] + R[3 * i + 2] * Qh[2][a];
    for (int k = 0; k < 8; ++k) {
      fe[3 * k + 0] = Q[0][0] * g[k] + Q[0][1] * g[8 + k] + Q[0][2] * g[16 + k] + Q[0][3] * g[24 + k];
      fe[3 * k + 1] = Q[1][0] * g[k] + Q[1][1] * g[8 + k] + Q[1][2] * g[16 + k] + Q[1][3] * g[24 + k];
      fe[3 * k + 2] = Q[2][0] * g[k] + Q[2][1] * g[8 + k] + Q[2][2] * g[16 + k] + Q[2][3] * g[24 + k];
    }
  }
  // 2. Material update of the whole chunk.
  MaterialChunk mc;
  mc.count = n;
  mc.dt = p.dtLast;
  for (int k = 0; k < 6; ++k) {
    mc.dstrain[k] = de[k];
    mc.stress[k] = stress_[k].data() + e0;
  }
  Real* hp[16];
  const size_t nh = std::min<size_t>(historyPtr_.size(), 16);
  for (size_t h = 0; h < nh; ++h) hp[h] = historyPtr_[h] + e0;
  mc.history = hp;
  material_->updateStressForElems(mc);
  // 3. Stress divergence f_iI += V Σ_j b_jI (σ + σ_d)_ij.
  const Real lam = mod_.lambda, mu = mod_.mu;
  const Real rate = (kDamp && p.dtLast > 0) ? p.beta / p.dtLast : 0;
  for (Index l = 0; l < n; ++l) {
    const size_t e = size_t(e0 + l);
    Real* __restrict fe = corner + 24 * e;
    if (!active_[e]) {
      for (int k = 0; k < 24; ++k) fe[k] = 0;
      continue;
    }
    Real s[6];
    Real w2 = 0;
    for (int k = 0; k < 6; ++k) {
      s[k] = stress_[k][e];
      w2 += s[k] * de[k][l];
    }
    const Real V = vol_[e];
    wStress += 0.5 * (w1[l] + w2) * V;
    if constexpr (kDamp) {
      // σ_d = β C : ε̇ with ε̇ = Δε/Δt_last = sym ∇v^{n-1/2} (lagged velocity).
      const Real tr = de[XX][l] + de[YY][l] + de[ZZ][l];
      Real sd[6];
      sd[XX] = rate * (lam * tr + 2 * mu * de[XX][l]);
      sd[YY] = rate * (lam * tr + 2 * mu * de[YY][l]);
      sd[ZZ] = rate * (lam * tr + 2 * mu * de[ZZ][l]);
      sd[XY] = rate * mu * de[XY][l];
      sd[YZ] = rate * mu * de[YZ][l];
      sd[ZX] = rate * mu * de[ZX][l];
      Real pd = 0;
      for (int k = 0; k < 6; ++k) {
        pd += sd[k] * de[k][l];
        s[k] += sd[k];
      }
      if (p.dtLast > 0) wDamp += pd * V * (p.dt / p.dtLast);
    }
    const Real* __restrict b = &b_[24 * e];
    for (int k = 0; k < 8; ++k) {
      const Real bx = b[k] * V, by = b[8 + k] * V, bz = b[16 + k] * V;
      fe[3 * k + 0] += bx * s[XX] + by * s[XY] + bz * s[ZX];
      fe[3 * k + 1] += bx * s[XY] + by * s[YY] + bz * s[YZ];
      fe[3 * k + 2] += bx * s[ZX] + by * s[YZ] + bz * s[ZZ];
    }
  }
  en.stressWork = wStress;
  en.storedEnergy = eHg;
  en.dampingWork = wDamp;
}

void ElementBlock::fullIntegrationChunk(Index c, const Real* __restrict u, Real* __restrict corner,
                                        BlockEnergy& en) {
  const Index e0 = c * kChunk, n = std::min(kChunk, nElems_ - e0);
  const Real lam = mod_.lambda, mu = mod_.mu;
  Real energy = 0;
  for (Index l = 0; l < n; ++l) {
    const size_t e = size_t(e0 + l);
    Real* fe = corner + 24 * e;
    for (int k = 0; k < 24; ++k) fe[k] = 0;
    if (!active_[e]) continue;
    Real ue[3][8];
    for (int k = 0; k < 8; ++k)
      for (int i = 0; i < 3; ++i) ue[i][k] = u[3 * size_t(conn_[8 * e + k]) + i];
    Real savg[6] = {}, eavg[6] = {};
    for (int gp = 0; gp < 8; ++gp) {
      const Real* bg = &bg_[192 * e + 24 * gp];
      const Real w = wdet_[8 * e + gp];
      Real L[3][3] = {};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 8; ++k) L[i][j] += ue[i][k] * bg[8 * j + k];
      const Real eps[6] = {L[0][0], L[1][1], L[2][2], L[0][1] + L[1][0], L[1][2] + L[2][1], L[2][0] + L[0][2]};
      const Real tr = eps[0] + eps[1] + eps[2];
      const Real s[6] = {lam * tr + 2 * mu * eps[0], lam * tr + 2 * mu * eps[1], lam * tr + 2 * mu * eps[2],
                         mu * eps[3], mu * eps[4], mu * eps[5]};
      for (int k = 0; k < 6; ++k) {
        savg[k] += s[k] * w;
        eavg[k] += eps[k] * w;
        energy += 0.5 * s[k] * eps[k] * w;
      }
      for (int k = 0; k < 8; ++k) {
        const Real bx = bg[k] * w, by = bg[8 + k] * w, bz = bg[16 + k] * w;
        fe[3 * k + 0] += bx * s[XX] + by * s[XY] + bz * s[ZX];
        fe[3 * k + 1] += bx * s[XY] + by * s[YY] + bz * s[YZ];
        fe[3 * k + 2] += bx * s[ZX] + by * s[YZ] + bz * s[ZZ];
      }
    }
    for (int k = 0; k < 6; ++k) {
      stress_[k][e] = savg[k] / vol_[e];
      strain_[k][e] = eavg[k] / vol_[e];
    }
  }
  en.stressWork = 0;
  en.storedEnergy = energy;
  en.dampingWork = 0;
}

BlockEnergy ElementBlock::computeForcesForElems(const NodalState& state, const ElementStepParams& p,
                                                Real* corner) {
  const Real* u = state.uData();
  const Real* v = state.vData();
  const Index nChunks = static_cast<Index>(chunkEnergy_.size());
  const bool full = formulation_ == Hex8Formulation::FullIntegration;
  if (full && p.beta > 0)
    throw InputError("block '" + name_ + "': full_integration does not support stiffness-proportional damping");
  const bool damp = p.beta > 0;
  // Small blocks run serially: a parallel region costs more than a few chunks of work, and
  // oversubscribed machines make its barrier expensive. Chunks are fixed, so results are the
  // same either way.
#pragma omp parallel for schedule(static) if (nChunks >= 8)
  for (Index c = 0; c < nChunks; ++c) {
    BlockEnergy& en = chunkEnergy_[size_t(c)];
    if (full)
      fullIntegrationChunk(c, u, corner, en);
    else if (damp)
      onePointChunk<true>(c, u, v, p, corner, en);
    else
      onePointChunk<false>(c, u, v, p, corner, en);
  }
  BlockEnergy total;  // fixed summation order: independent of the thread count
  for (const auto& en : chunkEnergy_) {
    total.stressWork += en.stressWork;
    total.storedEnergy += en.storedEnergy;
    total.dampingWork += en.dampingWork;
  }
  return total;
}

}  // namespace tq
