#!/bin/sh
# How many sample azimuths an anisotropic model needs (docs/checks.md,
# "Anisotropic materials"): for constructed anisotropic GGX materials
# (roughness ratios 1.5, 3 and 5 at three orientations), the aniso-ggx
# model fitted to in-plane captures of the DS2 grid at K = 1..4 sample
# azimuths (sample_azimuths: K, the rotating rig), beside the same model
# fitted to a dense out-of-plane reference on the same scene, on the
# full-domain log error (mean |log(1 + fhat cos theta_i) - log(1 + f cos
# theta_i)| over the domain turned to every azimuth of the sample,
# brdf/domain.h). The ratios are of those errors as they are, as the
# in-plane study's DS1 / oop200k; "needed" is the least K within 1.25 times
# the reference's error, then the same with the reference floored at 0.001,
# and the rig time of the unfloored K as a share of a DS1 capture of the
# same material and scene. lab gives counts: its captures name a
# calibration taken first (scripts/lab_calibration.sh).
#   scripts/aniso_table.sh [BUILD_BIN] [REFERENCE_PLAN] [SCENES] [RATIOS] [PHIS]
# REFERENCE_PLAN: oop200k (the default: 200,000 nodes, 190,038 outside the
# rig's blind zone; some 4 minutes a capture on a shared 2-core machine),
# oopNk (N thousand nodes drawn with oop200k's seed) or a plan's path;
# SCENES: "ideal lab" by default; RATIOS ("ax:ay ...") and PHIS (degrees)
# narrow the materials, to run the table in parts.
set -eu
BIN=${1:-build/bin}
REF=${2:-oop200k}
SCENES=${3:-ideal lab}
T=$(mktemp -d "${TMPDIR:-/dev/shm}/gonio-aniso-table.XXXXXX" 2>/dev/null || mktemp -d)
trap 'rm -rf "$T"' EXIT
. "$(dirname "$0")/lab_calibration.sh"
case "$SCENES" in *lab*) lab_calibrate "$BIN" "$T" rotating ;; esac
RATIOS=${4:-0.1:0.15 0.1:0.3 0.1:0.5}
PHIS=${5:-0 30 70}
CONF=$(dirname "$0")/../configs/plans

case "$REF" in oop200k) ;; oop*k) # the first N thousand nodes' plan, the same seed
    n=${REF#oop}; n=${n%k}000
    sed -e "s/^name: oop200k/name: $REF/" -e "s/^  n: 200000/  n: $n/" \
        "$CONF/oop200k.yaml" >"$T/$REF.yaml"
    REF=$T/$REF.yaml ;;
esac

# the DS2 grid at K sample azimuths
for k in 1 2 3 4; do
    sed -e "s/^name: ds2/name: ds2-az$k/" -e '/^progressive/d' "$CONF/ds2.yaml" >"$T/ds2-az$k.yaml"
    echo "sample_azimuths: $k" >>"$T/ds2-az$k.yaml"
done

# cap SCENE PLAN MATERIAL: capture with the aniso-ggx model into $T/c,
# print "full_error rig_time_s"
cap() {
    rm -rf "$T/c"
    nice -n 10 "$BIN/gonio" capture --offline --quiet --scene "$1" --rig rotating --plan "$2" \
        --material "$3" --model aniso-ggx $(lab_cal "$1") --out "$T/c" >/dev/null
    python3 -c 'import json, sys
r = json.load(open(sys.argv[1]))
print(r["errors"]["full"]["log"], r["rig_time_s"])' "$T/c/results.json"
}

echo "| material | scene | K = 1 | K = 2 | K = 3 | K = 4 | reference | K = 3 / reference | K = 4 / reference | azimuths needed | its rig time % of DS1 | azimuths needed, reference floored at 0.001 |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for r in $RATIOS; do
    for phi in $PHIS; do
        m="analytic:aniso-ggx?ax=${r%:*}&ay=${r#*:}&phi=$phi"
        for sc in $SCENES; do
            ref=$(cap "$sc" "$REF" "$m")
            ds1=$(cap "$sc" ds1 "$m")
            ks=""
            for k in 1 2 3 4; do
                ks="$ks $(cap "$sc" "$T/ds2-az$k.yaml" "$m")"
            done
            python3 -c 'import sys
m, sc, ref, ds1 = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[6])
v = [float(x) for x in sys.argv[7:]]
err, rig = v[0::2], v[1::2]
def least(bound):
    return next((k for k in range(4) if err[k] <= bound), None)
need, floored = least(1.25 * ref), least(1.25 * max(ref, 0.001))
print("| `%s` | %s | %s | %.5f | %.2f | %.2f | %s | %s | %s |" % (
    m, sc, " | ".join("%.5f" % e for e in err), ref, err[2] / ref, err[3] / ref,
    need + 1 if need is not None else "more than 4",
    "%.0f" % (100 * rig[need] / ds1) if need is not None else "-",
    floored + 1 if floored is not None else "more than 4"))
' "$m" "$sc" $ref $ds1 $ks
        done
    done
done
