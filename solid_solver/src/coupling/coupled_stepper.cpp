// tq-solid's time-loop step with the water coupling (tq/coupling/coupled_stepper.hpp).
#include "tq/coupling/coupled_stepper.hpp"

namespace tq {

void CoupledStepper::advance(const std::function<void()>& onFinal) {
  if (coupling_) return window(onFinal);
  solver_.step();
  ++steps_;
  onFinal();
}

// One coupling window, the protocol: save, solve the window, exchange, accept or restore.
// An implicit window of k > 1 steps the water did not accept is stepped again whole from the solver's
// state saved at its start. A one-step window is not stepped back: its one step is still open (begun,
// not finished) when the water answers, so the next pass predicts that same step again.
void CoupledStepper::window(const std::function<void()>& onFinal) {
  WindowCoupling& c = *coupling_;
  const bool whole = c.repeatsWindows();
  if (whole) {                 // save
    solver_.beginPass(false);  // what a re-pass restores; the first pass records what it takes from it
    start_.beginSave();
    solver_.checkpoint(start_);
    start_.end();
  }
  c.planWindow(solver_.state());
  for (;;) {
    if (!solver_.stepOpen()) solveWindow(!whole, onFinal);  // steps 1 … k−1, the last one's other forces
    if (c.exchange(solver_.dt(), solver_.state())) break;   // accepted
    if (whole) {                                            // restore: the window again, with the answer
      solver_.beginPass(true);                              // what the re-pass steps again (Solver::planRepasses)
      start_.beginRestore();
      solver_.checkpoint(start_);
      start_.end();
      ++restores_;
    }
  }
  if (whole) solver_.endPasses();
  solver_.finishStep();  // the last step with the accepted force (and the water the solid carries)
  c.acceptWindow();
  onFinal();
}

// The window up to its exchange: its steps 1 … k−1 with the plan's forces, then the last step's forces
// of the phases before the water's.
void CoupledStepper::solveWindow(bool stepsAreFinal, const std::function<void()>& onFinal) {
  for (Index j = 1; j < coupling_->windowSteps(); ++j) {
    coupling_->planStep(j, solver_.dt());
    solver_.step();
    ++steps_;
    if (stepsAreFinal) onFinal();
  }
  solver_.beginStep();
  ++steps_;
}

}  // namespace tq
