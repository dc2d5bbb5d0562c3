/// @file drm_field.hpp
/// @brief The free field at a domain-reduction layer's nodes (plain data: read from
///        solid_input.h5 /drm, used by tq/boundaries/drm.hpp).
#pragma once

#include <cstdint>
#include <vector>

#include "tq/core/types.hpp"

namespace tq {

/// The free field at the DRM layer's nodes, sampled at increasing times.
struct DrmFreeField {
  std::vector<Index> nodes;            ///< [N] mesh node indices (b and e)
  std::vector<std::uint8_t> internal;  ///< [N] 1 for an inner node (b), 0 for an outer one (e)
  std::vector<Real> time;              ///< [T] strictly increasing (s)
  std::vector<Real> u, v, a;           ///< [T][N][3] displacement (m), velocity (m/s), acceleration (m/s²)
  bool present() const { return !nodes.empty(); }
};

/// Throws InputError naming the problem (sizes, times, node indices, flags) if the field is unusable.
void checkDrmFreeField(const DrmFreeField& field, Index numNodes);

}  // namespace tq
