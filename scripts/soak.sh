#!/bin/sh
# The fault soak (docs/torture.md): captures of PLAN through goniod's
# Modbus drivers on gonio-sim, over RTU and TCP, with RATES percent of the
# exchanges dropped, garbled or late (a third each); then a jammed arm.
# Prints the table of faults injected, retries and points lost. Exit 1 when
# a value is wrong, a point missing or doubled, an axis left its limits, or
# a point was lost at a rate of 5 % or less.
#   scripts/soak.sh [PLAN] [RATES] [TRANSPORTS]   (default ds1 1,5,20 rtu,tcp)
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$here/build}
export GONIO_BIN="$build/bin" GONIO_TESTS_BIN="$build/tests" GONIO_TMP="$build/tmp"
export GONIO_CONFIG="${GONIO_CONFIG:-$here/configs}"
exec /usr/bin/python3 "$here/tests/daemon/soak.py" --plan "${1:-ds1}" --rates "${2:-1,5,20}" \
    --transports "${3:-rtu,tcp}" --retries "${SOAK_RETRIES:-4}"
