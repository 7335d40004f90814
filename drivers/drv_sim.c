#include "drivers/drv_sim.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drivers_private.h"

struct sim_axis_priv {
    sim_rig *rig;
    enum sim_axis_id id;
    double rest_at; /* rig time the last wait found the drive resting */
};

/* The primitives on the simulated drive; the mechanics (band, approach,
 * re-commands, alarm recovery) are the generic layer's, as on Modbus. */
static int sim_start_leg(void *priv, double from_deg, double target_deg, struct gonio_err *err)
{
    (void)from_deg;
    struct sim_axis_priv *p = priv;
    return sim_rig_start_move(p->rig, p->id, target_deg, err);
}

/* The simulated drive reports no IN-POS: the band decides. */
static int sim_wait_rest(void *priv, int *in_pos, unsigned *alarm, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    sim_rig_wait(p->rig, p->id, NULL); /* its alarm is read below */
    p->rest_at = sim_rig_now(p->rig);
    *in_pos = 0;
    *alarm = (unsigned)sim_rig_alarm(p->rig, p->id);
    return 0;
}

static double sim_rested(const void *priv)
{
    const struct sim_axis_priv *p = priv;
    return sim_rig_now(p->rig) - p->rest_at;
}

static int sim_feedback(void *priv, double *deg, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    *deg = sim_rig_position(p->rig, p->id);
    return 0;
}

static int sim_reset_alarm(void *priv, unsigned *still, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    sim_rig_reset_alarm(p->rig, p->id);
    *still = (unsigned)sim_rig_alarm(p->rig, p->id);
    return 0;
}

static int sim_home(void *priv, double from_deg, unsigned *alarm, struct gonio_err *err)
{
    int in_pos;
    int rc = sim_start_leg(priv, from_deg, 0.0, err);
    return rc < 0 ? rc : sim_wait_rest(priv, &in_pos, alarm, err);
}

static int sim_stop(void *priv, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    sim_rig_stop(p->rig, p->id);
    return 0;
}

static const struct drv_axis_ops sim_axis_ops = {
    .name = "sim",
    .start_leg = sim_start_leg,
    .wait_rest = sim_wait_rest,
    .rested = sim_rested,
    .feedback = sim_feedback,
    .reset_alarm = sim_reset_alarm,
    .home = sim_home,
    .stop = sim_stop,
    .free_priv = free,
};

/* A scene with communication faults: every call is one exchange over a
 * link that may drop, corrupt or delay the reply (sim/effects_faults.h). A
 * dropped or late reply costs the timeout on the rig clock, a corrupted one
 * is caught by its checksum; both are retried, and the request is carried
 * out once it gets through (absolute moves and reads are idempotent). */
static int exchange(sim_rig *rig, const char *device, const char *what, struct gonio_err *err)
{
    sim_faults *f = sim_rig_faults(rig);
    int attempts = 1 + sim_faults_retries(f);
    enum sim_fault kind = SIM_FAULT_NONE;
    for (int i = 0; i < attempts; i++) {
        if (sim_faults_next(f, &kind) == SIM_FAULT_NONE)
            return 0;
        if (kind != SIM_FAULT_CORRUPT)
            sim_rig_advance(rig, sim_faults_timeout(f));
    }
    return gonio_err_set(err, GONIO_EDEVICE, "simulated %s: %s: no valid reply in %d attempts "
                         "(last reply %s%s)", device, what, attempts, sim_fault_name(kind),
                         kind == SIM_FAULT_CORRUPT ? ": bad checksum" : ": timed out");
}

static const char *axis_device(const struct sim_axis_priv *p)
{
    static const char *names[SIM_N_AXES] = {"sample axis", "arm axis", "azimuth axis",
                                            "rotation axis"};
    return names[p->id];
}

static int faulty_start_leg(void *priv, double from_deg, double target_deg,
                            struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = exchange(p->rig, axis_device(p), "start move", err);
    return rc < 0 ? rc : sim_start_leg(priv, from_deg, target_deg, err);
}

static int faulty_wait_rest(void *priv, int *in_pos, unsigned *alarm, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = exchange(p->rig, axis_device(p), "status", err);
    return rc < 0 ? rc : sim_wait_rest(priv, in_pos, alarm, err);
}

static int faulty_feedback(void *priv, double *deg, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = exchange(p->rig, axis_device(p), "position", err);
    return rc < 0 ? rc : sim_feedback(priv, deg, err);
}

static int faulty_reset_alarm(void *priv, unsigned *still, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = exchange(p->rig, axis_device(p), "alarm reset", err);
    return rc < 0 ? rc : sim_reset_alarm(priv, still, err);
}

static int faulty_home(void *priv, double from_deg, unsigned *alarm, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = exchange(p->rig, axis_device(p), "home", err);
    return rc < 0 ? rc : sim_home(priv, from_deg, alarm, err);
}

static int faulty_stop(void *priv, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = exchange(p->rig, axis_device(p), "stop", err);
    return rc < 0 ? rc : sim_stop(priv, err);
}

static const struct drv_axis_ops sim_axis_faulty_ops = {
    .name = "sim",
    .start_leg = faulty_start_leg,
    .wait_rest = faulty_wait_rest,
    .rested = sim_rested,
    .feedback = faulty_feedback,
    .reset_alarm = faulty_reset_alarm,
    .home = faulty_home,
    .stop = faulty_stop,
    .free_priv = free,
};

drv_axis *drv_axis_new_sim(sim_rig *rig, enum sim_axis_id axis)
{
    static const char *names[SIM_N_AXES] = {"sample", "arm", "azimuth", "rotation"};
    const struct rig_profile *prof = sim_rig_profile(rig);
    const struct rig_axis *lim[SIM_N_AXES] = {&prof->sample, &prof->arm, &prof->azimuth,
                                              &prof->rotation};
    const struct drv_axis_mechanics mech = {
        .min_deg = lim[axis]->min, .max_deg = lim[axis]->max,
        .in_position_deg = prof->mech.in_position_deg, .backlash_deg = prof->mech.backlash_deg,
        .approach = prof->mech.approach, .move_retries = prof->mech.move_retries};
    char who[32];
    snprintf(who, sizeof who, "axis %s", names[axis]);
    struct sim_axis_priv *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->rig = rig;
    p->id = axis;
    /* the fault layer only where the scene has faults: no cost otherwise */
    return drv_axis_alloc(sim_rig_faults(rig) ? &sim_axis_faulty_ops : &sim_axis_ops, p,
                          names[axis], who, &mech);
}
static int sim_acquire(void *priv, double integration_s, struct drv_reading *out,
                       struct gonio_err *err)
{
    struct sim_reading r;
    int rc = sim_rig_acquire(priv, integration_s, &r, err);
    if (rc < 0)
        return rc;
    memcpy(out->rgb, r.rgb, sizeof out->rgb);
    out->integration_s = r.integration_s;
    out->flags = (r.flags & SIM_SIGNAL_SATURATED) ? DRV_READING_SATURATED : 0;
    out->monitor = r.monitor;
    if (r.counts) {
        out->unit = DRV_UNIT_COUNTS;
        out->full_scale = r.full_scale;
        out->nonlinearity = r.nonlinearity;
        out->n_bands = r.n_bands;
        out->bands_nm = r.bands_nm;
        out->bands = r.spectrum;
    }
    return 0;
}

static int sim_shutter(void *priv, int closed, struct gonio_err *err)
{
    (void)err;
    sim_rig_shutter(priv, closed);
    return 0;
}

static int faulty_shutter(void *priv, int closed, struct gonio_err *err)
{
    int rc = exchange(priv, "detector", closed ? "close shutter" : "open shutter", err);
    return rc < 0 ? rc : sim_shutter(priv, closed, err);
}

static int faulty_acquire(void *priv, double integration_s, struct drv_reading *out,
                          struct gonio_err *err)
{
    int rc = exchange(priv, "detector", "acquire", err);
    return rc < 0 ? rc : sim_acquire(priv, integration_s, out, err);
}

static const struct drv_detector_ops sim_detector_ops = {
    .name = "sim",
    .acquire = sim_acquire,
    .shutter = sim_shutter,
};

static const struct drv_detector_ops sim_detector_faulty_ops = {
    .name = "sim",
    .acquire = faulty_acquire,
    .shutter = faulty_shutter,
};

drv_detector *drv_detector_new_sim(sim_rig *rig)
{
    return drv_detector_alloc(sim_rig_faults(rig) ? &sim_detector_faulty_ops : &sim_detector_ops,
                              rig);
}

static double sim_now(void *priv)
{
    return sim_rig_now(priv);
}

static int sim_sleep(void *priv, double seconds)
{
    sim_rig_advance(priv, seconds);
    return 0;
}

static const struct drv_clock_ops sim_clock_ops = {
    .name = "sim",
    .now = sim_now,
    .sleep = sim_sleep,
};

drv_clock *drv_clock_new_sim(sim_rig *rig)
{
    return drv_clock_alloc(&sim_clock_ops, rig);
}
