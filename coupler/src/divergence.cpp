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
std::string fixText(SchemeKind scheme) {
  std::string s = "Fix: ";
  if (scheme != SchemeKind::Implicit)
    s += "use the implicit scheme (coupling.scheme implicit, acceleration iqn-ils), which "
         "converges the interface within each window whatever the mass ratio; ";
  else
    s += "lower the initial relaxation (coupling initial_relaxation) or raise the passes "
         "per window (coupling.max_iterations); ";
  s += "or model the water as compressible (water.model compressible: the mass it adds over "
       "one window, about rho c window per unit wall area, shrinks with the window, so a "
       "smaller window then helps; with incompressible water a smaller window does not); or "
       "stiffen the wall (docs/coupler.md \"Divergence detection\", `tunnelquake check` "
       "prints the added-mass ratios).";
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
        m << "participant '" << who_ << "': the coupling is unstable: in the last " << t.run
          << " windows (up to window " << window + 1 << " of " << config_.maxWindows
          << ", t = " << double(window + 1) * config_.windowSize << " s) the interface '" << f.name
          << "' changed sign from one window to the next, and its change grew by a "
             "factor "
          << amp << " per window (RMS change " << t.runStartChange << " -> " << change
          << "): an amplification of about " << -amp
          << " per window, a mode of period two windows that no response resolved by "
             "the window of "
          << config_.windowSize << " s can have. Likely cause: the added-mass instability of the '"
          << schemeName(config_.scheme) << "' scheme";
        if (config_.scheme == SchemeKind::Explicit)
          m << " (its error is amplified by about -m_a/m per window: the water's added "
               "mass is about "
            << amp << " times the wall's mass m_a/m > 1)";
        else
          m << " (the water's added mass is large against the wall's mass)";
        m << ". The run was stopped before any value overflowed. " << fixText(config_.scheme);
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
    m << "participant '" << who_ << "': the implicit coupling iteration diverges: " << unconvergedRun_
      << " consecutive windows (up to window " << window + 1 << " of " << config_.maxWindows
      << ", t = " << double(window + 1) * config_.windowSize << " s) ended at the limit of " << config_.maxIterations
      << " passes with a growing residual (" << unconvergedResiduals_.front() << " -> " << residual << ", tolerance "
      << config_.tolerance << ", acceleration " << accelerationName(config_.acceleration)
      << "). Likely cause: a strong added-mass effect (the water's added mass large against "
         "the wall's) that the acceleration cannot absorb at this window. The run was "
         "stopped before any value overflowed. "
      << fixText(config_.scheme);
    throw DivergenceError(m.str());
  }
}

}  // namespace tq::coupler
