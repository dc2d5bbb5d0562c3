// tq-solid: explicit dynamics of rock and lining (see docs/solid_solver.md).
//
//   tq-solid solid_input.h5 [-o results.h5] [--check [--json FILE]] [--threads N]
//
// A run is a starter and an engine. The starter reads and checks the input and the mesh and
// builds the model (element blocks and materials, supports, loads, the time step, the stages). The
// engine runs it: the static stages and the switch to the seismic stage, the water coupling, the
// time loop with its results, snapshots and restart checkpoints, then the timings and the status.
// Every error leaves through one exit (SolidRun::stop): the water is told, the results file gets
// the status, stderr the message, and the exit code says which kind (tq/app/app.hpp).
#include "tq/app/app.hpp"

#include <hdf5.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "tq/app/ranked_run.hpp"
#include "tq/app/stages.hpp"
#include "tq/coupling/coupled_stepper.hpp"
#include "tq/coupling/coupling_mpi.hpp"
#include "tq/coupling/coupling_results.hpp"
#include "tq/coupling/fluid_coupling.hpp"
#include "tq/io/input.hpp"
#include "tq/io/mesh.hpp"
#include "tq/io/restart.hpp"
#include "tq/io/results.hpp"

namespace tq {

namespace {
const char* kUsage =
    "usage: tq-solid solid_input.h5 [-o results.h5] [--check [--json FILE]] [--threads N]\n"
    "                [--checkpoint-dir DIR [--resume [--resume-sequence N]]]\n"
    "  Explicit hex8 dynamics of rock and lining. Reads solid_input.h5 and the mesh.h5 it names\n"
    "  (docs/formats.md), writes results.h5 (monitors, energy balance, snapshots, timings).\n"
    "  --check      validate input and mesh, print the stable step, do not run\n"
    "  --json FILE  with --check: also write the step it found to FILE as JSON (dt, dt_critical,\n"
    "               safety, t_end, steps, block, element; every number to full double precision)\n"
    "  --threads N  OpenMP threads (default: OMP_NUM_THREADS or all cores)\n"
    "  --distributed  run on the ranks of mpirun, the model partitioned between them (tunnelquake run\n"
    "               --ranks N; docs/architecture.md \"The solid on ranks\")\n"
    "  --capabilities  list what this build can run (tunnelquake run looks for staged-seismic)\n"
    "  --checkpoint-dir DIR  write restart checkpoints there every /output checkpoint_interval s of\n"
    "               simulated time (docs/formats.md \"Restart checkpoints\")\n"
    "  --resume     continue from the last checkpoint in DIR; the results end as if never stopped\n"
    "  --resume-sequence N  continue from checkpoint N (coupled with the water: the last window both\n"
    "               sides wrote, the last checkpoint or the one before)\n"
    "  With /coupling transport mpi it is one application of an MPMD job (docs/coupler.md\n"
    "  \"tq-solid under mpirun\"): mpirun --bind-to none -np 1 tq-solid solid_input.h5 : -np N <fluid> ...\n";

// What this build runs end to end; `tunnelquake run` drives tq-solid once "staged-seismic" is here.
const char* kCapabilities =
    "elastic hex8 central-difference rayleigh-damping staged-seismic in-situ excavation lining-activation "
    "hydrostatic bonded-interface viscoelastic-base free-field incident-motion solid-input-v2 "
    "mohr-coulomb-damage dynamic-contact water-coupling restart fault-offset lining-joints";

std::string hms(double s) {
  std::ostringstream os;
  if (s >= 3600) os << int(s / 3600) << " h ";
  if (s >= 60) os << int(std::fmod(s, 3600) / 60) << " min ";
  os << int(std::fmod(s, 60)) << " s";
  return os.str();
}
/// What a restart checkpoint belongs to (runInputHash, tq/io/restart.hpp).
std::string runFingerprint(const SolidInput& in, const Solver& s) {
  return hex64(runInputHash(in.path, in.meshPath, s.dt(), in.tEnd));
}
}  // namespace

namespace {

/// The command line.
struct CommandLine : RunOptions {
  std::string checkJson;
};

}  // namespace

bool takeRunOption(const std::vector<std::string>& args, size_t& i, RunOptions& o) {
  const std::string& a = args[i];
  const bool valued = i + 1 < args.size();
  if (a == "-o" && valued) {
    o.output = args[++i];
  } else if (a == "--check") {
    o.check = true;
  } else if (a == "--threads" && valued) {
    omp_set_num_threads(std::stoi(args[++i]));
  } else if (a == "--checkpoint-dir" && valued) {
    o.checkpointDir = args[++i];
  } else if (a == "--resume") {
    o.resume = true;
  } else if (a == "--resume-sequence" && valued) {
    o.resumeSequence = std::stoll(args[++i]);
  } else if (!a.empty() && a[0] != '-' && o.input.empty()) {
    o.input = a;
  } else {
    return false;
  }
  return true;
}

namespace {

/// Reads the command line into `cl`. Returns the exit code when the command line alone ends the
/// run (help, capabilities: 0; a wrong argument: 1), else -1.
int parseCommandLine(const std::vector<std::string>& args, std::ostream& out, std::ostream& err, CommandLine& cl) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      out << kUsage;
      return 0;
    } else if (a == "--capabilities") {
      out << "tq-solid capabilities: " << kCapabilities << "\n";
      return 0;
    } else if (a == "--json" && i + 1 < args.size()) {
      cl.checkJson = args[++i];
    } else if (!takeRunOption(args, i, cl)) {
      err << "tq-solid: unknown argument '" << a << "'\n" << kUsage;
      return 1;
    }
  }
  if (!cl.checkJson.empty() && !cl.check) {
    err << "tq-solid: --json goes with --check (it writes what the check found)\n" << kUsage;
    return 1;
  }
  if (cl.input.empty() || (cl.resume && cl.checkpointDir.empty())) {
    err << (cl.input.empty() ? "" : "tq-solid: --resume needs --checkpoint-dir (where the checkpoints are)\n")
        << kUsage;
    return 1;
  }
  return -1;
}

// ---- The starter: reads, checks and builds the model ------------------------------------------

/// What the starter builds and the engine runs. Filled in place and never moved: the solver and
/// the stages refer to the input and the mesh.
struct Model {
  SolidInput in;
  Mesh mesh;
  std::unique_ptr<Solver> solver;
  std::unique_ptr<StagedAnalysis> stages;  // version 2: the staged analysis (stages.cpp)
  Index nElems = 0;
};

/// Reads and checks the input and the mesh, builds the solver (element blocks and materials,
/// supports, loads, the time step) and the stages. Throws InputError.
void startModel(const std::string& input, Model& m) {
  m.in = readSolidInput(input);
  m.mesh = readInputMesh(m.in);
  m.solver = buildSolver(m.in, m.mesh);
  m.solver->checkSubcycling(m.in.options.subcyclingLevels);  // refused now, not after the static stages
  if (m.in.staged.present) m.stages = std::make_unique<StagedAnalysis>(m.in, m.mesh, *m.solver);
  for (const auto& b : m.solver->blocks()) m.nElems += b->numElems();
}

/// The model in a few lines: its size, the integrator, the time step, the stages.
void describeModel(const Model& m, std::ostream& out) {
  const Solver& s = *m.solver;
  const StableStep st = s.stableStep();
  out << "tq-solid: " << m.mesh.numNodes() << " nodes, " << m.nElems << " elements in " << s.blocks().size()
      << " block(s), " << integratorName(s.options().integrator) << ", " << formulationName(m.in.formulation)
      << "\n  stable step " << st.dtCritical << " s (element " << st.element << " of '" << st.block
      << "'), dt = " << s.dt() << " s, " << std::llround(std::ceil(m.in.tEnd / s.dt()))
      << " steps to t_end = " << m.in.tEnd << " s, " << omp_get_max_threads() << " thread(s)\n";
  if (m.stages) {
    out << "  stages:";
    for (const auto& n : m.in.staged.stages.sequence) out << " " << n;
    out << (m.in.staged.condition.empty() ? "" : " (condition " + m.in.staged.condition + ")") << "\n";
    const std::string w = elementSizeWarning(s, m.in.staged.motion.cutoffFrequency);
    if (!w.empty()) out << "tq-solid: " << w << "\n";
  }
}

/// What --check found, for programs (`tunnelquake run` sizes the coupling window and the water's
/// step from dt): one JSON object, every number with 17 significant digits (read back exactly),
/// written to FILE.part and renamed. Throws OutputError.
void writeCheckJson(const Model& m, const std::string& file) {
  const Solver& s = *m.solver;
  const StableStep st = s.stableStep();
  std::string block;
  for (char c : st.block) {
    if (c == '"' || c == '\\') block += '\\';
    block += c;
  }
  const std::string part = file + ".part";
  {
    std::ofstream f(part);
    f << std::setprecision(17) << "{\"dt\": " << s.dt() << ", \"dt_critical\": " << st.dtCritical
      << ", \"safety\": " << s.options().safety << ", \"t_end\": " << m.in.tEnd
      << ", \"steps\": " << std::llround(std::ceil(m.in.tEnd / s.dt())) << ", \"block\": \"" << block
      << "\", \"element\": " << st.element << "}\n";
    f.close();
    if (!f) throw OutputError("cannot write " + part);
  }
  if (std::rename(part.c_str(), file.c_str()) != 0) throw OutputError("cannot rename " + part + " to " + file);
}

// ---- The engine: runs the model ---------------------------------------------------------------

/// The checkpoint folder refuses the run (another tq-solid holds it, or it has no checkpoint of
/// this run to resume from): exit 2 with the message as it is.
class CheckpointRefusal : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Exit codes (tq/app/app.hpp).
enum Exit : int { kInputError = 2, kInstability = 3, kCouplingStopped = 4, kOutputError = 5 };

/// One run of tq-solid: the starter, then the engine's parts in the order they run (exec).
class SolidRun {
 public:
  SolidRun(CommandLine cl, std::ostream& out, std::ostream& err, std::unique_ptr<CouplingMpi>& mpi)
      : cl_(std::move(cl)), out_(out), err_(err), mpi_(mpi) {}
  SolidRun(const SolidRun&) = delete;
  SolidRun& operator=(const SolidRun&) = delete;
  /// Under mpirun, how the coupling ended decides how MPI ends (runSolid ends it after this).
  ~SolidRun() {
    if (mpi_ && coupling_) mpi_->note(*coupling_);
  }
  int exec();

 private:
  // The engine, in the order exec runs it.
  void startMpi();
  void openCheckpoints();
  bool runStatics();  // false: statics only, and the run is complete
  void connectWater();
  void addCouplingSeries();
  void enableSubcycling();
  void planRepasses();
  void restoreOrStart();
  void stepToEnd();
  void finish();
  // Its parts.
  void runState(StateArchive& a);
  void writeCheckpoint(Real t);
  void flushAndReport(Real t);
  void writeStages();
  void writeCouplingSummary();
  void writeTimings(double wall);
  double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
  /// The one way out of a run that stops on an error.
  int stop(Exit code, const std::string& message, const char* label = "");

  const CommandLine cl_;
  std::ostream& out_;
  std::ostream& err_;
  std::unique_ptr<CouplingMpi>& mpi_;  // set when /coupling transport is mpi
  Model m_;
  // Restart checkpoints (tq/io/restart.hpp): every checkpoint_interval s of simulated time, at the
  // end of a step (coupled: of an accepted window), the whole state (runState); --resume restores
  // the last.
  std::unique_ptr<RestartCheckpoints> checkpoints_;
  CheckpointManifest resumeFrom_;
  std::string fingerprint_;
  StateArchive checkpointArchive_;
  long long checkpointWindows_ = 0;
  long long checkpointSeq_ = 0, checkpointsWritten_ = 0;
  Real nextCheckpoint_ = 0;
  double checkpointSeconds_ = 0;
  bool writerStarted_ = false;
  std::unique_ptr<ResultsWriter> writer_;
  std::shared_ptr<FluidCoupling> coupling_;
  std::shared_ptr<CarriedWater> water_;  // the water's laws the solid carries (null: none)
  bool stagesWritten_ = false, stepping_ = false;
  size_t nextSnap_ = 0;
  Real tFinal_ = 0, gap_ = 0;  // the last final state's time, and the span to it from the one before
  std::chrono::steady_clock::time_point t0_, lastReport_, lastFlush_;
  Index step0_ = 0;
};

int SolidRun::exec() {
  try {
    try {
      startModel(cl_.input, m_);  // the starter
      describeModel(m_, out_);
      if (cl_.check) {
        if (!cl_.checkJson.empty()) writeCheckJson(m_, cl_.checkJson);
        out_ << "tq-solid: input and mesh are valid\n";
        return 0;
      }
      startMpi();
      openCheckpoints();
      writerStarted_ = true;
      writer_ = std::make_unique<ResultsWriter>(cl_.output, m_.in, *m_.solver);
      if (m_.stages && !runStatics()) return 0;
      connectWater();
      enableSubcycling();
      restoreOrStart();
      stepToEnd();
      finish();
      return 0;
    } catch (const InputError& e) {
      return stop(kInputError, e.what(), "input error: ");
    } catch (const CheckpointRefusal& e) {
      return stop(kInputError, e.what());
    } catch (const InstabilityError& e) {
      return stop(kInstability, e.what());
    } catch (const CouplingError& e) {  // the fluid is lost, silent or refused: stop with its cause
      return stop(kCouplingStopped, e.what());
    }
  } catch (const OutputError& e) {  // the file system refused a write, also one of stop's
    return stop(kOutputError, e.what());
  }
}

int SolidRun::stop(Exit code, const std::string& message, const char* label) {
  if (coupling_ && code != kCouplingStopped) coupling_->abort("the solid stopped: " + message);
  const std::string status = "stopped: " + message;
  err_ << "tq-solid: " << label << message << "\n";
  if (code == kOutputError) {          // a full disk, a quota, an I/O error
    if (!writerStarted_) return code;  // the checkpoint folder, before the results file
    if (!writer_) {                    // the file could not even be started: nothing of it is worth keeping
      std::remove(cl_.output.c_str());
      err_ << "  no results written (" << cl_.output << " removed); free space on its file system and run again\n";
    } else if (!writer_->stopAfterOutputError(status)) {
      err_ << "  " << cl_.output << " holds the samples up to its last flush; its status could not be written\n";
    } else if (writer_->samples() == 0) {
      err_ << "  no monitor sample written yet; " << cl_.output
           << " holds the run's set-up with status 'stopped: ...'; "
           << "free space on its file system and run again\n";
    } else {
      err_ << "  results up to t = " << writer_->lastSampleTime() << " s (" << writer_->samples() << " samples) are in "
           << cl_.output << " with status 'stopped: ...'; free space on its file system and "
           << "run again\n";
    }
    return code;
  }
  if (!writer_) return code;
  if (m_.stages && !stagesWritten_) writeStages();
  if (stepping_) writeCouplingSummary();
  writer_->setStatus(status);
  if (stepping_) writeTimings(elapsed());
  if (code == kInstability || code == kCouplingStopped) err_ << "  results so far are in " << cl_.output << "\n";
  return code;
}

// MPI only for the coupling's MPI transport (docs/coupler.md "tq-solid under mpirun"); started by
// mpirun with transport tcp, tq-solid stays a plain process and couples over TCP.
void SolidRun::startMpi() {
  const CouplingInput& ci = m_.in.staged.coupling;
  if (ci.present && ci.transport == "mpi") {
    mpi_ = std::make_unique<CouplingMpi>(ci);
    if (!mpi_->problem().empty()) throw CouplingError(mpi_->problem());
    out_ << "tq-solid: " << mpi_->describe() << "\n";
    if (const std::string w = mpi_->bindingWarning(); !w.empty()) out_ << "tq-solid: warning: " << w << "\n";
  } else if (const std::string n = CouplingMpi::launchedByMpirun(); ci.present && !n.empty()) {
    out_ << "tq-solid: started by mpirun (" << n << ") but /coupling transport is tcp: coupling over TCP through '"
         << ci.addressFile << "', without MPI (set transport mpi to couple over MPI: docs/coupler.md)\n";
  }
}

// What the checkpoints belong to, and with --resume the one to continue from, checked before
// anything is written (a refused resume leaves the results file as it was).
void SolidRun::openCheckpoints() {
  if (cl_.checkpointDir.empty()) return;
  fingerprint_ = runFingerprint(m_.in, *m_.solver);
  try {
    checkpoints_ = std::make_unique<RestartCheckpoints>(cl_.checkpointDir);
  } catch (const InputError& e) {
    throw CheckpointRefusal(e.what());
  }
  // Two are kept: coupled, the water's checkpoint of a window comes after the solid's; and a resume
  // falls back to the one before the last when the last is damaged.
  checkpoints_->setKeep(2);
  if (!cl_.resume) return;
  std::string why;
  if (!checkpoints_->last(resumeFrom_, why, cl_.resumeSequence)) throw CheckpointRefusal("cannot resume: " + why);
  if (resumeFrom_.fingerprint != fingerprint_) {
    std::ostringstream os;
    os << "cannot resume from " << checkpoints_->dir() << ": its checkpoint (t = " << resumeFrom_.time
       << " s) was written for another input (the case, its mesh or its motion changed since, or this is "
          "another build of tq-solid: fingerprint "
       << resumeFrom_.fingerprint << ", this run " << fingerprint_ << "); run without --resume to start again";
    throw CheckpointRefusal(os.str());
  }
}

// Static stages (dynamic relaxation), then the switch to the seismic stage.
bool SolidRun::runStatics() {
  m_.stages->runStatics(out_, m_.in.progressSeconds);
  if (m_.stages->hasSeismic()) m_.stages->switchToDynamics(out_);
  writeStages();
  if (m_.stages->hasSeismic()) return true;
  writer_->snapshot(*m_.solver);  // statics only: the equilibrium state is the result
  writer_->setStatus("completed");
  out_ << "tq-solid: completed the static stages (no seismic stage)\n  results: " << cl_.output << "\n";
  return false;
}

void SolidRun::writeStages() {
  for (const auto& r : m_.stages->reports())
    writer_->writeStage(r.name, r.steps, r.ratio, r.converged, r.wallSeconds, r.note);
  stagesWritten_ = true;
}

// The water coupling (dynamic_water): connects to the fluid after the static stages, so the
// displacement it writes is relative to the seismic start (docs/coupler.md "Solid adapter").
void SolidRun::connectWater() {
  const CouplingInput& ci = m_.in.staged.coupling;
  if (!ci.present) return;
  Solver& s = *m_.solver;
  // The seismic stage's step: window_size / k, so that k steps make the window both sides were given
  // (InputError when above the stable step). The adapter reads it.
  if (ci.windowSize > 0) s.setTimeStep(ci.windowSize / Real(ci.windowSteps));
  water_ = CarriedWater::fromCoupling(s, ci);
  coupling_ = std::make_shared<FluidCoupling>(s, ci, water_.get());
  out_ << "tq-solid: " << coupling_->describe() << "; waiting for the fluid" << std::endl;
  if (!cl_.resume) coupling_->initialize();                 // resumed: once its state is restored (restoreOrStart)
  s.addContributor(ForcePhase::Water, coupling_);           // the exchanged force, then
  if (water_) s.addContributor(ForcePhase::Water, water_);  // the pressure the solid carries
  m_.in.tEnd = coupling_->endTime();                        // whole windows
  addCouplingSeries();
  out_ << "tq-solid: coupled with the fluid; t_end = " << m_.in.tEnd << " s (" << coupling_->windowCount()
       << " windows)" << std::endl;
}

// The coupling's histories in the results (tq/coupling/coupling_results.hpp).
void SolidRun::addCouplingSeries() { tq::addCouplingSeries(*writer_, *m_.solver, m_.in, *coupling_, water_.get()); }

// After every contributor is in: they mark their fine nodes.
void SolidRun::enableSubcycling() {
  if (m_.in.options.subcyclingLevels <= 0) return;
  reportSubcycling(m_.solver->enableSubcycling(m_.in.options.subcyclingLevels), out_, *writer_);
}

// A window the water does not accept is stepped again over what its water force can reach only
// (Solver::planRepasses); TQ_REPASS_WHOLE=1 steps every re-pass whole (the same bits, for comparison).
void SolidRun::planRepasses() {
  if (!coupling_ || !coupling_->repeatsWindows()) return;
  const char* whole = std::getenv("TQ_REPASS_WHOLE");
  if (whole && *whole && std::string(whole) != "0") {
    out_ << "tq-solid: re-passes: stepped whole (TQ_REPASS_WHOLE)" << std::endl;
    return;
  }
  const Solver::RepassPlan p = m_.solver->planRepasses(coupling_->nodes(), coupling_->windowSteps());
  if (!p.why.empty()) {
    out_ << "tq-solid: re-passes: stepped whole: " << p.why << std::endl;
    return;
  }
  out_ << "tq-solid: re-passes: " << p.skippedChunks << " of " << p.chunks << " element chunks (" << p.skippedElements
       << " of " << p.elements << " elements) out of the water's reach within a window, left as the window's first "
       << "pass left them; " << p.replayNodes << " nodes take their internal force from it" << std::endl;
  if (p.whyNodes.empty())
    out_ << "tq-solid: re-passes: " << p.frozenNodeChunks << " of " << p.nodeChunks << " node chunks (" << p.frozenNodes
         << " nodes) read by nothing a re-pass steps, neither restored nor updated by it" << std::endl;
  else
    out_ << "tq-solid: re-passes: every node chunk stepped: " << p.whyNodes << std::endl;
}

// Everything a checkpoint holds, in this order (saved and restored alike).
void SolidRun::runState(StateArchive& a) {
  m_.solver->checkpoint(a);
  writer_->checkpoint(a);
  a.io(tFinal_);
  a.io(gap_);
  a.io(nextSnap_);
  a.io(nextCheckpoint_);
  a.io(checkpointSeq_);
  if (coupling_) coupling_->restartState(a);
}

// The start of the seismic record: from the checkpoint with --resume, else the first sample.
void SolidRun::restoreOrStart() {
  Solver& s = *m_.solver;
  tFinal_ = s.time();
  nextCheckpoint_ = m_.in.checkpointInterval;
  // Coupled with the water: a checkpoint at the end of every K-th window, K as /coupling
  // checkpoint_windows gives it (the water is given the same K).
  checkpointWindows_ =
      coupling_ && m_.in.checkpointInterval > 0 ? std::max<long long>(1, m_.in.staged.coupling.checkpointWindows) : 0;
  if (!cl_.resume) {
    if (checkpoints_) checkpoints_->clear();
    writer_->sample(s);
    return;
  }
  const CheckpointManifest& m = resumeFrom_;
  try {  // a build whose parts list other state: the archive's own checks (tq/core/state_archive.hpp)
    checkpoints_->read(m, checkpointArchive_);
    checkpointArchive_.beginRestore();
    runState(checkpointArchive_);
    checkpointArchive_.end();
  } catch (const std::exception& e) {
    throw CheckpointRefusal("cannot resume from " + checkpoints_->file(m.solid) + ": " + e.what() +
                            "; run without --resume to start again");
  }
  writer_->resumeFrom(checkpoints_->file(m.results), s);
  out_ << "tq-solid: resumed from checkpoint " << m.sequence << " at t = " << m.time << " s (step " << m.step << ", "
       << m.samples << " samples" << (m.window >= 0 ? ", coupling window " + std::to_string(m.window) : "") << ")"
       << std::endl;
  if (coupling_) coupling_->initializeResumed();
}

// The time loop: a step, or with the water a coupling window (CoupledStepper: an implicit window of
// several steps the water did not accept is stepped again from its start); results are sampled at
// the final states.
void SolidRun::stepToEnd() {
  Solver& s = *m_.solver;
  ResultsWriter& results = *writer_;
  t0_ = lastReport_ = lastFlush_ = std::chrono::steady_clock::now();
  step0_ = s.stepCount();
  CoupledStepper stepper(s, coupling_.get());
  planRepasses();
  stepping_ = true;
  // the kinetic energy summed only for the final states the balance is read at
  const auto wantKinetic = [&] { stepper.askKineticEnergy(results.nextSampleTime(), m_.in.tEnd); };
  const auto onFinal = [&] {
    if (coupling_) {
      const std::string note = coupling_->takeNote();
      if (!note.empty()) out_ << "tq-solid: " << note << std::endl;
    }
    const Real t = s.time();
    gap_ = t - tFinal_;
    tFinal_ = t;
    // The histories are written at k x monitor_dt, interpolated between the final states on
    // either side: observe this state when a requested time falls before the next final state
    // (expected one step, or window, on).
    if (t + gap_ >= results.nextSampleTime() - 1e-9 * gap_) results.sample(s);
    while (nextSnap_ < m_.in.snapshotTimes.size() && t >= m_.in.snapshotTimes[nextSnap_] - 0.5 * s.dt()) {
      results.snapshot(s);
      ++nextSnap_;
    }
    writeCheckpoint(t);
    flushAndReport(t);
    wantKinetic();
  };
  wantKinetic();
  try {
    while (s.time() < m_.in.tEnd - 1e-9 * s.dt() && (!coupling_ || coupling_->ongoing())) stepper.advance(onFinal);
  } catch (const CouplingError&) {
    // The state the fluid was lost at is the last sample where it is final: a one-step window's (its
    // step is predicted again when the water answers). Inside an implicit window of several steps
    // it is one the water never accepted: the histories end with the last window it accepted.
    if (!coupling_ || !coupling_->repeatsWindows()) results.sample(s);
    throw;
  }
  s.setKineticEnergyWanted(true);
}

// A restart checkpoint when one is due (none at the end: the results are then whole).
void SolidRun::writeCheckpoint(Real t) {
  const Solver& s = *m_.solver;
  const Real tEnd = m_.in.tEnd;
  const bool due =
      coupling_
          ? checkpointWindows_ > 0 && !coupling_->windowOpen() && coupling_->windowsDone() % checkpointWindows_ == 0 &&
                coupling_->windowsDone() < coupling_->windowCount()
          : m_.in.checkpointInterval > 0 && t >= nextCheckpoint_ - 1e-9 * s.dt() && t < tEnd - 1e-9 * s.dt();
  if (!checkpoints_ || !due) return;
  const auto c0 = std::chrono::steady_clock::now();
  while (t >= nextCheckpoint_ - 1e-9 * s.dt()) nextCheckpoint_ += m_.in.checkpointInterval;
  ++checkpointSeq_;
  writer_->flush();
  lastFlush_ = c0;
  checkpointArchive_.beginSave();
  runState(checkpointArchive_);
  checkpointArchive_.end();
  CheckpointManifest m;
  m.sequence = checkpointSeq_;
  m.time = t;
  m.step = s.stepCount();
  m.samples = writer_->samples();
  m.window = coupling_ ? coupling_->windowsDone() : -1;
  m.fingerprint = fingerprint_;
  m.inputs = inputDigest(m_.in.staged.inputFingerprint);
  checkpoints_->write(m, checkpointArchive_, writer_->path());
  ++checkpointsWritten_;
  checkpointSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
}

// The results flushed every 2 s of wall time; progress every progress_seconds.
void SolidRun::flushAndReport(Real t) {
  const Solver& s = *m_.solver;
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - lastFlush_).count() > 2.0) {
    writer_->flush();
    lastFlush_ = now;
  }
  if (std::chrono::duration<double>(now - lastReport_).count() < m_.in.progressSeconds) return;
  const double wall = elapsed(), rate = double(s.stepCount() - step0_) / wall;
  const double left = (m_.in.tEnd - t) / s.dt() / rate;
  out_ << "  t = " << std::setprecision(5) << t << " s / " << m_.in.tEnd << " s (" << std::setprecision(3)
       << 100 * t / m_.in.tEnd << " %), step " << s.stepCount() << ", " << std::setprecision(4) << rate
       << " steps/s, energy error " << std::setprecision(2) << s.checkedEnergyError()
       << " (t = " << std::setprecision(5) << s.checkedEnergyTime() << " s), ETA " << hms(left) << std::endl;
  lastReport_ = now;
}

void SolidRun::writeCouplingSummary() {
  if (coupling_) tq::writeCouplingSummary(*writer_, m_.in.staged.coupling, *coupling_, water_.get());
}

void SolidRun::writeTimings(double wall) {
  const long long steps = m_.solver->stepCount() - step0_;
  writer_->writeTimings(wall, steps, steps * m_.nElems, omp_get_max_threads());
}

// The end of a complete run: the water's last window, the timings and the status.
void SolidRun::finish() {
  if (coupling_) {
    coupling_->finalize();
    writeCouplingSummary();
    const FluidCouplingStats cs = coupling_->stats();
    if (cs.unconvergedWindows > 0)
      err_ << "tq-solid: warning: " << cs.unconvergedWindows << " of " << cs.windows
           << " coupling windows ended at the pass limit (coupling.max_iterations = "
           << m_.in.staged.coupling.maxIterations << ") with the interface residual above the tolerance "
           << m_.in.staged.coupling.tolerance
           << ": the water and the lining disagree there by more than asked. Raise coupling.max_iterations, or "
              "check the added-mass ratio (`tunnelquake check`, docs/coupler.md); /coupling unconverged_windows in "
              "the results counts them.\n";
  }
  const double wall = elapsed();
  const long long steps = m_.solver->stepCount() - step0_;
  writeTimings(wall);
  if (checkpoints_) {
    writer_->writeAttrs("/timings", {{"checkpoints", double(checkpointsWritten_)},
                                     {"checkpoint_s", checkpointSeconds_},
                                     {"checkpoint_interval", m_.in.checkpointInterval}});
  }
  writer_->setStatus("completed");
  if (checkpoints_) checkpoints_->clear();  // the results are whole: nothing left to resume
  out_ << "tq-solid: completed " << steps << " steps in " << hms(wall) << " ("
       << (steps > 0 ? 1e6 * wall / (double(steps) * m_.nElems) : 0.0) << " µs per element-step), energy error "
       << std::setprecision(3) << m_.solver->checkedEnergyError() << " (t = " << std::setprecision(6)
       << m_.solver->checkedEnergyTime() << " s)\n  results: " << cl_.output << "\n";
}

/// The whole run; `mpi` is set when /coupling transport is mpi (tq-solid under mpirun), and
/// runSolid ends MPI after this returns (results.h5 closed by then).
int runSolidBody(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
                 std::unique_ptr<CouplingMpi>& mpi) {
  CommandLine cl;
  if (const int rc = parseCommandLine(args, out, err, cl); rc >= 0) return rc;
  SolidRun run(std::move(cl), out, err, mpi);
  return run.exec();
}

}  // namespace

void reportSubcycling(const SubcyclingInfo& sc, std::ostream& out, ResultsWriter& writer) {
  std::ostringstream os;
  os << "tq-solid: subcycling: steps of 1";
  for (int l = 1; l <= sc.levels; ++l) os << ", " << (1 << l);
  os << " x dt for";
  for (size_t l = 0; l < sc.elements.size(); ++l) os << (l ? ", " : " ") << sc.elements[l];
  os << " elements (";
  for (size_t l = 0; l < sc.nodes.size(); ++l) os << (l ? ", " : "") << sc.nodes[l];
  os << " nodes): " << std::setprecision(3) << sc.costFraction << " of the element evaluations of one step for all\n";
  out << os.str();
  std::map<std::string, double> attrs{{"levels", double(sc.levels)}, {"cost_fraction", sc.costFraction}};
  for (size_t l = 0; l < sc.elements.size(); ++l) {
    attrs["elements_level_" + std::to_string(l)] = double(sc.elements[l]);
    attrs["nodes_level_" + std::to_string(l)] = double(sc.nodes[l]);
  }
  writer.writeAttrs("/subcycling", attrs, {});
}

int runSolid(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  // HDF5 closes what is still open at exit; a file whose flush failed then crashes it
  // (H5F__close_cb). Every file here is closed by its owner, so that pass is left out.
  H5dont_atexit();
  if (wantsRankedRun(args)) return runSolidOnRanks(args, out, err);  // on MPI ranks (tq/parallel/)
  std::unique_ptr<CouplingMpi> mpi;
  int rc = 0;
  try {
    rc = runSolidBody(args, out, err, mpi);
  } catch (const std::exception& e) {
    if (!mpi) throw;
    err << "tq-solid: error: " << e.what() << "\n";  // under mpirun: say it, then end MPI below
    rc = 1;
  }
  if (mpi) rc = mpi->finish(rc, err);
  return rc;
}

}  // namespace tq
