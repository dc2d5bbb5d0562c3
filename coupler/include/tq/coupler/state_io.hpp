#pragma once
/// @file state_io.hpp
/// @brief The coupling state as bytes, for restart checkpoints (docs/coupler.md "Restart"): each
/// part lists its mutable members once, in one `checkpoint(StateIo&)` that both saves and restores
/// (the StateIo's direction decides), so the two directions cannot drift apart.
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "tq/coupler/errors.hpp"

namespace tq::coupler {

class StateIo {
 public:
  /// Appends to `bytes` (saving).
  static StateIo saver(std::vector<unsigned char>& bytes) { return StateIo(&bytes, nullptr); }
  /// Reads `bytes` from the start (restoring).
  static StateIo loader(const std::vector<unsigned char>& bytes) { return StateIo(nullptr, &bytes); }
  bool saving() const { return out_ != nullptr; }
  /// Restoring: every byte was read (else the state belongs to another configuration).
  bool exhausted() const { return !in_ || pos_ == in_->size(); }

  template <class T>
  void io(T& x) {
    static_assert(std::is_trivially_copyable<T>::value, "plain values only");
    raw(&x, sizeof(T));
  }
  template <class T>
  void io(std::vector<T>& v) {
    static_assert(std::is_trivially_copyable<T>::value, "plain values only");
    std::uint64_t n = v.size();
    io(n);
    if (!saving()) {
      if (n > (in_->size() - pos_) / (sizeof(T) ? sizeof(T) : 1))
        throw ConfigError("restart state: a list longer than the bytes left (a damaged checkpoint)");
      v.resize(std::size_t(n));
    }
    if (n) raw(v.data(), std::size_t(n) * sizeof(T));
  }
  template <class T>
  void io(std::vector<std::vector<T>>& v) {
    std::uint64_t n = v.size();
    io(n);
    if (!saving()) v.resize(std::size_t(n));
    for (auto& x : v) io(x);
  }

 private:
  StateIo(std::vector<unsigned char>* out, const std::vector<unsigned char>* in) : out_(out), in_(in) {}
  void raw(void* p, std::size_t n) {
    if (out_) {
      const auto* b = static_cast<const unsigned char*>(p);
      out_->insert(out_->end(), b, b + n);
    } else {
      if (n > in_->size() - pos_)
        throw ConfigError("restart state: the bytes end early (a damaged checkpoint or another configuration)");
      std::memcpy(p, in_->data() + pos_, n);
      pos_ += n;
    }
  }
  std::vector<unsigned char>* out_;
  const std::vector<unsigned char>* in_;
  std::size_t pos_ = 0;
};

}  // namespace tq::coupler
