/// @file mesh.hpp
/// @brief mesh.h5 (docs/formats.md) read into and written from the solid mesh (tq/core/mesh.hpp).
#pragma once

#include <string>

#include "tq/core/mesh.hpp"

namespace tq {

/// Read mesh.h5 (format "tunnelquake-solid-mesh", version 1) with the HDF5 C API and check it.
Mesh readMeshH5(const std::string& path, const MeshRequirements& req = {});

/// Write a mesh in the mesh.h5 layout (used by tests and tools; the Python side writes the real ones).
void writeMeshH5(const Mesh& mesh, const std::string& path);

}  // namespace tq
