#!/bin/bash
# Run libFuzzer targets for a given time each and merge what they found
# into the committed corpora (docs/fuzzing.md). Used by `make fuzz`.
#   [FUZZ_MERGE=0] scripts/fuzz.sh BIN_DIR SECONDS PARALLEL TARGET...
# FUZZ_MERGE=0 (make fuzz-smoke, CI) leaves the committed corpora alone.
# Findings (crash-*, leak-*, timeout-*, oom-*, slow-unit-*) are left in
# BIN_DIR/../artifacts/ and the script exits 1; logs are in BIN_DIR/../logs/.
set -u
bin=$1 seconds=$2 parallel=$3
shift 3
top=$(cd "$(dirname "$0")/.." && pwd)
work=$(cd "$bin/.." && pwd)
mkdir -p "$work/logs" "$work/artifacts" "$work/new"
# The targets write their input to a scratch file per run: keep it in memory.
if [ -d /dev/shm ] && [ -w /dev/shm ]; then TMPDIR=/dev/shm; export TMPDIR; fi

run_one() {
    t=$1
    corpus="$top/fuzz/corpus/$t"
    mkdir -p "$corpus" "$work/new/$t"
    log="$work/logs/$t.log"
    echo "fuzz $t: ${seconds}s, log $log"
    # New inputs go to new/<t>; the committed corpus is only read.
    # Instrumented runs are 10-20x slower than a release build: a plan
    # ordered in 0.7 s takes 10 s here, libFuzzer's default slow-unit
    # mark, so a unit is reported slow only past half the timeout.
    "$bin/fuzz_$t" -max_total_time="$seconds" -timeout=30 -report_slow_units=15 -rss_limit_mb=2048 \
        -max_len=65536 -print_final_stats=1 -artifact_prefix="$work/artifacts/$t-" \
        "$work/new/$t" "$corpus" >"$log" 2>&1
    rc=$?
    # Keep what adds coverage to the committed corpus.
    [ "${FUZZ_MERGE:-1}" = 0 ] || "$bin/fuzz_$t" -merge=1 "$corpus" "$work/new/$t" >>"$log" 2>&1
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    echo "fuzz $t: exit $rc, ${execs:-?} executions, corpus $(ls "$corpus" | wc -l) files"
    return $rc
}

failed=0
running=0
for t in "$@"; do
    run_one "$t" &
    running=$((running + 1))
    if [ "$running" -ge "$parallel" ]; then
        wait -n
        running=$((running - 1))
    fi
done
wait
# Any artifact is a finding.
if [ -n "$(ls "$work/artifacts" 2>/dev/null)" ]; then
    echo "fuzz: findings in $work/artifacts:"; ls "$work/artifacts"
    failed=1
fi
exit $failed
