#pragma once
/// @file exact_sum.hpp
/// Sums of doubles held exactly, so that the sum does not depend on the order of its terms: every
/// finite double is an integer multiple of 2^-1074 below 2^1024, and the sum is kept as that integer
/// in 32-bit digits (each in an int64 limb, which holds 2^30 additions before a carry is due).
/// Two sums of disjoint terms add digit by digit (integers: any order, any grouping gives the same
/// digits), so the parts of a participant combine their partial sums into the one the whole
/// participant would have, bit for bit, whatever the part count (Participant::setPart). value()
/// rounds the exact sum to a double the same way every time (within 2 ulp of the exact sum).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace tq::coupler {

class ExactSum {
 public:
  /// 32-bit digits of 2^(32 i − 1074), i = 0 … kDigits − 1 (a double's bits reach digit 65; two
  /// more take the carries), then one limb counting non-finite terms.
  static constexpr int kDigits = 68;
  static constexpr int kLimbs = kDigits + 1;

  void add(double x) {
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    const int e = int((bits >> 52) & 0x7ff);
    std::uint64_t m = bits & ((std::uint64_t(1) << 52) - 1);
    if (e == 0x7ff) {
      ++limb_[kDigits];
      return;
    }
    if (e == 0 && m == 0) return;
    if (e > 0) m |= std::uint64_t(1) << 52;
    const int p = e > 0 ? e - 1 : 0;  // x = ±m 2^(p − 1074)
    const unsigned __int128 v = static_cast<unsigned __int128>(m) << (p & 31);
    const int i = p >> 5;
    const auto d0 = std::int64_t(std::uint64_t(v) & 0xffffffffu);
    const auto d1 = std::int64_t(std::uint64_t(v >> 32) & 0xffffffffu);
    const auto d2 = std::int64_t(std::uint64_t(v >> 64));
    if (bits >> 63) {
      limb_[i] -= d0, limb_[i + 1] -= d1, limb_[i + 2] -= d2;
    } else {
      limb_[i] += d0, limb_[i + 1] += d1, limb_[i + 2] += d2;
    }
    if (++pending_ >= (1u << 30)) normalize();
  }
  /// Adds a × b rounded to a double (the product rounds the same in every part).
  void addProduct(double a, double b) { add(a * b); }
  ExactSum& operator+=(const ExactSum& o) {
    for (int i = 0; i < kLimbs; ++i) limb_[i] += o.limb_[i];
    normalize();
    return *this;
  }

  /// The sum rounded to a double (NaN if a term was not finite).
  double value() const {
    ExactSum s = *this;
    s.normalize();
    if (s.limb_[kDigits] != 0) return std::numeric_limits<double>::quiet_NaN();
    bool negative = s.limb_[kDigits - 1] < 0;
    if (negative) {
      for (int i = 0; i < kDigits; ++i) s.limb_[i] = -s.limb_[i];
      s.normalize();
    }
    double r = 0;  // digits from the top: each term below the running sum's last bits but a few
    for (int i = kDigits - 1; i >= 0; --i)
      if (s.limb_[i] != 0) r += std::ldexp(double(s.limb_[i]), 32 * i - 1074);
    return negative ? -r : r;
  }

  /// The limbs, normalized (digits in [0, 2^32), the top one signed): the form parts add.
  void appendTo(std::vector<std::int64_t>& out) const {
    ExactSum s = *this;
    s.normalize();
    out.insert(out.end(), s.limb_, s.limb_ + kLimbs);
  }
  /// Reads the limbs written by appendTo (or their sum over parts) from `in` at `at`.
  void readFrom(const std::vector<std::int64_t>& in, std::size_t at) {
    std::memcpy(limb_, in.data() + at, sizeof limb_);
    pending_ = 0;
    normalize();
  }

 private:
  void normalize() {
    for (int i = 0; i + 1 < kDigits; ++i) {
      const std::int64_t carry = limb_[i] >> 32;  // floor(limb / 2^32)
      limb_[i] -= carry * (std::int64_t(1) << 32);
      limb_[i + 1] += carry;
    }
    pending_ = 0;
  }
  std::int64_t limb_[kLimbs] = {};
  std::uint32_t pending_ = 0;
};

/// Combines partial sums over the parts of a participant: replaces each by the sum of every part's.
/// One piece: nothing to do. A participant in parts: through its PartGroup (participant.hpp).
class SumCombiner {
 public:
  virtual ~SumCombiner() = default;
  virtual void combine(std::vector<ExactSum>& sums) const = 0;
  /// The number of values of a participant's vector of which this part holds `mine`.
  virtual std::size_t total(std::size_t mine) const = 0;
};

/// A participant in one piece.
class OnePiece final : public SumCombiner {
 public:
  void combine(std::vector<ExactSum>& /*sums*/) const override {}
  std::size_t total(std::size_t mine) const override { return mine; }
};

}  // namespace tq::coupler
