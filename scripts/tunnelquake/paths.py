"""Where the project's pieces are: repository root, build folder, native programs, shared data."""
from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def build_dir() -> Path:
    return Path(os.environ.get("TQ_BUILD_DIR", ROOT / "build"))


def solid_executable() -> Path | None:
    p = build_dir() / "solid_solver" / "tq-solid"
    return p if p.is_file() and os.access(p, os.X_OK) else None


def openfoam_library() -> Path | None:
    p = build_dir() / "openfoam_case" / "libtqFoam.so"
    return p if p.is_file() else None


def coupler_module() -> Path | None:
    """The coupler's compiled Python module (_coupler, built by the CMake target tqcoupler_py)."""
    from importlib.machinery import EXTENSION_SUFFIXES

    for suffix in EXTENSION_SUFFIXES:
        p = build_dir() / "coupler" / f"_coupler{suffix}"
        if p.is_file():
            return p
    return None


def shared_dir() -> Path:
    """The shared/ folder beside the checkout (reference paper, data); may be absent."""
    return Path(os.environ.get("TQ_SHARED_DIR", ROOT.parent / "shared"))


def openfoam_env() -> dict[str, str]:
    """Environment for running Debian's OpenFOAM binaries (they need WM_PROJECT_DIR)."""
    env = dict(os.environ)
    if "WM_PROJECT_DIR" not in env and Path("/usr/share/openfoam/etc/controlDict").is_file():
        env["WM_PROJECT_DIR"] = "/usr/share/openfoam"
    return env
