// Coupling schemes: serial explicit, serial implicit (and the paper's two-pass variant).
#include "tq/coupler/scheme.hpp"

#include <cmath>

#include "tq/coupler/errors.hpp"
#include "tq/coupler/messages.hpp"

namespace tq::coupler {

double relativeDifference(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  double d = 0, n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    d += (a[i] - b[i]) * (a[i] - b[i]);
    n += a[i] * a[i];
  }
  if (n == 0) return d == 0 ? 0.0 : std::numeric_limits<double>::infinity();
  return std::sqrt(d / n);
}

void addConvergenceSums(const std::vector<double>& a, const std::vector<double>& b,
                        const std::vector<FieldSlice>& slices, std::vector<ExactSum>& sums) {
  for (const auto& f : slices) {
    ExactSum d, n;
    for (std::size_t i = f.offset; i < f.offset + f.size && i < a.size() && i < b.size(); ++i) {
      const double e = a[i] - b[i];
      d.addProduct(e, e);
      n.addProduct(a[i], a[i]);
    }
    sums.push_back(d);
    sums.push_back(n);
  }
}

double convergenceFromSums(const std::vector<ExactSum>& sums, std::size_t at, const std::vector<FieldSlice>& slices,
                           double tolerance, const double* scale) {
  double worst = 0;
  for (std::size_t j = 0; j < slices.size(); ++j) {
    const FieldSlice& f = slices[j];
    const double d = sums[at + 2 * j].value();
    const double n = scale ? std::max(sums[at + 2 * j + 1].value(), scale[j]) : sums[at + 2 * j + 1].value();
    double m = n > 0 ? std::sqrt(d / n) : d == 0 ? 0.0 : std::numeric_limits<double>::infinity();
    if (f.absoluteTolerance > 0 && f.count() > 0)
      m = std::min(m, tolerance * std::sqrt(d / double(f.count())) / f.absoluteTolerance);
    worst = std::max(worst, m);
  }
  return worst;
}

double convergenceMeasure(const std::vector<double>& a, const std::vector<double>& b,
                          const std::vector<FieldSlice>& slices, double tolerance) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  std::vector<ExactSum> sums;
  addConvergenceSums(a, b, slices, sums);
  return convergenceFromSums(sums, 0, slices, tolerance);
}

// ---------------------------------------------------------------- explicit
void SerialExplicit::initialize(ExchangePort& port) {
  state_.ongoing = config_.maxWindows > 0;
  if (!first_ && state_.ongoing) port.receiveData(0, 0);
}

void SerialExplicit::endWindow(ExchangePort& port) {
  const std::uint64_t w = state_.window;
  const bool last = w + 1 >= config_.maxWindows;
  if (first_) {
    port.sendData(w, 0, last ? flags::kLastWindow : 0, std::nan(""));
    port.receiveData(w, 0);
  } else {
    port.sendData(w, 0, flags::kConverged | (last ? flags::kLastWindow : 0), std::nan(""));
  }
  ++state_.totalIterations;
  state_.window = w + 1;
  state_.iteration = 0;
  state_.ongoing = !last;
  state_.windowComplete = true;
  if (!first_ && state_.ongoing) port.receiveData(state_.window, 0);
}

void SerialExplicit::resume(ExchangePort& port) {
  if (!first_ && state_.ongoing) port.receiveData(state_.window, 0);
}

// ---------------------------------------------------------------- implicit
SerialImplicit::SerialImplicit(const CouplingConfig& c, bool amFirst, int maxPasses, bool testConvergence,
                               std::unique_ptr<Acceleration> acc)
    : CouplingScheme(c, amFirst), maxPasses_(maxPasses), test_(testConvergence), acc_(std::move(acc)) {}

void SerialImplicit::initialize(ExchangePort& port) {
  state_.ongoing = config_.maxWindows > 0;
  state_.writeCheckpoint = state_.ongoing;
  if (!first_ && state_.ongoing) {
    port.receiveData(0, 0);
    prevReceived_ = port.receivedValues();
    lastSent_ = port.writtenValues();  // what the first participant used: the initial values
    prevConverged_ = lastSent_;        // x_{−1} of an extrapolating predictor (the initial values)
    acc_->startWindow();
  }
}

void SerialImplicit::endWindow(ExchangePort& port) {
  const std::uint64_t w = state_.window;
  const std::uint32_t k = state_.iteration;
  const bool lastWindow = w + 1 >= config_.maxWindows;
  ++state_.totalIterations;
  bool complete = false;
  if (first_) {
    port.sendData(w, k, 0, std::nan(""));
    const auto got = port.receiveData(w, k);
    state_.residual = got.residual;
    complete = (got.flags & flags::kConverged) != 0;
    // A window the partner ended at the pass limit with its residual above the tolerance: counted
    // here too, so that the first participant (the solid, which writes the results) can report it.
    if (complete && test_ && !(got.residual < config_.tolerance)) ++state_.unconvergedWindows;
    if (!complete && int(k) + 1 >= maxPasses_)
      throw ProtocolError(ProtocolFault::BadPayload, "the partner asked for pass " + std::to_string(k + 2) +
                                                         " of window " + std::to_string(w) + " but at most " +
                                                         std::to_string(maxPasses_) + " are configured");
  } else {
    const std::vector<double> xt = port.writtenValues();  // x̃_k = H(x_k)
    const std::vector<double>& d = port.receivedValues();
    const double tol = config_.tolerance;
    // One combined sum a pass (the parts of a participant in parts): the non-finite values written,
    // then the write and read fields' residuals.
    std::vector<ExactSum> sums(1);
    for (double v : xt)
      if (!std::isfinite(v)) sums[0].add(1.0);
    addConvergenceSums(xt, lastSent_, port.writtenSlices(), sums);
    const std::size_t readAt = sums.size();
    if (k >= 1) addConvergenceSums(d, prevReceived_, port.receivedSlices(), sums);
    port.sums().combine(sums);
    if (sums[0].value() != 0)
      throw DivergenceError("non-finite interface values written in window " + std::to_string(w) + ", pass " +
                            std::to_string(k) +
                            ": the coupled iteration diverged (see docs/coupler.md, "
                            "added-mass instability)");
    const std::size_t nw = port.writtenSlices().size(), nr = port.receivedSlices().size();
    const bool largest = config_.residualScale == ResidualScale::Largest;
    if (largest && scale_.size() != nw + nr) scale_.assign(nw + nr, 0.0);
    const double* sw = largest ? scale_.data() : nullptr;
    const double* sr = largest ? scale_.data() + nw : nullptr;
    const double resWrite = lastSent_.size() == xt.size() ? convergenceFromSums(sums, 1, port.writtenSlices(), tol, sw)
                                                          : std::numeric_limits<double>::infinity();
    const double resRead = k >= 1 && prevReceived_.size() == d.size()
                               ? convergenceFromSums(sums, readAt, port.receivedSlices(), tol, sr)
                               : std::numeric_limits<double>::infinity();
    // Pass 0 with an extrapolating predictor: the fixed-point residual ‖H(x⁰) − x⁰‖ alone decides
    // (the read data has no earlier pass to compare with; the motion is a function of x⁰).
    const bool extrapolated = extrapolates(config_.predictor);
    state_.residual = k == 0 && extrapolated ? resWrite : std::max(resWrite, resRead);
    if (!std::isfinite(resWrite) && k >= 1)
      throw DivergenceError("interface residual is not finite in window " + std::to_string(w) + ", pass " +
                            std::to_string(k));
    const bool converged = test_ && (k >= 1 || extrapolated) && state_.residual < config_.tolerance;
    complete = converged || int(k) + 1 >= maxPasses_;
    if (complete) {
      if (test_ && !converged) ++state_.unconvergedWindows;
      if (largest) {  // each field's largest accepted ‖a‖² (the read fields' from passes that compared them)
        for (std::size_t j = 0; j < nw; ++j) scale_[j] = std::max(scale_[j], sums[1 + 2 * j + 1].value());
        if (k >= 1)
          for (std::size_t j = 0; j < nr; ++j)
            scale_[nw + j] = std::max(scale_[nw + j], sums[readAt + 2 * j + 1].value());
      }
      port.sendData(w, k, flags::kConverged | (lastWindow ? flags::kLastWindow : 0), state_.residual);
      if (extrapolated) {
        // The next window's x⁰ extrapolated (linear: 2 x_w − x_{w−1}; damped: x_w + ¾ (x_w − x_{w−1})),
        // x_w the value the first participant applied in this window's last pass (lastSent_), not
        // the answer x̃: extrapolating the answers would multiply each accepted error by the
        // added-mass feedback (a growing period-two mode that a relative residual does not see);
        // the applied values carry the accepted errors once.
        const std::vector<double> applied = lastSent_;
        for (std::size_t i = 0; i < applied.size() && i < prevConverged_.size(); ++i)
          lastSent_[i] = extrapolatedValue(config_.predictor, applied[i], prevConverged_[i]);
        prevConverged_ = applied;
      } else {
        lastSent_ = xt;
      }
    } else {
      acc_->useSums(port.sums());
      acc_->next(lastSent_, xt, next_);
      port.writtenValues() = next_;
      port.sendData(w, k, 0, state_.residual);
      lastSent_ = next_;
    }
  }
  state_.windowComplete = complete;
  if (complete) {
    state_.window = w + 1;
    state_.iteration = 0;
    state_.ongoing = !lastWindow;
    state_.writeCheckpoint = state_.ongoing;
    state_.readCheckpoint = false;
    if (!first_) {
      acc_->startWindow();
      if (state_.ongoing) {
        port.receiveData(state_.window, 0);
        prevReceived_ = port.receivedValues();
      }
    }
  } else {
    state_.iteration = k + 1;
    state_.readCheckpoint = true;
    state_.writeCheckpoint = false;
    if (!first_) {
      prevReceived_ = port.receivedValues();
      port.receiveData(w, k + 1);
    }
  }
}

void SerialImplicit::checkpoint(StateIo& io) {
  CouplingScheme::checkpoint(io);
  io.io(prevReceived_);
  io.io(lastSent_);
  io.io(next_);
  io.io(prevConverged_);
  if (config_.residualScale == ResidualScale::Largest) io.io(scale_);
  acc_->checkpoint(io);
}

void SerialImplicit::resume(ExchangePort& port) {
  if (!first_ && state_.ongoing) {
    port.receiveData(state_.window, 0);
    prevReceived_ = port.receivedValues();
  }
}

std::unique_ptr<CouplingScheme> makeScheme(const CouplingConfig& c, const std::string& me) {
  const bool amFirst = me == c.first;
  switch (c.scheme) {
    case SchemeKind::Explicit:
      return std::make_unique<SerialExplicit>(c, amFirst);
    case SchemeKind::Paper:
      return std::make_unique<SerialImplicit>(c, amFirst, 2, false, std::make_unique<NoAcceleration>());
    case SchemeKind::Implicit:
      return std::make_unique<SerialImplicit>(c, amFirst, c.maxIterations, true,
                                              makeAcceleration(c.acceleration, c.initialRelaxation, c.reuse));
  }
  throw ConfigError("unknown coupling scheme");
}

}  // namespace tq::coupler
