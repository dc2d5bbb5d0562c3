/// @file partition.hpp
/// @brief Domain decomposition of the solid for a run on MPI ranks: recursive coordinate bisection
///        (RCB) of the elements' centroids, weighted by each element's cost, and the cost weights.
#pragma once

#include <string>
#include <vector>

#include "tq/core/types.hpp"
#include "tq/io/input.hpp"
#include "tq/io/mesh.hpp"

namespace tq {

/// Relative cost of one element-step of a material model (elastic = 1), from the measured kernel
/// costs (docs/benchmarks.md): a Mohr–Coulomb element that stays elastic costs about 1.0–1.2 times
/// an elastic one and a yielding one 6.7 times; which elements yield is not known before the run,
/// so the weight is a middle value. An unknown model weighs 1.5.
Real materialCostWeight(const std::string& model);

/// Each element's cost weight from its region's material (SolidInput::materials).
std::vector<Real> elementCosts(const Mesh& mesh, const SolidInput& in);

/// Recursive coordinate bisection: the element set is cut across the axis of its centroids' largest
/// extent, at the weighted position that gives the two halves weights in proportion to the number
/// of parts each gets (parts need not be a power of 2), then each half is cut again. Ties in the
/// coordinate are broken by the element index, so the result is a function of the mesh, the weights
/// and `parts` alone. Returns the part (0 .. parts-1) of each element; every part gets at least one
/// element when the mesh has at least `parts` elements. Throws InputError for parts < 1 or more
/// parts than elements.
std::vector<int> partitionRcb(const Mesh& mesh, const std::vector<Real>& weight, int parts);

/// Per part: its summed weight, for the balance report (max / mean).
std::vector<Real> partWeights(const std::vector<int>& part, const std::vector<Real>& weight, int parts);

}  // namespace tq
