#!/bin/sh
# The chain's figures in docs/radiometry.md: dark, reference and three
# samples on the simulated raw lab rig (tests/unit/capture/test_chain.c),
# as a table. Run from the repository root with the build's bin folder on
# PATH (as make docs-check does), or give the build's tests folder.
set -eu
tests=${1:-$(dirname "$(command -v gonio)")/../tests}
out=$("$tests/test_chain" 2>&1 >/dev/null) || { echo "$out" >&2; exit 1; }
echo "| sample | median abs(measured/true - 1), SNR >= 100 | values used | z sd (per-sample terms) | without dark | standard as Lambertian |"
echo "|---|---|---|---|---|---|"
echo "$out" | sed -n 's/^analytic:\([a-z-]*\): median |measured\/true - 1| \([0-9.]*\) % over \([0-9]*\) values with SNR >= 100 (of \([0-9]*\)), their z-scores. sd \([0-9.]*\); without dark \([0-9.]*\) %, standard as Lambertian \([0-9.]*\) %$/| analytic:\1 | \2 % | \3 of \4 | \5 | \6 % | \7 % |/p'
echo
echo "$out" | sed -n 's/^photon-transfer gain \(.*\) ADU\/e, monitor noise \(.*\)$/Photon-transfer gain from the reference repeats: \1 ADU per electron (the scene: 0.8); lamp monitor noise \2 per reading./p'
