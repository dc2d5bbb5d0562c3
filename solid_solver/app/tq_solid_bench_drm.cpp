// tq-solid-bench-drm: the domain reduction layer's added time per step (not a test).
//
//   tq-solid-bench-drm [--n 40] [--steps 200] [--repeat 5] [--threads N] [--samples 2000]
//
// An elastic n x n x n box (1 m elements, free top) with a one-element DRM layer one element in from
// its sides and bottom, driven by a free field of `samples` time samples (a travelling sine: the
// values do not change the cost), every node given a small random velocity first. Times `steps` explicit steps `repeat`
// times with and without the layer's forces and prints the medians (ms per step), the ratio and the layer's share of
// elements.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tq/boundaries/drm.hpp"
#include "tq/core/solver.hpp"

int main(int argc, char** argv) {
  int n = 40, steps = 200, repeat = 5, threads = 0, samples = 2000;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    const int v = std::atoi(argv[i + 1]);
    if (a == "--n")
      n = v;
    else if (a == "--steps")
      steps = v;
    else if (a == "--repeat")
      repeat = v;
    else if (a == "--threads")
      threads = v;
    else if (a == "--samples")
      samples = v;
    else {
      std::fprintf(stderr,
                   "usage: tq-solid-bench-drm [--n 40] [--steps 200] [--repeat 5] [--threads N] [--samples 2000]\n");
      return 2;
    }
  }
  if (n < 5 || steps < 1 || repeat < 1 || samples < 2) {
    std::fprintf(stderr, "tq-solid-bench-drm: need n >= 5, steps >= 1, repeat >= 1, samples >= 2\n");
    return 2;
  }
  if (threads > 0) omp_set_num_threads(threads);
  tq::BoxSpec spec;
  spec.nx = spec.ny = spec.nz = n;
  spec.lx = spec.ly = spec.lz = n;
  const tq::Mesh mesh = tq::makeBoxMesh(spec);
  const tq::ElasticParams rock{2e8, 0.25, 2000};
  // Inner region [2, n − 2]² × [2, n]; outer boundary one element further out.
  const double lo = 2, hi = n - 2, tol = 1e-6;
  tq::DrmFreeField field;
  for (tq::Index k = 0; k < mesh.numNodes(); ++k) {
    const double* x = &mesh.coords[3 * size_t(k)];
    const bool inside = x[0] > lo - tol && x[0] < hi + tol && x[1] > lo - tol && x[1] < hi + tol && x[2] > lo - tol;
    const bool onB = std::abs(x[0] - lo) < tol || std::abs(x[0] - hi) < tol || std::abs(x[1] - lo) < tol ||
                     std::abs(x[1] - hi) < tol || std::abs(x[2] - lo) < tol;
    const bool inOuter =
        x[0] > lo - 1 - tol && x[0] < hi + 1 + tol && x[1] > lo - 1 - tol && x[1] < hi + 1 + tol && x[2] > lo - 1 - tol;
    if (inside && onB) field.nodes.push_back(k), field.internal.push_back(1);
    if (!inside && inOuter) field.nodes.push_back(k), field.internal.push_back(0);
  }
  const size_t N = field.nodes.size();
  for (int s = 0; s < samples; ++s) {
    const double t = 1e-3 * s;
    field.time.push_back(t);
    for (size_t i = 0; i < N; ++i) {
      const double z = mesh.coords[3 * size_t(field.nodes[i]) + 2], ph = 2 * M_PI * 5 * (t - z / 200);
      for (int d = 0; d < 3; ++d) {
        field.u.push_back(d == 0 ? 1e-3 * std::sin(ph) : 0.0);
        field.v.push_back(d == 0 ? 1e-3 * 2 * M_PI * 5 * std::cos(ph) : 0.0);
        field.a.push_back(0.0);
      }
    }
  }
  // Interleaved repeats (without, with, without, …) and the fastest of each: on a shared machine
  // the minimum is the least disturbed measurement.
  double best[2] = {1e300, 1e300}, bestForces = 1e300;
  tq::Index layer = 0;
  for (int r = 0; r < repeat; ++r)
    for (int withDrm = 0; withDrm < 2; ++withDrm) {
      tq::Solver s(mesh, tq::makeBlocksByRegion(mesh, {{"rock", std::make_shared<tq::ElasticMaterial>(rock)}}),
                   tq::SolverOptions{});
      std::shared_ptr<tq::DomainReduction> drm;
      if (withDrm) {
        drm = std::make_shared<tq::DomainReduction>(mesh, s.blocks(), field, 0.0);
        layer = drm->numLayerElements();
        s.addContributor(tq::ForcePhase::Boundaries, drm);
      }
      // Every node moving (as in tq-solid-bench): both runs step a model in motion, so the kernel's
      // cost is the same and the difference is the layer's forces alone.
      std::mt19937 rng(7);
      std::uniform_real_distribution<double> U(-1e-3, 1e-3);
      for (tq::Index k = 0; k < mesh.numNodes(); ++k)
        for (int d = 0; d < 3; ++d) s.state().v(k, d) = U(rng);
      auto a = std::chrono::steady_clock::now();
      for (int k = 0; k < steps; ++k) s.step();
      best[withDrm] =
          std::min(best[withDrm], std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count() / steps);
      if (withDrm) {  // the layer's forces alone, at the same times
        a = std::chrono::steady_clock::now();
        for (int k = 0; k < steps; ++k) drm->addForces(k * s.dt(), s.dt(), s.state());
        bestForces =
            std::min(bestForces, std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count() / steps);
      }
    }
  std::printf(
      "tq-solid-bench-drm: %d elements (%d in the DRM layer, %.1f %%), %zu DRM nodes, %d thread(s), fastest of %d: "
      "%.3f ms a step without, %.3f ms with the layer (+%.1f %%); the layer's forces alone %.3f ms (%.1f %% of a "
      "step without)\n",
      int(mesh.numElems()), int(layer), 100.0 * layer / mesh.numElems(), N, omp_get_max_threads(), repeat,
      1e3 * best[0], 1e3 * best[1], 100 * (best[1] / best[0] - 1), 1e3 * bestForces, 100 * bestForces / best[0]);
  return 0;
}
