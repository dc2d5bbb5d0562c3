#!/usr/bin/env bash
# The C++ layout of solid_solver/, coupler/ and tests/cpp/ (.clang-format; OpenFOAM-side code keeps
# OpenFOAM's own layout):
#   scripts/format.sh          reformat the files in place
#   scripts/format.sh --check  list the files whose layout differs, exit 1 if any (./Alltest runs this)
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(git ls-files 'solid_solver/*.cpp' 'solid_solver/*.hpp' \
  'coupler/*.cpp' 'coupler/*.hpp' 'tests/cpp/*.cpp' 'tests/cpp/*.hpp')
if ! command -v clang-format >/dev/null; then
  echo "format.sh: clang-format is not installed (scripts/bootstrap.sh installs it: apt-get install clang-format)" >&2
  exit 2
fi
if [[ ${1:-} == --check ]]; then
  bad=0
  for f in "${files[@]}"; do
    if ! clang-format --dry-run --Werror "$f" 2>/dev/null; then echo "layout differs: $f"; bad=1; fi
  done
  ((bad)) && echo "run scripts/format.sh to apply .clang-format"
  exit $bad
fi
clang-format -i "${files[@]}"
