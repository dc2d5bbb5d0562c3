// Thin RAII helpers over the HDF5 C API, private to tqsolid. Strings are read whether h5py wrote
// them variable-length (its default) or fixed-length; numbers are converted by HDF5 on read.
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

#include "tq/types.hpp"

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
Handle createFile(const std::string& path);                     // truncates
Handle openGroup(hid_t loc, const std::string& path);
Handle ensureGroup(hid_t loc, const std::string& path);          // creates missing levels
bool exists(hid_t loc, const std::string& path);                 // link path exists
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

/// Write a whole float64 dataset, creating it or overwriting the existing one of the same shape
/// (values that change during the run, e.g. envelopes).
void replaceDoubles(hid_t loc, const std::string& path, const double* data, const std::vector<hsize_t>& dims);

/// A 2-D dataset [rows, cols] that grows by rows (chunked, unlimited first dimension), float64 or,
/// with float32 = true, stored as float32 (rows are given as doubles; HDF5 rounds them).
class RowAppender {
public:
  RowAppender() = default;
  RowAppender(hid_t loc, const std::string& path, hsize_t cols, hsize_t chunkRows = 256, bool float32 = false);
  void append(const double* row);  ///< one row of `cols` values
  void append(const double* rows, hsize_t n);  ///< n rows of `cols` values, row after row
  hsize_t rows() const { return rows_; }

private:
  Handle ds_;
  hsize_t cols_ = 0, rows_ = 0;
};

}  // namespace tq::h5
