// tq-solid-bench-nl: cost of the nonlinear parts of tq-solid (damage material, dynamic contact), not a test.
//
//   tq-solid-bench-nl [--n 30] [--steps 100] [--repeat 5] [--threads N]
//
// 1. Material update alone (chunks of 64 elements, random strain increments), ns per element:
//    elastic; Mohr–Coulomb damage with every element elastic (trial inside the surface); with
//    every element yielding (trial outside, return mapping and implicit damage).
// 2. Whole explicit step on an n^3 box (base fixed), µs per element-step: elastic; Mohr–Coulomb
//    damage staying elastic (small random velocities); Mohr–Coulomb damage yielding (weak
//    material, large velocities: the share of yielding elements per step is printed).
// 3. Rock–lining dynamic contact: an n x n x n/2 rock box under an n x n x 2 lining box with
//    duplicated interface nodes, (n+1)^2 pairs; µs per pair-step of DynamicContact::addForces
//    and the whole step with and without it.
// Figures: median and best of `repeat` timed runs after a warm-up, the compared cases timed in
// turn so that a busy machine slows them alike.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "bench_options.hpp"
#include "tq/contact/contact.hpp"
#include "tq/core/solver.hpp"
#include "tq/materials/material_mc.hpp"

using namespace tq;

namespace {

double seconds(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

MohrCoulombDamageParams rockParams() {
  MohrCoulombDamageParams p;
  p.elastic = {8e9, 0.27, 2700};
  p.cohesion = 0.55e6;
  p.frictionAngle = 37;
  p.tensileStrength = 1.2e6;
  p.damageConstant = 100;
  return p;
}

// ns per element of updateStressForElems over `passes` passes of E elements in chunks of 64.
double materialNs(const Material& m, Index E, int passes, Real strainScale, Real stressScale, int repeat,
                  double* yieldShare) {
  std::mt19937 rng(5);
  std::normal_distribution<Real> G(0, 1);
  std::vector<Real> de[6], s[6], s0[6];
  for (int k = 0; k < 6; ++k) {
    de[k].resize(size_t(E));
    s0[k].resize(size_t(E));
    for (Index e = 0; e < E; ++e) {
      de[k][size_t(e)] = strainScale * G(rng);
      s0[k][size_t(e)] = stressScale * G(rng) - (k < 3 ? 3 * stressScale : 0);
    }
  }
  const size_t H = m.historyNames().size();
  std::vector<std::vector<Real>> h(H, std::vector<Real>(size_t(E), 0.0)), h0 = h;
  std::vector<double> times;
  for (int r = 0; r < repeat; ++r) {
    for (int k = 0; k < 6; ++k) s[k] = s0[k];
    h = h0;
    times.push_back(seconds([&] {
      for (int p = 0; p < passes; ++p) {
        for (int k = 0; k < 6; ++k) std::copy(s0[k].begin(), s0[k].end(), s[k].begin());  // same state each pass
        for (Index c = 0; c < E; c += 64) {
          MaterialChunk mc;
          mc.count = std::min<Index>(64, E - c);
          for (int k = 0; k < 6; ++k) {
            mc.dstrain[k] = de[k].data() + c;
            mc.stress[k] = s[k].data() + c;
          }
          Real* hp[16];
          for (size_t i = 0; i < H; ++i) hp[i] = h[i].data() + c;
          mc.history = hp;
          m.updateStressForElems(mc);
        }
      }
    }));
  }
  if (yieldShare && H > 0) {
    Index n = 0;
    for (Index e = 0; e < E; ++e) n += h[mc_history::kDissipation][size_t(e)] != 0 ? 1 : 0;
    *yieldShare = double(n) / E;
  }
  std::sort(times.begin(), times.end());
  return 1e9 * times.front() / (double(passes) * E);  // best of `repeat`
}

// A solver on an n^3 box (base fixed) with random initial velocities, warmed up.
std::unique_ptr<Solver> boxSolver(const Mesh& mesh, std::shared_ptr<const Material> mat, Real vScale) {
  auto s = std::make_unique<Solver>(mesh, makeBlocksByRegion(mesh, {{"rock", mat}}), SolverOptions{});
  s->fixFaceGroup("bottom", "xyz");
  std::mt19937 rng(1);
  std::uniform_real_distribution<Real> U(-vScale, vScale);
  for (Index i = 0; i < mesh.numNodes(); ++i)
    for (int d = 0; d < 3; ++d) s->state().v(i, d) = U(rng);
  for (int i = 0; i < 10; ++i) s->step();
  return s;
}

// Share of elements whose dissipation grows in one more step.
double yieldingShare(Solver& s) {
  const auto& b = *s.blocks()[0];
  const int hd = b.material().dissipationHistory();
  if (hd < 0) return 0;
  std::vector<Real> before(size_t(b.numElems()));
  for (Index e = 0; e < b.numElems(); ++e) before[size_t(e)] = b.history(hd, e);
  s.step();
  Index cnt = 0;
  for (Index e = 0; e < b.numElems(); ++e) cnt += b.history(hd, e) != before[size_t(e)] ? 1 : 0;
  return double(cnt) / b.numElems();
}

struct Timing {
  double median = 0, best = 0;
};
Timing summarize(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return {v[v.size() / 2], v.front()};
}

}  // namespace

int main(int argc, char** argv) {
  bench::SizeOptions size{30, 100, 5};
  for (int i = 1; i < argc; ++i)
    if (!bench::readSizeOption(argc, argv, i, size)) {
      std::fprintf(stderr, "usage: tq-solid-bench-nl [--n 30] [--steps 100] [--repeat 5] [--threads N]\n");
      return 1;
    }
  const int n = size.n, steps = size.steps, repeat = size.repeat;
  std::printf("tq-solid-bench-nl: %d thread(s), median of %d runs\n", omp_get_max_threads(), repeat);
  // 1. Material update alone.
  {
    const Index E = 64 * 1024;
    auto el = std::make_shared<ElasticMaterial>(ElasticParams{8e9, 0.27, 2700});
    auto mc = std::make_shared<MohrCoulombDamageMaterial>(rockParams());
    double share = 0;
    const double tEl = materialNs(*el, E, 20, 1e-7, 1e5, repeat, nullptr);
    const double tMcEl = materialNs(*mc, E, 20, 1e-7, 1e5, repeat, &share);
    const double shareEl = share;
    const double tMcY = materialNs(*mc, E, 20, 2e-4, 1e6, repeat, &share);
    std::printf(
        "material update, ns per element (best of %d): elastic %.2f; mohr_coulomb_damage elastic state %.2f (%.2fx, "
        "%.0f %% "
        "yielding); yielding state %.2f (%.2fx, %.0f %% yielding)\n",
        repeat, tEl, tMcEl, tMcEl / tEl, 100 * shareEl, tMcY, tMcY / tEl, 100 * share);
  }
  // 2. Whole step: the three solvers are timed in turn (interleaved), so that a busy machine
  //    slows them alike; median and best of `repeat`.
  {
    const Mesh mesh = makeBoxMesh({n, n, n, 0, 0, 0, 1.0 * n, 1.0 * n, 1.0 * n});
    auto el = std::make_shared<ElasticMaterial>(ElasticParams{8e9, 0.27, 2700});
    auto mc = std::make_shared<MohrCoulombDamageMaterial>(rockParams());
    auto weakP = rockParams();
    weakP.cohesion = 0.02e6;
    weakP.tensileStrength = 0.01e6;
    auto weak = std::make_shared<MohrCoulombDamageMaterial>(weakP);
    std::unique_ptr<Solver> S[3] = {boxSolver(mesh, el, 1e-3), boxSolver(mesh, mc, 1e-3), boxSolver(mesh, weak, 1.0)};
    std::vector<double> t[3];
    for (int r = 0; r < repeat; ++r)
      for (int k = 0; k < 3; ++k)
        t[k].push_back(1e6 * seconds([&] {
                         for (int i = 0; i < steps; ++i) S[k]->step();
                       }) /
                       (double(steps) * mesh.numElems()));
    const double shareEl = yieldingShare(*S[1]), shareY = yieldingShare(*S[2]);
    const Timing a = summarize(t[0]), b = summarize(t[1]), c = summarize(t[2]);
    std::printf(
        "whole step, %d^3 box (%d elements), us per element-step (median / best): elastic %.4f / %.4f; "
        "mohr_coulomb_damage elastic state %.4f / %.4f (%.3fx / %.3fx, %.1f %% yielding per step); "
        "yielding %.4f / %.4f (%.2fx / %.2fx, %.0f %% yielding per step)\n",
        n, mesh.numElems(), a.median, a.best, b.median, b.best, b.median / a.median, b.best / a.best, 100 * shareEl,
        c.median, c.best, c.median / a.median, c.best / a.best, 100 * shareY);
  }
  // 3. Contact.
  {
    const int nz = std::max(2, n / 2);
    Mesh r = makeBoxMesh({n, n, nz, 0, 0, -1.0 * nz, 1.0 * n, 1.0 * n, 1.0 * nz, "rock"});
    const Mesh l = makeBoxMesh({n, n, 2, 0, 0, 0, 1.0 * n, 1.0 * n, 2.0, "lining"});
    const Index off = r.numNodes();
    Mesh m = r;
    m.coords.insert(m.coords.end(), l.coords.begin(), l.coords.end());
    for (Index c : l.connectivity) m.connectivity.push_back(c + off);
    m.regionNames = {"rock", "lining"};
    for (Index e = 0; e < l.numElems(); ++e) m.region.push_back(1);
    m.faces.clear();
    m.faces["bottom"] = r.faces.at("bottom");
    for (Index q : l.faces.at("bottom")) m.faces["lining_outer"].push_back(q + off);
    const Index perLayer = (n + 1) * (n + 1);
    for (Index k = 0; k < perLayer; ++k) {
      m.rockLiningPairs.push_back(nz * perLayer + k);
      m.rockLiningPairs.push_back(off + k);
    }
    auto build = [&](bool withContact, std::shared_ptr<DynamicContact>& c) {
      auto s = std::make_unique<Solver>(
          m,
          makeBlocksByRegion(m, {{"rock", std::make_shared<ElasticMaterial>(ElasticParams{8e9, 0.27, 2700})},
                                 {"lining", std::make_shared<ElasticMaterial>(ElasticParams{28e9, 0.17, 2500})}}),
          SolverOptions{});
      s->fixFaceGroup("bottom", "xyz");
      if (withContact) {
        c = std::make_shared<DynamicContact>(*s, rockLiningPairs(m), ContactParams{});
        s->addContributor(ForcePhase::Interface, c);
      }
      std::mt19937 rng(1);
      std::uniform_real_distribution<Real> U(-1e-3, 1e-3);
      for (Index i = 0; i < m.numNodes(); ++i)
        for (int d = 0; d < 3; ++d) s->state().v(i, d) = U(rng);
      for (int i = 0; i < 10; ++i) s->step();
      return s;
    };
    std::shared_ptr<DynamicContact> none, c;
    auto s0 = build(false, none), s1 = build(true, c);
    std::vector<double> t0, t1, tc;
    for (int rr = 0; rr < repeat; ++rr) {
      t0.push_back(1e6 * seconds([&] {
                     for (int i = 0; i < steps; ++i) s0->step();
                   }) /
                   steps);
      t1.push_back(1e6 * seconds([&] {
                     for (int i = 0; i < steps; ++i) s1->step();
                   }) /
                   steps);
      tc.push_back(1e6 * seconds([&] {
                     for (int i = 0; i < steps; ++i) c->addForces(s1->time(), s1->dt(), s1->state());
                   }) /
                   (double(steps) * c->numPairs()));
    }
    const Timing a = summarize(t0), b = summarize(t1), pc = summarize(tc);
    std::printf(
        "contact: %d pairs (all bonded) on a %d-element model; addForces %.4f / %.4f us per pair-step "
        "(median / best); whole step %.1f / %.1f us without, %.1f / %.1f us with contact\n",
        perLayer, m.numElems(), pc.median, pc.best, a.median, a.best, b.median, b.best);
  }
  return 0;
}
