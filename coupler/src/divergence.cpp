// Coupling divergence detection (divergence.hpp; docs/coupler.md "Divergence detection").
#include "tq/coupler/divergence.hpp"

#include <cmath>
#include <sstream>

#include "tq/coupler/errors.hpp"

namespace tq::coupler {

DivergenceMonitor::DivergenceMonitor(const CouplingConfig& c, std::vector<FieldSlice> slices, std::string who,
                                     DivergenceSettings s)
    : config_(c), slices_(std::move(slices)), who_(std::move(who)), s_(s), tracks_(slices_.size()) {}

namespace {
/// The first fix to try, in one sentence; the rest are in docs/coupler.md "Divergence detection".
std::string fixText(SchemeKind scheme) {
  std::string s = "Fix: ";
  if (scheme != SchemeKind::Implicit)
    s += "coupling.scheme: implicit (acceleration iqn-ils)";
  else
    s += "coupling.tolerance ten times lower, or coupling.window_force_weight: 1 with windows of several steps";
  s += ", or water.model: compressible with a shorter window (docs/coupler.md \"Divergence detection\").";
  return s;
}
}  // namespace

void DivergenceMonitor::windowDone(std::uint64_t window, const std::vector<double>& x, bool unconverged,
                                   double residual) {
  for (std::size_t j = 0; j < slices_.size(); ++j) {
    const FieldSlice& f = slices_[j];
    Track& t = tracks_[j];
    if (f.size == 0 || f.offset + f.size > x.size()) continue;
    const double* xs = x.data() + f.offset;
    double sq = 0;
    for (std::size_t i = 0; i < f.size; ++i) sq += xs[i] * xs[i];
    t.peak = std::max(t.peak, std::sqrt(sq / double(f.size)));
    if (!t.hasPrev) {
      t.prev.assign(xs, xs + f.size);
      t.hasPrev = true;
      continue;
    }
    std::vector<double> delta(f.size);
    double c2 = 0;
    for (std::size_t i = 0; i < f.size; ++i) {
      delta[i] = xs[i] - t.prev[i];
      c2 += delta[i] * delta[i];
    }
    const double change = std::sqrt(c2 / double(f.size));
    const double floor = std::max(f.absoluteTolerance, s_.noiseFloor * t.peak);
    bool alternating = false;
    if (t.hasDelta && change > floor && t.prevChange > floor) {
      double dot = 0;
      for (std::size_t i = 0; i < f.size; ++i) dot += delta[i] * t.prevDelta[i];
      const double cosine = dot / (double(f.size) * change * t.prevChange);
      alternating = cosine < -0.5;
    }
    if (alternating) {
      if (t.run == 0) t.runStartChange = t.prevChange;
      ++t.run;
      const double amp = std::pow(change / t.runStartChange, 1.0 / t.run);
      lastAmp_ = -amp;
      if (t.run >= s_.windows && amp >= s_.growth) {
        std::ostringstream m;
        m.precision(3);
        m << "participant '" << who_ << "': the coupling is unstable at t = " << double(window + 1) * config_.windowSize
          << " s (window " << window + 1 << "): the interface '" << f.name
          << "' changed sign window after window, growing " << amp << "x a window over " << t.run
          << " windows: the added-mass instability of the '" << schemeName(config_.scheme)
          << "' scheme; stopped before any value overflowed. " << fixText(config_.scheme);
        throw DivergenceError(m.str());
      }
    } else {
      t.run = 0;
    }
    t.prev.assign(xs, xs + f.size);
    t.prevDelta = std::move(delta);
    t.prevChange = change;
    t.hasDelta = true;
  }
  // Implicit: the pass limit reached window after window with a growing residual.
  if (config_.scheme != SchemeKind::Implicit) return;
  if (!unconverged) {
    unconvergedRun_ = 0;
    unconvergedResiduals_.clear();
    return;
  }
  if (!unconvergedResiduals_.empty() && !(residual > unconvergedResiduals_.back())) {
    unconvergedResiduals_.clear();  // not growing: start counting again
    unconvergedRun_ = 0;
  }
  ++unconvergedRun_;
  unconvergedResiduals_.push_back(residual);
  if (unconvergedRun_ >= s_.unconverged && residual >= s_.residualGrowth * unconvergedResiduals_.front()) {
    std::ostringstream m;
    m.precision(3);
    m << "participant '" << who_
      << "': the implicit coupling iteration diverges at t = " << double(window + 1) * config_.windowSize
      << " s (window " << window + 1 << "): " << unconvergedRun_ << " windows in a row ended at the limit of "
      << config_.maxIterations << " passes with a growing residual (" << unconvergedResiduals_.front() << " -> "
      << residual << "): an added-mass effect the acceleration cannot absorb; stopped before any value overflowed. "
      << fixText(config_.scheme);
    throw DivergenceError(m.str());
  }
}

}  // namespace tq::coupler
