/// @file coupling_results.hpp
/// @brief What the water coupling writes into the results file: its histories (the works, the
///        volume law's pressure, with open ends along the axis and a surge tank's level, the water
///        pressure at the monitors, the wetted face's total force and mean acceleration) and its summary (/coupling
///        attributes). One copy for the run as one process (app.cpp) and the run on ranks (ranked_run.cpp, from rank
///        0's whole-model mirror and the wet nodes' force gathered there).
#pragma once

#include <functional>
#include <vector>

#include "tq/coupling/fluid_coupling.hpp"
#include "tq/io/input.hpp"
#include "tq/io/results.hpp"

namespace tq {

/// The coupling's histories, sampled from `view` (the solver the results are written from) and the
/// adapter `c` (and the carried laws `water`, may be null); all must outlive the writer's sampling.
/// `nodes` and `force`: the whole wetted face's nodes in `view` and the force last added to them
/// (null: c.nodes() and c.force(); on ranks, where `c` holds rank 0's part, the gathered face's).
void addCouplingSeries(ResultsWriter& results, const Solver& view, const SolidInput& in, FluidCoupling& c,
                       const CarriedWater* water, const std::vector<Index>* nodes = nullptr,
                       std::function<const std::vector<Real>&()> force = {});

/// The /coupling attributes: windows, passes, works, energies, the cost split.
void writeCouplingSummary(ResultsWriter& results, const CouplingInput& in, const FluidCoupling& c,
                          const CarriedWater* water);

}  // namespace tq
