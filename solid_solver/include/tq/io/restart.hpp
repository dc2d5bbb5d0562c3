#pragma once
/// @file restart.hpp
/// @brief Restart checkpoints of one tq-solid run (docs/formats.md "Restart checkpoints"): every
/// `checkpoint_interval` s of simulated time the run's whole mutable state (tq/core/state_archive.hpp)
/// and a copy of its results file go to a folder, and a manifest naming both is written last, by
/// rename, so a run stopped at any instant leaves the previous complete checkpoint. `tq-solid
/// --resume` builds the run again, restores the last one and goes on; the results end bitwise
/// equal to those of a run that was never stopped.
#include <cstdint>
#include <string>
#include <vector>

#include "tq/core/state_archive.hpp"

namespace tq {

/// What checkpoint.json says (the files it names sit beside it).
struct CheckpointManifest {
  long long sequence = 0;            ///< 1 for the first checkpoint of a run, +1 each
  double time = 0;                   ///< simulated time, s
  long long step = 0;                ///< solid steps taken
  long long samples = 0;             ///< monitor rows in the results copy
  long long window = -1;             ///< coupled with the water: completed coupling windows (-1: not coupled)
  std::string fingerprint;           ///< of the case and the state's layout: a resume of another case is refused
  std::string inputs;                ///< the digest of the input fingerprint the run was given ("" when none)
  std::string solidCrc, resultsCrc;  ///< CRC-32 (8 hex digits) of the two files, verified before a resume
  std::string solid, results;        ///< file names: the state, the results copy
};

class RestartCheckpoints {
 public:
  /// `dir` is created if missing, and locked for this process (flock on DIR/lock, released when
  /// the process ends however it ends): a second tq-solid on the same checkpoints, e.g. a resume
  /// while the solver of a run whose supervisor was killed still runs, is an InputError naming it.
  explicit RestartCheckpoints(std::string dir);
  ~RestartCheckpoints();
  RestartCheckpoints(const RestartCheckpoints&) = delete;
  RestartCheckpoints& operator=(const RestartCheckpoints&) = delete;
  const std::string& dir() const { return dir_; }
  /// Keep the files of the last `n` checkpoints (default 1). A run coupled with the water keeps 2,
  /// each with its own manifest checkpoint-<n>.json beside checkpoint.json: the water writes its
  /// checkpoint of a window after the solid's, so the last window both sides wrote is the solid's
  /// last or the one before.
  void setKeep(int n) { keep_ = n < 1 ? 1 : n; }
  /// A fresh start: remove the checkpoint files an earlier run of this folder left (the water's
  /// fluid-*.bin included).
  void clear() const;
  /// The last complete checkpoint, or with `sequence` > 0 that one (kept by setKeep(2)). False
  /// with `why` set when there is none or it cannot be used: the manifest's own checksum fails, or
  /// a file it names is missing, of another size or of another CRC-32 than the manifest says.
  bool last(CheckpointManifest& m, std::string& why, long long sequence = 0) const;
  /// Write checkpoint `m.sequence` (the state `a` as last saved, and a copy of the flushed results
  /// file `results`), then the manifest, then remove the earlier checkpoint's files. Throws
  /// OutputError when the file system refuses (the previous checkpoint stays the valid one).
  void write(CheckpointManifest m, const StateArchive& a, const std::string& results) const;
  /// Read the state of checkpoint `m` into `a` (throws InputError when it is damaged).
  void read(const CheckpointManifest& m, StateArchive& a) const;
  std::string file(const std::string& name) const { return dir_ + "/" + name; }

 private:
  std::string dir_;
  int lock_ = -1;
  int keep_ = 1;
};

/// The manifest's text as written: its lines, the last `"manifest_crc32": "<8 hex>"`, the CRC-32 of
/// every byte before that line. Returns `why` empty when the text is whole.
std::string manifestProblem(const std::string& text);

/// FNV-1a (64 bit) of bytes, chained: a fingerprint of what a checkpoint belongs to.
std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = 1469598103934665603ULL);
std::string hex64(std::uint64_t h);

/// What a restart checkpoint belongs to: FNV-1a of the bytes of the input and the mesh file (every
/// setting, the motion, the mesh), then of the step and the end time (a build whose parts save other
/// state is caught by the archive's own checks on restore).
std::uint64_t runInputHash(const std::string& inputPath, const std::string& meshPath, double dt, double tEnd);

/// The "digest" of an input fingerprint (a JSON text whose first key is "digest"), or "": a manifest
/// names it, and `tunnelquake run --resume` resumes only a checkpoint of today's inputs.
std::string inputDigest(const std::string& fingerprintJson);

}  // namespace tq
