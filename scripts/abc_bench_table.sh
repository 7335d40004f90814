#!/bin/sh
# docs/fit-measured.md "Measured": the ABC fit of ten NBRDF materials on DS1-DS4
# and the oop200k nodes, full-domain log error and fit time, from
# bench/abc_fit_bench.c (under a minute; times depend on the machine's load).
# Usage: scripts/abc_bench_table.sh [BIN_DIR] (default build/bin).
set -eu
bin=${1:-build/bin}
"$bin/abc_fit_bench" | awk '
    /^[a-z-]+ +DS1 / { m = $1; ds1[m] = $3; t1[m] = $4; ds4[m] = $9; oop[m] = $13; t200[m] = $14
                       gsub(/\(/, "", t1[m]); gsub(/\(/, "", t200[m]); order[++n] = m; next }
    /^    DS2 / { ds2[m] = $2; ds3[m] = $6; next }
    /^mean full-domain/ { mean1 = $6; mean200 = $8; ratio = $10 }
    END {
        print "| material | DS1 (912) | DS1 time | DS2 (160) | DS3 (52) | DS4 (6) | oop200k | oop200k time |"
        print "|---|---|---|---|---|---|---|---|"
        for (i = 1; i <= n; i++) { m = order[i]
            printf "| %s | %s | %.0f ms | %s | %s | %s | %s | %.2f s |\n", m, ds1[m], 1000 * t1[m],
                   ds2[m], ds3[m], ds4[m], oop[m], t200[m] }
        sub(/,$/, "", mean1)
        sub(/,$/, "", mean200)
        printf "| **mean** | **%s** | | | | | **%s** | |\n\nDS1 / oop200k mean ratio: %s (limit 1.15).\n",
               mean1, mean200, ratio
    }'
