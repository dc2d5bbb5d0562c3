#pragma once
/// @file state_archive.hpp
/// @brief A copy of the solid's mutable state to go back to: a coupling window of several solid
/// steps is repeated until the water and the solid agree (docs/coupler.md "Windows of several
/// steps"), so the solver, its element blocks and its force contributors save and restore
/// everything that a step changes.
///
/// Each part lists its mutable members once, in one `checkpoint(StateArchive&)` method that both
/// saves and restores (the archive's mode decides), so the two directions cannot drift apart.
/// Storage is reused from one save to the next: after the first window no allocation happens.
#include <cstddef>
#include <cstring>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace tq {

class StateArchive {
 public:
  enum class Mode { Save, Restore };

  /// Start writing a new copy (replaces the previous one).
  void beginSave() {
    mode_ = Mode::Save;
    pos_ = 0;
  }
  /// Start reading the last copy back, in the same order it was written.
  void beginRestore() {
    if (!saved_) throw std::logic_error("StateArchive: restore before any save");
    mode_ = Mode::Restore;
    pos_ = 0;
  }
  /// End of a save or restore: checks that a restore read every item the save wrote.
  void end() {
    if (mode_ == Mode::Save) {
      count_ = pos_;
      saved_ = true;
    } else if (pos_ != count_) {
      throw std::logic_error("StateArchive: restored " + std::to_string(pos_) + " items of " + std::to_string(count_) +
                             " saved (a part changed its checkpoint list)");
    }
  }
  Mode mode() const { return mode_; }
  bool saving() const { return mode_ == Mode::Save; }
  /// A coupling window's start (CoupledStepper), stepped again from in the same run: the parts may
  /// leave out what every step writes before it reads it. A restart file's copy holds everything.
  void setWindowStart(bool w) { windowStart_ = w; }
  bool windowStart() const { return windowStart_; }
  /// Bytes held (for the log).
  std::size_t bytes() const {
    std::size_t b = 0;
    for (std::size_t i = 0; i < count_; ++i) b += slots_[i].size();
    return b;
  }

  /// Item sizes of the last save, in order: two archives of the same build and case have the same.
  std::vector<std::size_t> layout() const {
    std::vector<std::size_t> l(count_);
    for (std::size_t i = 0; i < count_; ++i) l[i] = slots_[i].size();
    return l;
  }
  /// The last save as bytes (a file of a restart checkpoint): the item count, then each item's
  /// size and bytes, sizes as 64-bit little-endian integers (this machine's byte order).
  void write(std::ostream& os) const {
    const auto put = [&os](unsigned long long n) { os.write(reinterpret_cast<const char*>(&n), sizeof n); };
    put(count_);
    for (std::size_t i = 0; i < count_; ++i) {
      put(slots_[i].size());
      os.write(reinterpret_cast<const char*>(slots_[i].data()), std::streamsize(slots_[i].size()));
    }
  }
  /// Replace the copy held by one that write() wrote; false if the bytes end early.
  bool read(std::istream& is) {
    unsigned long long n = 0;
    const auto get = [&is](unsigned long long& v) { return bool(is.read(reinterpret_cast<char*>(&v), sizeof v)); };
    if (!get(n)) return false;
    std::vector<std::vector<unsigned char>> slots(n);
    for (auto& s : slots) {
      unsigned long long size = 0;
      if (!get(size) || size > (1ULL << 40)) return false;
      s.resize(size);
      if (size && !is.read(reinterpret_cast<char*>(s.data()), std::streamsize(size))) return false;
    }
    slots_ = std::move(slots);
    count_ = slots_.size();
    pos_ = 0;
    saved_ = true;
    return true;
  }

  /// A vector of trivially copyable values; restored to the same size.
  template <class T>
  void io(std::vector<T>& v) {
    static_assert(std::is_trivially_copyable<T>::value, "StateArchive stores plain values only");
    std::vector<unsigned char>& s = slot();
    const std::size_t n = v.size() * sizeof(T);
    if (mode_ == Mode::Save) {
      s.resize(n);
      copyBytes(s.data(), v.data(), n);
    } else {
      v.resize(s.size() / sizeof(T));
      copyBytes(v.data(), s.data(), s.size());
    }
  }
  /// io(v), but with `only` a save copies the index ranges [first, second) it lists (the slot
  /// keeps v's size; its other bytes are not written) and a restore copies them back, leaving v's
  /// other values as they are (v of the size saved): a save with `only` is restored with the same
  /// ranges. `only` null or an empty v: io(v). A coupling window's re-pass restores what it steps
  /// again only, and the window's start saves that only (Solver::planRepasses).
  template <class T>
  void io(std::vector<T>& v, const std::vector<std::pair<std::size_t, std::size_t>>* only) {
    if (!only || v.empty()) return io(v);
    std::vector<unsigned char>& s = slot();
    if (mode_ == Mode::Save) {
      s.resize(v.size() * sizeof(T));
      for (const auto& r : *only)
        copyBytes(s.data() + r.first * sizeof(T), v.data() + r.first, (r.second - r.first) * sizeof(T));
      return;
    }
    if (s.size() != v.size() * sizeof(T))
      throw std::logic_error("StateArchive: a partly restored item changed size between save and restore");
    for (const auto& r : *only)
      copyBytes(v.data() + r.first, s.data() + r.first * sizeof(T), (r.second - r.first) * sizeof(T));
  }
  /// One trivially copyable value (a scalar or a struct of scalars).
  template <class T>
  void io(T& x) {
    static_assert(std::is_trivially_copyable<T>::value, "StateArchive stores plain values only");
    std::vector<unsigned char>& s = slot();
    if (mode_ == Mode::Save) {
      s.resize(sizeof(T));
      std::memcpy(s.data(), &x, sizeof(T));
    } else {
      if (s.size() != sizeof(T)) throw std::logic_error("StateArchive: item size changed between save and restore");
      std::memcpy(&x, s.data(), sizeof(T));
    }
  }

 private:
  /// memcpy; a large item in fixed pieces over the threads of an OpenMP team (state_archive.cpp).
  static void copyBytes(void* dst, const void* src, std::size_t n);

  std::vector<unsigned char>& slot() {
    if (mode_ == Mode::Save) {
      if (pos_ == slots_.size()) slots_.emplace_back();
    } else if (pos_ >= count_) {
      throw std::logic_error("StateArchive: more items restored than saved (a part changed its checkpoint list)");
    }
    return slots_[pos_++];
  }

  Mode mode_ = Mode::Save;
  std::vector<std::vector<unsigned char>> slots_;
  std::size_t pos_ = 0, count_ = 0;
  bool saved_ = false;
  bool windowStart_ = false;
};

}  // namespace tq
