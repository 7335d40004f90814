# Sourced by the table scripts whose captures run on a scene of counts
# (lab, bad-day and their seeded copies): lab_calibrate BIN DIR RIG [SCENE]
# calibrates the in-process detector of SCENE (default lab) on RIG into DIR
# as an operator would, a dark at every rung of the ranging ladder, then the
# reference standard on configs/plans/reference-grid.yaml (5 deg apart to
# 80 deg: every geometry a capture or a premise check reads), and sets CAL
# to the capture options that name it; a step that fails prints its error
# and returns 1. lab_cal SCENE prints CAL for a scene of counts and nothing
# for an ideal one.
lab_calibrate() {
    mkdir -p "$2"
    "$1/gonio" calibrate dark --offline --scene "${4:-lab}" --rig "$3" --ladder \
        --out "$2/cal" >/dev/null 2>"$2/cal.err" || { cat "$2/cal.err" >&2; return 1; }
    "$1/gonio" calibrate reference --offline --scene "${4:-lab}" --rig "$3" \
        --plan reference-grid --out "$2/cal" >/dev/null 2>"$2/cal.err" ||
        { cat "$2/cal.err" >&2; return 1; }
    CAL="--calibration newest --calibrations $2/cal"
}

lab_cal() {
    case $1 in ideal*) ;; *) echo "$CAL" ;; esac
}
