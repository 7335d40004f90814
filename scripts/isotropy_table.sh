#!/bin/sh
# The isotropy check's figures in docs/checks.md: verdicts on constructed
# anisotropic materials (roughness ratio 1.5-3, several orientations) and on
# the ten held-out MERL materials, on the ideal and lab scenes, DS1 with
# --check isotropy on the rotating rig; then the false-alarm rate over N
# seeded isotropic lab captures (DS3, the held-out materials in turn). lab
# gives counts: its captures name a calibration taken first
# (scripts/lab_calibration.sh).
#   scripts/isotropy_table.sh [BUILD_BIN] [N] [PART]
# (defaults build/bin, 300; PART verdicts or alarms: only that half)
set -eu
BIN=${1:-build/bin}
N=${2:-300}
PART=${3:-all}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. "$(dirname "$0")/lab_calibration.sh"
lab_calibrate "$BIN" "$T" rotating
HELD="alum-bronze blue-acrylic brass gold-metallic-paint nylon pearl-paint red-plastic specular-black-phenolic tungsten-carbide white-diffuse-bball"

# capture SCENE PLAN MATERIAL: prints verdict, significance, rig-time share
capture() {
    rm -rf "$T/c"
    "$BIN/gonio" capture --offline --quiet --scene "$1" --rig rotating --plan "$2" \
        --material "$3" --check isotropy $(lab_cal "$1") --out "$T/c" >/dev/null
    python3 -c '
import json, sys
r = json.load(open(sys.argv[1]))
c = r["checks"]["isotropy"]
sig = c["significance"]
print("%s %s %.1f %.1f %.2f" % (c["verdict"], "-" if sig is None else "%.1f" % sig,
      c["threshold"] or 0, 100 * (2.718281828 ** c["max_deviation"] - 1), 100 * c["rig_time_share"]))
' "$T/c/results.json"
}

if [ "$PART" != alarms ]; then
echo "| material | scene | verdict | significance | threshold | largest deviation % | rig time % of DS1 |"
echo "|---|---|---|---|---|---|---|"
for r in "0.1 0.15" "0.2 0.3" "0.06 0.18"; do
    set -- $r
    for phi in 0 45 90; do
        m="analytic:aniso-ggx?ax=$1&ay=$2&phi=$phi"
        for sc in ideal lab; do
            capture $sc ds1 "$m" | (read v s t d c; echo "| \`$m\` | $sc | $v | $s | $t | $d | $c |")
        done
    done
done
for m in $HELD; do
    for sc in ideal lab; do
        capture $sc ds1 "nbrdf:$m" | (read v s t d c; echo "| $m | $sc | $v | $s | $t | $d | $c |")
    done
done

fi
[ "$PART" = verdicts ] && exit 0
# false alarms: N seeded lab captures of isotropic materials
alarms=0 undet=0 i=0
set -- $HELD
while [ $i -lt "$N" ]; do
    m=$(echo $HELD | cut -d' ' -f$((i % 10 + 1)))
    sed "s/^seed: .*/seed: $((i + 100))/; s/^name: .*/name: lab-seed/" configs/scenes/lab.yaml \
        >"$T/lab-seed.yaml"
    v=$(capture "$T/lab-seed.yaml" ds3 "nbrdf:$m" | cut -d' ' -f1)
    [ "$v" = anisotropic ] && alarms=$((alarms + 1))
    [ "$v" = undetermined ] && undet=$((undet + 1))
    i=$((i + 1))
done
echo
echo "false alarms: $alarms of $N seeded isotropic lab captures (DS3), undetermined: $undet"
