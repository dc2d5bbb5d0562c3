/// @file input.hpp
/// @brief solid_input.h5: the run parameters tq-solid reads (written by the Python side; layout in
///        docs/formats.md, "## solid_input.h5"). Read and checked apart from the time loop.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/io/staged_input.hpp"
#include "tq/materials/material.hpp"

namespace tq {

/// A load on the nodes of a face group or node set.
struct LoadInput {
  std::string name;
  std::string target;  ///< face group or node set name
  int direction = 0;   ///< 0 x, 1 y, 2 z
  Real force = 0;      ///< total force (N): by tributary area on a face group, equally on a node set
  TimeFunction function = TimeFunction::constant(1.0);
};

/// A named monitor point; the nearest node and the element whose centroid is nearest.
struct MonitorInput {
  std::string name;
  Real point[3] = {0, 0, 0};
};

/// Everything in solid_input.h5.
struct SolidInput {
  std::string path;      ///< the input file itself
  std::string meshPath;  ///< resolved mesh.h5 path
  SolverOptions options;
  Hex8Formulation formulation = Hex8Formulation::OnePointAssumedStrain;
  Real tEnd = 0;  ///< end time (s)
  /// Region -> its material as read (model and parameters by name, those of no model included), in
  /// the file's order; buildSolver makes each from its model's factory (tq/materials/registry.hpp).
  std::vector<std::pair<std::string, MaterialValues>> materials;
  std::map<std::string, std::string> fixed;  ///< face group -> directions ("xyz", "z", ...)
  std::vector<LoadInput> loads;
  std::vector<MonitorInput> monitors;
  Real monitorDt = 0.005;           ///< monitor and energy sampling interval (s)
  bool ringForces = true;           ///< lining section forces and diameter changes at every sample (tq/ring_forces.hpp)
  std::vector<Real> snapshotTimes;  ///< field snapshot times (s)
  Real progressSeconds = 5;         ///< wall time between progress lines (s)
  /// simulated time between restart checkpoints (s; 0 = none), written when tq-solid is given
  /// --checkpoint-dir (tq/restart.hpp)
  Real checkpointInterval = 0;
  std::vector<std::string> requiredFaces;  ///< face groups the run needs (checked on the mesh)
  StagedInput staged;                      ///< stages, in-situ stress, boundaries, motion (tq/staged_input.hpp)
};

/// Read and validate solid_input.h5 against its table (solid_solver/src/input_schema.inc, generated
/// from scripts/tunnelquake/solver_input_schema.py). Unknown groups and attributes are rejected with
/// their path and the allowed names.
SolidInput readSolidInput(const std::string& path);

/// What was read, as JSON: the path, the table's hash, each region's model and parameters
/// (`tq-solid --print-input`).
std::string inputJson(const SolidInput& in);

/// A load's share of its total force per node (sums to 1): by tributary area on a face group, equal
/// on a node set. Throws InputError when the target is neither.
std::map<Index, Real> loadShares(const SolidInput& in, const Mesh& mesh, const LoadInput& load);
/// Build the solver (blocks per region, supports, loads) for an input and its mesh.
std::unique_ptr<Solver> buildSolver(const SolidInput& in, const Mesh& mesh);
/// The input's mesh (readMeshH5 with the faces it requires); when the input subcycles, with the
/// estimate of its nodes' levels that the element blocks' order follows (setOrderLevels from its
/// regions' p-wave speeds: the chunks' elements then share a level).
Mesh readInputMesh(const SolidInput& in);

}  // namespace tq
