#include "h5util.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

namespace tq::h5 {

void quiet() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

static void check(bool ok, const std::string& what) {
  if (!ok) throw InputError("HDF5: " + what);
}

namespace {
struct StackText {
  int errnum = 0;
  std::string innermost;
};
// HDF5's file drivers put "errno = N, error message = '...'" into the description of the error
// they push; the innermost record comes first walking downward.
herr_t readStack(unsigned n, const H5E_error2_t* e, void* data) {
  auto* out = static_cast<StackText*>(data);
  if (!e->desc) return 0;
  if (n == 0) out->innermost = e->desc;
  if (out->errnum == 0)
    if (const char* p = std::strstr(e->desc, "errno = ")) out->errnum = std::atoi(p + 8);
  return 0;
}
}  // namespace

std::string writeFailure(hid_t loc) {
  StackText st;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, readStack, &st);  // before any call that clears it
  const int saved = errno;
  std::string file = "?";
  if (loc >= 0) {
    const ssize_t n = H5Fget_name(loc, nullptr, 0);
    if (n > 0) {
      std::string buf(size_t(n) + 1, '\0');
      H5Fget_name(loc, buf.data(), buf.size());
      file = buf.c_str();
    }
  }
  std::string why = st.errnum               ? std::strerror(st.errnum)
                    : !st.innermost.empty() ? st.innermost
                    : saved                 ? std::strerror(saved)
                                            : "HDF5 reported a write error";
  return "'" + file + "': " + why;
}

static void checkWrite(bool ok, hid_t loc, const std::string& what) {
  if (!ok) {
    const std::string where = writeFailure(loc);
    throw OutputError("cannot write " + what + " to " + where);
  }
}

Handle openFile(const std::string& path, bool write) {
  quiet();
  hid_t f = H5Fopen(path.c_str(), write ? H5F_ACC_RDWR : H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw InputError("cannot open HDF5 file '" + path + "' (missing, unreadable or not HDF5)");
  return Handle(f, H5Fclose);
}

Handle createFile(const std::string& path) {
  quiet();
  errno = 0;
  hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) {
    StackText st;
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, readStack, &st);
    const int e = st.errnum ? st.errnum : errno;
    throw OutputError("cannot create HDF5 file '" + path + "'" + (e ? std::string(": ") + std::strerror(e) : "") +
                      " (check the folder exists and is writable)");
  }
  return Handle(f, H5Fclose);
}

bool exists(hid_t loc, const std::string& path) {
  // Walk the path level by level: H5Lexists fails on a missing intermediate group.
  std::string cur;
  size_t pos = 0;
  while (pos <= path.size()) {
    size_t next = path.find('/', pos);
    if (next == std::string::npos) next = path.size();
    std::string part = path.substr(pos, next - pos);
    if (!part.empty()) {
      cur += (cur.empty() && path[0] != '/' ? "" : "/") + part;
      if (H5Lexists(loc, cur.c_str(), H5P_DEFAULT) <= 0) return false;
    }
    pos = next + 1;
  }
  return true;
}

Handle openGroup(hid_t loc, const std::string& path) {
  hid_t g = H5Gopen2(loc, path.c_str(), H5P_DEFAULT);
  check(g >= 0, "cannot open group '" + path + "'");
  return Handle(g, H5Gclose);
}

Handle ensureGroup(hid_t loc, const std::string& path) {
  std::string cur;
  size_t pos = 0;
  while (pos < path.size()) {
    size_t next = path.find('/', pos);
    if (next == std::string::npos) next = path.size();
    std::string part = path.substr(pos, next - pos);
    if (!part.empty()) {
      cur += "/" + part;
      if (H5Lexists(loc, cur.c_str(), H5P_DEFAULT) <= 0) {
        hid_t g = H5Gcreate2(loc, cur.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
        checkWrite(g >= 0, loc, "group '" + cur + "'");
        H5Gclose(g);
      }
    }
    pos = next + 1;
  }
  return openGroup(loc, path.empty() ? "/" : path);
}

bool hasAttr(hid_t obj, const std::string& name) { return H5Aexists(obj, name.c_str()) > 0; }

static herr_t collectName(hid_t, const char* name, const H5A_info_t*, void* data) {
  static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}
std::vector<std::string> attrNames(hid_t obj) {
  std::vector<std::string> out;
  H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectName, &out);
  return out;
}

static herr_t collectLink(hid_t, const char* name, const H5L_info_t*, void* data) {
  static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}
std::vector<std::string> members(hid_t group) {
  std::vector<std::string> out;
  H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectLink, &out);
  return out;
}

static std::vector<std::string> readStringsFrom(hid_t obj, bool isAttr, const std::string& what) {
  Handle type(isAttr ? H5Aget_type(obj) : H5Dget_type(obj), H5Tclose);
  Handle space(isAttr ? H5Aget_space(obj) : H5Dget_space(obj), H5Sclose);
  check(type.valid() && space.valid(), "cannot inspect " + what);
  if (H5Tget_class(type) != H5T_STRING) throw InputError(what + " must be a string");
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  std::vector<std::string> out;
  if (H5Tis_variable_str(type) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem, H5T_VARIABLE);
    H5Tset_cset(mem, H5Tget_cset(type));
    std::vector<char*> buf(static_cast<size_t>(n), nullptr);
    herr_t st = isAttr ? H5Aread(obj, mem, buf.data()) : H5Dread(obj, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
    check(st >= 0, "cannot read " + what);
    for (auto* p : buf) out.emplace_back(p ? p : "");
    H5Dvlen_reclaim(mem, space, H5P_DEFAULT, buf.data());
  } else {
    const size_t len = H5Tget_size(type);
    std::vector<char> buf(len * static_cast<size_t>(n) + 1, 0);
    herr_t st = isAttr ? H5Aread(obj, type, buf.data()) : H5Dread(obj, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
    check(st >= 0, "cannot read " + what);
    for (hssize_t i = 0; i < n; ++i) {
      std::string s(buf.data() + i * len, len);
      s = s.substr(0, std::strlen(s.c_str()));
      out.push_back(s);
    }
  }
  return out;
}

std::string readStringAttr(hid_t obj, const std::string& name) {
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError("attribute '" + name + "' is missing");
  auto v = readStringsFrom(a, true, "attribute '" + name + "'");
  return v.empty() ? std::string() : v[0];
}

std::vector<std::string> readStringListAttr(hid_t obj, const std::string& name) {
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError("attribute '" + name + "' is missing");
  return readStringsFrom(a, true, "attribute '" + name + "'");
}

double readDoubleAttr(hid_t obj, const std::string& name) {
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError("attribute '" + name + "' is missing");
  Handle type(H5Aget_type(a), H5Tclose);
  const auto cls = H5Tget_class(type);
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) throw InputError("attribute '" + name + "' must be a number");
  double v = 0;
  check(H5Aread(a, H5T_NATIVE_DOUBLE, &v) >= 0, "cannot read attribute '" + name + "'");
  return v;
}

long long readIntAttr(hid_t obj, const std::string& name) {
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError("attribute '" + name + "' is missing");
  Handle type(H5Aget_type(a), H5Tclose);
  if (H5Tget_class(type) != H5T_INTEGER) throw InputError("attribute '" + name + "' must be an integer");
  long long v = 0;
  check(H5Aread(a, H5T_NATIVE_LLONG, &v) >= 0, "cannot read attribute '" + name + "'");
  return v;
}

template <class T>
static std::vector<T> readNumeric(hid_t loc, const std::string& path, hid_t memType, std::vector<hsize_t>* dims) {
  Handle ds(H5Dopen2(loc, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError("dataset '" + path + "' is missing");
  Handle space(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> d(static_cast<size_t>(std::max(rank, 0)));
  H5Sget_simple_extent_dims(space, d.data(), nullptr);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  std::vector<T> out(static_cast<size_t>(n));
  if (n > 0)
    check(H5Dread(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) >= 0,
          "cannot read dataset '" + path + "' as numbers");
  if (dims) *dims = d;
  return out;
}

std::vector<double> readDoubles(hid_t loc, const std::string& path, std::vector<hsize_t>* dims) {
  return readNumeric<double>(loc, path, H5T_NATIVE_DOUBLE, dims);
}
std::vector<Index> readInts(hid_t loc, const std::string& path, std::vector<hsize_t>* dims) {
  return readNumeric<Index>(loc, path, H5T_NATIVE_INT32, dims);
}
std::vector<std::string> readStrings(hid_t loc, const std::string& path) {
  Handle ds(H5Dopen2(loc, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError("dataset '" + path + "' is missing");
  return readStringsFrom(ds, false, "dataset '" + path + "'");
}

static Handle vlenStringType() {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t, H5T_VARIABLE);
  H5Tset_cset(t, H5T_CSET_UTF8);
  return t;
}

static void replaceAttr(hid_t obj, const std::string& name) {
  if (H5Aexists(obj, name.c_str()) > 0) checkWrite(H5Adelete(obj, name.c_str()) >= 0, obj, "attribute '" + name + "'");
}

void writeStringAttr(hid_t obj, const std::string& name, const std::string& value) {
  replaceAttr(obj, name);
  Handle t = vlenStringType();
  Handle sp(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(obj, name.c_str(), t, sp, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  const char* p = value.c_str();
  checkWrite(a.valid() && H5Awrite(a, t, &p) >= 0, obj, "attribute '" + name + "'");
}

void writeStringListAttr(hid_t obj, const std::string& name, const std::vector<std::string>& v) {
  replaceAttr(obj, name);
  Handle t = vlenStringType();
  hsize_t n = v.size();
  Handle sp(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle a(H5Acreate2(obj, name.c_str(), t, sp, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  std::vector<const char*> p;
  for (auto& s : v) p.push_back(s.c_str());
  checkWrite(a.valid() && H5Awrite(a, t, p.data()) >= 0, obj, "attribute '" + name + "'");
}

void writeDoubleAttr(hid_t obj, const std::string& name, double value) {
  replaceAttr(obj, name);
  Handle sp(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(obj, name.c_str(), H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  checkWrite(a.valid() && H5Awrite(a, H5T_NATIVE_DOUBLE, &value) >= 0, obj, "attribute '" + name + "'");
}

void writeIntAttr(hid_t obj, const std::string& name, long long value) {
  replaceAttr(obj, name);
  Handle sp(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(obj, name.c_str(), H5T_STD_I64LE, sp, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  checkWrite(a.valid() && H5Awrite(a, H5T_NATIVE_LLONG, &value) >= 0, obj, "attribute '" + name + "'");
}

static void writeNumeric(hid_t loc, const std::string& path, const void* data, const std::vector<hsize_t>& dims,
                         hid_t fileType, hid_t memType) {
  Handle sp(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl, 1);
  Handle ds(H5Dcreate2(loc, path.c_str(), fileType, sp, lcpl, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  checkWrite(ds.valid(), loc, "dataset '" + path + "'");
  checkWrite(H5Dwrite(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0, loc, "dataset '" + path + "'");
}

void writeDoubles(hid_t loc, const std::string& path, const double* data, const std::vector<hsize_t>& dims) {
  writeNumeric(loc, path, data, dims, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE);
}
void writeInts(hid_t loc, const std::string& path, const Index* data, const std::vector<hsize_t>& dims) {
  writeNumeric(loc, path, data, dims, H5T_STD_I32LE, H5T_NATIVE_INT32);
}
void writeStrings(hid_t loc, const std::string& path, const std::vector<std::string>& v) {
  Handle t = vlenStringType();
  hsize_t n = v.size();
  Handle sp(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl, 1);
  Handle ds(H5Dcreate2(loc, path.c_str(), t, sp, lcpl, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  std::vector<const char*> p;
  for (auto& s : v) p.push_back(s.c_str());
  checkWrite(ds.valid() && H5Dwrite(ds, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, p.data()) >= 0, loc,
             "dataset '" + path + "'");
}

void replaceDoubles(hid_t loc, const std::string& path, const double* data, const std::vector<hsize_t>& dims) {
  if (!exists(loc, path)) {
    writeDoubles(loc, path, data, dims);
    return;
  }
  Handle ds(H5Dopen2(loc, path.c_str(), H5P_DEFAULT), H5Dclose);
  checkWrite(ds.valid() && H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0, loc,
             "dataset '" + path + "'");
}

RowAppender::RowAppender(hid_t loc, const std::string& path, hsize_t cols, SpaceLedger* ledger, hsize_t chunkRows,
                         bool float32)
    : cols_(cols), chunkRows_(chunkRows), valueBytes_(float32 ? sizeof(float) : sizeof(double)), ledger_(ledger) {
  hsize_t dims[2] = {0, cols}, maxd[2] = {H5S_UNLIMITED, cols}, chunk[2] = {chunkRows, cols};
  Handle sp(H5Screate_simple(2, dims, maxd), H5Sclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(dcpl, 2, chunk);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl, 1);
  ds_ = Handle(H5Dcreate2(loc, path.c_str(), float32 ? H5T_IEEE_F32LE : H5T_IEEE_F64LE, sp, lcpl, dcpl, H5P_DEFAULT),
               H5Dclose);
  checkWrite(ds_.valid(), loc, "dataset '" + path + "'");
  if (ledger_) ledger_->nextRow += chunkRows_ * cols_ * valueBytes_;
}

void RowAppender::append(const double* row) { append(row, 1); }

void RowAppender::append(const double* rows, hsize_t n) {
  if (n == 0) return;
  hsize_t newDims[2] = {rows_ + n, cols_};
  checkWrite(H5Dset_extent(ds_, newDims) >= 0, ds_, "a history row");
  Handle fs(H5Dget_space(ds_), H5Sclose);
  hsize_t start[2] = {rows_, 0}, count[2] = {n, cols_};
  H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, nullptr, count, nullptr);
  Handle ms(H5Screate_simple(2, count, nullptr), H5Sclose);
  checkWrite(H5Dwrite(ds_, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, rows) >= 0, ds_, "a history row");
  if (ledger_) {
    const hsize_t chunk = chunkRows_ * cols_ * valueBytes_;
    for (hsize_t k = rows_; k < rows_ + n; ++k) {
      if (k % chunkRows_ == 0) {  // row k starts a chunk
        ledger_->pending += chunk;
        ledger_->nextRow -= chunk;
      }
      if ((k + 1) % chunkRows_ == 0) ledger_->nextRow += chunk;  // the row after it starts one
    }
  }
  rows_ += n;
}

std::string RowAppender::path() const {
  const ssize_t n = H5Iget_name(ds_, nullptr, 0);
  std::string name(size_t(n > 0 ? n : 0), '\0');
  if (n > 0) H5Iget_name(ds_, name.data(), size_t(n) + 1);
  return name;
}

void RowAppender::appendFrom(hid_t src) {
  std::vector<hsize_t> dims;
  const std::vector<double> rows = readDoubles(src, path(), &dims);
  if (dims.size() != 2 || dims[1] != cols_)
    throw InputError("dataset '" + path() + "' of the checkpoint's results has another shape");
  append(rows.data(), dims[0]);
}

void OutputClock::observe(double t) {
  due_.clear();
  const double tol = 1e-9 * dt_;
  for (double tk = next(); tk <= t + tol; tk = next()) {
    double w = 1;
    if (observed_ && t > tObs_) w = std::min(1.0, std::max(0.0, (tk - tObs_) / (t - tObs_)));
    due_.emplace_back(tk, w);
    ++k_;
    if (!(dt_ > 0)) break;  // no clock: one row per observation, at its own time
  }
  if (!(dt_ > 0)) due_.assign(1, {t, 1.0});
  tObs_ = t;
  observed_ = true;
}

void ClockedRows::observe(const double* row) {
  prev_.swap(cur_);
  cur_.assign(row, row + cols_);
  if (prev_.empty()) prev_ = cur_;  // the first state: nothing before it to interpolate from
}

void ClockedRows::write(double t, double w) {
  out_.resize(cols_);
  for (hsize_t c = 0; c < cols_; ++c) {
    const bool near = c < nearest_.size() && nearest_[c];
    out_[c] = near ? (w < 0.5 ? prev_[c] : cur_[c]) : prev_[c] + w * (cur_[c] - prev_[c]);  // exact where equal
  }
  if (timeCol_ >= 0) out_[size_t(timeCol_)] = t;
  rows_.append(out_.data());
}

std::string bytesText(unsigned long long b) {
  char buf[32];
  if (b >= 1000000ULL)
    std::snprintf(buf, sizeof buf, "%.1f MB", double(b) / 1e6);
  else if (b >= 1000ULL)
    std::snprintf(buf, sizeof buf, "%.0f kB", double(b) / 1e3);
  else
    std::snprintf(buf, sizeof buf, "%llu B", b);
  return buf;
}

unsigned long long freeBytes(const std::string& path) {
  struct statvfs v {};
  if (statvfs(path.c_str(), &v) != 0) return 0;
  return static_cast<unsigned long long>(v.f_bavail) * v.f_frsize;
}

static bool noRoom(int e) { return e == ENOSPC || e == EDQUOT || e == EFBIG; }

static std::string folderOf(const std::string& path) {
  const size_t k = path.find_last_of('/');
  return k == std::string::npos ? "." : k == 0 ? "/" : path.substr(0, k);
}

SpaceGuard::SpaceGuard(hid_t file, const std::string& path, hsize_t stopReserve) : file_(file), path_(path) {
  void* handle = nullptr;
  if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || !handle) return;  // not a POSIX file: unguarded
  fd_ = *static_cast<int*>(handle);
  const std::string dir = folderOf(path);
  reserveFd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (reserveFd_ < 0) {  // a file system without O_TMPFILE: a named file, unlinked at once
    std::string tmpl = dir + "/.tq-solid-reserve.XXXXXX";
    reserveFd_ = ::mkstemp(tmpl.data());
    if (reserveFd_ >= 0) {
      ::unlink(tmpl.c_str());
      ::fcntl(reserveFd_, F_SETFD, FD_CLOEXEC);
    }
  }
  if (reserveFd_ >= 0) {
    const int r = posix_fallocate(reserveFd_, 0, off_t(stopReserve));
    if (noRoom(r)) {
      ::close(reserveFd_);
      reserveFd_ = -1;
      throw OutputError("cannot write '" + path + "': " + std::strerror(r) + " (" + bytesText(stopReserve) +
                        " needed to start, " + bytesText(freeBytes(dir)) + " free on its file system)");
    }
  }
  active_ = true;
}

SpaceGuard::~SpaceGuard() {
  if (reserveFd_ >= 0) ::close(reserveFd_);
}

void SpaceGuard::reserve(hsize_t bytes) {
  if (!active_) return;
  haddr_t eoa = 0;
  if (H5Fget_eoa(file_, &eoa) < 0) return;
  const hsize_t target = hsize_t(eoa) + bytes;
  if (target <= allocated_) return;
  const int r = posix_fallocate(fd_, off_t(allocated_), off_t(target - allocated_));
  if (r == 0) {
    allocated_ = target;
  } else if (noRoom(r)) {
    throw OutputError("cannot write '" + path_ + "': " + std::strerror(r) + " (the next results need " +
                      bytesText(target - allocated_) + ", " + bytesText(freeBytes(folderOf(path_))) +
                      " free on its file system)");
  } else {
    active_ = false;  // cannot allocate ahead here: HDF5's own write errors still stop the run
  }
}

void SpaceGuard::flushed() {
  haddr_t eoa = 0;
  if (H5Fget_eoa(file_, &eoa) >= 0) lastEoa_ = hsize_t(eoa);
  struct stat st {};
  if (fd_ >= 0 && ::fstat(fd_, &st) == 0) allocated_ = std::min(allocated_, hsize_t(st.st_size));
}

void SpaceGuard::release() {
  active_ = false;
  if (reserveFd_ >= 0) ::close(reserveFd_);
  reserveFd_ = -1;
}

void SpaceGuard::trimClosed() const {
  struct stat st {};
  if (fd_ < 0 || lastEoa_ == 0 || ::stat(path_.c_str(), &st) != 0) return;
  if (hsize_t(st.st_size) > lastEoa_) {
    if (::truncate(path_.c_str(), off_t(lastEoa_)) != 0) return;  // only unused allocation is cut
  }
}

}  // namespace tq::h5
