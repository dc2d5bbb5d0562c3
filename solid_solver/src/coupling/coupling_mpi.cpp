// tq-solid as one application of an MPMD mpirun job (tq/coupling/coupling_mpi.hpp; docs/coupler.md
// "tq-solid under mpirun").
#include "tq/coupling/coupling_mpi.hpp"

#include <omp.h>
#include <sched.h>

#include <cstdlib>
#include <sstream>
#include <thread>

#include "tq/coupler/errors.hpp"
#include "tq/coupler/participant.hpp"

namespace tq {

namespace cp = tq::coupler;

CouplingMpi::CouplingMpi(const CouplingInput& in) : partner_(in.partner) {
  cp::mpi::initialize(nullptr, nullptr);
  cp::mpi::stopOnTerminationSignals();
  const std::string n = launchedByMpirun();
  worldSize_ = n.empty() ? 1 : std::atoi(n.c_str());
  try {
    cp::mpi::splitWorld(in.participant, in.partner);
  } catch (const cp::CouplerError& e) {
    problem_ = std::string("water coupling over MPI (/coupling transport mpi): ") + e.what() +
               ". Fix: start tq-solid and the fluid under one mpirun, e.g. mpirun -np 1 tq-solid solid_input.h5 : "
               "-np 1 <fluid> (docs/coupler.md \"tq-solid under mpirun\"), or set /coupling transport tcp to run "
               "the two as separate processes.";
    return;
  }
  partnerInJob_ = true;
  if (const int k = cp::mpi::appSize(); k > 1)
    problem_ = "water coupling over MPI: " + std::to_string(k) +
               " processes of tq-solid in the job; tq-solid runs "
               "as one MPI process (it is threaded with OpenMP: --threads). Fix: mpirun -np 1 tq-solid ... : "
               "-np N <fluid> ... (docs/coupler.md \"tq-solid under mpirun\")";
}

CouplingMpi::~CouplingMpi() {
  if (!finished_) {
    std::ostringstream sink;
    finish(1, sink);
  }
}

std::string CouplingMpi::launchedByMpirun() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(var); v && *v) return std::string(v) + " processes";
  return "";
}

std::string CouplingMpi::describe() const {
  std::ostringstream os;
  os << "MPI: one application of an MPMD job of " << worldSize_ << " process(es), coupled with '" << partner_
     << "' over MPI; " << omp_get_max_threads() << " OpenMP thread(s)";
  return os.str();
}

std::string CouplingMpi::bindingWarning() const {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return "";
  const unsigned mine = unsigned(CPU_COUNT(&set)), all = std::thread::hardware_concurrency();
  if (all == 0 || mine >= all) return "";
  std::ostringstream os;
  os << "this process is bound to " << mine << " of the machine's " << all << " cores (mpirun binds each process "
     << "to a core by default), so its " << omp_get_max_threads() << " OpenMP thread(s) share "
     << (mine == 1 ? "it" : "them") << ". Fix: mpirun --bind-to none -np 1 tq-solid ... (docs/coupler.md \"tq-solid "
     << "under mpirun\")";
  return os.str();
}

void CouplingMpi::note(const FluidCoupling& c) {
  noted_ = true;
  released_ = c.partnerReleased();
}

int CouplingMpi::finish(int exitCode, std::ostream& err) {
  if (finished_) return exitCode;
  finished_ = true;
  if (cp::mpi::terminationSignal() != 0) return exitCode;  // mpirun is ending the job (a process died)
  if (exitCode == 0 || !partnerInJob_ || (noted_ && released_)) {
    cp::mpi::finalize();
    return exitCode;
  }
  err << "tq-solid: ending the MPI job (MPI_Abort, code " << exitCode << "): '" << partner_ << "' "
      << (noted_ && !released_ && partnerInJob_ ? "does not answer" : "was never reached")
      << ", so it would not end by itself" << std::endl;
  cp::mpi::abortJob(exitCode);
}

}  // namespace tq
