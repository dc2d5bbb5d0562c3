/// @file simd_util.hpp
/// @brief Short vectors of Reals (GCC vector extensions) and their unaligned loads and stores,
///        shared by the element kernel (element_block.cpp) and the node update (solver.cpp):
///        2 lanes (SSE2) for the generic x86-64 path, 4 lanes for the AVX2 path and 8 for the element
///        kernel's AVX-512 path, chosen at run time (ElementBlock::defaultSimd). Internal to the
///        solver's sources; include it after `#pragma GCC diagnostic ignored "-Wpsabi"` (the helpers
///        are always inlined, so the AVX ABI note does not apply).
#pragma once

#include <cstring>

#include "tq/core/types.hpp"

namespace tq {

typedef Real V2 __attribute__((vector_size(16)));
typedef Real V4 __attribute__((vector_size(32)));
typedef Real V8 __attribute__((vector_size(64)));

template <class V>
inline __attribute__((always_inline)) V loadv(const Real* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class V>
inline __attribute__((always_inline)) void storev(Real* p, V v) {
  std::memcpy(p, &v, sizeof v);
}

}  // namespace tq
