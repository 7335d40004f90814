#include "sim/sim.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/angles.h"
#include "rig/motion.h"
#include "sim/effects.h"
#include "sim/effects_detector.h"

struct sim_axis {
    const struct rig_axis *prof;
    const char *name;
    double from, to;  /* current move: positions */
    double t0, t1;    /* and its start and end on the simulated clock */
    double speed, accel; /* of the current move: the profile's unless overridden */
    /* scene effects (sim/effects.h): the motor positions above are what
     * the encoder reports; the load sits hidden degrees further (backlash) */
    double commanded, hidden;
    int last_dir;
    long moves;
    int alarm; /* driver alarm code, 0 none; set by stall/alarm effects */
    char alarm_msg[200];
};

struct sim_rig {
    const struct rig_profile *profile;
    const brdf_material *material;
    double now;
    struct sim_axis axis[SIM_N_AXES];
    sim_effects *fx;   /* the scene's pipeline (empty without effects) */
    sim_detector *det;
};

static sim_rig *rig_alloc(const struct rig_profile *profile, const brdf_material *material,
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
    rig->axis[SIM_AXIS_ROTATION] =
        (struct sim_axis){.prof = &profile->rotation, .name = "rotation"};
    return rig;
}

sim_rig *sim_rig_new_scene(const struct rig_profile *profile, const brdf_material *material,
                           const struct sim_scene *scene, const char *out_dir,
                           struct gonio_err *err)
{
    struct sim_scene ideal;
    if (!scene) {
        sim_scene_ideal(&ideal, NULL);
        scene = &ideal;
    }
    sim_rig *rig = rig_alloc(profile, material, err);
    if (!rig)
        return NULL;
    char csv[4096];
    if (out_dir && snprintf(csv, sizeof csv, "%s/spectra.csv", out_dir) >= (int)sizeof csv) {
        sim_rig_free(rig);
        gonio_err_set(err, ENAMETOOLONG, "%s: path too long", out_dir);
        return NULL;
    }
    rig->fx = sim_effects_new(scene, err);
    if (rig->fx)
        rig->det = sim_detector_new(profile, material, scene, rig->fx, out_dir ? csv : NULL, err);
    if (!rig->det) {
        sim_rig_free(rig);
        return NULL;
    }
    return rig;
}

sim_rig *sim_rig_new(const struct rig_profile *profile, const brdf_material *material,
                     struct gonio_err *err)
{
    return sim_rig_new_scene(profile, material, NULL, NULL, err);
}

int sim_rig_mount(sim_rig *rig, const brdf_material *material, const struct sim_scene *scene,
                  struct gonio_err *err)
{
    rig->material = material;
    return sim_detector_mount(rig->det, material, scene, err);
}

void sim_rig_free(sim_rig *rig)
{
    if (!rig)
        return;
    sim_detector_free(rig->det);
    sim_effects_free(rig->fx);
    free(rig);
}

int sim_rig_counts(const sim_rig *rig)
{
    return rig->fx && sim_effects_adc(rig->fx, NULL);
}

const struct rig_profile *sim_rig_profile(const sim_rig *rig)
{
    return rig->profile;
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
 * dist (the profile whose duration rig_axis_time gives). */
static double trapezoid_distance(double dist, double speed, double accel, double t)
{
    double total = rig_axis_time(dist, speed, accel);
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
    const struct rig_axis *prof = rig->axis[id].prof;
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
    if (ax->alarm)
        return gonio_err_set(err, GONIO_EDEVICE, "simulated %s axis: in alarm 0x%02x (reset it "
                             "before moving): %s", ax->name, ax->alarm, ax->alarm_msg);
    /* A new move replaces the current one from where the axis is now; the
     * simplification (restarting from rest) only matters for moves
     * retargeted mid-flight, which the capture engine never does. */
    double here = sim_rig_position(rig, id);
    double to = target_deg;
    {
        struct sim_move m = {.axis = id, .number = ++ax->moves, .commanded_prev = ax->commanded,
                             .target = target_deg,
                             /* the same command again leaves the motor where it went */
                             .motor_target = target_deg == ax->commanded ? ax->to : target_deg,
                             .hidden_deg = ax->hidden, .last_dir = ax->last_dir};
        sim_effects_move(rig->fx, &m);
        ax->commanded = target_deg;
        ax->hidden = m.hidden_deg;
        ax->last_dir = m.last_dir;
        to = m.motor_target;
        if (m.alarm) {
            to = here + m.stop_fraction * (to - here);
            ax->alarm = m.alarm;
            snprintf(ax->alarm_msg, sizeof ax->alarm_msg,
                     "%s on move %ld (to %g deg), stopped at %g deg",
                     m.alarm == 0x10 ? "excessive position deviation (motor stalled)"
                                     : "driver alarm",
                     m.number, target_deg, to);
        }
    }
    ax->from = here;
    ax->to = to;
    ax->speed = speed;
    ax->accel = accel;
    ax->t0 = rig->now;
    ax->t1 = rig->now + rig_axis_time(fabs(to - here), speed, accel);
    return 0;
}

int sim_rig_wait(sim_rig *rig, enum sim_axis_id id, struct gonio_err *err)
{
    struct sim_axis *ax = &rig->axis[id];
    sim_rig_advance(rig, sim_rig_move_end(rig, id) - rig->now);
    if (ax->alarm)
        return gonio_err_set(err, GONIO_EDEVICE, "simulated %s axis: alarm 0x%02x: %s", ax->name,
                             ax->alarm, ax->alarm_msg);
    return 0;
}

int sim_rig_alarm(const sim_rig *rig, enum sim_axis_id id)
{
    return rig->axis[id].alarm;
}

void sim_rig_reset_alarm(sim_rig *rig, enum sim_axis_id id)
{
    rig->axis[id].alarm = 0;
    rig->axis[id].alarm_msg[0] = '\0';
}

sim_faults *sim_rig_faults(sim_rig *rig)
{
    return sim_effects_faults(rig->fx);
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
    ax->commanded = here;
}

void sim_axes_optics(double s, double a, double az, struct brdf_pair *pp, double *cos_i)
{
    /* The planner's three-axis mapping inverted: theta_i = s, theta_o =
     * a - s, and the azimuth axis turns the detector's plane, az = 0 being
     * the plane of incidence (phi_o - phi_i = 180). In-plane this is the
     * design's wo = (-sin theta_r, 0, cos theta_r) with theta_r = a - s. */
    struct brdf_pair p;
    if (az == 0.0) /* exactly in plane: no sin(180 deg) rounding in wo.y */
        brdf_pair_inplane(s, a - s, &p);
    else
        brdf_pair_spherical(s, 0.0, a - s, az + 180.0, &p);
    *pp = p;
    double c = cos(s * BRDF_DEG);
    *cos_i = c > 1e-3 ? c : 1e-3;
}

/* The pair the optics see: the load positions (motor plus backlash slack). */
static void sim_rig_optics(const sim_rig *rig, struct brdf_pair *pp, double *cos_i)
{
    double s = sim_rig_position(rig, SIM_AXIS_SAMPLE) + rig->axis[SIM_AXIS_SAMPLE].hidden;
    double a = sim_rig_position(rig, SIM_AXIS_ARM) + rig->axis[SIM_AXIS_ARM].hidden;
    double az = sim_rig_position(rig, SIM_AXIS_AZIMUTH) + rig->axis[SIM_AXIS_AZIMUTH].hidden;
    sim_axes_optics(s, a, az, pp, cos_i);
    /* the sample's own rotation: what its frame sees (0 on rigs without) */
    brdf_pair_rotate(pp, sim_rig_position(rig, SIM_AXIS_ROTATION));
}

int sim_rig_sample(const sim_rig *rig, double rgb[3])
{
    struct brdf_pair p;
    double cos_i;
    sim_rig_optics(rig, &p, &cos_i);
    brdf_material_eval(rig->material, &p, 1, rgb);
    return 0;
}

int sim_rig_read(sim_rig *rig, double integration_s, struct sim_reading *out,
                 struct gonio_err *err)
{
    if (!(integration_s > 0))
        return gonio_err_set(err, EINVAL, "simulated detector: integration time %g s",
                             integration_s);
    struct brdf_pair p;
    double cos_i, ti, tr;
    sim_rig_optics(rig, &p, &cos_i);
    brdf_axes_to_inplane(sim_rig_position(rig, SIM_AXIS_SAMPLE),
                         sim_rig_position(rig, SIM_AXIS_ARM), &ti, &tr);
    return sim_detector_read(rig->det, &p, cos_i, rig->now, integration_s, ti, tr, out, err);
}

void sim_rig_shutter(sim_rig *rig, int closed)
{
    sim_detector_shutter(rig->det, closed);
}

int sim_rig_acquire(sim_rig *rig, double integration_s, struct sim_reading *out,
                    struct gonio_err *err)
{
    int rc = sim_rig_read(rig, integration_s, out, err);
    if (rc == 0)
        sim_rig_advance(rig, out->integration_s);
    return rc;
}

int sim_rig_measure(sim_rig *rig, double integration_s, double rgb[3], struct gonio_err *err)
{
    if (!(integration_s > 0))
        return gonio_err_set(err, EINVAL, "simulated detector: integration time %g s",
                             integration_s);
    struct sim_reading r;
    int rc = sim_rig_acquire(rig, integration_s, &r, err);
    if (rc == 0)
        memcpy(rgb, r.rgb, sizeof r.rgb);
    return rc;
}
