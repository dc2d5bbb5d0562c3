// Thin RAII helpers over the HDF5 C API, private to tqsolid. Strings are read whether h5py wrote
// them variable-length (its default) or fixed-length; numbers are converted by HDF5 on read.
// Read failures throw InputError; write failures throw OutputError naming the file and the
// system's reason (e.g. "No space left on device").
#pragma once

#include <hdf5.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "tq/core/types.hpp"

namespace tq::h5 {

/// Owns one hid_t and closes it with the right H5*close.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*closer)(hid_t)) : id_(id), close_(closer) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    reset();
    id_ = o.id_;
    close_ = o.close_;
    o.id_ = -1;
    return *this;
  }
  ~Handle() { reset(); }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = -1;
  }
  hid_t get() const { return id_; }
  operator hid_t() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

/// Turn off HDF5's automatic error printing (we report our own messages).
void quiet();

Handle openFile(const std::string& path, bool write = false);  // throws InputError
Handle createFile(const std::string& path);                    // truncates; throws OutputError
Handle openGroup(hid_t loc, const std::string& path);
Handle ensureGroup(hid_t loc, const std::string& path);  // creates missing levels
bool exists(hid_t loc, const std::string& path);         // link path exists
bool hasAttr(hid_t obj, const std::string& name);
std::vector<std::string> attrNames(hid_t obj);
std::vector<std::string> members(hid_t group);

std::string readStringAttr(hid_t obj, const std::string& name);
std::vector<std::string> readStringListAttr(hid_t obj, const std::string& name);
double readDoubleAttr(hid_t obj, const std::string& name);
long long readIntAttr(hid_t obj, const std::string& name);

/// Read a whole dataset; dims receives its shape.
std::vector<double> readDoubles(hid_t loc, const std::string& path, std::vector<hsize_t>* dims = nullptr);
std::vector<Index> readInts(hid_t loc, const std::string& path, std::vector<hsize_t>* dims = nullptr);
std::vector<std::string> readStrings(hid_t loc, const std::string& path);

void writeStringAttr(hid_t obj, const std::string& name, const std::string& value);
void writeStringListAttr(hid_t obj, const std::string& name, const std::vector<std::string>& v);
void writeDoubleAttr(hid_t obj, const std::string& name, double value);
void writeIntAttr(hid_t obj, const std::string& name, long long value);
void writeDoubles(hid_t loc, const std::string& path, const double* data, const std::vector<hsize_t>& dims);
void writeInts(hid_t loc, const std::string& path, const Index* data, const std::vector<hsize_t>& dims);
void writeStrings(hid_t loc, const std::string& path, const std::vector<std::string>& v);

/// The file name of an open object and why the HDF5 call just made failed: the system's reason
/// (strerror of the errno its file driver recorded) or HDF5's innermost message.
std::string writeFailure(hid_t loc);

/// File space that appended rows will take: HDF5 allocates a chunk in the file when it first
/// writes it out (at a flush), so every chunk started since the last flush is still to come.
struct SpaceLedger {
  hsize_t pending = 0;  ///< bytes of the chunks started since the last flush
  hsize_t nextRow = 0;  ///< bytes of the chunks the appenders' next rows start
};

/// Write a whole float64 dataset, creating it or overwriting the existing one of the same shape
/// (values that change during the run, e.g. envelopes).
void replaceDoubles(hid_t loc, const std::string& path, const double* data, const std::vector<hsize_t>& dims);

/// A 2-D dataset [rows, cols] that grows by rows (chunked, unlimited first dimension), float64 or,
/// with float32 = true, stored as float32 (rows are given as doubles; HDF5 rounds them).
class RowAppender {
 public:
  RowAppender() = default;
  RowAppender(hid_t loc, const std::string& path, hsize_t cols, SpaceLedger* ledger = nullptr, hsize_t chunkRows = 256,
              bool float32 = false);
  void append(const double* row);              ///< one row of `cols` values
  void append(const double* rows, hsize_t n);  ///< n rows of `cols` values, row after row
  hsize_t rows() const { return rows_; }
  bool valid() const { return ds_.valid(); }
  /// The dataset's path in its file.
  std::string path() const;
  /// Append the rows of the dataset at the same path in `src` (another results file: a restart
  /// checkpoint's copy), bit for bit.
  void appendFrom(hid_t src);

 private:
  Handle ds_;
  hsize_t cols_ = 0, rows_ = 0, chunkRows_ = 256, valueBytes_ = sizeof(double);
  SpaceLedger* ledger_ = nullptr;
};

/// The even clock of the histories: rows are written at the times k·interval (k = 0, 1, ...),
/// not at the solver's steps. Each solver state that is sampled is observed (observe(t)); the
/// requested times in (t_previous, t] are then due, each written as the linear interpolation
/// between the previous observed state (weight 1 − w) and this one (weight w). An interval of 0
/// (in-memory inputs only; the file's monitor_dt must be > 0) writes one row per observed state,
/// at its own time.
class OutputClock {
 public:
  explicit OutputClock(double interval = 0) : dt_(interval) {}
  /// A state at time t is observed: sets due().
  void observe(double t);
  /// (t_k, w) of the rows this observation completes, in order.
  const std::vector<std::pair<double, double>>& due() const { return due_; }
  /// The next requested time not written yet.
  double next() const { return double(k_) * dt_; }
  /// The clock's state (restart checkpoints: tq/core/state_archive.hpp); `Archive` has io(x).
  template <class Archive>
  void checkpoint(Archive& a) {
    a.io(k_);
    a.io(tObs_);
    a.io(observed_);
  }

 private:
  double dt_;
  long long k_ = 0;
  double tObs_ = 0;
  bool observed_ = false;
  std::vector<std::pair<double, double>> due_;
};

/// A RowAppender whose rows are written on an OutputClock: observe() keeps a state's row, write()
/// appends the row at a due time, interpolated between the previous kept row and the last. The
/// column `timeCol` (if ≥ 0) is written as t_k exactly; the columns flagged in `nearest` (counts)
/// take the value of the nearer of the two states instead.
class ClockedRows {
 public:
  ClockedRows() = default;
  ClockedRows(RowAppender rows, hsize_t cols, int timeCol, std::vector<char> nearest = {})
      : rows_(std::move(rows)), cols_(cols), timeCol_(timeCol), nearest_(std::move(nearest)) {}
  void observe(const double* row);
  void write(double t, double w);
  hsize_t rows() const { return rows_.rows(); }
  /// Whether column `col` is finite in both kept states (the rows due now are interpolated from them).
  bool keptFinite(hsize_t col) const {
    return col < prev_.size() && col < cur_.size() && std::isfinite(prev_[col]) && std::isfinite(cur_[col]);
  }
  RowAppender& appender() { return rows_; }
  /// The two kept states the next rows are interpolated between (restart checkpoints).
  template <class Archive>
  void checkpoint(Archive& a) {
    a.io(prev_);
    a.io(cur_);
  }

 private:
  RowAppender rows_;
  hsize_t cols_ = 0;
  int timeCol_ = -1;
  std::vector<char> nearest_;
  std::vector<double> prev_, cur_, out_;
};

/// Keeps the file space of the next writes allocated on disk before HDF5 makes them, so that a
/// full disk is met here, between complete samples, and never inside HDF5 (a write HDF5 cannot
/// finish leaves the file unreadable). It allocates the file past HDF5's end of allocation (EOA)
/// with posix_fallocate; H5Fflush truncates the file to its EOA, giving that back, so the next
/// reserve() allocates again. A small reserve held beside the file (an unlinked file) is freed by
/// release() for the writes that close the run (status, timings, the last flush).
class SpaceGuard {
 public:
  SpaceGuard() = default;
  /// Throws OutputError when the stop reserve itself does not fit.
  SpaceGuard(hid_t file, const std::string& path, hsize_t stopReserve);
  SpaceGuard(const SpaceGuard&) = delete;
  SpaceGuard& operator=(const SpaceGuard&) = delete;
  ~SpaceGuard();
  /// Make sure [0, EOA + bytes) of the file is allocated. Throws OutputError naming the file, the
  /// reason, the space needed and the space free when the file system has no room.
  void reserve(hsize_t bytes);
  /// To call after every H5Fflush.
  void flushed();
  /// Free the stop reserve; reserve() does nothing from then on.
  void release();
  /// Cut the file (closed by then) back to the EOA of its last flush.
  void trimClosed() const;
  bool active() const { return active_; }

 private:
  hid_t file_ = -1;
  std::string path_;
  int fd_ = -1, reserveFd_ = -1;
  hsize_t allocated_ = 0, lastEoa_ = 0;
  bool active_ = false;
};

/// "1.2 MB", "48 kB", "512 B".
std::string bytesText(unsigned long long bytes);
/// Bytes a non-root user may still write on the file system holding `path` (0 if unknown).
unsigned long long freeBytes(const std::string& path);

}  // namespace tq::h5
