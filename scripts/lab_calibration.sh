# Sourced by the table scripts whose captures run on a scene of counts
# (lab and its seeded copies): lab_calibrate BIN DIR RIG calibrates the
# in-process lab detector on RIG into DIR as an operator would, a dark at
# every rung of the ranging ladder, then the reference standard on a 5 deg
# grid to 80 deg (every geometry a capture or a premise check reads), and
# sets CAL to the capture options that name it. lab_cal SCENE prints CAL for
# a scene of counts and nothing for an ideal one.
lab_calibrate() {
    mkdir -p "$2"
    cat >"$2/reference-grid.yaml" <<'PLAN'
name: reference-grid
description: the reference at every incidence and view to 80 deg, 5 deg apart
grid:
  theta_i_step: 5
  theta_i_max: 80
  diffuse_step: 5
  glossy_step: 5
  glossy_half_width: 15
  theta_r_min: -80
  theta_r_max: 80
  blind: 5
order: travel
stop: all
PLAN
    "$1/gonio" calibrate dark --offline --scene lab --rig "$3" --ladder --out "$2/cal" \
        >/dev/null 2>&1
    "$1/gonio" calibrate reference --offline --scene lab --rig "$3" \
        --plan "$2/reference-grid.yaml" --out "$2/cal" >/dev/null 2>&1
    CAL="--calibration newest --calibrations $2/cal"
}

lab_cal() {
    case $1 in ideal*) ;; *) echo "$CAL" ;; esac
}
