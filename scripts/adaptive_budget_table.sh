#!/bin/sh
# The budget table of docs/adaptive.md ("Holding the budget"): adaptive
# captures (DS1's pairs, the abc policy, --stop all) of the ten held-out
# materials on each scene, at each budget: mean and largest rig time, how
# many ended past the budget, how many had too few samples for the final
# fit (the capture then fails; its rig time and samples are the journal's),
# mean samples. The realistic scenes' detectors give counts: each is
# calibrated once, its own detector on the default rig
# (scripts/lab_calibration.sh: a dark over the ranging ladder, the reference
# on a grid to 80 deg, which DS1's pairs need), and every capture on it
# names that calibration and ranges.
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
. "$(dirname "$0")/lab_calibration.sh"

echo "| scene | budget | mean / max rig time | over | no fit | mean samples |"
echo "|---|---:|---|---:|---:|---:|"
for s in $scenes; do
    cal=""
    case $s in
    ideal*) ;;  # the detector reports BRDF: nothing to calibrate
    *) lab_calibrate "$bin" "$out/cal-$s" default "$s"; cal=$CAL ;;
    esac
    for b in $budgets; do
        for m in $materials; do
            d="$out/$s-$b-$m"
            if "$bin/gonio" capture --offline --quiet --plan ds1 --order adaptive --stop all \
                --budget "$b" --scene "$s" --material "nbrdf:$m" --out "$d" \
                $cal >/dev/null 2>"$d.err"; then
                jq -r '"\(.rig_time_s) \(.samples) 1"' "$d/results.json"
            elif grep -q "final fit" "$d.err" && [ -f "$d/samples.csv" ]; then
                # too few samples in the budget to fit: the journal's figures
                awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
                    { t = $col["rig_time_s"]; if ($col["flags"] == 0) k++ }
                    END { print t, k + 0, 0 }' "$d/samples.csv"
            else
                cat "$d.err" >&2
                echo fail
            fi
        done | awk -v s="$s" -v b="$b" '
            $1 == "fail" { fail = 1; next }
            { n++; t += $1; if ($1 > max) max = $1; if ($1 > 60 * b) over++; k += $2
              if (!$3) nofit++ }
            END { if (fail) exit 1
                  printf "| %s | %g s | %.2f / %.2f s | %d/%d | %d/%d | %.1f |\n", s, 60 * b,
                  t / n, max, over, n, nofit, n, k / n }'
    done
done
