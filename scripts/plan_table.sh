#!/bin/sh
# docs/plans.md's table of a plan's time estimate by order (default DS1 on
# the default rig): `gonio plan PLAN --order O` for each order, in minutes.
# Usage: scripts/plan_table.sh [PLAN] (gonio from PATH; docs-check puts
# the build's bin first). Seconds to run: scripts/docs_check.sh checks it.
set -eu
plan=${1:-ds1}
echo "| order | move | settle | integration | total |"
echo "|---|---|---|---|---|"
for order in as-written progressive greedy travel; do
    gonio plan "$plan" --order "$order" |
        sed -n 's/^estimate: total .*(\([0-9.]*\) s): move .*(\([0-9.]*\) s), settle .*(\([0-9.]*\) s), integration .*(\([0-9.]*\) s)$/\1 \2 \3 \4/p' |
        awk -v o="$order" '{ printf "| %s | %.1f min | %.2f min | %.2f min | %.1f min |\n", o, $2 / 60, $3 / 60, $4 / 60, $1 / 60 }'
done
