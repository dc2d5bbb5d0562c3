// tq-solid: explicit dynamics of rock and lining (see docs/solid_solver.md).
//
//   tq-solid solid_input.h5 [-o results.h5] [--check] [--threads N]
//
// Steps: 1. read and check the input and the mesh; 2. build blocks, supports and loads; 3. pick
// and check the time step; 4. integrate to t_end writing monitors, energies and snapshots;
// 5. write timings and the final status.
#include "tq/app/app.hpp"

#include <hdf5.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "tq/coupling/fluid_coupling.hpp"
#include "tq/io/input.hpp"
#include "tq/io/restart.hpp"
#include "tq/io/results.hpp"
#include "tq/app/stages.hpp"

namespace tq {

namespace {
const char* kUsage =
    "usage: tq-solid solid_input.h5 [-o results.h5] [--check] [--threads N] [--checkpoint-dir DIR [--resume [--resume-sequence N]]]\n"
    "  Explicit hex8 dynamics of rock and lining. Reads solid_input.h5 and the mesh.h5 it names\n"
    "  (docs/formats.md), writes results.h5 (monitors, energy balance, snapshots, timings).\n"
    "  --check      validate input and mesh, print the stable step, do not run\n"
    "  --threads N  OpenMP threads (default: OMP_NUM_THREADS or all cores)\n"
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
    "hydrostatic bonded-interface viscoelastic-base free-field incident-motion solid-input-v1 solid-input-v2 "
    "mohr-coulomb-damage dynamic-contact water-coupling restart";

std::string hms(double s) {
  std::ostringstream os;
  if (s >= 3600) os << int(s / 3600) << " h ";
  if (s >= 60) os << int(std::fmod(s, 3600) / 60) << " min ";
  os << int(std::fmod(s, 60)) << " s";
  return os.str();
}
/// What a restart checkpoint belongs to: the bytes of the input and mesh files (every setting,
/// the motion, the mesh), the step and the end (a build whose parts save other state is caught by
/// the archive's own checks on restore).
std::string runFingerprint(const SolidInput& in, const Solver& s) {
  std::uint64_t h = fnv1a(nullptr, 0);
  for (const std::string& path : {in.path, in.meshPath}) {
    std::ifstream is(path, std::ios::binary);
    std::vector<char> buf(1 << 16);
    while (is.read(buf.data(), std::streamsize(buf.size())) || is.gcount() > 0)
      h = fnv1a(buf.data(), size_t(is.gcount()), h);
  }
  const Real numbers[2] = {s.dt(), in.tEnd};
  return hex64(fnv1a(numbers, sizeof numbers, h));
}
}  // namespace

namespace {

/// The whole run; `mpi` is set when /coupling transport is mpi (tq-solid under mpirun), and
/// runSolid ends MPI after this returns (results.h5 closed by then).
int runSolidBody(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
                 std::unique_ptr<CouplingMpi>& mpi) {
  std::string input, output = "results.h5", checkpointDir;
  bool check = false, resume = false;
  long long resumeSequence = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      out << kUsage;
      return 0;
    } else if (a == "-o" && i + 1 < args.size()) {
      output = args[++i];
    } else if (a == "--capabilities") {
      out << "tq-solid capabilities: " << kCapabilities << "\n";
      return 0;
    } else if (a == "--check") {
      check = true;
    } else if (a == "--checkpoint-dir" && i + 1 < args.size()) {
      checkpointDir = args[++i];
    } else if (a == "--resume") {
      resume = true;
    } else if (a == "--resume-sequence" && i + 1 < args.size()) {
      resumeSequence = std::stoll(args[++i]);
    } else if (a == "--threads" && i + 1 < args.size()) {
      omp_set_num_threads(std::stoi(args[++i]));
    } else if (!a.empty() && a[0] != '-' && input.empty()) {
      input = a;
    } else {
      err << "tq-solid: unknown argument '" << a << "'\n" << kUsage;
      return 1;
    }
  }
  if (input.empty() || (resume && checkpointDir.empty())) {
    err << (input.empty() ? "" : "tq-solid: --resume needs --checkpoint-dir (where the checkpoints are)\n") << kUsage;
    return 1;
  }
  // 1-3. Input, mesh, solver, time step (the "starter").
  SolidInput in;
  Mesh mesh;
  std::unique_ptr<Solver> solver;
  std::unique_ptr<StagedAnalysis> stages;  // version 2: the staged analysis (stages.cpp)
  try {
    in = readSolidInput(input);
    mesh = readMeshH5(in.meshPath, {in.requiredFaces});
    solver = buildSolver(in, mesh);
    if (in.staged.present) stages = std::make_unique<StagedAnalysis>(in, mesh, *solver);
  } catch (const InputError& e) {
    err << "tq-solid: input error: " << e.what() << "\n";
    return 2;
  }
  Solver& s = *solver;
  const StableStep st = s.stableStep();
  Index nElems = 0;
  for (const auto& b : s.blocks()) nElems += b->numElems();
  out << "tq-solid: " << mesh.numNodes() << " nodes, " << nElems << " elements in " << s.blocks().size()
      << " block(s), " << integratorName(s.options().integrator) << ", " << formulationName(in.formulation)
      << "\n  stable step " << st.dtCritical << " s (element " << st.element << " of '" << st.block
      << "'), dt = " << s.dt() << " s, " << std::llround(std::ceil(in.tEnd / s.dt())) << " steps to t_end = "
      << in.tEnd << " s, " << omp_get_max_threads() << " thread(s)\n";
  if (stages) {
    out << "  stages:";
    for (const auto& n : in.staged.stages.sequence) out << " " << n;
    out << (in.staged.condition.empty() ? "" : " (condition " + in.staged.condition + ")") << "\n";
    const std::string w = elementSizeWarning(s, in.staged.motion.cutoffFrequency);
    if (!w.empty()) out << "tq-solid: " << w << "\n";
  }
  if (check) {
    out << "tq-solid: input and mesh are valid\n";
    return 0;
  }
  // MPI only for the coupling's MPI transport (docs/coupler.md "tq-solid under mpirun"); started by
  // mpirun with transport tcp, tq-solid stays a plain process and couples over TCP.
  const CouplingInput& ci = in.staged.coupling;
  if (ci.present && ci.transport == "mpi") {
    mpi = std::make_unique<CouplingMpi>(ci);
    if (!mpi->problem().empty()) {
      err << "tq-solid: " << mpi->problem() << "\n";
      return 4;
    }
    out << "tq-solid: " << mpi->describe() << "\n";
    if (const std::string w = mpi->bindingWarning(); !w.empty()) out << "tq-solid: warning: " << w << "\n";
  } else if (const std::string n = CouplingMpi::launchedByMpirun(); ci.present && !n.empty()) {
    out << "tq-solid: started by mpirun (" << n << ") but /coupling transport is tcp: coupling over TCP through '"
        << ci.addressFile << "', without MPI (set transport mpi to couple over MPI: docs/coupler.md)\n";
  }
  // Restart checkpoints (tq/io/restart.hpp): what they belong to, and with --resume the one to continue
  // from, checked before anything is written (a refused resume leaves the results file as it was).
  std::unique_ptr<RestartCheckpoints> checkpoints;
  CheckpointManifest resumeFrom;
  const std::string fingerprint = runFingerprint(in, s);
  if (!checkpointDir.empty()) {
    try {
      checkpoints = std::make_unique<RestartCheckpoints>(checkpointDir);
      if (ci.present) checkpoints->setKeep(2);  // the water's checkpoint of a window comes after the solid's
    } catch (const OutputError& e) {
      err << "tq-solid: " << e.what() << "\n";
      return 5;
    } catch (const InputError& e) {
      err << "tq-solid: " << e.what() << "\n";
      return 2;
    }
    std::string why;
    if (resume && !checkpoints->last(resumeFrom, why, resumeSequence)) {
      err << "tq-solid: cannot resume: " << why << "\n";
      return 2;
    }
    if (resume && resumeFrom.fingerprint != fingerprint) {
      err << "tq-solid: cannot resume from " << checkpoints->dir() << ": its checkpoint (t = " << resumeFrom.time
          << " s) was written for another input (the case, its mesh or its motion changed since, or this is "
             "another build of tq-solid: fingerprint "
          << resumeFrom.fingerprint << ", this run " << fingerprint << "); run without --resume to start again\n";
      return 2;
    }
  }
  // 4. Time loop (the "engine"), in `engine` below. A write the file system refuses (a full disk,
  //    a quota, an I/O error) ends it from anywhere with an OutputError: the water is told to
  //    stop, the status is written into the samples already there, and tq-solid exits 5.
  std::unique_ptr<ResultsWriter> writer;
  std::shared_ptr<FluidCoupling> coupling;
  auto engine = [&]() -> int {
    ResultsWriter& results = *writer;
    if (stages) {  // 4a. Static stages (dynamic relaxation), then the switch to the seismic stage.
      auto writeStages = [&] {
        for (const auto& r : stages->reports())
          results.writeStage(r.name, r.steps, r.ratio, r.converged, r.wallSeconds, r.note);
      };
      try {
        stages->runStatics(out, in.progressSeconds);
        if (stages->hasSeismic()) stages->switchToDynamics(out);
      } catch (const InstabilityError& e) {
        writeStages();
        results.setStatus(std::string("stopped: ") + e.what());
        err << "tq-solid: " << e.what() << "\n  results so far are in " << output << "\n";
        return 3;
      } catch (const InputError& e) {
        results.setStatus(std::string("stopped: ") + e.what());
        err << "tq-solid: input error: " << e.what() << "\n";
        return 2;
      }
      writeStages();
      if (!stages->hasSeismic()) {  // statics only: the equilibrium state is the result
        results.snapshot(s);
        results.setStatus("completed");
        out << "tq-solid: completed the static stages (no seismic stage)\n  results: " << output << "\n";
        return 0;
      }
    }
    // 4b. The water coupling (dynamic_water): connects to the fluid after the static stages, so the
    //     displacement it writes is relative to the seismic start (docs/coupler.md "Solid adapter").
    // Under mpirun, how the coupling ended decides how MPI ends: noted on every way out of here.
    struct NoteForMpi {
      CouplingMpi* mpi;
      const std::shared_ptr<FluidCoupling>& c;
      ~NoteForMpi() {
        if (mpi && c) mpi->note(*c);
      }
    } noteForMpi{mpi.get(), coupling};
    if (in.staged.coupling.present) {
      try {
        coupling = std::make_shared<FluidCoupling>(s, in.staged.coupling, in.tEnd);
        out << "tq-solid: " << coupling->describe() << "; waiting for the fluid" << std::endl;
        if (!resume) coupling->initialize();  // resumed: once its state is restored (below)
        s.addContributor(ForcePhase::Water, coupling);
        in.tEnd = coupling->endTime();  // whole windows
        results.addSeries("/energy/fluid_work", [c = coupling.get()] { return c->fluidWork(); }, "fluid_work");
        results.addSeries("/energy/fluid_received_work", [c = coupling.get()] { return c->fluidReceivedWork(); },
                          "fluid_received_work");
        results.addSeries("/energy/coupling_energy", [c = coupling.get()] { return c->couplingEnergy(); },
                          "coupling_energy");
        if (coupling->hasVolumeLaw())
          results.addSeries("/coupling/volume_pressure", [c = coupling.get()] { return c->volumePressure(); },
                            "volume_pressure");
        results.addWaterPressure(s.mesh(), in.staged.coupling.face, in.monitors, coupling->nodes(),
                                 [c = coupling.get()]() -> const std::vector<Real>& { return c->force(); });
        // The wetted face as a whole (docs/verification.md, the rigidly shaken lining): the total interface
        // force R3 the coupling added (N) and the mass-weighted mean acceleration a^n of its nodes
        // (m/s²), both of the same step, per direction.
        for (int d = 0; d < 3; ++d) {
          const std::string axis(1, "xyz"[d]);
          results.addSeries("/coupling/force_" + axis, [c = coupling.get(), d] {
            Real sum = 0;
            const auto& F = c->force();
            for (size_t k = 0; k < c->nodes().size(); ++k) sum += F[3 * k + size_t(d)];
            return sum;
          }, "force_" + axis);
          results.addSeries("/coupling/acceleration_" + axis, [c = coupling.get(), &s, d] {
            Real ma = 0, m = 0;
            for (Index n : c->nodes()) {
              ma += s.state().mass(n) * s.state().a(n, d);
              m += s.state().mass(n);
            }
            return m > 0 ? ma / m : Real(0);
          }, "acceleration_" + axis);
        }
        out << "tq-solid: coupled with the fluid; t_end = " << in.tEnd << " s (" << coupling->windowCount()
            << " windows)" << std::endl;
      } catch (const InputError& e) {
        if (coupling) coupling->abort(e.what());
        results.setStatus(std::string("stopped: ") + e.what());
        err << "tq-solid: input error: " << e.what() << "\n";
        return 2;
      } catch (const CouplingError& e) {
        results.setStatus(std::string("stopped: ") + e.what());
        err << "tq-solid: " << e.what() << "\n  results so far are in " << output << "\n";
        return 4;
      }
    }
    auto couplingSummary = [&] {
      if (!coupling) return;
      const FluidCouplingStats cs = coupling->stats();
      results.writeAttrs("/coupling", {{"windows", double(cs.windows)}, {"passes", double(cs.passes)},
                                       {"max_passes", double(cs.maxPasses)}, {"exchange_s", cs.secondsExchanging},
                                       {"unconverged_windows", double(cs.unconvergedWindows)},
                                       {"window_size", coupling->windowSize()}, {"fluid_work", coupling->fluidWork()},
                                       {"fluid_received_work", coupling->fluidReceivedWork()},
                                       {"coupling_energy", coupling->couplingEnergy()},
                                       {"volume_law_work", coupling->volumeLawWork()},
                                       {"enclosed_volume", coupling->enclosedVolume()},
                                       {"interface_work_peak", coupling->interfaceWorkPeak()},
                                       {"energy_floor", coupling->energyFloor()},
                                       {"energy_limit", in.staged.coupling.energyLimit},
                                       // cost split over the stepping (docs/coupler.md "Exchange cost")
                                       {"coupled_wall_s", cs.secondsCoupled},
                                       {"solid_s", cs.secondsCoupled - cs.secondsInCoupler},
                                       {"coupler_s", cs.secondsInCoupler},
                                       {"exchange_wait_s", cs.secondsWaiting},
                                       {"exchange_work_s", cs.secondsInCoupler - cs.secondsWaiting},
                                       {"mapping_s", cs.secondsMapping},
                                       {"solid_cpu_s", cs.cpuCoupled - cs.cpuInCoupler},
                                       {"coupler_cpu_s", cs.cpuInCoupler}},
                         {{"scheme", in.staged.coupling.scheme}});
  };
  if (in.options.subcyclingLevels > 0) {  // after every contributor is in: they mark their fine nodes
    try {
      const SubcyclingInfo sc = s.enableSubcycling(in.options.subcyclingLevels);
      std::ostringstream os;
      os << "tq-solid: subcycling: steps of 1";
      for (int l = 1; l <= sc.levels; ++l) os << ", " << (1 << l);
      os << " x dt for";
      for (size_t l = 0; l < sc.elements.size(); ++l) os << (l ? ", " : " ") << sc.elements[l];
      os << " elements (";
      for (size_t l = 0; l < sc.nodes.size(); ++l) os << (l ? ", " : "") << sc.nodes[l];
      os << " nodes): " << std::setprecision(3) << sc.costFraction
         << " of the element evaluations of one step for all\n";
      out << os.str();
      std::map<std::string, double> attrs{{"levels", double(sc.levels)},
                                                        {"cost_fraction", sc.costFraction}};
      for (size_t l = 0; l < sc.elements.size(); ++l) {
        attrs["elements_level_" + std::to_string(l)] = double(sc.elements[l]);
        attrs["nodes_level_" + std::to_string(l)] = double(sc.nodes[l]);
      }
      results.writeAttrs("/subcycling", attrs, {});
    } catch (const InputError& e) {
      if (coupling) coupling->abort(e.what());
      results.setStatus(std::string("stopped: ") + e.what());
      err << "tq-solid: input error: " << e.what() << "\n";
      return 2;
    }
  }
  // Restart checkpoints (tq/io/restart.hpp): every checkpoint_interval s of simulated time, at the end
  // of a step (coupled: of an accepted window), the whole state below; --resume restores the last.
  size_t nextSnap = 0;
  Real tFinal = s.time(), gap = 0;  // the last final state's time, and the span to it from the one before
  Real nextCheckpoint = in.checkpointInterval;
  long long checkpointSeq = 0, checkpointsWritten = 0;
  double checkpointSeconds = 0;
  auto runState = [&](StateArchive& a) {
    s.checkpoint(a);
    results.checkpoint(a);
    a.io(tFinal);
    a.io(gap);
    a.io(nextSnap);
    a.io(nextCheckpoint);
    a.io(checkpointSeq);
    if (coupling) coupling->restartState(a);
  };
  // Coupled with the water: a checkpoint at the end of every K-th window (K = the interval in
  // windows, at least 1), a rule the water applies to its own window count too.
  const long long checkpointWindows =
      coupling && in.checkpointInterval > 0
          ? std::max(1LL, (long long)std::llround(in.checkpointInterval / coupling->windowSize()))
          : 0;
  StateArchive checkpointArchive;
  if (resume) {
    const CheckpointManifest& m = resumeFrom;
    try {  // a build whose parts list other state: the archive's own checks (tq/core/state_archive.hpp)
      checkpoints->read(m, checkpointArchive);
      checkpointArchive.beginRestore();
      runState(checkpointArchive);
      checkpointArchive.end();
    } catch (const std::exception& e) {
      err << "tq-solid: cannot resume from " << checkpoints->file(m.solid) << ": " << e.what()
          << "; run without --resume to start again\n";
      return 2;
    }
    results.resumeFrom(checkpoints->file(m.results), s);
    out << "tq-solid: resumed from checkpoint " << m.sequence << " at t = " << m.time << " s (step " << m.step
        << ", " << m.samples << " samples" << (m.window >= 0 ? ", coupling window " + std::to_string(m.window) : "")
        << ")" << std::endl;
    if (coupling) {
      try {
        coupling->initializeResumed();
      } catch (const CouplingError& e) {
        results.setStatus(std::string("stopped: ") + e.what());
        err << "tq-solid: " << e.what() << "\n  results so far are in " << output << "\n";
        return 4;
      }
    }
  } else {
    if (checkpoints) checkpoints->clear();
    results.sample(s);
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto lastReport = t0, lastFlush = t0;
  const Index step0 = s.stepCount();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  // Implicit coupling windows of several steps: the state at each window start is kept, and a
  // window the water did not accept is stepped again from it; results are sampled at window ends.
  WindowedStepper stepper(s, coupling.get());
  try {
    while (s.time() < in.tEnd - 1e-9 * s.dt() && (!coupling || coupling->ongoing())) {
      if (!stepper.step()) continue;
      if (coupling) {
        const std::string note = coupling->takeNote();
        if (!note.empty()) out << "tq-solid: " << note << std::endl;
      }
      const Real t = s.time();
      gap = t - tFinal;
      tFinal = t;
      // The histories are written at k x monitor_dt, interpolated between the final states on
      // either side: observe this state when a requested time falls before the next final state
      // (expected one step, or window, on).
      if (t + gap >= results.nextSampleTime() - 1e-9 * gap) results.sample(s);
      while (nextSnap < in.snapshotTimes.size() && t >= in.snapshotTimes[nextSnap] - 0.5 * s.dt()) {
        results.snapshot(s);
        ++nextSnap;
      }
      // (none at the end: the results are then whole)
      const bool checkpointDue =
          coupling ? checkpointWindows > 0 && !coupling->windowOpen() && coupling->windowsDone() % checkpointWindows == 0 &&
                         coupling->windowsDone() < coupling->windowCount()
                   : in.checkpointInterval > 0 && t >= nextCheckpoint - 1e-9 * s.dt() && t < in.tEnd - 1e-9 * s.dt();
      if (checkpoints && checkpointDue) {
        const auto c0 = std::chrono::steady_clock::now();
        while (t >= nextCheckpoint - 1e-9 * s.dt()) nextCheckpoint += in.checkpointInterval;
        ++checkpointSeq;
        results.flush();
        lastFlush = c0;
        checkpointArchive.beginSave();
        runState(checkpointArchive);
        checkpointArchive.end();
        CheckpointManifest m;
        m.sequence = checkpointSeq;
        m.time = t;
        m.step = s.stepCount();
        m.samples = results.samples();
        m.window = coupling ? coupling->windowsDone() : -1;
        m.fingerprint = fingerprint;
        checkpoints->write(m, checkpointArchive, results.path());
        ++checkpointsWritten;
        checkpointSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
      }
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - lastFlush).count() > 2.0) {
        results.flush();
        lastFlush = now;
      }
      if (std::chrono::duration<double>(now - lastReport).count() >= in.progressSeconds) {
        const double wall = elapsed(), rate = double(s.stepCount() - step0) / wall;
        const double left = (in.tEnd - t) / s.dt() / rate;
        out << "  t = " << std::setprecision(5) << t << " s / " << in.tEnd << " s (" << std::setprecision(3)
            << 100 * t / in.tEnd << " %), step " << s.stepCount() << ", " << std::setprecision(4) << rate
            << " steps/s, energy error " << std::setprecision(2) << s.energy().error << ", ETA " << hms(left)
            << std::endl;
        lastReport = now;
      }
    }
  } catch (const InstabilityError& e) {
    if (coupling) coupling->abort(std::string("the solid stopped: ") + e.what());
    couplingSummary();
    results.setStatus(std::string("stopped: ") + e.what());
    results.writeTimings(elapsed(), s.stepCount() - step0, (long long)(s.stepCount() - step0) * nElems,
                         omp_get_max_threads());
    err << "tq-solid: " << e.what() << "\n  results so far are in " << output << "\n";
    return 3;
  } catch (const InputError& e) {
    if (coupling) coupling->abort(std::string("the solid stopped: ") + e.what());
    results.setStatus(std::string("stopped: ") + e.what());
    err << "tq-solid: input error: " << e.what() << "\n";
    return 2;
  } catch (const CouplingError& e) {  // the fluid is lost, silent or refused: stop with its cause
    results.sample(s);
    couplingSummary();
    results.setStatus(std::string("stopped: ") + e.what());
    results.writeTimings(elapsed(), s.stepCount() - step0, (long long)(s.stepCount() - step0) * nElems,
                         omp_get_max_threads());
    err << "tq-solid: " << e.what() << "\n  results so far are in " << output << "\n";
    return 4;
  }
  if (coupling) {
    try {
      coupling->finalize();
    } catch (const CouplingError& e) {
      couplingSummary();
      results.setStatus(std::string("stopped: ") + e.what());
      err << "tq-solid: " << e.what() << "\n  results so far are in " << output << "\n";
      return 4;
    }
    couplingSummary();
    const FluidCouplingStats cs = coupling->stats();
    if (cs.unconvergedWindows > 0)
      err << "tq-solid: warning: " << cs.unconvergedWindows << " of " << cs.windows
          << " coupling windows ended at the pass limit (coupling.max_iterations = " << in.staged.coupling.maxIterations
          << ") with the interface residual above the tolerance " << in.staged.coupling.tolerance
          << ": the water and the lining disagree there by more than asked. Raise coupling.max_iterations, or check "
             "the added-mass ratio (`tunnelquake check`, docs/coupler.md); /coupling unconverged_windows in the "
             "results counts them.\n";
  }
  // 5. Timings and status.
  const double wall = elapsed();
  const long long steps = s.stepCount() - step0;
  results.writeTimings(wall, steps, steps * nElems, omp_get_max_threads());
  if (checkpoints) {
    results.writeAttrs("/timings", {{"checkpoints", double(checkpointsWritten)}, {"checkpoint_s", checkpointSeconds},
                                    {"checkpoint_interval", in.checkpointInterval}});
  }
  results.setStatus("completed");
  if (checkpoints) checkpoints->clear();  // the results are whole: nothing left to resume
  out << "tq-solid: completed " << steps << " steps in " << hms(wall) << " ("
      << (steps > 0 ? 1e6 * wall / (double(steps) * nElems) : 0.0) << " µs per element-step), energy error "
      << s.energy().error << "\n  results: " << output << "\n";
  return 0;
  };
  try {
    writer = std::make_unique<ResultsWriter>(output, in, s);
    return engine();
  } catch (const OutputError& e) {
    if (coupling) coupling->abort(std::string("the solid stopped: ") + e.what());
    err << "tq-solid: " << e.what() << "\n";
    if (!writer) {  // the file could not even be started: nothing of it is worth keeping
      std::remove(output.c_str());
      err << "  no results written (" << output << " removed); free space on its file system and run again\n";
    } else if (!writer->stopAfterOutputError(std::string("stopped: ") + e.what())) {
      err << "  " << output << " holds the samples up to its last flush; its status could not be written\n";
    } else if (writer->samples() == 0) {
      err << "  no monitor sample written yet; " << output << " holds the run's set-up with status 'stopped: ...'; "
          << "free space on its file system and run again\n";
    } else {
      err << "  results up to t = " << writer->lastSampleTime() << " s (" << writer->samples()
          << " samples) are in " << output << " with status 'stopped: ...'; free space on its file system and run "
          << "again\n";
    }
    return 5;
  }
}

}  // namespace

int runSolid(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  // HDF5 closes what is still open at exit; a file whose flush failed then crashes it
  // (H5F__close_cb). Every file here is closed by its owner, so that pass is left out.
  H5dont_atexit();
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
