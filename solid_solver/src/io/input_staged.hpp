// solid_input.h5 version 2 groups (private to tqsolid; docs/formats.md "## solid_input.h5").
#pragma once

#include <hdf5.h>

#include <string>

#include "tq/io/input.hpp"

namespace tq {

/// Root members and attributes a version 2 file may have besides version 1's.
inline const char* const kStagedRootGroups[] = {"stages", "in_situ", "hydrostatic", "interfaces", "boundaries",
                                                "motion", "coupling"};
/// Material attributes passed through for the Mohr-Coulomb damage model and ignored
/// by the elastic material.
inline const char* const kMohrCoulombAttrs[] = {"model", "cohesion", "friction_angle", "dilation_angle",
                                                "tensile_strength", "damage_constant", "damage_effect"};

/// Read the v2 groups of an open solid_input.h5 into in.staged (and the gravity into
/// in.options). Unknown attributes and members are rejected with their path.
void readStagedInput(hid_t file, SolidInput& in);

/// Write in.staged's groups (tests and tools).
void writeStagedInput(hid_t file, const SolidInput& in);

}  // namespace tq
