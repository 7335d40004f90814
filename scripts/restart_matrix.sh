#!/bin/sh
# The drive-restart fault matrix at full length: tests/rig/test_restart.py
# with 20 DS2 captures over Modbus TCP and 10 over RTU, each with gonio-sim
# killed and started again 0-0.5 s later on its port and pty link part way
# through, and the late-replies capture. Prints one line per capture (its
# samples, worst axis error against its plan point, rig time, estimate,
# and the failures that `resume` then completed).
# Usage: restart_matrix.sh [BUILD_DIR] (default: build)
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
cd "$build"
GONIO_BIN=$build/bin GONIO_CONFIG=$here/configs PYTHONPATH=$here/tests \
    RESTARTS_TCP=${RESTARTS_TCP:-20} RESTARTS_RTU=${RESTARTS_RTU:-10} \
    /usr/bin/python3 -m pytest -q -s -p no:cacheprovider "$here/tests/rig/test_restart.py" 2>&1 |
    grep -v '^gonio-sim'
