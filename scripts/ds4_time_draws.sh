#!/bin/sh
# The DS4-time table of docs/notes/adaptive.md ("Ten days in the lab"): the adaptive
# capture with DS4's rig time as its budget (the study's adaptive-ds4) against
# DS4 itself, latent fits, the ten held-out materials, on DRAWS copies of the
# lab scene that differ only in their seed (the detector's noise, the lamp's
# drift and the drives' jitter of another day). One draw is what the study
# measures; the table shows how much of its "at most DS4's error on N of 10"
# is the day's luck.
#
# Usage, from the repository root: scripts/ds4_time_draws.sh [BIN_DIR]
# (default build/bin); env DRAWS_OUT (work dir, default out/ds4_time_draws;
# its scenes/ and study/ are replaced), DRAWS (default 10), JOBS (study
# workers, default 2). Needs the shared data (nbrdf:).
# Prints the Markdown tables on stdout.
set -eu
bin=${1:-build/bin}
out=${DRAWS_OUT:-out/ds4_time_draws}
draws=${DRAWS:-10}
jobs=${JOBS:-2}
rm -rf "$out/scenes" "$out/study"
mkdir -p "$out/scenes"

scenes=""
k=1
while [ "$k" -le "$draws" ]; do
    sed -e "s/^name: lab\$/name: lab-seed$k/" -e "s/^seed: .*/seed: $k/" configs/scenes/lab.yaml \
        >"$out/scenes/lab-seed$k.yaml"
    grep -q "^seed: $k\$" "$out/scenes/lab-seed$k.yaml" ||
        { echo "ds4_time_draws: configs/scenes/lab.yaml has no seed line" >&2; exit 2; }
    scenes="$scenes${scenes:+,}$out/scenes/lab-seed$k.yaml"
    k=$((k + 1))
done
"$bin/gonio" study --quiet --jobs "$jobs" --plans ds4,adaptive-ds4 --models latent \
    --scenes "$scenes" --out "$out/study" >&2

# results.csv's columns by name (docs/study.md); a row without a full-domain
# error (no truth) is left out.
awk -F, '
NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
$col["model"] == "latent" && $col["full_log"] != "" {
    m = $col["material"]; sc = $col["scene"]; e = $col["full_log"] + 0; k = m SUBSEP sc
    if ($col["plan"] == "ds4") ds4[k] = e
    else if ($col["plan"] == "adaptive-ds4") { ad[k] = e; n[k] = $col["samples"] + 0 }
    if (!(sc in seen)) { seen[sc] = 1; scenes[++ns] = sc }
    if (!(m in mseen)) { mseen[m] = 1; mats[++nm] = m }
}
END {
    print "| draw | at most DS4 | geometric mean of adaptive / DS4 | mean samples |"
    print "|---|---:|---:|---:|"
    for (i = 1; i <= ns; i++) {
        w = 0; t = 0; lr = 0; s = 0
        for (j = 1; j <= nm; j++) {
            k = mats[j] SUBSEP scenes[i]
            if (!(k in ds4) || !(k in ad)) continue
            win = ad[k] <= ds4[k]
            t++; s += n[k]; lr += log(ad[k] / ds4[k]); w += win; mw[mats[j]] += win
            mt[mats[j]]++; mlr[mats[j]] += log(ad[k] / ds4[k]); ms[mats[j]] += n[k]
            W += win; T++; LR += log(ad[k] / ds4[k])
        }
        if (t) printf "| %s | %d/%d | %.3f | %.1f |\n", scenes[i], w, t, exp(lr / t), s / t
        if (t && w >= 0.8 * t) met++
    }
    printf "| all %d draws | %d/%d | %.3f | |\n\n", ns, W, T, T ? exp(LR / T) : 0
    printf "At most DS4'\''s error on at least 80 %% of the materials: %d of %d draws.\n\n", met, ns
    print "| material | at most DS4 | geometric mean of adaptive / DS4 | mean samples |"
    print "|---|---:|---:|---:|"
    for (j = 1; j <= nm; j++)
        if (mt[mats[j]])
            printf "| %s | %d/%d | %.3f | %.1f |\n", mats[j], mw[mats[j]], mt[mats[j]],
                   exp(mlr[mats[j]] / mt[mats[j]]), ms[mats[j]] / mt[mats[j]]
}' "$out/study/results.csv"
