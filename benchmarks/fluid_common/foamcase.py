"""Small helpers to write and run OpenFOAM v1912 cases from Python tests.

Used by tests/python/test_openfoam_*.py and tests/verification/fluid_*/.
Paths are derived from this file's location; the build folder defaults to
<repo>/build and can be overridden with TQ_BUILD_DIR.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("TQ_BUILD_DIR", REPO / "build"))
LIBRARY = BUILD / "openfoam_case" / "libtqFoam.so"
# Debian's OpenFOAM binaries need WM_PROJECT_DIR pointing at the package's share folder.
WM_PROJECT_DIR = os.environ.get("TQ_WM_PROJECT_DIR", "/usr/share/openfoam")


def openfoam_missing_reason() -> str | None:
    """Why OpenFOAM cannot run here, or None when it can."""
    for exe in ("pimpleFoam", "blockMesh"):
        if shutil.which(exe) is None:
            return f"OpenFOAM v1912 not installed ({exe} not on PATH)"
    if not Path(WM_PROJECT_DIR, "etc", "controlDict").exists():
        return f"OpenFOAM etc/ not found in WM_PROJECT_DIR={WM_PROJECT_DIR}"
    return None


def env() -> dict:
    e = dict(os.environ)
    e["WM_PROJECT_DIR"] = WM_PROJECT_DIR
    e.setdefault("FOAM_SIGFPE", "true")
    lib = str(LIBRARY.parent)
    e["LD_LIBRARY_PATH"] = lib + (":" + e["LD_LIBRARY_PATH"] if e.get("LD_LIBRARY_PATH") else "")
    return e


HEADER = """FoamFile
{{
    version     2.0;
    format      ascii;
    class       {cls};
    object      {obj};
}}
"""


def write(case: Path, rel: str, body: str, cls: str = "dictionary") -> Path:
    """Write an OpenFOAM dictionary file with a FoamFile header."""
    path = Path(case, rel)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(HEADER.format(cls=cls, obj=path.name) + body)
    return path


def run(case: Path, *cmd: str, log: str | None = None, timeout: float = 300) -> str:
    """Run an OpenFOAM utility in a case; raise with the log tail on failure."""
    name = log or cmd[0]
    proc = subprocess.run(
        list(cmd) + ["-case", str(case)],
        env=env(),
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    out = proc.stdout + proc.stderr
    Path(case, f"log.{name}").write_text(out)
    if proc.returncode != 0 or "FOAM FATAL" in out:
        raise RuntimeError(f"{' '.join(cmd)} failed in {case}:\n{out[-4000:]}")
    return out


def read_interface(case: Path, name: str = "interface") -> np.ndarray:
    """Rows of postProcessing/<name>/<t0>/interface.dat as a structured array."""
    files = sorted(Path(case, "postProcessing", name).glob("*/interface*.dat"))
    if not files:
        raise FileNotFoundError(f"no interface.dat under {case}/postProcessing/{name}")
    data = np.vstack([np.loadtxt(f, comments="#", ndmin=2) for f in files])
    names = [
        "t",
        "accepted",
        "Fx",
        "Fy",
        "Fz",
        "Fpx",
        "Fpy",
        "Fpz",
        "Fvx",
        "Fvy",
        "Fvz",
        "Fhsx",
        "Fhsy",
        "Fhsz",
        "Sx",
        "Sy",
        "Sz",
        "pMean",
        "nRollbacks",
    ]
    return np.rec.fromarrays(data.T, names=names)


def read_forces(case: Path, name: str = "forces") -> np.ndarray:
    """OpenFOAM 'forces' force.dat: columns t, total(3), pressure(3), viscous(3)."""
    files = sorted(Path(case, "postProcessing", name).glob("*/force*.dat"))
    rows = []
    for f in files:
        for line in f.read_text().splitlines():
            if line.startswith("#") or not line.strip():
                continue
            rows.append([float(x) for x in re.sub(r"[()]", " ", line).split()])
    return np.array(rows)


def read_faces(case: Path, time: str, name: str = "interface") -> np.ndarray:
    """faces.dat of a write time: x y z Sx Sy Sz pWall pCell fx fy fz."""
    return np.loadtxt(Path(case, "postProcessing", name, time, "faces.dat"), comments="#", ndmin=2)


def read_points(case: Path, time: str, name: str = "interface") -> np.ndarray:
    """points.dat of a write time: x0(3) x(3) u(3) v(3) f(3)."""
    return np.loadtxt(Path(case, "postProcessing", name, time, "points.dat"), comments="#", ndmin=2)


def harmonic_fit(t: np.ndarray, y: np.ndarray, omega: float) -> tuple[float, float, float]:
    """Least-squares y = A cos(wt) + B sin(wt) + C; returns (amplitude, phase, C)
    with y ~ amp*cos(wt - phase) + C."""
    M = np.column_stack([np.cos(omega * t), np.sin(omega * t), np.ones_like(t)])
    (a, b, c), *_ = np.linalg.lstsq(M, y, rcond=None)
    return float(np.hypot(a, b)), float(np.arctan2(b, a)), float(c)


def read_internal_field(path: Path) -> np.ndarray:
    """internalField of an ascii OpenFOAM field file (uniform or nonuniform), as an array."""
    text = Path(path).read_text()
    i = text.index("internalField")
    head = text[i : i + 200]
    if "nonuniform" not in head:
        m = re.search(r"uniform\s+(\([^)]*\)|[-+0-9.eE]+)", head)
        return np.array([float(x) for x in m.group(1).strip("()").split()])
    j = text.index("(", i)
    k = text.index("\n)", j)
    body = text[j + 1 : k]
    return np.array([float(x) for x in re.sub(r"[()]", " ", body).split()])
