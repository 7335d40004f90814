#!/bin/sh
# The budget table of docs/adaptive.md ("Holding the budget"): adaptive
# captures (DS1's pairs, the abc policy, --stop all) of the ten held-out
# materials on each scene, at each budget: mean and largest rig time, how
# many ended past the budget, mean samples. The realistic scenes' detectors
# give counts: each scene is calibrated once for DS1 (a dark, then the
# reference) and every capture on it names that calibration.
#
# Usage: scripts/adaptive_budget_table.sh [BIN_DIR] (default build/bin); env
# BUDGET_OUT (work dir, default out/adaptive_budget), SCENES, BUDGETS
# (minutes), MATERIALS to narrow the run. Needs the shared data (nbrdf:).
# Prints the Markdown table on stdout.
set -eu
bin=${1:-build/bin}
out=${BUDGET_OUT:-out/adaptive_budget}
scenes=${SCENES:-lab bad-day}
budgets=${BUDGETS:-0.25 2}
materials=${MATERIALS:-nylon tungsten-carbide specular-black-phenolic blue-acrylic brass gold-metallic-paint white-diffuse-bball red-plastic alum-bronze pearl-paint}
rm -rf "$out"
mkdir -p "$out"

echo "| scene | budget | mean / max rig time | over | mean samples |"
echo "|---|---:|---|---:|---:|"
for s in $scenes; do
    cal=""
    if "$bin/gonio" calibrate dark --offline --scene "$s" --out "$out/cal-$s" >/dev/null 2>&1
    then
        "$bin/gonio" calibrate reference --offline --scene "$s" --plan ds1 \
            --out "$out/cal-$s" >/dev/null
        cal="--calibrations $out/cal-$s"
    fi  # else the detector reports BRDF: nothing to calibrate
    for b in $budgets; do
        for m in $materials; do
            "$bin/gonio" capture --offline --quiet --plan ds1 --order adaptive --stop all \
                --budget "$b" --scene "$s" --material "nbrdf:$m" --out "$out/$s-$b-$m" \
                $cal >/dev/null
            jq -r '"\(.rig_time_s) \(.samples)"' "$out/$s-$b-$m/results.json"
        done | awk -v s="$s" -v b="$b" '
            { n++; t += $1; if ($1 > max) max = $1; if ($1 > 60 * b) over++; k += $2 }
            END { printf "| %s | %g s | %.2f / %.2f s | %d/%d | %.1f |\n", s, 60 * b,
                  t / n, max, over, n, k / n }'
    done
done
