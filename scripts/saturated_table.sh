#!/bin/sh
# docs/fitting.md "Saturated readings": offline captures on lab's light and
# noise read by the simulator's ideal meter (no ADC: the detector reports
# BRDF and flags what its well clipped; lab itself gives counts, and a
# calibration leaves a clipped reading no value to fit), fitted
# with their saturated readings at the clipped value and as lower bounds
# (`gonio fit --saturated clipped|censored`), full-domain log error /
# relative RMSE against the truth (in-plane for mlp, which has no value out
# of plane) and the censored fit's findings (fit/fit_status.h).
# Usage: scripts/saturated_table.sh [MODEL...] (default abc latent; gonio
# from PATH). Needs ../shared (the NBRDF truths): exits 77 without it.
set -eu
models=${*:-abc latent}
shared=${GONIO_SHARED:-../shared}
if [ ! -d "$shared/data/merl" ]; then
    echo "docs-check: skip: no shared data folder ($shared)" >&2
    exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/metered.yaml" <<EOF
name: metered
material: default
rig: default
detector: {kind: rgb, responsivity: 1.0e6, target_e: 30000}
seed: 1
effects:
  - {name: lamp_drift, sigma: 0.005, tau_s: 1800}
  - {name: stray_light, floor: 0.0005}
  - {name: dark, rate_e_per_s: 500}
  - {name: shot_noise}
  - {name: read_noise, sigma_e: 12}
  - {name: saturation, full_well_e: 100000}
  - {name: jitter, sigma_deg: 0.02}
  - {name: backlash, deg: 0.05, axes: [sample, arm]}
EOF
figures() { # domain file: "log / rel"
    sed -n "s/^$1 *log \([^,]*\), rel_rmse \([^ ]*\) .*/\1 \2/p" "$2" |
        awk '{ printf "%.4f / %.3g", $1, $2 }'
}
echo "| capture | saturated | model | clipped | censored | censored findings |"
echo "|---|---|---|---|---|---|"
for material in brass specular-black-phenolic tungsten-carbide; do
    for plan in ds1 ds3; do
        dir="$tmp/$material-$plan"
        gonio capture --offline --quiet --scene "$tmp/metered.yaml" --material "nbrdf:$material" --plan "$plan" \
            --out "$dir" >/dev/null
        sat=$(awk -F, 'NR > 1 && $14 % 2 == 1 { n++ } END { print n + 0 }' "$dir/samples.csv")
        for m in $models; do
            domain=full
            [ "$m" = mlp ] && domain=inplane
            for s in clipped censored; do
                gonio fit "$dir" --model "$m" --truth "nbrdf:$material" --saturated "$s" \
                    --quiet -o "$dir/$m-$s.model" >"$dir/$m-$s.txt"
            done
            printf '| %s %s | %s | %s | %s | %s | %s |\n' "$material" "$plan" "$sat" "$m" \
                "$(figures $domain "$dir/$m-clipped.txt")" \
                "$(figures $domain "$dir/$m-censored.txt")" \
                "$(sed -n 's/^status *\([a-z,-]*\).*/\1/p' "$dir/$m-censored.txt")"
        done
    done
done
