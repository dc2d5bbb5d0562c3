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
#include <stdexcept>
#include <string>
#include <type_traits>
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
      throw std::logic_error("StateArchive: restored " + std::to_string(pos_) + " items of " +
                             std::to_string(count_) + " saved (a part changed its checkpoint list)");
    }
  }
  Mode mode() const { return mode_; }
  bool saving() const { return mode_ == Mode::Save; }
  /// Bytes held (for the log).
  std::size_t bytes() const {
    std::size_t b = 0;
    for (std::size_t i = 0; i < count_; ++i) b += slots_[i].size();
    return b;
  }

  /// A vector of trivially copyable values; restored to the same size.
  template <class T>
  void io(std::vector<T>& v) {
    static_assert(std::is_trivially_copyable<T>::value, "StateArchive stores plain values only");
    std::vector<unsigned char>& s = slot();
    const std::size_t n = v.size() * sizeof(T);
    if (mode_ == Mode::Save) {
      s.resize(n);
      if (n) std::memcpy(s.data(), v.data(), n);
    } else {
      v.resize(s.size() / sizeof(T));
      if (!s.empty()) std::memcpy(v.data(), s.data(), s.size());
    }
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
};

}  // namespace tq
