/// @file coupling_mpi.hpp
/// @brief tq-solid under mpirun: MPI's start-up and end for the water coupling over MPI.
#pragma once

#include <ostream>
#include <string>

#include "tq/coupling/fluid_coupling.hpp"

namespace tq {

/// tq-solid as one application of an MPMD mpirun job (/coupling transport mpi; docs/coupler.md
/// "tq-solid under mpirun"): `mpirun -np 1 tq-solid ... : -np N fluid ...`. MPI is initialised
/// only here, with MPI_THREAD_FUNNELED (the solid's OpenMP threads make no MPI calls), and the
/// world is split by application before the static stages, so a missing partner is reported at
/// once. tq-solid is one MPI process (it is threaded with OpenMP): a second solid rank is refused.
class CouplingMpi {
 public:
  /// MPI_Init, SIGTERM/SIGINT handling (mpirun's way of ending the job when a process died),
  /// world split. A partner missing from the job or a second solid process is a problem().
  explicit CouplingMpi(const CouplingInput& in);
  CouplingMpi(const CouplingMpi&) = delete;
  CouplingMpi& operator=(const CouplingMpi&) = delete;
  ~CouplingMpi();  ///< finish(1) unless finish() was called

  /// Why the coupling cannot run in this job (its message and fix), or empty. The run then
  /// stops (exit 4) and finish() ends MPI: MPI_Finalize without a partner, else MPI_Abort.
  const std::string& problem() const { return problem_; }
  /// One line: the job's size and this process's cores and OpenMP threads.
  std::string describe() const;
  /// Warning (empty if none) when mpirun bound this process to fewer cores than the machine has
  /// (Open MPI binds to a core by default for up to 2 processes): OpenMP then runs on those only.
  std::string bindingWarning() const;
  /// Records how the coupling ended (read before the coupling object goes away).
  void note(const FluidCoupling& c);
  /// Ends MPI for a run that returns `exitCode`, after results.h5 is closed:
  /// - a termination signal arrived (mpirun is ending the job): nothing — MPI_Finalize would wait
  ///   for the dead process; the job ends anyway;
  /// - the fluid is known to end by itself (completed, or told the error, or it stopped on its own
  ///   error): MPI_Finalize, so mpirun reports tq-solid's exit code and message, not an abort;
  /// - otherwise (the fluid fell silent, or was never reached: an error before the handshake):
  ///   MPI_Abort with exitCode, since the fluid would never reach MPI_Finalize. Does not return then.
  /// Returns exitCode.
  int finish(int exitCode, std::ostream& err);

  /// "N processes" when this process was started by mpirun/mpiexec (Open MPI, MPICH), else "".
  static std::string launchedByMpirun();

 private:
  bool finished_ = false, partnerInJob_ = false, noted_ = false, released_ = false;
  int worldSize_ = 1;
  std::string partner_, problem_;
};

}  // namespace tq
