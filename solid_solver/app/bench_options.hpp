// The options every solid benchmark reads: its size and repetitions, and the threads.
#pragma once

#include <omp.h>

#include <string>

namespace tq::bench {

/// The box's elements along each edge, the steps timed, the runs repeated.
struct SizeOptions {
  int n = 0, steps = 0, repeat = 0;
};

/// Reads argv[i] with its value when it is --n, --steps, --repeat or --threads (which sets the
/// OpenMP threads), leaving i at the value; false for any other argument or one without a value.
inline bool readSizeOption(int argc, char** argv, int& i, SizeOptions& o) {
  const std::string a = argv[i];
  if (i + 1 >= argc) return false;
  if (a == "--n")
    o.n = std::stoi(argv[++i]);
  else if (a == "--steps")
    o.steps = std::stoi(argv[++i]);
  else if (a == "--repeat")
    o.repeat = std::stoi(argv[++i]);
  else if (a == "--threads")
    omp_set_num_threads(std::stoi(argv[++i]));
  else
    return false;
  return true;
}

}  // namespace tq::bench
