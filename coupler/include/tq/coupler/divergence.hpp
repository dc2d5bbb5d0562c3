#pragma once
/// @file divergence.hpp
/// Detection of a coupling instability during the run, before any value overflows
/// (docs/coupler.md "Divergence detection").
///
/// What separates numerical from physical growth: a response the coupling window resolves
/// changes smoothly from window to window, so two consecutive changes of the interface data,
/// Δ_n = x_n − x_{n−1} and Δ_{n−1}, point the same way (their cosine is near +1, below zero only
/// at an isolated extremum), whether the response decays, oscillates or grows (a resonant forced
/// response grows by a factor 1 + O(ωΔt) per window). The added-mass instability of a staggered
/// scheme is the opposite: its error has the amplification factor λ ≈ −m_a/m per window (explicit
/// scheme), a mode of period two windows that no physical response resolved by the window can
/// have: consecutive changes point in opposite directions window after window and grow by |λ|.
/// The monitor flags a window as alternating when cos(Δ_n, Δ_{n−1}) < −½ and both changes are
/// above the noise floor, and stops the run when the last `windows` windows all alternate, the
/// change grew by at least `growth` per window on average over them, and it passed the level the
/// alternating part held before them. A window's alternating part is half the RMS of its second
/// difference Δ_n − Δ_{n−1} (equal to the change of a signal alternating in sign, (ωΔ)²/2 of the
/// change of a response the windows resolve); the level is its largest value over the earlier
/// windows, a memory that halves every `memoryWindows` windows. The level test separates a mode the
/// scheme amplifies, which grows past every earlier level, from a decaying oscillation the windows
/// sample at period two (a response near the window's Nyquist frequency, several modes beating),
/// whose change recovers by 2x or more from each dip of its beat within 8 windows but stays below
/// the level it held before the dip. The growth is taken over the last `windows` windows, not since
/// the run began, so a mode that grows inside a longer alternating oscillation is stopped once it
/// dominates it. An implicit scheme that
/// reaches its pass limit in `unconverged` consecutive windows with a residual that grows in each
/// and by `residualGrowth` over them is stopped too (a residual that stagnates near the tolerance
/// is not: that is a slow iteration, counted in SchemeState::unconvergedWindows).

#include <cstdint>
#include <string>
#include <vector>

#include "tq/coupler/config.hpp"
#include "tq/coupler/scheme.hpp"

namespace tq::coupler {

struct DivergenceSettings {
  int windows = 8;             ///< consecutive alternating windows before stopping
  double growth = 1.1;         ///< least mean growth per window of the alternating change
  int unconverged = 5;         ///< consecutive unconverged implicit windows with growing residual
  double residualGrowth = 10;  ///< ... that grew by at least this factor over them
  double noiseFloor = 1e-9;    ///< with no absolute tolerance: the floor relative to the peak RMS
  int memoryWindows = 4000;    ///< half-life (windows) of the remembered alternating level; 0: none
};

class DivergenceMonitor {
 public:
  /// `slices`: the monitored fields in `x` (normally the data the partner sends);
  /// `who`: the participant named in the message.
  DivergenceMonitor(const CouplingConfig& c, std::vector<FieldSlice> slices, std::string who,
                    DivergenceSettings s = {});
  /// After every completed window: its final data and the scheme's state (residual and
  /// whether the window ended at the pass limit). Throws DivergenceError naming the likely
  /// cause and the fix.
  void windowDone(std::uint64_t window, const std::vector<double>& x, bool unconverged, double residual);
  /// x is this part's piece of a participant in parts: the sums are completed over every part.
  void useSums(const SumCombiner& s) { sums_ = &s; }
  /// Estimated amplification per window of the alternating mode (0 when none seen).
  double lastAmplification() const { return lastAmp_; }
  /// Restart checkpoints: save or restore the windows' history.
  void checkpoint(StateIo& io) {
    std::uint64_t n = tracks_.size();
    io.io(n);
    if (!io.saving()) tracks_.resize(std::size_t(n));
    for (auto& t : tracks_) {
      io.io(t.prev);
      io.io(t.prevDelta);
      io.io(t.prevChange);
      io.io(t.peak);
      io.io(t.run);
      io.io(t.runChanges);
      io.io(t.recent);
      io.io(t.level);
      io.io(t.hasPrev);
      io.io(t.hasDelta);
    }
    io.io(unconvergedRun_);
    io.io(unconvergedResiduals_);
    io.io(lastAmp_);
  }

 private:
  struct Track {
    std::vector<double> prev, prevDelta;
    double prevChange = 0, peak = 0;
    int run = 0;
    // the change before the current run of alternating windows, then the run's changes (at most the
    // last `windows` + 1)
    std::vector<double> runChanges;
    // the alternating part (half the RMS second difference) of the last `windows` windows, and the
    // level: the largest of the windows before them, forgotten at the half-life memoryWindows
    std::vector<double> recent;
    double level = 0;
    bool hasPrev = false, hasDelta = false;
  };
  const CouplingConfig& config_;
  std::vector<FieldSlice> slices_;
  std::string who_;
  DivergenceSettings s_;
  std::vector<Track> tracks_;
  int unconvergedRun_ = 0;
  std::vector<double> unconvergedResiduals_;
  double lastAmp_ = 0;
  const SumCombiner* sums_ = &onePiece_;
  static inline const OnePiece onePiece_{};
};

}  // namespace tq::coupler
