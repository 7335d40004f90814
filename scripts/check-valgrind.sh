#!/bin/sh
# make check-valgrind: the unit, daemon and rig tests again under valgrind's
# memcheck, failing on any memory error or definite leak. What runs at which
# size, and the times: docs/testing-memory.md.
#   sh scripts/check-valgrind.sh BUILD_DIR JOBS
set -eu
build=${1:-build}
jobs=${2:-2}
opts="--error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite --num-callers=30"
command -v valgrind >/dev/null || { echo "check-valgrind: valgrind is not installed (scripts/deps.sh)" >&2; exit 1; }

cd "$build"
rc=0
# Every unit test under memcheck; the heavy ones see RUNNING_ON_VALGRIND
# and run at their small size (tests/gonio_test.h, gonio_test_small). Each
# test's TIMEOUT holds under memcheck (cmake/GonioTest.cmake).
ctest -T memcheck -L unit -j "$jobs" --output-on-failure \
    --overwrite MemoryCheckCommand="$(command -v valgrind)" \
    --overwrite MemoryCheckCommandOptions="$opts" || rc=1
# The daemon and rig tests with goniod and gonio-sim under memcheck: the
# tests start them through GONIO_WRAP (tests/daemon/goniod_harness.py, wrap)
# and fail a test whose valgrind report shows an error.
GONIO_WRAP="valgrind $opts" ctest -L 'daemon|rig' -j "$jobs" --output-on-failure || rc=1
exit $rc
