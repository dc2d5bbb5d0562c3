"""The TunnelQuake coupler (C++ library tqcoupler, coupler/) from Python: its compiled module
_coupler (CMake target tqcoupler_py, in the build folder) gives the configuration, a participant
over TCP or MPI and the analytic ring scenario; fakes.py has the fake participants built on it.
See docs/coupler.md."""

from __future__ import annotations

import importlib.util
import sys

from ..paths import build_dir, coupler_module


def _load():
    name = f"{__name__}._coupler"
    if name in sys.modules:
        return sys.modules[name]
    path = coupler_module()
    if path is None:
        raise ImportError(f"the coupler's Python module _coupler is not built in {build_dir() / 'coupler'}: "
                          "run scripts/bootstrap.sh, or `cmake --build build --target tqcoupler_py` "
                          "(set TQ_BUILD_DIR for another build folder)")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


_c = _load()
ConfigError = _c.ConfigError
CouplerError = _c.CouplerError
CouplingConfig = _c.CouplingConfig
CouplingTimeoutError = _c.CouplingTimeoutError
DivergenceError = _c.DivergenceError
FieldSpec = _c.FieldSpec
HandshakeError = _c.HandshakeError
MapError = _c.MapError
MeshSpec = _c.MeshSpec
Participant = _c.Participant
PartnerLostError = _c.PartnerLostError
ProtocolError = _c.ProtocolError
RingScenario = _c.RingScenario
TransportError = _c.TransportError
convergence_measure = _c.convergence_measure
have_mpi = _c.have_mpi
mpi_finalize = _c.mpi_finalize
mpi_initialize = _c.mpi_initialize
mpi_split_world = _c.mpi_split_world

__all__ = [
    "ConfigError",
    "CouplerError",
    "CouplingConfig",
    "CouplingTimeoutError",
    "DivergenceError",
    "FieldSpec",
    "HandshakeError",
    "MapError",
    "MeshSpec",
    "Participant",
    "PartnerLostError",
    "ProtocolError",
    "RingScenario",
    "TransportError",
    "convergence_measure",
    "have_mpi",
    "mpi_finalize",
    "mpi_initialize",
    "mpi_split_world",
]
