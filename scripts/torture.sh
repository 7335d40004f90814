#!/bin/sh
# The crash torture (docs/torture.md): KILLS SIGKILLs of goniod aimed at
# moves, journal writes, progressive fits and final fits, each followed by
# a restart and a resume; prints kills per phase, samples planned /
# present / duplicated / wrong and the wall time as JSON. Exit 1 on any
# lost, duplicated or wrong sample or a torn record the reader accepted.
#   scripts/torture.sh [KILLS] [PLAN]          (default 200 ds3)
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$here/build}
export GONIO_BIN="$build/bin" GONIO_TESTS_BIN="$build/tests" GONIO_TMP="$build/tmp"
export GONIO_CONFIG="${GONIO_CONFIG:-$here/configs}"
exec /usr/bin/python3 "$here/tests/daemon/torture.py" --kills "${1:-200}" --plan "${2:-ds3}"
