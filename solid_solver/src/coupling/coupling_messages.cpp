// What the solid adapter of the water coupling says when it stops or warns
// (src/coupling/coupling_messages.hpp).
#include "coupling/coupling_messages.hpp"

#include <sstream>

#include "tq/coupler/errors.hpp"

namespace tq {

namespace cp = tq::coupler;

/// The cause-specific advice appended to a coupler error.
std::string couplingFix(const std::exception& e, const CouplingInput& in) {
  std::ostringstream os;
  if (dynamic_cast<const cp::TimeoutError*>(&e))
    os << "The water solver sent nothing within the coupling timeout of " << in.timeout
       << " s. Fix: see the water solver's log (hung or crashed); if it is only slow, raise coupling.timeout "
          "(solid_input.h5 /coupling timeout).";
  else if (dynamic_cast<const cp::PartnerLostError*>(&e))
    os << "The water solver stopped or closed the connection. Fix: see the water solver's log for its error, "
          "correct it and start the run again.";
  else if (dynamic_cast<const cp::HandshakeError*>(&e))
    os << "The water solver is configured differently or belongs to another run. Fix: start both sides from "
          "the same `tunnelquake run` (same coupling section, mesh and token).";
  else if (dynamic_cast<const cp::ProtocolError*>(&e))
    os << "A malformed or out-of-step message arrived. Fix: check that both sides are built from the same "
          "release; a foreign program may have connected to the coupling port.";
  else if (dynamic_cast<const cp::DivergenceError*>(&e)) {
    // the coupler's message names the cause and the first fix; one more when it applies
    if (in.scheme == "implicit" && in.windowSteps > 1 && in.windowForceWeight < 1)
      os << "Or raise coupling.window_force_weight toward 1 (here " << in.windowForceWeight
         << "; docs/coupler.md \"Window force weight\").";
  } else if (dynamic_cast<const cp::MapError*>(&e))
    os << "The interface meshes do not match. Fix: regenerate the water mesh from the same geometry as mesh.h5 "
          "(its interface points must coincide with the solid's '"
       << in.face << "' nodes), or use map projection.";
  else if (dynamic_cast<const cp::TransportError*>(&e))
    os << "The connection to the water solver failed. Fix: check the address file '" << in.addressFile
       << "' and that both sides run on this machine (or set transport mpi under mpirun).";
  else
    os << "Fix: check /coupling in solid_input.h5 against the water side's configuration.";
  return os.str();
}

std::string describeCoupling(const CouplingInput& in, Real window, long long windows, size_t nodes,
                             const CarriedWater* water) {
  std::ostringstream os;
  os.precision(6);
  os << "water coupling: scheme " << in.scheme << ", window " << window << " s (" << in.windowSteps
     << " solid step(s)) x " << windows << ", " << nodes << " nodes of '" << in.face << "' as mesh '" << in.mesh
     << "', writes";
  for (const auto& f : in.writeFields) os << " " << f;
  os << ", reads force; " << in.transport;
  if (in.transport == "tcp") os << " (address file " << in.addressFile << ")";
  os << ", timeout " << in.timeout << " s";
  if (in.scheme == "implicit")
    os << ", tolerance " << in.tolerance << ", at most " << in.maxIterations << " passes, " << in.acceleration
       << ", predictor " << in.predictor;
  if (in.scheme == "implicit" && in.residualScale != "current") os << ", residual against the largest so far";
  if (water) os << "; " << water->describe();
  return os.str();
}

std::string energyCreatedMessage(const CouplingInput& in, Real ec, Real ratio, Real ref, const std::string& where,
                                 bool waterCarried) {
  std::ostringstream os;
  os << "the water coupling created energy: " << ec << " J at " << where << ", " << 100 * ratio
     << " % of the largest interface work so far (" << ref << " J), above coupling.energy_limit = " << in.energyLimit
     << ". The scheme (" << in.scheme << ", windows of " << in.windowSteps << " step(s), tolerance " << in.tolerance
     << ") accepts errors that feed a weakly damped mode of the water and the lining; the results past "
        "the point where /energy/coupling_energy left zero are not trustworthy. ";
  if (!waterCarried)
    os << "If the water's section is closed (a slice, or closed ends), let the solid carry its volume law "
          "(coupling.volume_law: solid): the whole pressure exchanged created energy from 3.3 s on the "
          "example slice with K = 22 GPa, and ran the record with the law in the solid. Otherwise ";
  os << "lower coupling.tolerance (e.g. ten times)";
  if (in.windowSteps > 1 && in.windowForceWeight < 1)
    os << ", or raise coupling.window_force_weight toward 1 (here " << in.windowForceWeight << ")";
  os << " (docs/coupler.md \"Energy guard\"; a shorter window did not help: windows of 8 steps stopped "
        "sooner than 16 on the example slice)";
  return os.str();
}

std::string energyWarning(const CouplingInput& in, Real ec, Real ratio, const std::string& where) {
  std::ostringstream os;
  os << "warning: the water coupling has created " << ec << " J at " << where << ", " << 100 * ratio
     << " % of the largest interface work so far; the run stops at " << 100 * in.energyLimit
     << " % (coupling.energy_limit)";
  return os.str();
}

}  // namespace tq
