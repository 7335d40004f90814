/* Rig profiles (rig/rig.h): YAML from the operator. */
#include <math.h>

#include "fuzz/fuzz.h"
#include "rig/rig.h"

static int axis_ok(const struct rig_axis *a)
{
    return a->speed > 0 && a->accel > 0 && isfinite(a->speed) && isfinite(a->accel) &&
           a->min <= a->max && isfinite(a->min) && isfinite(a->max);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("rig.yaml", data, size);
    struct rig_profile rig;
    struct gonio_err err = {0};
    if (rig_profile_load(path, &rig, &err) < 0) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    /* "Every value is range-checked": what loads is usable by the planner. */
    FUZZ_CHECK(axis_ok(&rig.sample) && axis_ok(&rig.arm));
    FUZZ_CHECK(!rig.out_of_plane || axis_ok(&rig.azimuth));
    FUZZ_CHECK(rig.blind_deg >= 0 && rig.settle_s >= 0 && rig.integration_s >= 0);
    FUZZ_CHECK(isfinite(rig.blind_deg) && isfinite(rig.settle_s) && isfinite(rig.integration_s));
    /* ... and by the axis mechanics (drivers/drivers.h). */
    const struct rig_mechanics *m = &rig.mech;
    FUZZ_CHECK(m->in_position_deg > 0 && isfinite(m->in_position_deg));
    FUZZ_CHECK(m->backlash_deg >= 0 && isfinite(m->backlash_deg));
    FUZZ_CHECK((m->approach == 1 || m->approach == -1) && m->move_retries >= 0);
    return 0;
}
