#pragma once
/// @file scheme.hpp
/// Coupling schemes: what is exchanged at the end of a window and when a window is repeated.
/// Abstract base + variants (SerialExplicit, SerialImplicit) + factory (makeScheme). A scheme
/// sees the data only through an ExchangePort, so it can be tested without a transport.

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "tq/coupler/acceleration.hpp"
#include "tq/coupler/config.hpp"
#include "tq/coupler/state_io.hpp"

namespace tq::coupler {

/// One field's place in the concatenated written or received values.
struct FieldSlice {
  std::string name;
  std::size_t offset = 0, size = 0;
  double absoluteTolerance = 0.0;  ///< FieldSpec::absoluteTolerance (field units, RMS)
  std::size_t total = 0;           ///< the field's values on every part of a participant in parts (0: size)
  std::size_t count() const { return total ? total : size; }
};

/// What a scheme needs from its participant.
class ExchangePort {
 public:
  virtual ~ExchangePort() = default;
  /// Sends this side's written fields (as currently held) in a DATA message.
  virtual void sendData(std::uint64_t window, std::uint32_t iteration, std::uint32_t flags, double residual) = 0;
  struct Received {
    std::uint32_t flags = 0;
    double residual = 0.0;
  };
  /// Receives the partner's DATA for (window, iteration) into the read fields.
  virtual Received receiveData(std::uint64_t window, std::uint32_t iteration) = 0;
  /// This side's written values, all written fields concatenated (may be modified: the
  /// second participant replaces them by the accelerated values before sending).
  virtual std::vector<double>& writtenValues() = 0;
  /// The partner's values as last received, all read fields concatenated.
  virtual const std::vector<double>& receivedValues() const = 0;
  /// Where each written / read field lies in writtenValues() / receivedValues().
  virtual const std::vector<FieldSlice>& writtenSlices() const = 0;
  virtual const std::vector<FieldSlice>& receivedSlices() const = 0;
  /// Completes sums over the parts of a participant in parts (one piece: nothing to add).
  virtual const SumCombiner& sums() const = 0;
};

struct SchemeState {
  std::uint64_t window = 0;     ///< index of the current window (0-based)
  std::uint32_t iteration = 0;  ///< pass within the window (0-based)
  bool ongoing = true;
  bool windowComplete = false;                                 ///< the last advance() completed a window
  bool writeCheckpoint = false;                                ///< save state now: a window starts that may be repeated
  bool readCheckpoint = false;                                 ///< restore state now: the window is repeated
  double residual = std::numeric_limits<double>::quiet_NaN();  ///< last measured residual
  std::uint64_t totalIterations = 0;                           ///< passes over all windows
  std::uint64_t unconvergedWindows = 0;                        ///< implicit windows that hit maxIterations
};

class CouplingScheme {
 public:
  CouplingScheme(const CouplingConfig& c, bool amFirst) : config_(c), first_(amFirst) {}
  virtual ~CouplingScheme() = default;
  /// After the handshake. The second participant receives the first's window-0 data here.
  virtual void initialize(ExchangePort& port) = 0;
  /// At the end of a window (the participant has advanced through windowSize): exchange,
  /// decide whether the window is repeated, update the state.
  virtual void endWindow(ExchangePort& port) = 0;
  /// Restart checkpoints: save or restore the scheme's state at a completed window.
  virtual void checkpoint(StateIo& io) { io.io(state_); }
  /// Instead of initialize(), after checkpoint() restored a completed window: the second
  /// participant receives the first's data of the next window again (its checkpoint was taken
  /// after that data arrived, the first's before it was sent; the values are the same).
  virtual void resume(ExchangePort& port) = 0;
  const SchemeState& state() const { return state_; }
  /// Called by the participant when a step did not complete the window.
  void clearFlags() { state_.windowComplete = state_.writeCheckpoint = state_.readCheckpoint = false; }
  bool isFirst() const { return first_; }

 protected:
  const CouplingConfig& config_;
  bool first_;
  SchemeState state_;
};

/// Staggered (Gauss–Seidel): first sends, second answers, once per window.
class SerialExplicit final : public CouplingScheme {
 public:
  using CouplingScheme::CouplingScheme;
  void initialize(ExchangePort& port) override;
  void endWindow(ExchangePort& port) override;
  void resume(ExchangePort& port) override;
};

/// Serial implicit: passes repeated with checkpoint/rollback until converged (the second
/// participant measures, field by field, ‖d_k − d_{k−1}‖/‖d_k‖ of what it reads and
/// ‖x̃_k − x_k‖/‖x̃_k‖ of what it writes; a field has converged when that is below tolerance
/// or the RMS of its residual is below the field's absolute tolerance; all fields, k ≥ 1) or
/// maxIterations; it accelerates its writes.
/// With fixedPasses = 2 and no convergence test this is the paper's predictor–corrector.
class SerialImplicit final : public CouplingScheme {
 public:
  SerialImplicit(const CouplingConfig& c, bool amFirst, int maxPasses, bool testConvergence,
                 std::unique_ptr<Acceleration> acceleration);
  void initialize(ExchangePort& port) override;
  void endWindow(ExchangePort& port) override;
  void checkpoint(StateIo& io) override;
  void resume(ExchangePort& port) override;

 private:
  int maxPasses_;
  bool test_;
  std::unique_ptr<Acceleration> acc_;
  std::vector<double> prevReceived_;  ///< second: d_{k−1}
  std::vector<double> lastSent_;      ///< second: x_k (what the first used in this pass)
  std::vector<double> next_;
  std::vector<double> prevConverged_;  ///< second, predictor linear or damped: x applied in window w−1
  std::vector<double> scale_;          ///< second, residual scale largest: each field's largest accepted ‖a‖²
};

std::unique_ptr<CouplingScheme> makeScheme(const CouplingConfig& c, const std::string& me);

/// ‖a − b‖ / ‖a‖ (0 when both are zero, +inf when only a is zero).
double relativeDifference(const std::vector<double>& a, const std::vector<double>& b);

/// The convergence measure of one pass, max over the fields of
/// min(‖a − b‖/‖a‖, tolerance × rms(a − b) / absoluteTolerance) (the second term only where the
/// field has an absolute tolerance): the pass has converged when it is below `tolerance`. It is
/// the relative residual except where the absolute floor is nearer to being met. The sums are
/// exact (exact_sum.hpp), so a participant in parts measures what it would in one piece.
/// `scale` (ResidualScale::Largest): each field's ‖a‖² is taken as at least scale[field].
double convergenceMeasure(const std::vector<double>& a, const std::vector<double>& b,
                          const std::vector<FieldSlice>& slices, double tolerance);
/// The sums of convergenceMeasure, appended to `sums` (‖a − b‖², ‖a‖² per field) for combining over
/// parts; then the measure from them (`at`: where they start).
void addConvergenceSums(const std::vector<double>& a, const std::vector<double>& b,
                        const std::vector<FieldSlice>& slices, std::vector<ExactSum>& sums);
double convergenceFromSums(const std::vector<ExactSum>& sums, std::size_t at, const std::vector<FieldSlice>& slices,
                           double tolerance, const double* scale = nullptr);

}  // namespace tq::coupler
