#pragma once
/// @file acceleration.hpp
/// Acceleration of the interface fixed-point iteration x ← H(x) (x: the data the second
/// participant writes, H: one pass of first then second participant). Abstract base +
/// variants + factory.

#include <cstdint>
#include <memory>
#include <vector>

#include "tq/coupler/config.hpp"
#include "tq/coupler/exact_sum.hpp"
#include "tq/coupler/state_io.hpp"

namespace tq::coupler {

class Acceleration {
 public:
  virtual ~Acceleration() = default;
  /// A new coupling window starts: forget the iteration history of the last one.
  virtual void startWindow() = 0;
  /// Given the input x_k of this iteration and the output x̃_k = H(x_k), computes x_{k+1}.
  virtual void next(const std::vector<double>& x, const std::vector<double>& xTilde, std::vector<double>& xNext) = 0;
  /// Relaxation factor used in the last step (1 for none; IQN-ILS: the first-step factor).
  virtual double lastRelaxation() const = 0;
  /// Save or restore what the iterations of later windows depend on (restart checkpoints).
  virtual void checkpoint(StateIo& /*io*/) {}
  /// How sums over the interface are completed: x is this part's share of a participant in parts
  /// (Participant::setPart), and every dot product and norm is a sum over every part's share,
  /// held exactly (exact_sum.hpp), so that the step does not depend on the part count.
  void useSums(const SumCombiner& s) { sums_ = &s; }

 protected:
  const SumCombiner& sums() const { return *sums_; }

 private:
  static const SumCombiner& onePiece() {
    static const OnePiece one;
    return one;
  }
  const SumCombiner* sums_ = &onePiece();
};

/// x_{k+1} = x̃_k.
class NoAcceleration final : public Acceleration {
 public:
  void startWindow() override {}
  void next(const std::vector<double>& x, const std::vector<double>& xTilde, std::vector<double>& xNext) override;
  double lastRelaxation() const override { return 1.0; }
};

/// x_{k+1} = x_k + ω (x̃_k − x_k), fixed ω.
class ConstantRelaxation final : public Acceleration {
 public:
  explicit ConstantRelaxation(double omega);
  void startWindow() override {}
  void next(const std::vector<double>& x, const std::vector<double>& xTilde, std::vector<double>& xNext) override;
  double lastRelaxation() const override { return omega_; }

 private:
  double omega_;
};

/// Aitken Δ²: ω_k = −ω_{k−1} r_{k−1}ᵀ(r_k − r_{k−1}) / ‖r_k − r_{k−1}‖², r = x̃ − x;
/// ω_0 = initial relaxation in every window.
class Aitken final : public Acceleration {
 public:
  explicit Aitken(double initialOmega);
  void startWindow() override;
  void next(const std::vector<double>& x, const std::vector<double>& xTilde, std::vector<double>& xNext) override;
  double lastRelaxation() const override { return omega_; }
  void checkpoint(StateIo& io) override {
    io.io(omega_);
    io.io(rPrev_);
    io.io(first_);
  }

 private:
  double omega0_, omega_;
  std::vector<double> rPrev_;
  bool first_ = true;
};

/// QR2 filter threshold of IQN-ILS (relative to each column's norm).
inline constexpr double kIqnIlsFilter = 1e-3;

/// Interface quasi-Newton with an inverse Jacobian from least squares (IQN-ILS, Degroote,
/// Bathe & Vierendeels 2009): V = [Δr], W = [Δx̃] of this window; α = argmin‖Vα + r_k‖;
/// x_{k+1} = x̃_k + Wα. The first iteration of a window is relaxed by the initial ω. QR2 filter
/// (Haelterman et al. 2016): with the columns newest first, a column whose part orthogonal to the
/// newer ones is below filterEps × its norm is dropped (docs/coupler.md "IQN-ILS filter").
/// The least squares is solved from V's Gram matrix VᵀV (its entries exact sums, kept from pass
/// to pass: a new column adds one row) by Cholesky, R of V = QR, so that a participant in parts
/// needs one combined sum a pass and every part computes the same α.
class IqnIls final : public Acceleration {
 public:
  /// reuse: the secant columns of that many earlier windows are kept (IQN-ILS(reuse)); 0 = each
  /// window starts from a relaxation step.
  explicit IqnIls(double initialOmega, double filterEps = kIqnIlsFilter, int reuse = 0);
  void startWindow() override;
  void next(const std::vector<double>& x, const std::vector<double>& xTilde, std::vector<double>& xNext) override;
  double lastRelaxation() const override { return omega0_; }
  std::size_t columns() const { return dr_.size(); }
  void checkpoint(StateIo& io) override {
    io.io(window_);
    io.io(rPrev_);
    io.io(xtPrev_);
    io.io(dr_);
    io.io(dxt_);
    io.io(colWindow_);
    io.io(first_);
    io.io(gram_);
  }

 private:
  double omega0_, eps_;
  int reuse_ = 0;
  std::uint64_t window_ = 0;
  std::vector<double> rPrev_, xtPrev_;
  std::vector<std::vector<double>> dr_, dxt_;  ///< newest last
  std::vector<std::uint64_t> colWindow_;       ///< the window each column was made in
  std::vector<std::vector<double>> gram_;      ///< dr_[i]·dr_[j], j ≤ i (row i: i + 1 entries)
  std::size_t total_ = 0;                      ///< the values of every part (0: not asked yet)
  void dropColumn(std::size_t j);              ///< j: index in dr_ (0 = oldest)
  bool first_ = true;
};

/// reuse: IQN-ILS only, the windows whose columns are kept (CouplingConfig::reuse).
std::unique_ptr<Acceleration> makeAcceleration(AccelerationKind kind, double initialRelaxation, int reuse = 0);

}  // namespace tq::coupler
