/// @file types.hpp
/// @brief Scalar and index types of the solid solver, and its error types.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace tq {

/// Floating-point type of every physical quantity (SI units throughout).
using Real = double;
/// Index type of nodes, elements and degrees of freedom (meshes up to 2^31 entities).
using Index = std::int32_t;

/// Where component d (0 x, 1 y, 2 z) of node n stands in a nodal array of 3N values, node-major (x, y,
/// z of node n at 3n, 3n+1, 3n+2): the layout of NodalState's vectors, the mesh's coordinates and
/// every [3N] force or flag array.
constexpr std::size_t dofIndex(std::size_t n, std::size_t d) { return 3 * n + d; }

/// Bad user input (mesh, parameters, options). The message says what is wrong, the offending
/// value, where it came from and how to fix it.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

/// A run that went unstable: a non-finite or exploding value was detected. The message names
/// the step, the time, the quantity, the node or element and the likely cause.
class InstabilityError : public std::runtime_error {
 public:
  explicit InstabilityError(const std::string& what) : std::runtime_error(what) {}
};

/// Results that cannot be written: the file system refused a write (full, over quota, read-only,
/// an I/O error). The message names the file and the system's reason; for a full disk also the
/// space the next write needed and the space left.
class OutputError : public std::runtime_error {
 public:
  explicit OutputError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace tq
