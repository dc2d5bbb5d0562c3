/// @file app.hpp
/// @brief The tq-solid command line, callable from tests: runSolid({"input.h5", "-o", "r.h5"}).
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

namespace tq {

/// What every tq-solid run reads from its command line, on one process or on ranks.
struct RunOptions {
  std::string input, output = "results.h5", checkpointDir;
  bool check = false, resume = false;
  long long resumeSequence = 0;
};

/// Takes args[i] (and the value after it, advancing i) when it is one of RunOptions' arguments
/// (the input file, -o, --check, --threads N, --checkpoint-dir DIR, --resume, --resume-sequence N);
/// false, i unchanged, otherwise.
bool takeRunOption(const std::vector<std::string>& args, size_t& i, RunOptions& o);

/// Exit codes: 0 completed, 1 usage, 2 input error, 3 run stopped (instability), 4 run stopped by
/// the water coupling (fluid lost, silent or refused; the message names the cause and the fix).
int runSolid(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

struct SubcyclingInfo;
class ResultsWriter;
/// The subcycling's levels as a run reports them: a line on `out`, the /subcycling attributes.
void reportSubcycling(const SubcyclingInfo& sc, std::ostream& out, ResultsWriter& writer);

}  // namespace tq
