#!/usr/bin/env bash
# TunnelQuake bootstrap: takes a fresh Debian bookworm machine (as root) to a working install.
#
#   1. Debian packages: OpenFOAM v1912 (`openfoam`), Eigen, HDF5, Open MPI, compilers, CMake,
#      GoogleTest, CalculiX (`calculix-ccx`, for the solid benchmark), and the X/GL runtime
#      libraries the gmsh wheel needs.
#   2. OpenFOAM v1912 headers from Debian's own source package (Debian ships none): deb-src is
#      derived from this machine's own apt source entries, the source is unpacked once into a
#      cache and lnInclude folders are made the way wmakeLnInclude makes them.
#   3. A Python virtual environment (.venv) with the `tunnelquake` package and its dependencies
#      (pybind11 among them: step 4 builds the coupler's Python module with it).
#   4. The CMake build of all native code (build/), the coupler's Python module included.
#
# Every step checks first and does nothing when its result is already there, so a second run is a
# quick no-op. Environment knobs:
#   TQ_OPENFOAM_SRC   use this OpenFOAM src/ (e.g. a full install's $WM_PROJECT_DIR/src) instead
#                     of the Debian source package
#   TQ_CACHE          where the OpenFOAM headers are unpacked (default ~/.cache/tunnelquake)
#   TQ_SKIP_APT=1     do not touch Debian packages (non-root machines with everything installed)
#   TQ_BUILD_TYPE     CMake build type (default Release)
#
# `scripts/bootstrap.sh --check` changes nothing: it reports each part and exits 1 if one is missing.
set -euo pipefail
CHECK_ONLY=0
[[ ${1:-} == --check ]] && CHECK_ONLY=1

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
CACHE=${TQ_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/tunnelquake}
VENV=$ROOT/.venv
BUILD=$ROOT/build
BUILD_TYPE=${TQ_BUILD_TYPE:-Release}

say() { printf '[bootstrap] %s\n' "$*"; }
die() { printf '[bootstrap] ERROR: %s\n' "$*" >&2; exit 1; }

t_start=$(date +%s)

# ---------------------------------------------------------------------------------------------
# 1. Debian packages
# ---------------------------------------------------------------------------------------------
APT_PACKAGES=(
  openfoam                                   # OpenFOAM v1912 (ESI) binaries and libraries
  libeigen3-dev libhdf5-dev hdf5-tools       # solid solver: linear algebra, results files
  openmpi-bin libopenmpi-dev                 # MPI transport, decomposed OpenFOAM runs
  build-essential cmake ninja-build pkg-config libgtest-dev googletest
  python3-venv python3-dev dpkg-dev xz-utils shellcheck clang-format   # clang-format: ./Alltest's C++ layout check
  calculix-ccx                               # CalculiX: the solid benchmark's side-by-side run
  libglu1-mesa libxrender1 libxcursor1 libxft2 libxinerama1 libgl1   # gmsh wheel runtime
)

missing_packages() {
  local p
  for p in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}

if ((CHECK_ONLY)); then
  status=0
  mapfile -t missing < <(missing_packages)
  if ((${#missing[@]})); then say "MISSING Debian packages: ${missing[*]}"; status=1
  else say "ok: Debian packages (${#APT_PACKAGES[@]})"; fi
  of_src=${TQ_OPENFOAM_SRC:-$CACHE/openfoam-1912/src}
  if [[ -f $of_src/finiteVolume/lnInclude/fvCFD.H ]]; then say "ok: OpenFOAM v1912 headers in $of_src"
  else say "MISSING OpenFOAM headers in $of_src"; status=1; fi
  if [[ -x $VENV/bin/tunnelquake ]] && "$VENV/bin/python" -c "import gmsh, meshio, h5py, mpi4py, numpy, scipy, matplotlib, yaml, importlinter, pybind11" 2>/dev/null
  then say "ok: Python environment $VENV"
  else say "MISSING Python environment or one of its packages in $VENV"; status=1; fi
  for exe in "$BUILD/openfoam_case/libtqFoam.so" "$BUILD/solid_solver/tq-solid"; do
    if [[ -e $exe ]]; then say "ok: built $(basename "$exe")"; else say "MISSING build output $exe"; status=1; fi
  done
  if compgen -G "$BUILD/coupler/_coupler.*.so" >/dev/null; then say "ok: built the coupler's Python module"
  else say "MISSING build output $BUILD/coupler/_coupler.*.so"; status=1; fi
  exit $status
fi

if [[ "${TQ_SKIP_APT:-0}" != 1 ]]; then
  mapfile -t missing < <(missing_packages)
  if ((${#missing[@]})); then
    [[ $(id -u) == 0 ]] || die "missing Debian packages (${missing[*]}); run this script as root or install them and set TQ_SKIP_APT=1"
    say "installing Debian packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    apt-get install -y -q --no-install-recommends "${missing[@]}"
  else
    say "Debian packages: all present"
  fi
fi

# ---------------------------------------------------------------------------------------------
# 2. OpenFOAM v1912 headers
# ---------------------------------------------------------------------------------------------
# Derive deb-src entries from this machine's own apt sources (the Debian archive stanzas serving
# this release's main component). No mirror host is written anywhere in the repository.
enable_deb_src() {
  local out=/etc/apt/sources.list.d/tunnelquake-deb-src.sources
  local legacy=/etc/apt/sources.list.d/tunnelquake-deb-src.list
  [[ -s $out || -s $legacy ]] && return 0
  [[ $(id -u) == 0 ]] || die "deb-src is not enabled and this is not root; set TQ_OPENFOAM_SRC to an OpenFOAM src/"
  local codename
  # shellcheck disable=SC1091
  codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-bookworm}")
  python3 - "$codename" "$out" "$legacy" <<'PY'
import glob, re, sys
codename, out, legacy = sys.argv[1:]
stanzas, lines = [], []
for path in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
    for block in re.split(r"\n\s*\n", open(path).read()):
        fields = {}
        for ln in block.splitlines():
            if ln.startswith("#") or ":" not in ln:
                continue
            k, v = ln.split(":", 1)
            fields[k.strip()] = v.strip()
        if "deb" not in fields.get("Types", "").split():
            continue
        if codename not in fields.get("Suites", "").split() or "main" not in fields.get("Components", "").split():
            continue
        fields["Types"] = "deb-src"
        stanzas.append("\n".join(f"{k}: {v}" for k, v in fields.items()))
for path in ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list")):
    try:
        for ln in open(path):
            parts = ln.split()
            if len(parts) >= 4 and parts[0] == "deb" and parts[2] == codename and "main" in parts[3:]:
                lines.append("deb-src " + " ".join(parts[1:]))
    except FileNotFoundError:
        pass
if stanzas:
    open(out, "w").write("# written by TunnelQuake bootstrap: deb-src twins of this machine's apt sources\n"
                         + "\n\n".join(stanzas) + "\n")
elif lines:
    open(legacy, "w").write("# written by TunnelQuake bootstrap\n" + "\n".join(lines) + "\n")
else:
    sys.exit(f"no apt source entry for '{codename}' main found to derive deb-src from")
PY
  apt-get update -q
}

# Make lnInclude/ in every library folder of src/ (a folder holding Make/files), linking each
# header and template source found below it, as OpenFOAM's wmakeLnInclude does.
make_lnincludes() {
  python3 - "$1" <<'PY'
import os, sys
src = sys.argv[1]
exts = (".H", ".C", ".h", ".hxx", ".cxx", ".hpp", ".cpp", ".type")
for dirpath, dirnames, filenames in os.walk(src):
    if "lnInclude" in dirnames:
        dirnames.remove("lnInclude")
    if not os.path.isfile(os.path.join(dirpath, "Make", "files")):
        continue
    lnk = os.path.join(dirpath, "lnInclude")
    os.makedirs(lnk, exist_ok=True)
    for sub, subdirs, files in os.walk(dirpath):
        subdirs[:] = [d for d in subdirs if d not in ("lnInclude", "Make") and not d.startswith(".")]
        for f in files:
            if f.endswith(exts):
                dst = os.path.join(lnk, f)
                if not os.path.lexists(dst):
                    os.symlink(os.path.relpath(os.path.join(sub, f), lnk), dst)
PY
}

OF_SRC=${TQ_OPENFOAM_SRC:-}
if [[ -z $OF_SRC && -n ${WM_PROJECT_DIR:-} && -d ${WM_PROJECT_DIR}/src/OpenFOAM/lnInclude ]]; then
  OF_SRC=$WM_PROJECT_DIR/src   # a full OpenFOAM install with its own src/
fi
if [[ -z $OF_SRC ]]; then
  OF_SRC=$CACHE/openfoam-1912/src
  if [[ ! -f $CACHE/openfoam-1912/.lninclude-done ]]; then
    enable_deb_src
    mkdir -p "$CACHE/dl"
    say "downloading Debian's openfoam source package (headers for v1912)"
    (cd "$CACHE/dl" && apt-get source -q --download-only openfoam)
    dsc=$(find "$CACHE/dl" -maxdepth 1 -name 'openfoam_*.dsc' | head -1)
    rm -rf "$CACHE/openfoam-1912.tmp"
    say "unpacking $(basename "$dsc") (with Debian's patches)"
    dpkg-source --no-check -x "$dsc" "$CACHE/openfoam-1912.tmp" >/dev/null
    # Keep only what building against the library needs: src/ (headers) and wmake/ (rules).
    find "$CACHE/openfoam-1912.tmp" -mindepth 1 -maxdepth 1 ! -name src ! -name wmake ! -name etc \
      -exec rm -rf {} +
    rm -rf "$CACHE/openfoam-1912"
    mv "$CACHE/openfoam-1912.tmp" "$CACHE/openfoam-1912"
    say "making lnInclude folders"
    make_lnincludes "$OF_SRC"
    touch "$CACHE/openfoam-1912/.lninclude-done"
    rm -rf "$CACHE/dl"
  else
    say "OpenFOAM headers: present in $CACHE/openfoam-1912"
  fi
fi
[[ -f $OF_SRC/OpenFOAM/lnInclude/fvCFD.H || -f $OF_SRC/finiteVolume/lnInclude/fvCFD.H ]] \
  || die "no OpenFOAM headers in $OF_SRC (expected finiteVolume/lnInclude/fvCFD.H)"

# ---------------------------------------------------------------------------------------------
# 3. Python virtual environment
# ---------------------------------------------------------------------------------------------
PY_STAMP=$VENV/.tq-stamp
py_hash=$(sha256sum <"$ROOT/scripts/pyproject.toml" | cut -c1-16)
if [[ ! -f $PY_STAMP || $(cat "$PY_STAMP") != "$py_hash" ]]; then
  say "creating Python environment in .venv"
  [[ -x $VENV/bin/python ]] || python3 -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  "$VENV/bin/python" -m pip install -q -e "$ROOT/scripts[test]"
  echo "$py_hash" >"$PY_STAMP"
else
  say "Python environment: up to date"
fi

# ---------------------------------------------------------------------------------------------
# 4. Native build
# ---------------------------------------------------------------------------------------------
if [[ ! -f $BUILD/CMakeCache.txt ]]; then
  say "configuring CMake ($BUILD_TYPE)"
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE" \
    -DTQ_OPENFOAM_SRC="$OF_SRC" -DPython_EXECUTABLE="$VENV/bin/python" >"$BUILD.configure.log" 2>&1 \
    || { cat "$BUILD.configure.log"; die "CMake configure failed"; }
fi
say "building native code"
if ! cmake --build "$BUILD" -- -j"$(nproc)" >"$BUILD.log" 2>&1; then
  tail -50 "$BUILD.log"; die "build failed (full log: $BUILD.log)"
fi
if grep -q "no work to do" "$BUILD.log"; then say "native build: up to date"; else say "native build: done"; fi

say "ready in $(($(date +%s) - t_start)) s. Activate with: source .venv/bin/activate"
