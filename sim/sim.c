#include "sim/sim.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "brdf/angles.h"
#include "planner/motion.h"

struct sim_axis {
    const struct plan_axis *prof;
    const char *name;
    double from, to;  /* current move: positions */
    double t0, t1;    /* and its start and end on the simulated clock */
    double speed, accel; /* of the current move: the profile's unless overridden */
};

struct sim_rig {
    const struct plan_rig *profile;
    const brdf_material *material;
    double now;
    struct sim_axis axis[SIM_N_AXES];
};

sim_rig *sim_rig_new(const struct plan_rig *profile, const brdf_material *material,
                     struct gonio_err *err)
{
    sim_rig *rig = calloc(1, sizeof *rig);
    if (!rig) {
        gonio_err_set(err, ENOMEM, "simulated rig: out of memory");
        return NULL;
    }
    rig->profile = profile;
    rig->material = material;
    rig->axis[SIM_AXIS_SAMPLE] = (struct sim_axis){.prof = &profile->sample, .name = "sample"};
    rig->axis[SIM_AXIS_ARM] = (struct sim_axis){.prof = &profile->arm, .name = "arm"};
    rig->axis[SIM_AXIS_AZIMUTH] = (struct sim_axis){.prof = &profile->azimuth, .name = "azimuth"};
    return rig;
}

void sim_rig_free(sim_rig *rig)
{
    free(rig);
}

double sim_rig_now(const sim_rig *rig)
{
    return rig->now;
}

void sim_rig_advance(sim_rig *rig, double seconds)
{
    if (seconds > 0)
        rig->now += seconds;
}

/* Distance covered t seconds into a rest-to-rest trapezoidal move of length
 * dist (the profile whose duration plan_axis_time gives). */
static double trapezoid_distance(double dist, double speed, double accel, double t)
{
    double total = plan_axis_time(dist, speed, accel);
    if (t >= total)
        return dist;
    if (t <= 0)
        return 0;
    double t_acc = speed / accel;
    if (dist < speed * t_acc) /* triangular: never reaches speed */
        t_acc = total / 2;
    double v_peak = accel * t_acc;
    if (t < t_acc)
        return 0.5 * accel * t * t;
    double d_acc = 0.5 * accel * t_acc * t_acc;
    double t_dec = total - t_acc;
    if (t < t_dec)
        return d_acc + v_peak * (t - t_acc);
    double r = total - t;
    return dist - 0.5 * accel * r * r;
}

double sim_rig_position(const sim_rig *rig, enum sim_axis_id id)
{
    const struct sim_axis *ax = &rig->axis[id];
    if (rig->now >= ax->t1)
        return ax->to;
    double dist = fabs(ax->to - ax->from);
    double done = trapezoid_distance(dist, ax->speed, ax->accel, rig->now - ax->t0);
    return ax->from + (ax->to >= ax->from ? done : -done);
}

int sim_rig_start_move(sim_rig *rig, enum sim_axis_id id, double target_deg,
                       struct gonio_err *err)
{
    const struct plan_axis *prof = rig->axis[id].prof;
    return sim_rig_start_move_at(rig, id, target_deg, prof->speed, prof->accel, err);
}

int sim_rig_start_move_at(sim_rig *rig, enum sim_axis_id id, double target_deg, double speed,
                          double accel, struct gonio_err *err)
{
    struct sim_axis *ax = &rig->axis[id];
    if (!isfinite(target_deg) || target_deg < ax->prof->min || target_deg > ax->prof->max)
        return gonio_err_set(err, GONIO_EUNREACHABLE,
                             "simulated %s axis: target %g deg outside its limits [%g, %g]",
                             ax->name, target_deg, ax->prof->min, ax->prof->max);
    if (!(speed > 0) || !(accel > 0) || !isfinite(speed) || !isfinite(accel))
        return gonio_err_set(err, EINVAL, "simulated %s axis: speed %g, acceleration %g",
                             ax->name, speed, accel);
    /* A new move replaces the current one from where the axis is now; the
     * simplification (restarting from rest) only matters for moves
     * retargeted mid-flight, which the capture engine never does. */
    double here = sim_rig_position(rig, id);
    ax->from = here;
    ax->to = target_deg;
    ax->speed = speed;
    ax->accel = accel;
    ax->t0 = rig->now;
    ax->t1 = rig->now + plan_axis_time(fabs(target_deg - here), speed, accel);
    return 0;
}

double sim_rig_move_end(const sim_rig *rig, enum sim_axis_id id)
{
    return rig->axis[id].t1 > rig->now ? rig->axis[id].t1 : rig->now;
}

void sim_rig_stop(sim_rig *rig, enum sim_axis_id id)
{
    struct sim_axis *ax = &rig->axis[id];
    double here = sim_rig_position(rig, id);
    ax->from = ax->to = here;
    ax->t0 = ax->t1 = rig->now;
}

int sim_rig_sample(const sim_rig *rig, double rgb[3])
{
    /* The planner's three-axis mapping inverted: theta_i = s, theta_o =
     * a - s, and the azimuth axis turns the detector's plane, az = 0 being
     * the plane of incidence (phi_o - phi_i = 180). In-plane this is the
     * design's wo = (-sin theta_r, 0, cos theta_r) with theta_r = a - s. */
    double s = sim_rig_position(rig, SIM_AXIS_SAMPLE);
    double a = sim_rig_position(rig, SIM_AXIS_ARM);
    double az = sim_rig_position(rig, SIM_AXIS_AZIMUTH);
    struct brdf_pair p;
    if (az == 0.0) /* exactly in plane: no sin(180 deg) rounding in wo.y */
        brdf_pair_inplane(s, a - s, &p);
    else
        brdf_pair_spherical(s, 0.0, a - s, az + 180.0, &p);
    brdf_material_eval(rig->material, &p, 1, rgb);
    return 0;
}

int sim_rig_measure(sim_rig *rig, double integration_s, double rgb[3], struct gonio_err *err)
{
    if (!(integration_s > 0))
        return gonio_err_set(err, EINVAL, "simulated detector: integration time %g s",
                             integration_s);
    sim_rig_sample(rig, rgb);
    sim_rig_advance(rig, integration_s);
    return 0;
}
