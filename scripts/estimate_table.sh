#!/bin/sh
# The estimate-against-actual table of docs/plans.md ("Estimates on a real
# day"): for each plan and scene, the rig time `gonio plan --scene` estimates
# before the first move, the plan's fixed-integration estimate (`gonio plan`
# without a scene), and the rig time an offline capture of the scene
# reports (results.json's rig_time_s, the simulated clock). A scene whose
# detector gives counts is estimated at the fixed integration (the material
# is not known before the first reading; gonio plan prints the bound
# auto-ranging can reach) and captured --uncalibrated: it ranges and costs
# as a capture with a calibration over the ranging ladder does, and its
# rig time is what is compared.
#
# Usage: scripts/estimate_table.sh [BIN_DIR] (default build/bin); env
# ESTIMATE_OUT (work dir, default out/estimate_table), PLANS, SCENES to narrow
# the run. Prints the Markdown table on stdout; with ESTIMATE_DOC=docs/plans.md
# it replaces the table between the document's estimate-table markers.
set -eu
bin=${1:-build/bin}
out=${ESTIMATE_OUT:-out/estimate_table}
plans=${PLANS:-ds1 ds2 ds3 ds4}
scenes=${SCENES:-ideal lab spectral-lab}
rm -rf "$out"
mkdir -p "$out"
table="$out/table.md"

total() { jq -r '.estimate.total_s'; }
pct() { awk -v e="$1" -v a="$2" 'BEGIN { printf "%+.1f %%", 100 * (e - a) / a }'; }

{
    echo "| plan | scene | fixed estimate (s) | scene estimate (s) | actual (s) | fixed vs actual | scene vs actual |"
    echo "|---|---|---|---|---|---|---|"
    for p in $plans; do
        for s in $scenes; do
            fixed=$("$bin/gonio" plan "$p" --json | total)
            est=$("$bin/gonio" plan "$p" --scene "$s" --json | total)
            "$bin/gonio" capture --offline --quiet --uncalibrated --scene "$s" --plan "$p" \
                --out "$out/$p-$s" >/dev/null
            act=$(jq -r '.rig_time_s' "$out/$p-$s/results.json")
            printf '| %s | %s | %.1f | %.1f | %.1f | %s | %s |\n' "$p" "$s" "$fixed" "$est" \
                "$act" "$(pct "$fixed" "$act")" "$(pct "$est" "$act")"
        done
    done
} >"$table"

if [ -n "${ESTIMATE_DOC:-}" ]; then
    awk -v t="$table" '
        /<!-- estimate-table begin/ { print; while ((getline l < t) > 0) print l; skip = 1; next }
        /<!-- estimate-table end/ { skip = 0 }
        !skip' "$ESTIMATE_DOC" >"$ESTIMATE_DOC.new"
    mv "$ESTIMATE_DOC.new" "$ESTIMATE_DOC"
fi
cat "$table"
