#!/bin/sh
# make check's ctest: runs ctest in BUILD_DIR with the given arguments, then
# says how many tests ctest reports as skipped (they exited 77:
# tests/gonio_test.h, tests/ctest_skips.py) and why, from the SKIPPED lines
# of their output. Exits with ctest's status.
#   sh scripts/ctest-skips.sh BUILD_DIR [CTEST_ARGS...]
set -u
build=$1
shift
cd "$build" || exit 2
out=$(mktemp)
trap 'rm -f "$out" "$out.rc"' EXIT
{ ctest "$@"; echo $? >"$out.rc"; } | tee "$out"
rc=$(cat "$out.rc")
skipped=$(sed -n 's/^[[:space:]]*[0-9]* - \(.*\) (Skipped)$/\1/p' "$out")
[ -n "$skipped" ] || exit "$rc"
echo
echo "$(echo "$skipped" | wc -l) test(s) skipped (exit 77), and why:"
for t in $skipped; do
    # The test's block of LastTest.log, from "N/M Test: name" to its end.
    why=$(awk -v t="$t" '/^[0-9]+\/[0-9]+ Test: / { on = ($3 == t); next }
                         /^<end of output>/ { on = 0 }
                         on && /^SKIPPED/' Testing/Temporary/LastTest.log | sort -u)
    echo "  $t:"
    echo "${why:-(no SKIPPED line in its output)}" | sed 's/^/    /'
done
exit "$rc"
