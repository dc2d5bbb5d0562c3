// tq-solid-bench: time per element-step of elastic hex8 on an n x n x n box (not a test).
//
//   tq-solid-bench [--n 40] [--steps 200] [--repeat 5] [--threads N] [--damping]
//
// Builds the box in memory (one region, base fixed), gives it small random velocities, and
// times `steps` explicit steps `repeat` times; prints the median µs per element-step, the
// figure of merit (element-steps per second) and, per stage, where the time goes.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "tq/solver.hpp"

int main(int argc, char** argv) {
  using namespace tq;
  int n = 40, steps = 200, repeat = 5;
  bool damping = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--n" && i + 1 < argc) n = std::stoi(argv[++i]);
    else if (a == "--steps" && i + 1 < argc) steps = std::stoi(argv[++i]);
    else if (a == "--repeat" && i + 1 < argc) repeat = std::stoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) omp_set_num_threads(std::stoi(argv[++i]));
    else if (a == "--damping") damping = true;
    else {
      std::fprintf(stderr, "usage: tq-solid-bench [--n 40] [--steps 200] [--repeat 5] [--threads N] [--damping]\n");
      return 1;
    }
  }
  const Mesh mesh = makeBoxMesh({n, n, n, 0, 0, 0, 1.0 * n, 1.0 * n, 1.0 * n});
  SolverOptions opt;
  if (damping) opt.damping = RayleighDamping::fromRatio(0.05, 1.0, 20.0);
  auto mat = std::make_shared<ElasticMaterial>(ElasticParams{8e9, 0.27, 2700});
  Solver s(mesh, makeBlocksByRegion(mesh, {{"rock", mat}}), opt);
  s.fixFaceGroup("bottom", "xyz");
  std::mt19937 rng(1);
  std::uniform_real_distribution<Real> U(-1e-3, 1e-3);
  for (Index i = 0; i < mesh.numNodes(); ++i)
    for (int d = 0; d < 3; ++d) s.state().v(i, d) = U(rng);
  for (int i = 0; i < 10; ++i) s.step();  // warm-up (first touch, caches)
  std::vector<double> us;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < steps; ++i) s.step();
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    us.push_back(1e6 * sec / (double(steps) * mesh.numElems()));
  }
  std::sort(us.begin(), us.end());
  const double med = us[us.size() / 2];
  std::printf("tq-solid-bench: %d elements (%d^3 box), %d nodes, elastic hex8 one_point_assumed_strain, "
              "damping %s, %d thread(s)\n",
              mesh.numElems(), n, mesh.numNodes(), damping ? "on (stiffness+mass)" : "off", omp_get_max_threads());
  std::printf("  %d x %d steps: median %.4f us per element-step (min %.4f, max %.4f); "
              "%.3g element-steps/s; energy error %.2e\n",
              repeat, steps, med, us.front(), us.back(), 1.0 / med * 1e6, s.energy().error);
  return 0;
}
