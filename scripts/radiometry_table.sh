#!/bin/sh
# The budget table and honesty figures of docs/radiometry.md: the synthetic
# rig's 200 seeded repeats (tests/unit/radiometry/test_honesty.c), printed.
# Run from the repository root with the build's bin folder on PATH (as
# make docs-check does), or give the build's tests folder.
set -eu
tests=${1:-$(dirname "$(command -v gonio)")/../tests}
GONIO_RADIOMETRY_TABLE=1 "$tests/test_honesty" 2>/dev/null | grep -v '^\[' 
