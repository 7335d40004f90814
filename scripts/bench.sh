#!/bin/sh
# make bench: orderings, the capture loop and the fits, each figure printed
# beside a reference measured in the same run (never against a stored
# number, so the ratios mean the same on any machine):
#   1. orderings of DS1-DS3: move and total rig time, move time over greedy
#      nearest neighbour and over the lower bound of any order, CPU time;
#   2. the capture loop: wall time and samples/s of an offline DS1 capture
#      (travel, stop all = the reference), and of the progressive capture
#      stopped on convergence, with rig times and full-domain log errors;
#   3. ABC fit time per plan (DS1 the reference).
# Nothing here is asserted: the tests never time anything.
set -eu
bin=${1:-build/bin}
out=${BENCH_OUT:-out/bench}
scene=${BENCH_SCENE:-ideal-nylon}
materials=${BENCH_MATERIALS:-nbrdf:nylon nbrdf:blue-acrylic nbrdf:brass}
rm -rf "$out"
mkdir -p "$out"

now() { date +%s.%N; }
calc() { awk "BEGIN { print $1 }"; } # floating-point arithmetic without bc
num() { # key file: the first numeric value of "key" in a JSON file
    sed -n "s/.*\"$1\": *\([-0-9.eE+]*\).*/\1/p" "$2" | head -n 1
}
full_log() { # the "log" value inside "full" of results.json
    tr -d ' \n' <"$1" | sed -n 's/.*"full":{"log":\([-0-9.eE+]*\).*/\1/p'
}
capture() { # dir args...: run a quiet offline capture, print its wall time
    dir=$1
    shift
    t0=$(now)
    "$bin/gonio" capture --offline --quiet --scene "$scene" --out "$out/$dir" "$@" >/dev/null
    t1=$(now)
    calc "$t1 - $t0"
}

echo "== 1. orderings (default rig): move time over greedy and over the lower bound"
"$bin/order_bench" ds1 ds2 ds3

if [ ! -d "${GONIO_SHARED:-../shared}/data/merl" ]; then
    materials=default
    echo "(../shared not found: captures use the embedded default material)"
fi

echo
echo "== 2. capture loop: DS1 travel/stop all (reference) vs progressive/stop converge"
printf '%-20s %-22s %6s %8s %7s %9s %8s %7s %9s %6s\n' material run samples wall_s ratio \
    samples/s rig_s ratio full_log ratio
for m in $materials; do
    name=$(echo "$m" | sed 's/.*://')
    wr=$(capture "$name-full" --material "$m" --plan ds1 --order travel --stop all)
    wc=$(capture "$name-conv" --material "$m" --plan ds1 --order progressive --stop converge)
    nr=$(num samples "$out/$name-full/results.json")
    nc=$(num samples "$out/$name-conv/results.json")
    rr=$(num rig_time_s "$out/$name-full/results.json")
    rc=$(num rig_time_s "$out/$name-conv/results.json")
    er=$(full_log "$out/$name-full/results.json")
    ec=$(full_log "$out/$name-conv/results.json")
    printf '%-20s %-22s %6s %8.2f %7.3f %9.0f %8.1f %7.3f %9.4f %6.3f\n' "$m" travel/all "$nr" \
        "$wr" 1 "$(calc "$nr / $wr")" "$rr" 1 "$er" 1
    printf '%-20s %-22s %6s %8.2f %7.3f %9.0f %8.1f %7.3f %9.4f %6.3f\n' "$m" \
        progressive/converge "$nc" "$wc" "$(calc "$wc / $wr")" \
        "$(calc "$nc / $wc")" "$rc" "$(calc "$rc / $rr")" "$ec" \
        "$(calc "$ec / $er")"
done

echo
echo "== 3. ABC fit time per plan (the capture's final fit; DS1 the reference)"
m=$(echo "$materials" | cut -d' ' -f1)
printf '%-6s %7s %10s %7s\n' plan samples fit_s ratio
ref=""
for p in ds1 ds2 ds3 ds4; do
    if [ "$p" != ds1 ]; then
        capture "fit-$p" --material "$m" --plan "$p" --stop all >/dev/null
        r="$out/fit-$p/results.json"
    else
        r="$out/$(echo "$m" | sed 's/.*://')-full/results.json"
    fi
    f=$(num fit_time_s "$r")
    [ -n "$ref" ] || ref=$f
    printf '%-6s %7s %10.4f %7.3f\n' "$p" "$(num samples "$r")" "$f" "$(calc "$f / $ref")"
done

echo
echo "== 4. ABC fit at equal work: C (fit_abc) vs SciPy least_squares on the same DS1 samples and starts"
if [ -d "${GONIO_SHARED:-../shared}/data/merl" ] && /usr/bin/python3 -c "import scipy" 2>/dev/null; then
    mkdir -p "$out/abc_scipy"
    "$bin/abc_scipy" "$out/abc_scipy" >/dev/null
    /usr/bin/python3 "$(dirname "$0")/../bench/abc_scipy.py" "$out/abc_scipy"
else
    echo "(needs ../shared and python3-scipy: skipped)"
fi

echo
echo "== 5. MLP training: C vs PyTorch per epoch (same network, loss, Adam, batch)"
"$bin/mlp_bench" 200 32

echo
echo "== 6. scene effects: ns per sample of the bare pipeline and of each effect"
"$bin/effects_bench" 200000

echo
echo "== 7. gonio render: sphere pixels per second (CPU time), direct light vs light + environment"
"$bin/render_bench" 256

echo
echo "== 8. the bus: requests per point and rig time over the plan's estimate (RTU, TCP)"
sh "$(dirname "$0")/bench_bus.sh" "$bin" "$out/bus"
