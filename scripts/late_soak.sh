#!/bin/sh
# Late replies on the bad-day scene for MINUTES (default 15): DS2 captures
# back to back through goniod over Modbus TCP on gonio-sim, half the bus's
# answers 0.05 s late on top of the scene's own faults; each journal is
# checked for a rig clock that never goes back (tests/rig/test_restart.py)
# and goniod's log for a rig time the clock had to hold.
# Usage: late_soak.sh [BUILD_DIR] [MINUTES] [SCENE]
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
cd "$build"
GONIO_BIN=$build/bin GONIO_CONFIG=$here/configs PYTHONPATH=$here/tests \
    LATE_MINUTES=${2:-15} LATE_SCENE=${3:-bad-day} \
    /usr/bin/python3 -m pytest -q -s -p no:cacheprovider \
    "$here/tests/rig/test_restart.py::test_late_replies_never_take_the_clock_back" 2>&1 |
    grep -v '^gonio-sim'
