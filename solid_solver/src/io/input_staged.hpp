// solid_input.h5's staged groups (private to tqsolid; docs/formats.md "## solid_input.h5").
#pragma once

#include <hdf5.h>

#include <string>

#include "tq/io/input.hpp"

namespace tq {

/// Read the staged groups of an open solid_input.h5 into in.staged (and the gravity into
/// in.options): /stages, and what the stages use. Without /stages (and without the groups that
/// need it) in.staged stays absent: one dynamic stage from rest. Unknown attributes and members
/// are rejected with their path.
void readStagedInput(hid_t file, SolidInput& in);

}  // namespace tq
