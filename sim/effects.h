/* The effects of a scene as a pipeline: built once from the scene (an array
 * of {apply function, state} per place where effects act), so an effect the
 * scene does not name is not in the pipeline and costs nothing: no branch,
 * no random draw. A scene with no effects leaves every value untouched.
 *
 * Every effect owns a GSL random stream seeded from the scene seed, its
 * index in the scene's list and its name, so a run is reproducible and
 * adding an effect does not change the draws of the others.
 *
 * Where effects act (sim.c and sim/effects_detector.c call these):
 *   light   lamp_drift, stray_light: on the signal before the exposure is
 *           chosen (the auto-exposure meter sees them too);
 *   sensor  dark, shot_noise, read_noise, saturation: in electrons, which
 *           is where the integration time enters; then adc (electrons to
 *           counts) and lamp_monitor (the source's own counts);
 *   move    jitter, backlash, stall, alarm: on each axis move command;
 *   faults  comm_faults: the decision per exchange (sim/effects_faults.h). */
#ifndef GONIO_SIM_EFFECTS_H
#define GONIO_SIM_EFFECTS_H

#include "common/err.h"
#include "sim/effects_faults.h"
#include "sim/scene.h"

#define SIM_SIGNAL_SATURATED 0x1u /* same bit as DRV_READING_SATURATED */

/* One detector reading on its way through the pipeline. Values are in the
 * calibrated unit (BRDF, 1/sr); a sensor effect converts to electrons with
 * e = v * responsivity * cos_i * integration_s and back. The adc effect,
 * last, turns them into counts (ADU) and sets counts. */
struct sim_signal {
    double *v;             /* n channel (or band) values */
    int n;
    double cos_i;          /* cosine of the incidence angle (source irradiance) */
    double integration_s;  /* set between the light and sensor stages */
    double now_s;          /* rig clock at the start of the integration */
    double responsivity;   /* e-/s per 1/sr at normal incidence */
    unsigned flags;        /* SIM_SIGNAL_* */
    double lamp_dev;       /* the source's relative deviation from nominal (lamp_drift) */
    int counts;            /* out: v holds ADC counts (adc) */
    double monitor;        /* out: the lamp monitor's counts (lamp_monitor); the caller
                            * sets NAN, what a scene without a monitor reports */
};

/* What a scene's ADC states of itself (the adc effect's parameters). */
struct sim_adc_info {
    double full_scale;   /* 2^bits - 1 */
    double nonlinearity; /* k */
    double offset;       /* ADU */
    double gain;         /* ADU per electron */
};

/* One axis move command as the move effects see it. The caller keeps the
 * per-axis state (hidden_deg, last_dir) from one move to the next. */
struct sim_move {
    int axis;              /* enum sim_axis_id */
    long number;           /* 1-based count of move commands on this axis */
    double commanded_prev; /* the previous commanded target */
    double target;         /* the commanded target */
    double motor_target;   /* out: where the motor goes (target + jitter) */
    double hidden_deg;     /* in/out: load minus motor (backlash slack) */
    int last_dir;          /* in/out: +1/-1, direction of the last real move */
    int alarm;             /* out: alarm code raised by this move, 0 none */
    double stop_fraction;  /* out: with an alarm, the part of the move done */
};

typedef struct sim_effects sim_effects;

/* Build the pipeline of a loaded scene. Returns NULL with err on failure
 * (out of memory only: the scene's parameters were checked on load). */
sim_effects *sim_effects_new(const struct sim_scene *scene, struct gonio_err *err);
void sim_effects_free(sim_effects *fx);

/* Number of effects in the pipeline (all places). */
int sim_effects_count(const sim_effects *fx);

/* True when the scene has detector noise (shot, read, dark): the detector
 * then chooses its integration time by auto-exposure. */
int sim_effects_noisy(const sim_effects *fx);

/* True when the scene has an adc: its readings are raw counts, and *info
 * (may be NULL) gets what the ADC states. */
int sim_effects_adc(const sim_effects *fx, struct sim_adc_info *info);

void sim_effects_light(sim_effects *fx, struct sim_signal *s);
void sim_effects_sensor(sim_effects *fx, struct sim_signal *s);

/* The light stage's expected effect, without a random draw or a state
 * change: the stray-light floor (a lamp's drift averages out). What an
 * estimate of the exposure before the capture can know (sim/estimate.h). */
void sim_effects_light_mean(const sim_effects *fx, struct sim_signal *s);

/* Apply the move effects: m->motor_target starts as m->target. */
void sim_effects_move(sim_effects *fx, struct sim_move *m);

/* The scene's communication faults, or NULL when it has none (borrowed). */
sim_faults *sim_effects_faults(sim_effects *fx);

/* The seed of the stream of the effect at index in a scene seeded seed. */
unsigned long sim_effects_stream_seed(unsigned long seed, int index, const char *name);

#endif
