#include "sim/effects.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "sim/poisson.h"

/* The state of one effect: its parameters, its random stream and what it
 * carries from one call to the next. */
struct fx_state {
    struct sim_effect_spec spec;
    gsl_rng *rng;
    double x;      /* lamp_drift: current relative deviation */
    double t_last; /* lamp_drift: time of the last update */
    int started;
};

typedef void (*signal_fn)(struct fx_state *st, struct sim_signal *s);
typedef void (*move_fn)(struct fx_state *st, struct sim_move *m);

struct signal_stage {
    signal_fn fn;
    struct fx_state *st;
};

struct move_stage {
    move_fn fn;
    struct fx_state *st;
};

struct sim_faults {
    struct fx_state *st;
    long counts[4];
};

struct sim_effects {
    struct fx_state states[SIM_SCENE_MAX_EFFECTS];
    int n_states;
    struct signal_stage light[SIM_SCENE_MAX_EFFECTS], sensor[SIM_SCENE_MAX_EFFECTS];
    struct move_stage move[SIM_SCENE_MAX_EFFECTS];
    int n_light, n_sensor, n_move;
    int noisy;
    const struct fx_state *adc; /* the adc effect's, NULL without */
    sim_faults *faults;
};

/* ---- light: before the exposure ---------------------------------------- */

/* Lamp drift: the source's output is 1 + x(t), x an Ornstein-Uhlenbeck
 * process (standard deviation sigma, correlation time tau_s) advanced
 * exactly over the time between readings; x = 0 at the first reading (the
 * lamp was calibrated when the capture started). 1 - a^2 is computed as
 * -expm1(-2 dt / tau): with dt a millionth of tau or less, 1 - a * a
 * loses most of its digits, and all of them below 1e-16. A lamp emits no
 * negative light: the output holds at 0 where x < -1 (at sigma 0.5, the
 * largest a scene allows, 2.3% of the time). */
static void fx_lamp_drift(struct fx_state *st, struct sim_signal *s)
{
    if (!st->started) {
        st->started = 1;
        st->x = 0;
    } else {
        double dt = fmax(s->now_s - st->t_last, 0) / st->spec.tau_s;
        st->x = exp(-dt) * st->x +
                st->spec.sigma * sqrt(-expm1(-2 * dt)) * gsl_ran_ugaussian(st->rng);
    }
    st->t_last = s->now_s;
    double gain = fmax(1 + st->x, 0);
    s->lamp_dev = gain - 1;
    for (int k = 0; k < s->n; k++)
        s->v[k] *= gain;
}

/* Stray light: a constant additive floor in every channel. */
static void fx_stray_light(struct fx_state *st, struct sim_signal *s)
{
    for (int k = 0; k < s->n; k++)
        s->v[k] += st->spec.level;
}

/* ---- sensor: in electrons ---------------------------------------------- */

static double electrons_per_unit(const struct sim_signal *s)
{
    return s->responsivity * s->cos_i * s->integration_s;
}

/* Dark current: rate * t electrons on top of the signal (not subtracted:
 * this is the offset a dark frame would have to remove). */
static void fx_dark(struct fx_state *st, struct sim_signal *s)
{
    double add = st->spec.level * s->integration_s / electrons_per_unit(s);
    for (int k = 0; k < s->n; k++)
        s->v[k] += add;
}

/* Shot noise: the electron count is Poisson with the signal as its mean
 * (sim/poisson.h: exact where GSL is, for any mean a scene allows). */
static void fx_shot_noise(struct fx_state *st, struct sim_signal *s)
{
    double scale = electrons_per_unit(s);
    for (int k = 0; k < s->n; k++) {
        double e = s->v[k] * scale;
        if (e > 0) /* also skips NAN (no data) */
            s->v[k] = sim_poisson(st->rng, e) / scale;
    }
}

/* Read noise: Gaussian, sigma_e electrons, independent of the signal. */
static void fx_read_noise(struct fx_state *st, struct sim_signal *s)
{
    double sigma = st->spec.sigma / electrons_per_unit(s);
    for (int k = 0; k < s->n; k++)
        s->v[k] += gsl_ran_gaussian(st->rng, sigma);
}

/* Saturation: a channel holds at most full_well_e electrons. */
static void fx_saturation(struct fx_state *st, struct sim_signal *s)
{
    double full = st->spec.level / electrons_per_unit(s);
    for (int k = 0; k < s->n; k++)
        if (s->v[k] > full) {
            s->v[k] = full;
            s->flags |= SIM_SIGNAL_SATURATED;
        }
}

/* ADC: counts = offset + x - k x^2 / full_scale, x = gain * electrons, as
 * the ADC quantises it (rounded to the nearest count) and clipped to
 * 0..2^bits - 1; a reading at the top is flagged saturated, as the full
 * well's is. The values leave the pipeline as counts (s->counts). */
static uint64_t mix64(uint64_t z);

/* Channel k's offset: the scene's, moved by its fixed pattern (the same
 * on every reading and run: a property of the device, drawn from no
 * stream) within +-offset_spread. */
static double adc_offset(const struct fx_state *st, int k)
{
    if (!(st->spec.offset_spread > 0))
        return st->spec.offset;
    double z = (double)(mix64(0x0ff5e7ull + (uint64_t)k) >> 11) * 0x1p-53;
    return st->spec.offset + st->spec.offset_spread * (2 * z - 1);
}

static void fx_adc(struct fx_state *st, struct sim_signal *s)
{
    double scale = electrons_per_unit(s);
    double full = ldexp(1.0, st->spec.bits) - 1;
    for (int k = 0; k < s->n; k++) {
        double x = st->spec.gain * s->v[k] * scale;
        double adu = floor(adc_offset(st, k) + x - st->spec.nonlinearity * x * x / full + 0.5);
        if (isnan(adu) || adu >= full) { /* NAN: no data, which no ADC gives */
            adu = full;
            s->flags |= SIM_SIGNAL_SATURATED;
        }
        s->v[k] = fmax(adu, 0);
    }
    s->counts = 1;
}

/* Lamp monitor: a second detector that sees the source, not the sample:
 * rate counts per second at the nominal output, times the lamp's present
 * output (lamp_drift), Poisson over the integration. */
static void fx_lamp_monitor(struct fx_state *st, struct sim_signal *s)
{
    double mean = st->spec.level * (1 + s->lamp_dev) * s->integration_s;
    s->monitor = mean > 0 ? sim_poisson(st->rng, mean) : 0;
}

/* ---- moves ----------------------------------------------------------------- */

/* A real move: the commanded target changed (a repeated command leaves the
 * motor where it is, so it draws nothing). */
static int moves(const struct sim_move *m)
{
    return m->target != m->commanded_prev;
}

static int on_axis(const struct fx_state *st, const struct sim_move *m)
{
    return (st->spec.axes >> m->axis) & 1u;
}

/* Jitter: the motor settles sigma_deg (Gaussian) away from the target. */
static void fx_jitter(struct fx_state *st, struct sim_move *m)
{
    if (on_axis(st, m) && moves(m))
        m->motor_target += gsl_ran_gaussian(st->rng, st->spec.sigma);
}

/* Backlash: positive approach is the reference side; a move ending in the
 * negative direction leaves the load deg behind the motor (on the positive
 * side). The motor's encoder does not see it: only the detector does. */
static void fx_backlash(struct fx_state *st, struct sim_move *m)
{
    if (!on_axis(st, m) || !moves(m))
        return;
    int dir = m->target > m->commanded_prev ? 1 : -1;
    m->hidden_deg = dir > 0 ? 0.0 : st->spec.level;
}

static int listed(const struct sim_effect_spec *sp, long number)
{
    for (int i = 0; i < sp->n_at_moves; i++)
        if (sp->at_moves[i] == number)
            return 1;
    return 0;
}

/* Stall: the motor stops part-way (a uniform 20-80% of the move) with the
 * alarm code; alarm: the driver refuses the move with its code. */
static void fx_stall(struct fx_state *st, struct sim_move *m)
{
    if (!on_axis(st, m) || m->alarm)
        return;
    int hit = listed(&st->spec, m->number);
    if (st->spec.rate > 0 && gsl_rng_uniform(st->rng) < st->spec.rate)
        hit = 1;
    if (!hit)
        return;
    m->alarm = st->spec.code;
    m->stop_fraction =
        st->spec.kind == SIM_FX_STALL ? 0.2 + 0.6 * gsl_rng_uniform(st->rng) : 0.0;
}

/* ---- faults ---------------------------------------------------------------- */

int sim_faults_next(sim_faults *f, enum sim_fault *kind)
{
    const struct sim_effect_spec *sp = &f->st->spec;
    double u = gsl_rng_uniform(f->st->rng);
    enum sim_fault k = SIM_FAULT_NONE;
    if (u < sp->drop)
        k = SIM_FAULT_DROP;
    else if (u < sp->drop + sp->corrupt)
        k = SIM_FAULT_CORRUPT;
    else if (u < sp->drop + sp->corrupt + sp->late)
        k = SIM_FAULT_LATE;
    f->counts[k]++;
    if (kind)
        *kind = k;
    return (int)k;
}

double sim_faults_timeout(const sim_faults *f)
{
    return f->st->spec.timeout_s;
}

int sim_faults_retries(const sim_faults *f)
{
    return f->st->spec.retries;
}

const char *sim_fault_name(enum sim_fault kind)
{
    switch (kind) {
    case SIM_FAULT_DROP: return "dropped";
    case SIM_FAULT_CORRUPT: return "corrupted";
    case SIM_FAULT_LATE: return "late";
    default: return "none";
    }
}

void sim_faults_counts(const sim_faults *f, long counts[4])
{
    memcpy(counts, f->counts, sizeof f->counts);
}

/* ---- the pipeline ---------------------------------------------------------- */

/* splitmix64's finaliser: a well-mixed 64-bit value from any input. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

unsigned long sim_effects_stream_seed(unsigned long seed, int index, const char *name)
{
    uint64_t h = 0xcbf29ce484222325ull; /* FNV-1a of the name */
    for (const char *c = name; *c; c++)
        h = (h ^ (unsigned char)*c) * 0x100000001b3ull;
    uint64_t z = mix64(mix64((uint64_t)seed) ^ mix64(h + (uint64_t)index));
    /* GSL's mt19937 takes 32 bits of seed and treats 0 as its default */
    unsigned long s = (unsigned long)(z & 0xffffffffu);
    return s ? s : 1;
}

sim_effects *sim_effects_new(const struct sim_scene *scene, struct gonio_err *err)
{
    static const signal_fn signal_fns[SIM_FX_KINDS] = {
        [SIM_FX_LAMP_DRIFT] = fx_lamp_drift, [SIM_FX_STRAY_LIGHT] = fx_stray_light,
        [SIM_FX_DARK] = fx_dark,             [SIM_FX_SHOT_NOISE] = fx_shot_noise,
        [SIM_FX_READ_NOISE] = fx_read_noise, [SIM_FX_SATURATION] = fx_saturation,
        [SIM_FX_ADC] = fx_adc,               [SIM_FX_LAMP_MONITOR] = fx_lamp_monitor,
    };
    static const move_fn move_fns[SIM_FX_KINDS] = {
        [SIM_FX_JITTER] = fx_jitter, [SIM_FX_BACKLASH] = fx_backlash,
        [SIM_FX_STALL] = fx_stall,   [SIM_FX_ALARM] = fx_stall,
    };
    sim_effects *fx = calloc(1, sizeof *fx);
    if (!fx) {
        gonio_err_set(err, ENOMEM, "scene effects: out of memory");
        return NULL;
    }
    /* Stages in the physical order of enum sim_effect_kind, whatever the
     * order in the file; the stream of each still follows its index. */
    for (int kind = 0; kind < SIM_FX_KINDS; kind++) {
        for (int i = 0; i < scene->n_effects; i++) {
            const struct sim_effect_spec *sp = &scene->effects[i];
            if ((int)sp->kind != kind)
                continue;
            struct fx_state *st = &fx->states[fx->n_states++];
            st->spec = *sp;
            st->rng = gsl_rng_alloc(gsl_rng_mt19937);
            if (!st->rng) {
                sim_effects_free(fx);
                gonio_err_set(err, ENOMEM, "scene effects: out of memory");
                return NULL;
            }
            gsl_rng_set(st->rng, sim_effects_stream_seed(scene->seed, sp->index,
                                                         sim_effect_name(sp->kind)));
            if (kind <= SIM_FX_STRAY_LIGHT)
                fx->light[fx->n_light++] = (struct signal_stage){signal_fns[kind], st};
            else if (kind <= SIM_FX_LAMP_MONITOR)
                fx->sensor[fx->n_sensor++] = (struct signal_stage){signal_fns[kind], st};
            else if (kind <= SIM_FX_ALARM)
                fx->move[fx->n_move++] = (struct move_stage){move_fns[kind], st};
            if (kind == SIM_FX_DARK || kind == SIM_FX_SHOT_NOISE || kind == SIM_FX_READ_NOISE)
                fx->noisy = 1;
            if (kind == SIM_FX_ADC)
                fx->adc = st;
            if (kind == SIM_FX_COMM_FAULTS) {
                fx->faults = calloc(1, sizeof *fx->faults);
                if (!fx->faults) {
                    sim_effects_free(fx);
                    gonio_err_set(err, ENOMEM, "scene effects: out of memory");
                    return NULL;
                }
                fx->faults->st = st;
            }
        }
    }
    return fx;
}

void sim_effects_free(sim_effects *fx)
{
    if (!fx)
        return;
    for (int i = 0; i < fx->n_states; i++)
        gsl_rng_free(fx->states[i].rng);
    free(fx->faults);
    free(fx);
}

int sim_effects_count(const sim_effects *fx)
{
    return fx->n_states;
}

int sim_effects_noisy(const sim_effects *fx)
{
    return fx->noisy;
}

int sim_effects_adc(const sim_effects *fx, struct sim_adc_info *info)
{
    if (!fx->adc)
        return 0;
    if (info)
        *info = (struct sim_adc_info){.full_scale = ldexp(1.0, fx->adc->spec.bits) - 1,
                                      .nonlinearity = fx->adc->spec.nonlinearity,
                                      .offset = fx->adc->spec.offset,
                                      .gain = fx->adc->spec.gain};
    return 1;
}

void sim_effects_light(sim_effects *fx, struct sim_signal *s)
{
    for (int i = 0; i < fx->n_light; i++)
        fx->light[i].fn(fx->light[i].st, s);
}

void sim_effects_light_mean(const sim_effects *fx, struct sim_signal *s)
{
    for (int i = 0; i < fx->n_light; i++)
        if (fx->light[i].fn == fx_stray_light)
            fx_stray_light(fx->light[i].st, s);
}

void sim_effects_sensor(sim_effects *fx, struct sim_signal *s)
{
    for (int i = 0; i < fx->n_sensor; i++)
        fx->sensor[i].fn(fx->sensor[i].st, s);
}

void sim_effects_move(sim_effects *fx, struct sim_move *m)
{
    for (int i = 0; i < fx->n_move; i++)
        fx->move[i].fn(fx->move[i].st, m);
}

sim_faults *sim_effects_faults(sim_effects *fx)
{
    return fx->faults;
}
