/* One point measured on the capture's devices (capture/measure.h). */
#include "capture/measure.h"

#include <math.h>
#include <string.h>

#include "capture/job.h"
#include "rig/motion.h"

void capture_clock_start(struct capture_clock *rc, drv_clock *clock, double base)
{
    rc->clock = clock;
    rc->base = base;
    rc->t0 = rc->last = drv_clock_now(clock);
    rc->paused = 0;
}

double capture_clock_now(struct capture_clock *rc)
{
    rc->last = drv_clock_now(rc->clock);
    return rc->base + (rc->last - rc->t0) - rc->paused;
}

void capture_clock_paused(struct capture_clock *rc)
{
    double now = drv_clock_now(rc->clock);
    rc->paused += now - rc->last;
    rc->last = now;
}

static int journal_dark(void *user, const struct drv_reading *r, struct gonio_err *err)
{
    struct capture_ranging *rg = user;
    struct journal_sample s = *rg->at;
    s.counts = 1;
    memcpy(s.raw, r->rgb, sizeof s.raw);
    for (int c = 0; c < 3; c++)
        s.rgb[c] = NAN;
    s.integration_s = s.integration_total_s = r->integration_s;
    s.gain_state = r->gain_state;
    s.monitor = r->monitor;
    s.flags = JOURNAL_FLAG_DARK | ((r->flags & DRV_READING_SATURATED) ? JOURNAL_FLAG_SATURATED : 0);
    s.rig_time_s = capture_clock_now(rg->clk);
    int rc = journal_append(rg->j, &s, err);
    rg->darks += rc == 0;
    return rc;
}

/* Move the axes together, settle, integrate, and record where the axes
 * actually were: the sample is what the rig measured, not what was asked.
 * The settle runs from when the last axis came to rest, as its drive said
 * (drv_axis_rested); the encoders are read while it runs, so that their
 * reads add nothing to the point's time where the bus is slow. */
int capture_measure_point(struct capture_devices *d, struct capture_clock *clk,
                          const struct capture_hooks *hooks, const struct rig_profile *rig,
                          const struct plan_point *pt, double rotation_deg, int index,
                          struct capture_ranging *rg, struct journal_sample *s,
                          struct gonio_err *err)
{
    /* the axes the rig has: sample, arm, then azimuth and rotation if any */
    drv_axis *axes[4] = {d->sample, d->arm};
    double to[4] = {pt->ax.s, pt->ax.a};
    const struct rig_axis *prof[4] = {&rig->sample, &rig->arm};
    double at[4] = {0, 0, 0, 0}, rested = INFINITY;
    int n = 2, rc;
    /* A turn without the drive would journal the unturned sample as turned. */
    if (!d->rotation && rotation_deg != 0)
        return gonio_err_set(err, GONIO_EUSAGE, "the plan turns the sample to %g deg, but the "
                             "rig source has no rotation axis device", rotation_deg);
    if (d->azimuth) {
        axes[n] = d->azimuth;
        prof[n] = &rig->azimuth;
        to[n++] = pt->ax.az;
    }
    if (d->rotation) {
        axes[n] = d->rotation;
        prof[n] = &rig->rotation;
        to[n++] = rotation_deg;
    }
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_start_move(axes[i], to[i], err)) < 0)
            return rc;
    capture_phase_enter(hooks, CAPTURE_PHASE_MOVE, index);
    /* An axis moving against its approach direction stops beyond the
     * target, then comes back: each such approach leg is sent as its first
     * leg ends, the axes whose first legs end first first, so the move
     * lasts as long as its slowest axis (rig/motion.h). */
    int by_leg[4] = {0, 1, 2, 3};
    double leg[4];
    for (int i = 0; i < n; i++)
        leg[i] = rig_axis_time(drv_axis_leg_deg(axes[i]), prof[i]->speed, prof[i]->accel);
    for (int i = 1; i < n; i++)
        for (int k = i; k > 0 && leg[by_leg[k]] < leg[by_leg[k - 1]]; k--) {
            int tmp = by_leg[k];
            by_leg[k] = by_leg[k - 1];
            by_leg[k - 1] = tmp;
        }
    for (int k = 0; k < n; k++)
        if ((rc = drv_axis_wait_leg(axes[by_leg[k]], err)) < 0)
            return rc;
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_wait(axes[i], err)) < 0)
            return rc;
    capture_phase_enter(hooks, CAPTURE_PHASE_ACQUIRE, index);
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_position(axes[i], &at[i], err)) < 0)
            return rc;
    for (int i = 0; i < n; i++)
        rested = fmin(rested, drv_axis_rested(axes[i]));
    /* The integration starts no sooner than the detector's lag after the
     * call: the settle is over by then. */
    double left = rig->settle_s - rested - drv_detector_lag(d->detector);
    if (left > 0 && (rc = drv_clock_sleep(d->clock, left)) < 0)
        return gonio_err_set(err, -rc, "settle: %s", gonio_strerror(rc));
    journal_sample_clear(s);
    s->point = index;
    s->s = at[0];
    s->a = at[1];
    /* Angles from the axes, with the planner's mapping (sim.c explains). */
    brdf_axes_to_inplane(s->s, s->a, &s->theta_i, &s->theta_r);
    s->theta_o = fabs(s->theta_r);
    s->phi_i = 0.0;
    s->phi_o = fmod((d->azimuth ? at[2] : 0.0) + (s->theta_r >= 0 ? 180.0 : 0.0) + 360.0, 360.0);
    if (d->rotation && rotation_deg != 0) /* the pair on the turned sample, as it read */
        journal_sample_turn(s, at[n - 1]);
    rg->clk = clk;
    rg->at = s;
    struct autorange_take take;
    if ((rc = autorange_acquire(&rg->ar, d->detector, journal_dark, rg, &take, err)) < 0)
        return rc;
    const struct drv_reading r = take.r;
    capture_bands_take(&rg->bands, &r);
    if (r.unit == DRV_UNIT_COUNTS) { /* the record is the counts; BRDF is derived */
        s->counts = 1;
        memcpy(s->raw, r.rgb, sizeof s->raw);
        s->gain_state = r.gain_state;
    } else {
        memcpy(s->rgb, r.rgb, sizeof s->rgb);
    }
    s->monitor = r.monitor;
    s->integration_s = r.integration_s;
    s->integration_total_s = take.total_s;
    s->flags = (r.flags & DRV_READING_SATURATED) ? JOURNAL_FLAG_SATURATED : 0;
    s->rig_time_s = capture_clock_now(clk);
    return 0;
}

/* What the axes' mechanics cost (re-commands, alarms, re-homes), summed. */
void capture_axis_stats_add(const struct capture_devices *d, struct drv_axis_stats *sum)
{
    const drv_axis *axes[4] = {d->sample, d->arm, d->azimuth, d->rotation};
    for (int i = 0; i < 4; i++) {
        struct drv_axis_stats st;
        if (!axes[i])
            continue;
        drv_axis_stats(axes[i], &st);
        sum->moves += st.moves;
        sum->recommands += st.recommands;
        sum->alarms_recovered += st.alarms_recovered;
        sum->rehomes += st.rehomes;
    }
}

void capture_axes_stop(struct capture_devices *d)
{
    drv_axis_stop(d->sample, NULL);
    drv_axis_stop(d->arm, NULL);
    if (d->azimuth)
        drv_axis_stop(d->azimuth, NULL);
    if (d->rotation)
        drv_axis_stop(d->rotation, NULL);
}
