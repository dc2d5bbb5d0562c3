// tq-solid-bench: time per element-step of elastic hex8 on an n x n x n box (not a test).
//
//   tq-solid-bench [--n 40] [--steps 200] [--repeat 5] [--threads N [--against M]] [--damping] [--generic | --avx2]
//                  [--column P --dt DT [--write-ccx deck.inp]]
//
// Default case: builds the box in memory (one region, base fixed), gives it small random
// velocities, and times `steps` explicit steps `repeat` times; prints the median µs per
// element-step and the figure of merit (element-steps per second).
// --column P: the CalculiX side-by-side case (tests/verification/solid_benchmark/
// calculix_compare.py): the same box at rest, base on rollers (u_z = 0), sides on rollers
// (u_x = 0 on x faces, u_y = 0 on y faces), a step pressure P (Pa) on the top as nodal forces
// P A/4 per quad corner, fixed step DT; every repeat starts from rest, and the top centre node's
// u_z after `steps` steps is printed. --write-ccx writes the same problem as a CalculiX deck
// (*DYNAMIC, EXPLICIT, DIRECT; C3D8R; same nodes, elements, loads and step).
// --generic: the generic x86-64 kernel instead of the widest one (same as TQ_SOLID_SIMD=generic);
// --avx2: the AVX2 kernel where the CPU also has AVX-512 (same as TQ_SOLID_SIMD=avx2).
// The default case also prints the busiest thread's CPU time per element-step (CLOCK_THREAD_CPUTIME_ID
// of each thread of the team, the largest): about the time the steps take with every thread on a
// core of its own, which a machine shared with other work does not change as it changes the wall time
// (check's thread speed-up, scripts/tunnelquake/rates.py).
// --against M: each of the `repeat` timings is a pair, `steps` steps on M threads and `steps` on N
// (in turn M N, N M, ...), and the median of the pairs' ratios of the busiest thread's CPU is printed:
// the speed-up of N threads over M. The two halves of a pair run a tenth of a second apart in one
// process, so a machine whose speed drifts over seconds (a shared VM: 0.08 to 0.12 us per
// element-step within a minute) moves both alike, where two processes run in turn would not.
#include <omp.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "bench_options.hpp"
#include "tq/core/solver.hpp"

namespace {

// Each thread of the OpenMP team's CPU seconds so far, by thread number.
std::vector<double> teamCpuSeconds() {
  std::vector<double> t(size_t(omp_get_max_threads()), 0.0);
#pragma omp parallel
  {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    t[size_t(omp_get_thread_num())] = double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
  }
  return t;
}

// The CalculiX deck of the column case: node k of the mesh is node k + 1, element e is e + 1.
void writeCcxDeck(const tq::Mesh& mesh, const std::vector<std::pair<tq::Index, double>>& topForces,
                  const tq::ElasticParams& mat, double dt, int steps, tq::Index monitor, const std::string& path) {
  std::ofstream f(path);
  f.precision(17);
  f << "** tq-solid-bench --column: elastic box, rollers on base and sides, step load on top\n*NODE, NSET=NALL\n";
  for (tq::Index n = 0; n < mesh.numNodes(); ++n)
    f << n + 1 << ", " << mesh.coords[3 * n] << ", " << mesh.coords[3 * n + 1] << ", " << mesh.coords[3 * n + 2]
      << "\n";
  f << "*ELEMENT, TYPE=C3D8R, ELSET=EALL\n";
  for (tq::Index e = 0; e < mesh.numElems(); ++e) {
    f << e + 1;
    for (int k = 0; k < 8; ++k) f << ", " << mesh.connectivity[8 * size_t(e) + k] + 1;
    f << "\n";
  }
  auto nset = [&](const char* name, const std::vector<tq::Index>& nodes) {
    f << "*NSET, NSET=" << name << "\n";
    for (size_t i = 0; i < nodes.size(); ++i)
      f << nodes[i] + 1 << ((i % 8 == 7 || i + 1 == nodes.size()) ? "\n" : ", ");
  };
  nset("NBOT", mesh.faceNodes("bottom"));
  std::vector<tq::Index> xs = mesh.faceNodes("xmin"), ys = mesh.faceNodes("ymin");
  for (tq::Index n : mesh.faceNodes("xmax")) xs.push_back(n);
  for (tq::Index n : mesh.faceNodes("ymax")) ys.push_back(n);
  nset("NXS", xs);
  nset("NYS", ys);
  nset("NMON", {monitor});
  f << "*MATERIAL, NAME=ROCK\n*ELASTIC\n"
    << mat.youngsModulus << ", " << mat.poissonRatio << "\n*DENSITY\n"
    << mat.density << "\n*SOLID SECTION, ELSET=EALL, MATERIAL=ROCK\n";
  f << "*BOUNDARY\nNBOT, 3, 3\nNXS, 1, 1\nNYS, 2, 2\n";
  f << "*AMPLITUDE, NAME=STEPLOAD\n0., 1., 1.e6, 1.\n";
  // initial, period, minimum, maximum increment: the fixed step (CalculiX takes the maximum when
  // its own Courant estimate is larger)
  f << "*STEP, INC=" << steps + 10 << "\n*DYNAMIC, EXPLICIT, DIRECT\n"
    << dt << ", " << dt * steps << ", " << dt << ", " << dt << "\n";
  f << "*CLOAD, AMPLITUDE=STEPLOAD\n";
  for (const auto& [n, F] : topForces) f << n + 1 << ", 3, " << F << "\n";
  f << "*NODE PRINT, NSET=NMON, FREQUENCY=" << steps << "\nU\n*END STEP\n";
}

// One line naming the processor, so that figures from different machines are not compared as if
// they came from one: the model name, family and model (the model name alone is often just
// "AMD EPYC" on a VM), the cores this process may use and the widest vector extension.
std::string machineLine() {
  std::ifstream f("/proc/cpuinfo");
  std::string line, name = "unknown processor", family = "?", model = "?", flags;
  auto value = [](const std::string& l) {
    const auto c = l.find(':');
    return c == std::string::npos ? std::string() : l.substr(c + 1 + (c + 1 < l.size() && l[c + 1] == ' '));
  };
  while (std::getline(f, line)) {
    if (line.rfind("model name", 0) == 0)
      name = value(line);
    else if (line.rfind("cpu family", 0) == 0)
      family = value(line);
    else if (line.rfind("model\t", 0) == 0 || line.rfind("model ", 0) == 0)
      model = value(line);
    else if (line.rfind("flags", 0) == 0)
      flags = " " + value(line) + " ";
    if (line.empty() && !flags.empty()) break;  // the first processor is enough
  }
  const char* vec = flags.find(" avx512f ") != std::string::npos ? "AVX-512"
                    : flags.find(" avx2 ") != std::string::npos  ? "AVX2"
                                                                 : "SSE";
  return name + " (family " + family + ", model " + model + "), " + std::to_string(omp_get_num_procs()) + " core(s), " +
         vec;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace tq;
  bench::SizeOptions size{40, 200, 5};
  bool damping = false, generic = false, avx2 = false;
  int against = 0;
  double columnP = 0, fixedDt = 0;
  std::string ccxDeck;
  for (int i = 1; i < argc; ++i) {
    if (bench::readSizeOption(argc, argv, i, size)) continue;
    const std::string a = argv[i];
    if (a == "--damping")
      damping = true;
    else if (a == "--generic")
      generic = true;
    else if (a == "--avx2")
      avx2 = true;
    else if (a == "--against" && i + 1 < argc)
      against = std::stoi(argv[++i]);
    else if (a == "--column" && i + 1 < argc)
      columnP = std::stod(argv[++i]);
    else if (a == "--dt" && i + 1 < argc)
      fixedDt = std::stod(argv[++i]);
    else if (a == "--write-ccx" && i + 1 < argc)
      ccxDeck = argv[++i];
    else {
      std::fprintf(stderr,
                   "usage: tq-solid-bench [--n 40] [--steps 200] [--repeat 5] [--threads N [--against M]] "
                   "[--damping] [--generic | --avx2] [--column P --dt DT [--write-ccx deck.inp]]\n");
      return 1;
    }
  }
  const int n = size.n, steps = size.steps, repeat = size.repeat;
  if (columnP > 0 && !(fixedDt > 0)) {
    std::fprintf(stderr, "tq-solid-bench: --column needs --dt (the fixed step shared with CalculiX)\n");
    return 1;
  }
  if (generic || avx2) setenv("TQ_SOLID_SIMD", generic ? "generic" : "avx2", 1);
  const Mesh mesh = makeBoxMesh({n, n, n, 0, 0, 0, 1.0 * n, 1.0 * n, 1.0 * n});
  SolverOptions opt;
  if (damping) opt.damping = RayleighDamping::fromRatio(0.05, 1.0, 20.0);
  const ElasticParams matParams{8e9, 0.27, 2700};
  auto mat = std::make_shared<ElasticMaterial>(matParams);
  if (columnP > 0) {
    opt.dt = fixedDt;
    // Nodal forces of the uniform pressure: P A / 4 per corner of each top quad.
    std::vector<Real> fz(size_t(mesh.numNodes()), 0.0);
    const auto& quads = mesh.faces.at("top");
    for (size_t q = 0; q < quads.size() / 4; ++q) {
      const Real* x0 = &mesh.coords[3 * size_t(quads[4 * q])];
      const Real* x2 = &mesh.coords[3 * size_t(quads[4 * q + 2])];
      const Real area = std::abs((x2[0] - x0[0]) * (x2[1] - x0[1]));  // axis-parallel squares
      for (int k = 0; k < 4; ++k) fz[size_t(quads[4 * q + k])] -= columnP * area / 4;
    }
    std::vector<std::pair<Index, double>> topForces;
    for (Index i = 0; i < mesh.numNodes(); ++i)
      if (fz[size_t(i)] != 0) topForces.emplace_back(i, fz[size_t(i)]);
    const Index monitor = (n / 2) + (n + 1) * ((n / 2) + (n + 1) * n);  // top centre
    if (!ccxDeck.empty()) writeCcxDeck(mesh, topForces, matParams, fixedDt, steps, monitor, ccxDeck);
    std::vector<double> us;
    double uz = 0;
    Index elems = 0;
    for (int r = 0; r < repeat; ++r) {
      Solver s(mesh, makeBlocksByRegion(mesh, {{"rock", mat}}), opt);
      s.fixFaceGroup("bottom", "z");
      s.fixFaceGroup("xmin", "x");
      s.fixFaceGroup("xmax", "x");
      s.fixFaceGroup("ymin", "y");
      s.fixFaceGroup("ymax", "y");
      for (const auto& [node, F] : topForces) s.addLoad({{node}, 2, F, TimeFunction::constant(1.0)});
      const auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < steps; ++i) s.step();
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      us.push_back(1e6 * sec / (double(steps) * mesh.numElems()));
      uz = s.relativeDisplacement(monitor, 2);
      elems = mesh.numElems();
    }
    std::sort(us.begin(), us.end());
    std::printf("tq-solid-bench: machine: %s\n", machineLine().c_str());
    std::printf(
        "tq-solid-bench --column: %d elements, %d steps of dt %.6g s, pressure %.6g Pa, %d thread(s), %s kernel\n",
        elems, steps, fixedDt, columnP, omp_get_max_threads(), generic ? "generic" : "default");
    std::printf("  median %.4f us per element-step (min %.4f, max %.4f) over %d runs\n", us[us.size() / 2], us.front(),
                us.back(), repeat);
    std::printf("  top centre node %d: u_z = %.12e m\n", monitor + 1, uz);
    return 0;
  }
  Solver s(mesh, makeBlocksByRegion(mesh, {{"rock", mat}}), opt);
  s.fixFaceGroup("bottom", "xyz");
  std::mt19937 rng(1);
  std::uniform_real_distribution<Real> U(-1e-3, 1e-3);
  for (Index i = 0; i < mesh.numNodes(); ++i)
    for (int d = 0; d < 3; ++d) s.state().v(i, d) = U(rng);
  const int threads = omp_get_max_threads();
  // `steps` steps on `team` threads: the wall and the busiest thread's CPU, us per element-step
  auto timedSteps = [&](int team) {
    omp_set_num_threads(team);
    const std::vector<double> c0 = teamCpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < steps; ++i) s.step();
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::vector<double> c1 = teamCpuSeconds();
    double busiest = 0;
    for (size_t k = 0; k < c0.size() && k < c1.size(); ++k) busiest = std::max(busiest, c1[k] - c0[k]);
    const double perElemStep = 1e6 / (double(steps) * mesh.numElems());
    return std::pair<double, double>{sec * perElemStep, busiest * perElemStep};
  };
  for (int team : {against, threads}) {
    if (team <= 0) continue;
    omp_set_num_threads(team);
    for (int i = 0; i < 10; ++i) s.step();  // warm-up (first touch, caches, the team's threads)
  }
  std::vector<double> us, cpuUs, pairRatio;
  for (int r = 0; r < repeat; ++r) {
    double other = 0;
    if (against > 0 && r % 2 == 0) other = timedSteps(against).second;
    const auto [wall, cpu] = timedSteps(threads);
    if (against > 0 && r % 2 == 1) other = timedSteps(against).second;
    us.push_back(wall);
    cpuUs.push_back(cpu);
    if (against > 0) pairRatio.push_back(other / cpu);
  }
  omp_set_num_threads(threads);
  std::sort(us.begin(), us.end());
  std::sort(cpuUs.begin(), cpuUs.end());
  const double med = us[us.size() / 2];
  std::printf("tq-solid-bench: machine: %s\n", machineLine().c_str());
  std::printf(
      "tq-solid-bench: %d elements (%d^3 box), %d nodes, elastic hex8 one_point_assumed_strain, "
      "damping %s, %d thread(s), %s kernel\n",
      mesh.numElems(), n, mesh.numNodes(), damping ? "on (stiffness+mass)" : "off", omp_get_max_threads(),
      ElementBlock::simdName(s.blocks()[0]->simd()));
  std::printf(
      "  %d x %d steps: median %.4f us per element-step (min %.4f, max %.4f); "
      "%.3g element-steps/s; energy error %.2e\n",
      repeat, steps, med, us.front(), us.back(), 1.0 / med * 1e6, s.energy().error);
  std::printf("  busiest thread's CPU: median %.4f us per element-step (min %.4f, max %.4f)\n", cpuUs[cpuUs.size() / 2],
              cpuUs.front(), cpuUs.back());
  if (!pairRatio.empty()) {
    std::sort(pairRatio.begin(), pairRatio.end());
    std::printf(
        "  speed-up of %d thread(s) over %d, busiest thread's CPU: median %.4f of %d pairs (min %.4f, max %.4f)\n",
        threads, against, pairRatio[pairRatio.size() / 2], int(pairRatio.size()), pairRatio.front(), pairRatio.back());
  }
  return 0;
}
