#!/bin/sh
# The bus's cost: DS3 on the ideal scene captured by
# goniod over gonio-sim, with gonio-sim emulating the line (--baud: an RTU
# exchange takes its frames' time; --tcp-latency: each TCP reply is late).
# Per run: requests per point (goniod's bus statistics), the capture's rig
# time and its ratio to the plan's estimate (gonio plan --json); overhead
# = rig time / estimate - 1. The first row has no line cost at all: what
# remains there is the drivers' polling and the host's own time per request
# (multiplied by the time scale), so the rows below it also show the line's
# share (their rig time minus the first row's, over the estimate), and
# where the requests go: per point, to the sample, arm and azimuth drives
# and to the detector (gonio-sim --stats).
# Usage: bench_bus.sh BIN OUT. BENCH_BUS_SCALE: gonio-sim's --time-scale
# (default 1, a real rig's clock: at scale k the host's own time per
# request counts k times over; 4 runs the bench four times faster).
set -eu
bin=$1
out=$2
scale=${BENCH_BUS_SCALE:-1}
mkdir -p "$out"

calc() { awk "BEGIN { print $1 }"; }
estimate=$("$bin/gonio" plan ds3 --json | tr ',' '\n' | sed -n 's/.*"total_s": *\([0-9.eE+-]*\).*/\1/p')

run() { # dir transport sim-args...: one capture; prints "requests points rig_s s a az det"
    d=$out/$1
    kind=$2
    shift 2
    rm -rf "$d"
    mkdir -p "$d/cap"
    "$bin/gonio-sim" --scene ideal --time-scale "$scale" --tcp 127.0.0.1:0 --stats "$d/stats.json" "$@" \
        >"$d/sim.out" 2>"$d/sim.err" &
    sim=$!
    i=0
    until [ "$(cat "$d/sim.out" 2>/dev/null | wc -l)" -ge 2 ] || [ $i -ge 100 ]; do
        sleep 0.05
        i=$((i + 1))
    done
    if [ "$kind" = rtu ]; then
        link="  kind: modbus-rtu\n  device: $(sed -n 1p "$d/sim.out")\n  baud: ${BAUD:-115200}\n"
    else
        link="  kind: modbus-tcp\n  host: 127.0.0.1\n  port: $(sed -n 's/.*://p' "$d/sim.out")\n"
    fi
    printf "rig: default\ndriver:\n${link}  time_scale: %s\n  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\ncapture_root: cap\nsocket:\n  path: s.sock\n" \
        "$scale" >"$d/goniod.yaml"
    "$bin/goniod" --config "$d/goniod.yaml" 2>"$d/goniod.log" &
    daemon=$!
    i=0
    until [ -S "$d/s.sock" ] || [ $i -ge 100 ]; do
        sleep 0.05
        i=$((i + 1))
    done
    "$bin/gonio" capture --plan ds3 --name bus --wait --socket "$d/s.sock" >"$d/capture.out" 2>&1 ||
        echo "bench_bus: $1: capture failed (see $d)" >&2
    kill "$daemon" "$sim" 2>/dev/null || true
    wait "$daemon" "$sim" || true
    requests=$(sed -n 's/.*: bus \([0-9]*\) requests.*/\1/p' "$d/goniod.log" | tail -n 1)
    points=$(sed -n 's/.*, \([0-9]*\) samples, rig time.*/\1/p' "$d/capture.out")
    rig=$(tr -d ' \n' <"$d/cap/bus/results.json" | sed -n 's/.*"rig_time_s":\([-0-9.eE+]*\).*/\1/p')
    by=$(tr -d ' \n' <"$d/stats.json" |
        sed -n 's/.*"detector":{"exchanges":\([0-9]*\)}.*"sample":{"exchanges":\([0-9]*\),.*"arm":{"exchanges":\([0-9]*\),.*"azimuth":{"exchanges":\([0-9]*\),.*/\2 \3 \4 \1/p')
    echo "${requests:-0} ${points:-0} ${rig:-nan} ${by:-0 0 0 0}"
}

echo "DS3, ideal scene, goniod over gonio-sim --time-scale $scale; plan estimate $estimate s of rig time"
printf '%-24s %8s %6s %9s %7s %9s %9s  %s\n' bus requests points req/point rig_s overhead line \
    "per point: sample/arm/azimuth/detector"
free=""
row() { # label dir kind sim-args...
    label=$1
    shift
    set -- $(run "$@")
    per=$(calc "$1 / ($2 > 0 ? $2 : 1)")
    over=$(calc "100 * ($3 / $estimate - 1)")
    [ -n "$free" ] || free=$3
    line=$(calc "100 * ($3 - $free) / $estimate")
    n=$(calc "($2 > 0 ? $2 : 1)")
    printf '%-24s %8s %6s %9.1f %7.1f %8.1f%% %8.1f%%  %.1f/%.1f/%.1f/%.1f\n' "$label" "$1" "$2" \
        "$per" "$3" "$over" "$line" "$(calc "$4 / $n")" "$(calc "$5 / $n")" "$(calc "$6 / $n")" \
        "$(calc "$7 / $n")"
}
row "RTU, no line cost" rtu-free rtu
BAUD=115200 row "RTU 115200 baud" rtu-115200 rtu --baud 115200
BAUD=19200 row "RTU 19200 baud" rtu-19200 rtu --baud 19200
row "TCP, 1 ms latency" tcp-1ms tcp --tcp-latency 1
echo "targets: overhead <= 2 % at 115200 baud, <= 5 % at 19200"
