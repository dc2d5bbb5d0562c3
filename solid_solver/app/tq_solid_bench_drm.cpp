// tq-solid-bench-drm: the domain reduction layer's added time per step (not a test).
//
//   tq-solid-bench-drm [--n 40] [--steps 200] [--repeat 5] [--threads N] [--samples 2000]
//                      [--steps-per-sample 10]
//
// An elastic n x n x n box (1 m elements, free top) with a one-element DRM layer one element in from
// its sides and bottom, driven by a free field of `samples` time samples `steps-per-sample` stable
// steps apart (a travelling sine: the values do not change the cost; below 1 the samples are finer
// than the step), every node given a small random velocity first. Times `steps` explicit steps
// `repeat` times without and with the layer's forces, interleaved, in CPU time of the process (on a
// shared machine the wall clock measures the others' load too), and prints each round's ratio and
// their median, the median times (ms per step), the layer's forces alone and the layer's share of
// elements.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tq/boundaries/drm.hpp"
#include "tq/core/solver.hpp"

int main(int argc, char** argv) {
  int n = 40, steps = 200, repeat = 5, threads = 0, samples = 2000;
  double stepsPerSample = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    const int v = std::atoi(argv[i + 1]);
    if (a == "--steps-per-sample")
      stepsPerSample = std::atof(argv[i + 1]);
    else if (a == "--n")
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
                   "usage: tq-solid-bench-drm [--n 40] [--steps 200] [--repeat 5] [--threads N] [--samples 2000] "
                   "[--steps-per-sample 10]\n");
      return 2;
    }
  }
  if (n < 5 || steps < 1 || repeat < 1 || samples < 2 || !(stepsPerSample > 0)) {
    std::fprintf(stderr,
                 "tq-solid-bench-drm: need n >= 5, steps >= 1, repeat >= 1, samples >= 2, steps-per-sample > 0\n");
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
  const auto blocks = [&] {
    return tq::makeBlocksByRegion(mesh, {{"rock", std::make_shared<tq::ElasticMaterial>(rock)}});
  };
  const double stepDt = tq::Solver(mesh, blocks(), tq::SolverOptions{}).dt(), sampleDt = stepsPerSample * stepDt;
  for (int s = 0; s < samples; ++s) {
    const double t = sampleDt * s;
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
  // Interleaved repeats (without, with, without, …): each round's ratio of two neighbouring runs,
  // and the median over the rounds.
  const auto cpu = [] {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
  };
  const auto median = [](std::vector<double> x) {
    std::sort(x.begin(), x.end());
    const size_t m = x.size() / 2;
    return x.size() % 2 ? x[m] : 0.5 * (x[m - 1] + x[m]);
  };
  std::vector<double> without, with, forces, ratio;
  tq::Index layer = 0, products = 0;
  for (int r = 0; r < repeat; ++r)
    for (int withDrm = 0; withDrm < 2; ++withDrm) {
      tq::Solver s(mesh, blocks(), tq::SolverOptions{});
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
      double a = cpu();
      for (int k = 0; k < steps; ++k) s.step();
      (withDrm ? with : without).push_back((cpu() - a) / steps);
      if (withDrm) {  // the layer's forces alone, at the same times, from a layer that kept nothing
        products = drm->numProducts();
        tq::DomainReduction fresh(mesh, s.blocks(), field, 0.0);
        a = cpu();
        for (int k = 0; k < steps; ++k) fresh.addForces(k * s.dt(), s.dt(), s.state());
        forces.push_back((cpu() - a) / steps);
        ratio.push_back(with.back() / without.back());
      }
    }
  std::printf(
      "tq-solid-bench-drm: %d elements (%d in the DRM layer, %.1f %%), %zu DRM nodes, %d thread(s), samples every "
      "%g steps (%d products in %d steps), CPU time, medians of %d interleaved rounds: %.3f ms a step without, "
      "%.3f ms with the layer; with/without a round %.3f (+%.1f %%; rounds",
      int(mesh.numElems()), int(layer), 100.0 * layer / mesh.numElems(), N, omp_get_max_threads(), stepsPerSample,
      int(products), steps, repeat, 1e3 * median(without), 1e3 * median(with), median(ratio),
      100 * (median(ratio) - 1));
  for (double x : ratio) std::printf(" %+.1f", 100 * (x - 1));
  std::vector<double> share;
  for (size_t r = 0; r < forces.size(); ++r) share.push_back(forces[r] / without[r]);
  std::printf(" %%); the layer's forces alone %.4f ms (%.2f %% of a step without)\n", 1e3 * median(forces),
              100 * median(share));
  return 0;
}
