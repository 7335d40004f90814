#!/bin/sh
# The lab-chain honesty figures of docs/radiometry.md: a hundred seeded
# repeats of dark, stray and reference calibrations and a glossy capture on
# the simulated raw lab rig, each with its own plaque drawn from the
# standard's certificate (tests/unit/capture/test_chain_honesty.c),
# printed. Run from the repository root with the build's bin folder on
# PATH (as make docs-check does), or give the build's tests folder. About
# 30 s on a quiet machine.
set -eu
tests=${1:-$(dirname "$(command -v gonio)")/../tests}
bin=$(cd "$tests/../bin" && pwd)
out=$(GONIO_BIN=$bin "$tests/test_chain_honesty" 2>/dev/null) || { echo "$out" >&2; exit 1; }
echo "$out" | grep -v '^\['
