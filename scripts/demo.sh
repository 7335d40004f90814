#!/bin/sh
# make demo: offline captures of the embedded default material (the
# published shifted-gamma fit of MERL nylon, no shared data needed) on DS2
# and DS4, fitted with ABC; with ../shared present, also NBRDF nylon and
# tungsten carbide on DS2. Results land in out/demo/.
set -eu
bin=${1:-build/bin}
out=out/demo
rm -rf "$out"
mkdir -p "$out"

run() { # name plan scene [material]
    name=$1 plan=$2 scene=$3
    shift 3
    "$bin/gonio" capture --offline --quiet --scene "$scene" --plan "$plan" "$@" \
        --out "$out/$name" >/dev/null
    dirs="$dirs $out/$name"
}

dirs=""
echo "gonio demo: offline captures on the in-process simulated rig, ABC fits"
run default-ds2 ds2 ideal
run default-ds4 ds4 ideal
if [ -d "${GONIO_SHARED:-../shared}/data/merl" ]; then
    run nylon-ds2 ds2 ideal-nylon
    run tungsten-carbide-ds2 ds2 ideal-tungsten-carbide
else
    echo "(../shared not found: MERL-backed materials skipped)"
fi
echo
# shellcheck disable=SC2086
"$bin/gonio" results $dirs
echo
echo "gonio render: the default material next to its ABC fits from DS2 and DS4 (docs/render.md)"
for p in ds2 ds4; do
    "$bin/gonio" fit "$out/default-$p" --model abc --quiet >/dev/null
done
"$bin/gonio" render --grid --truth default \
    --model "model:$out/default-ds2/abc.model" --label "DS2 ABC" \
    --model "model:$out/default-ds4/abc.model" --label "DS4 ABC" \
    --size 128 --quiet --out "$out/renders"
echo
echo "Capture directories (plan.json, setup.json, samples.csv, results.json) are in $out/;"
echo "renderings (grid.png, grid.exr, one EXR/PNG per cell, render.json) in $out/renders/."
