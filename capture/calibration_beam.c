/* The absolute method's calibration (capture/calibration_beam.h). */
#include "capture/calibration_beam.h"

#include <string.h>

int cal_beam_meta(struct cal_meta *m, const struct rig_profile *rig, struct gonio_err *err)
{
    const struct rig_beam *b = &rig->beam;
    if (!b->on)
        return gonio_err_set(err, GONIO_EBADCONFIG, "beam: rig '%s' states no beam geometry "
                             "(the rig profile's beam section: the detector's aperture and "
                             "distance, docs/plans.md)", rig->name);
    m->beam.on = 1;
    m->beam.omega_sr = rig_beam_omega(b, &m->beam.omega_rel_u);
    m->beam.attenuation = b->attenuation;
    m->beam.attenuation_rel_u = b->attenuation_u / b->attenuation;
    /* The absolute equation holds with the detector seeing the whole spot:
     * what it receives goes with cos(theta_r), the beam's whole flux. */
    m->spot = RAD_SPOT_UNDERFILLED;
    return 0;
}

void cal_beam_point(const struct rig_profile *rig, struct plan_point *pt)
{
    memset(pt, 0, sizeof *pt);
    pt->theta_i = 0;
    pt->theta_r = rig->beam.arm_deg;
    pt->ax.s = 0;
    pt->ax.a = rig->beam.arm_deg;
}
