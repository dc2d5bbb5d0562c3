// tq-verification-ladder: one run of a solid verification case at given settings, for the
// error-against-wall-time ladders of `tunnelquake bench`. Not a test: it prints the
// case's errors against its closed form and the wall time as one line
//   RESULT {"case": ..., "wall_s": ..., ...}
// which the Python driver parses. The cases are the functions the verification tests use
// (wave_cases.hpp, tunnel_cases.hpp), so the ladder measures exactly what the tests check.
//
//   tq-verification-ladder wave --dir sh|p --n N [--dt-factor f] [--height H]
//   tq-verification-ladder kirsch --n N [--k 0.5] [--outer 80]
//   tq-verification-ladder lined --n N [--through M] [--outer 80] [--p0 5e6]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

#include "tunnel_cases.hpp"
#include "wave_cases.hpp"

namespace {

int usage() {
  std::cerr << "usage: tq-verification-ladder wave --dir sh|p --n N [--dt-factor f] [--height H]\n"
               "       tq-verification-ladder kirsch --n N [--k 0.5] [--outer 80]\n"
               "       tq-verification-ladder lined --n N [--through M] [--outer 80] [--p0 5e6]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string what = argv[1];
  std::string dir = "sh";
  long n = 0, through = 0;
  double dtFactor = 0, height = 100, k = 0.5, outer = 80, p0 = 5e6;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i], val = argv[i + 1];
    if (key == "--dir")
      dir = val;
    else if (key == "--n")
      n = std::atol(val.c_str());
    else if (key == "--dt-factor")
      dtFactor = std::atof(val.c_str());
    else if (key == "--height")
      height = std::atof(val.c_str());
    else if (key == "--k")
      k = std::atof(val.c_str());
    else if (key == "--outer")
      outer = std::atof(val.c_str());
    else if (key == "--through")
      through = std::atol(val.c_str());
    else if (key == "--p0")
      p0 = std::atof(val.c_str());
    else
      return usage();
  }
  if (n <= 0) return usage();
  try {
    if (what == "wave") {
      if (dir != "sh" && dir != "p") return usage();
      if (dtFactor > 0.9) {
        std::cerr << "--dt-factor above the solver's safety 0.9 would be refused\n";
        return 2;
      }
      const auto r = tqcases::waveColumn(dir == "sh" ? 0 : 2, n, dtFactor, height);
      std::printf(
          "RESULT {\"case\": \"wave_column\", \"dir\": \"%s\", \"n\": %ld, \"h\": %.9g, \"dt_factor\": %.6g, "
          "\"dt\": %.9g, \"steps\": %lld, \"peak_error\": %.9g, \"l2_error\": %.9g, \"tail_energy\": %.9g, "
          "\"balance_error\": %.9g, \"wall_s\": %.6f}\n",
          dir.c_str(), n, height / double(n), dtFactor > 0 ? dtFactor : 0.9, r.dt, (long long)r.steps, r.peakErr, r.l2,
          r.tailEnergy, r.balance, r.wallSeconds);
    } else if (what == "kirsch") {
      const auto t0 = std::chrono::steady_clock::now();
      const auto r = tqcases::kirsch(n, 10e6, k, outer);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf(
          "RESULT {\"case\": \"kirsch\", \"n\": %ld, \"k\": %.6g, \"outer\": %.6g, \"elements\": %lld, "
          "\"steps\": %lld, \"sidewall_error\": %.9g, \"crown_error\": %.9g, \"wall_s\": %.6f}\n",
          n, k, outer, (long long)r.elems, (long long)r.steps, r.errSide, r.errCrown, wall);
    } else if (what == "lined") {
      // Lined tunnel under internal water pressure (123 m), the rock prestressed by p0 before the
      // lining goes in; elements through the lining n/4 unless given (the paper's mesh: n = 12, 3).
      if (through <= 0) through = std::max(1L, n / 4);
      const auto t0 = std::chrono::steady_clock::now();
      const auto r = tqcases::linedTunnel(n, through, tqcases::kLinedPi, p0, outer);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const auto ref = tqcases::linedReference(tqcases::kLinedPi);
      std::printf(
          "RESULT {\"case\": \"lined_tunnel\", \"n\": %ld, \"through\": %ld, \"outer\": %.6g, \"p0\": %.6g, "
          "\"pi\": %.9g, \"elements\": %lld, \"steps\": %lld, \"contact_error\": %.9g, "
          "\"contact_tie_error\": %.9g, \"inner_hoop_error\": %.9g, \"outer_hoop_error\": %.9g, "
          "\"wall_s\": %.6f}\n",
          n, through, outer, p0, tqcases::kLinedPi, (long long)r.elems, (long long)r.steps, r.pc / ref.pc - 1,
          r.pcTie / ref.pc - 1, r.hoopIn / ref.hoopIn - 1, r.hoopOut / ref.hoopOut - 1, wall);
    } else {
      return usage();
    }
  } catch (const std::exception& e) {
    std::cerr << "tq-verification-ladder: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
