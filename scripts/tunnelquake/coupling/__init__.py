"""Pure-Python twin of the TunnelQuake coupler (coupler/ in C++): the same wire protocol
(protocol), transports (transport: TCP, MPI through mpi4py), participant API (participant) and
fake participants (fakes). See docs/coupler.md."""

from .participant import Participant
from .protocol import (
    ConfigError,
    CouplerError,
    CouplingConfig,
    CouplingTimeoutError,
    DivergenceError,
    FieldSpec,
    HandshakeError,
    MapError,
    MeshSpec,
    PartnerLostError,
    ProtocolError,
    TransportError,
)

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
    "TransportError",
]
