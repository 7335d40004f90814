#!/bin/sh
# docs/fitting.md "Saturated readings": two studies of the same rows, one run
# with --saturated clipped and one with --saturated censored, compared per
# model and plan: mean log error (full domain; in-plane for mlp) and how
# many rows each treatment made better or worse (log error, relative RMSE;
# rows that differ by less than 1e-9 are neither).
# Usage: scripts/saturated_study_table.sh CLIPPED_DIR CENSORED_DIR
set -eu
[ $# -eq 2 ] || { echo "usage: $0 CLIPPED_DIR CENSORED_DIR" >&2; exit 2; }
awk -F, '
FNR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; file++; next }
{
    lk = $col["model"] == "mlp" ? "inplane_log" : "full_log"
    rk = $col["model"] == "mlp" ? "inplane_rel_rmse" : "full_rel_rmse"
    id = $col["row_id"]; key = $col["model"] " " $col["plan"]
    if (file == 1) { cl[id] = $col[lk]; cr[id] = $col[rk]; next }
    if (!(id in cl) || cl[id] == "" || $col[lk] == "") next
    if (!(key in n)) order[++k] = key
    n[key]++; sc[key] += cl[id]; sx[key] += $col[lk]
    lb[key] += $col[lk] < cl[id] - 1e-9; lw[key] += $col[lk] > cl[id] + 1e-9
    rb[key] += $col[rk] < cr[id] - 1e-9; rw[key] += $col[rk] > cr[id] + 1e-9
}
END {
    print "| model | plan | rows | log clipped | log censored | log better / worse | rel RMSE better / worse |"
    print "|---|---|---|---|---|---|---|"
    for (i = 1; i <= k; i++) { key = order[i]; split(key, a, " ")
        printf "| %s | %s | %d | %.4f | %.4f | %d / %d | %d / %d |\n", a[1], a[2], n[key],
               sc[key] / n[key], sx[key] / n[key], lb[key], lw[key], rb[key], rw[key] }
}' "$1/results.csv" "$2/results.csv"
