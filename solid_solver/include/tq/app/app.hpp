/// @file app.hpp
/// @brief The tq-solid command line, callable from tests: runSolid({"input.h5", "-o", "r.h5"}).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace tq {

/// Exit codes: 0 completed, 1 usage, 2 input error, 3 run stopped (instability), 4 run stopped by
/// the water coupling (fluid lost, silent or refused; the message names the cause and the fix).
int runSolid(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace tq
