"""Meshing: the tunnel's structured all-hex gmsh model, the solid mesh.h5 and the water mesh.

Public API (the case file's ``mesh:`` section takes exactly the keys of MESH_DEFAULTS):

    MESH_DEFAULTS, MESH_DOC      parameters, their defaults, meaning and units
    build_tunnel_mesh(geometry, mesh, out_dir) -> summary dict
    format_summary(summary) -> str
    check_element_size(max_size, shear_velocity, cutoff_hz) -> warning str or None

See docs/meshing.md for the topology and docs/formats.md for the files written.
"""

from .build import build_tunnel_mesh, format_summary
from .params import (
    GEOMETRY_KEYS,
    MESH_DEFAULTS,
    MESH_DOC,
    PAPER_GEOMETRY,
    MeshInputError,
    check_element_size,
)

__all__ = [
    "GEOMETRY_KEYS",
    "MESH_DEFAULTS",
    "MESH_DOC",
    "PAPER_GEOMETRY",
    "MeshInputError",
    "build_tunnel_mesh",
    "check_element_size",
    "format_summary",
]
