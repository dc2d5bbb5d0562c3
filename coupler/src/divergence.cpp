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
  const double forget = s_.memoryWindows > 0 ? std::pow(0.5, 1.0 / double(s_.memoryWindows)) : 0.0;
  // Every field's sums first (x², change², change · last change, change of the change²), combined
  // over the parts of a participant in parts in one go: each part holds a piece of x.
  std::vector<ExactSum> sums(4 * slices_.size());
  std::vector<std::vector<double>> deltas(slices_.size());
  for (std::size_t j = 0; j < slices_.size(); ++j) {
    const FieldSlice& f = slices_[j];
    Track& t = tracks_[j];
    if (f.offset + f.size > x.size()) continue;
    const double* xs = x.data() + f.offset;
    for (std::size_t i = 0; i < f.size; ++i) sums[4 * j].addProduct(xs[i], xs[i]);
    if (!t.hasPrev) continue;
    std::vector<double>& delta = deltas[j];
    delta.resize(f.size);
    for (std::size_t i = 0; i < f.size; ++i) {
      delta[i] = xs[i] - t.prev[i];
      sums[4 * j + 1].addProduct(delta[i], delta[i]);
    }
    if (!t.hasDelta) continue;
    for (std::size_t i = 0; i < f.size; ++i) {
      sums[4 * j + 2].addProduct(delta[i], t.prevDelta[i]);
      const double dd = delta[i] - t.prevDelta[i];
      sums[4 * j + 3].addProduct(dd, dd);
    }
  }
  sums_->combine(sums);
  for (std::size_t j = 0; j < slices_.size(); ++j) {
    const FieldSlice& f = slices_[j];
    Track& t = tracks_[j];
    const double count = double(f.count());
    if (f.count() == 0 || f.offset + f.size > x.size()) continue;
    const double* xs = x.data() + f.offset;
    t.peak = std::max(t.peak, std::sqrt(sums[4 * j].value() / count));
    if (!t.hasPrev) {
      t.prev.assign(xs, xs + f.size);
      t.hasPrev = true;
      continue;
    }
    std::vector<double> delta = std::move(deltas[j]);
    const double change = std::sqrt(sums[4 * j + 1].value() / count);
    const double floor = std::max(f.absoluteTolerance, s_.noiseFloor * t.peak);
    bool alternating = false;
    if (t.hasDelta) {
      // the alternating part of this window: half the RMS second difference (a smooth response's
      // is (ωΔ)²/2 of its change, an alternating one's equals its change)
      const double dot = sums[4 * j + 2].value(), d2 = sums[4 * j + 3].value();
      t.recent.push_back(0.5 * std::sqrt(d2 / count));
      if (change > floor && t.prevChange > floor) alternating = dot / (count * change * t.prevChange) < -0.5;
    }
    // the level: the largest alternating part of the windows before the last `windows`
    t.level *= forget;
    if (t.recent.size() > std::size_t(s_.windows)) {
      if (s_.memoryWindows > 0) t.level = std::max(t.level, t.recent.front());
      t.recent.erase(t.recent.begin());
    }
    if (alternating) {
      if (t.run == 0) t.runChanges.assign(1, t.prevChange);
      ++t.run;
      t.runChanges.push_back(change);
      if (t.runChanges.size() > std::size_t(s_.windows) + 1) t.runChanges.erase(t.runChanges.begin());
      const int span = std::min(t.run, s_.windows);
      const double amp = std::pow(change / t.runChanges[t.runChanges.size() - 1 - std::size_t(span)], 1.0 / span);
      lastAmp_ = -amp;
      if (t.run >= s_.windows && amp >= s_.growth && change > t.level) {
        std::ostringstream m;
        m.precision(3);
        m << "participant '" << who_ << "': the coupling is unstable at t = " << double(window + 1) * config_.windowSize
          << " s (window " << window + 1 << "): the interface '" << f.name
          << "' changed sign window after window, growing " << amp << "x a window over the last " << span
          << " windows: the added-mass instability of the '" << schemeName(config_.scheme)
          << "' scheme; stopped before any value overflowed. " << fixText(config_.scheme);
        throw DivergenceError(m.str());
      }
    } else {
      t.runChanges.clear();
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
