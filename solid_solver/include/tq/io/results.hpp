/// @file results.hpp
/// @brief results.h5 writer: monitor histories, energy balance, field snapshots, timings, and the
///        run status. Rows are appended as the run goes and the file is flushed regularly, so it
///        stays readable (h5py) after a stop at any point. The file space of each write is
///        allocated before HDF5 writes, so a full disk stops the run between samples with an
///        OutputError and the file stays whole (h5util.hpp, SpaceGuard).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/core/state_archive.hpp"
#include "tq/io/input.hpp"

namespace tq {

/// Principal stresses in ascending order (σ1 ≤ σ2 ≤ σ3, Pa): with tension positive σ1 is the
/// most compressive, as in the paper.
void principalStresses(const Real s[6], Real p[3]);

class ResultsWriter {
 public:
  ResultsWriter(const std::string& path, const SolidInput& in, const Solver& solver);
  ~ResultsWriter();
  /// Observe the solver's current state for the histories (monitors, energy, series, ring
  /// forces), which are written at the times k·monitor_dt: each requested time in (t_previous, t]
  /// gets a row interpolated linearly between the previous observed state and this one. Call it
  /// at the states on either side of every requested time (nextSampleTime()); between them it
  /// may be skipped.
  void sample(const Solver& solver);
  /// The next requested history time not written yet, s.
  Real nextSampleTime() const;
  /// Write a field snapshot (u, v, stress) at the solver's current time.
  void snapshot(const Solver& solver);
  /// Set the status attribute ("running", "completed", "stopped: ...") and flush.
  void setStatus(const std::string& status);
  void writeTimings(double wallSeconds, long long steps, long long elementSteps, int threads);
  /// One static stage's report: /stages/<k>_<name> attrs steps, unbalanced_ratio, converged, wall_s, note.
  void writeStage(const std::string& name, long long steps, double ratio, bool converged, double wallSeconds,
                  const std::string& note);
  /// Flush to disk; throws OutputError when the file system refuses.
  void flush();
  /// After an OutputError: free the space held back for this, write `status` and flush, so the
  /// file holds every sample written so far. False if even that could not be written.
  bool stopAfterOutputError(const std::string& status);
  /// Time of the last monitor sample written (−1 before the first), and how many were written.
  double lastSampleTime() const;
  long long samples() const;
  /// An extra time series sampled with every sample(): dataset `path` [rows, 2] = (time, value()),
  /// e.g. /energy/fluid_work (the water coupling).
  void addSeries(const std::string& path, std::function<Real()> value, const std::string& unit);
  /// The water pressure on the lining at the monitors (paper Fig. 5), sampled with every sample():
  /// for each monitor, the node of face group `face` nearest to it, its tributary area A (a quarter
  /// of each adjacent quad's area vector, summed; A its length) and unit normal n (its direction,
  /// out of the solid into the water).
  /// Adds /monitors/<name>/water_pressure [T, 2] = (time, −F·n / A) with F = force()[3k..3k+2] the
  /// interface force on that node (`nodes` ascending, as FluidCoupling::nodes()), and the attrs
  /// water_node, water_area, water_nx, water_ny, water_nz on /monitors/<name>. The water coupling transfers the
  /// hydrodynamic force only (the hydrostatic part is a static load), so this is the hydrodynamic pressure.
  void addWaterPressure(const Mesh& mesh, const std::string& face, const std::vector<MonitorInput>& monitors,
                        const std::vector<Index>& nodes, std::function<const std::vector<Real>&()> force);
  /// Attributes on a group (created if missing), e.g. the coupling's summary.
  void writeAttrs(const std::string& group, const std::map<std::string, double>& numbers,
                  const std::map<std::string, std::string>& texts = {});

  /// The file's path.
  const std::string& path() const;
  /// What a restart needs beyond the rows in the file: the sample and snapshot counts and the
  /// lining envelopes (saved and restored alike, tq/core/state_archive.hpp). Call flush() before a save.
  void checkpoint(StateArchive& archive);
  /// After a restore by checkpoint(): append the rows and copy the snapshots of `copy` (the
  /// results file as the checkpoint saved it) into this freshly started file.
  void resumeFrom(const std::string& copy, const Solver& solver);

 private:
  /// Hold `bytes` of file space (plus what pending rows and metadata need) before writing them:
  /// a full disk throws OutputError here, before HDF5 starts a write it could not finish.
  void reserve(unsigned long long bytes);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tq
