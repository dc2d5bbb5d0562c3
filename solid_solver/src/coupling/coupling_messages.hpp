// What the solid adapter of the water coupling says when it stops or warns (fluid_coupling.cpp's
// texts, kept apart from the protocol). Private to src/coupling.
#pragma once

#include <exception>
#include <string>

#include "tq/io/staged_input.hpp"
#include "tq/water/carried_water.hpp"

namespace tq {

/// FluidCoupling::describe(): the scheme, the window of `window` s × `windows`, the interface of
/// `nodes` nodes, the transport, and the laws the solid carries (`water`, may be null).
std::string describeCoupling(const CouplingInput& in, Real window, long long windows, size_t nodes,
                             const CarriedWater* water);
/// The cause-specific advice appended to a coupler error.
std::string couplingFix(const std::exception& e, const CouplingInput& in);
/// The energy guard's stop: the coupling created ec J (ratio of the reference ref) at `where`;
/// waterCarried: the solid carries the water's volume law.
std::string energyCreatedMessage(const CouplingInput& in, Real ec, Real ratio, Real ref, const std::string& where,
                                 bool waterCarried);
/// The energy guard's warning, printed once at a fifth of the limit.
std::string energyWarning(const CouplingInput& in, Real ec, Real ratio, const std::string& where);

}  // namespace tq
