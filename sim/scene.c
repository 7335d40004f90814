#include "sim/scene.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/spectral.h"
#include "common/cfg.h"
#include "common/paths.h"
#include "rig/rig.h"

/* Default detector: a white diffuser (1/pi per sr) gives about 3.2e5 e-/s
 * at normal incidence, so with a 30000 e- auto-exposure target (a 100k e-
 * well kept below a third) it integrates about 0.1 s, and a dark sample
 * (0.01/sr) reaches the 2 s cap of the default rig. */
#define DEFAULT_RESPONSIVITY 1e6
#define DEFAULT_TARGET_E 3e4

static const char *const effect_names[SIM_FX_KINDS] = {
    [SIM_FX_LAMP_DRIFT] = "lamp_drift",   [SIM_FX_STRAY_LIGHT] = "stray_light",
    [SIM_FX_DARK] = "dark",               [SIM_FX_SHOT_NOISE] = "shot_noise",
    [SIM_FX_READ_NOISE] = "read_noise",   [SIM_FX_SATURATION] = "saturation",
    [SIM_FX_ADC] = "adc",                 [SIM_FX_LAMP_MONITOR] = "lamp_monitor",
    [SIM_FX_JITTER] = "jitter",           [SIM_FX_BACKLASH] = "backlash",
    [SIM_FX_STALL] = "stall",             [SIM_FX_ALARM] = "alarm",
    [SIM_FX_COMM_FAULTS] = "comm_faults", [SIM_FX_STANDARD_DRAW] = "standard_draw",
};

/* The keys each effect accepts besides "name" (NULL-terminated). */
static const char *const *effect_keys(enum sim_effect_kind k)
{
    static const char *const drift[] = {"name", "sigma", "tau_s", NULL};
    static const char *const stray[] = {"name", "floor", NULL};
    static const char *const dark[] = {"name", "rate_e_per_s", NULL};
    static const char *const shot[] = {"name", NULL};
    static const char *const read[] = {"name", "sigma_e", NULL};
    static const char *const sat[] = {"name", "full_well_e", NULL};
    static const char *const adc[] = {"name", "gain_adu_per_e", "bits", "offset_adu",
                                      "nonlinearity", "offset_spread_adu", NULL};
    static const char *const monitor[] = {"name", "rate_counts_per_s", NULL};
    static const char *const jitter[] = {"name", "sigma_deg", "axes", NULL};
    static const char *const backlash[] = {"name", "deg", "axes", NULL};
    static const char *const stall[] = {"name", "rate", "at_moves", "axes", "code", NULL};
    static const char *const comm[] = {"name",    "drop",    "corrupt", "late",
                                       "timeout_s", "retries", NULL};
    switch (k) {
    case SIM_FX_LAMP_DRIFT: return drift;
    case SIM_FX_STRAY_LIGHT: return stray;
    case SIM_FX_DARK: return dark;
    case SIM_FX_SHOT_NOISE: return shot;
    case SIM_FX_READ_NOISE: return read;
    case SIM_FX_SATURATION: return sat;
    case SIM_FX_ADC: return adc;
    case SIM_FX_LAMP_MONITOR: return monitor;
    case SIM_FX_JITTER: return jitter;
    case SIM_FX_BACKLASH: return backlash;
    case SIM_FX_STALL:
    case SIM_FX_ALARM: return stall;
    case SIM_FX_COMM_FAULTS: return comm;
    default: return shot;
    }
}

const char *sim_effect_name(enum sim_effect_kind kind)
{
    return (unsigned)kind < SIM_FX_KINDS ? effect_names[kind] : NULL;
}

static int copy_string(const struct cfg_doc *doc, const struct cfg_node *root, const char *key,
                       enum cfg_need need, char *out, size_t size, struct gonio_err *err)
{
    const char *v;
    int rc = cfg_string(doc, root, key, need, &v, err);
    if (rc <= 0)
        return rc;
    if (strlen(v) >= size)
        return cfg_error(doc, cfg_get(doc, root, key), key, err, "value longer than %zu characters",
                         size - 1);
    memcpy(out, v, strlen(v) + 1);
    return 1;
}

/* axes: [sample, arm, azimuth] (any subset); absent: all axes. */
static int parse_axes(const struct cfg_doc *doc, const struct cfg_node *map, unsigned *mask,
                      struct gonio_err *err)
{
    static const char *const axis_names[] = {"sample", "arm", "azimuth"};
    const struct cfg_node *seq;
    *mask = SIM_AXES_ALL;
    int rc = cfg_seq(doc, map, "axes", CFG_OPTIONAL, &seq, err);
    if (rc < 0 || !seq)
        return rc < 0 ? rc : 0;
    size_t n = cfg_seq_len(doc, seq);
    if (n == 0)
        return cfg_error(doc, seq, "axes", err, "empty list (name sample, arm or azimuth)");
    *mask = 0;
    for (size_t i = 0; i < n; i++) {
        const struct cfg_node *item = cfg_seq_item(doc, seq, i);
        const char *name;
        if ((rc = cfg_node_string(doc, item, "axes", &name, err)) < 0)
            return rc;
        unsigned bit = 0;
        for (unsigned a = 0; a < 3; a++)
            if (!strcmp(name, axis_names[a]))
                bit = 1u << a;
        if (!bit)
            return cfg_error(doc, item, "axes", err, "unknown axis '%s' (use sample, arm, azimuth)",
                             name);
        *mask |= bit;
    }
    return 0;
}

static int parse_at_moves(const struct cfg_doc *doc, const struct cfg_node *map,
                          struct sim_effect_spec *fx, struct gonio_err *err)
{
    const struct cfg_node *seq;
    int rc = cfg_seq(doc, map, "at_moves", CFG_OPTIONAL, &seq, err);
    if (rc < 0 || !seq)
        return rc < 0 ? rc : 0;
    size_t n = cfg_seq_len(doc, seq);
    if (n > SIM_EFFECT_MAX_MOVES)
        return cfg_error(doc, seq, "at_moves", err, "%zu moves listed, at most %d", n,
                         SIM_EFFECT_MAX_MOVES);
    for (size_t i = 0; i < n; i++) {
        const struct cfg_node *item = cfg_seq_item(doc, seq, i);
        double v;
        if ((rc = cfg_node_double(doc, item, "at_moves", 1, 1e9, &v, err)) < 0)
            return rc;
        if (v != floor(v))
            return cfg_error(doc, item, "at_moves", err, "move number %g is not an integer", v);
        fx->at_moves[fx->n_at_moves++] = (long)v;
    }
    return 0;
}

/* adc: an ADC of bits bits after a gain, with an offset that must leave
 * room for a signal, and a nonlinearity that keeps the response rising up
 * to full scale (x - k x^2 / FS has its maximum at x = FS / 2k). */
static int parse_adc(const struct cfg_doc *doc, const struct cfg_node *item,
                     struct sim_effect_spec *fx, struct gonio_err *err)
{
    long bits = 16;
    int rc;
    if ((rc = cfg_double(doc, item, "gain_adu_per_e", CFG_REQUIRED, 1e-6, 1e6, &fx->gain,
                         err)) < 0 ||
        (rc = cfg_int(doc, item, "bits", CFG_OPTIONAL, 8, 32, &bits, err)) < 0 ||
        (rc = cfg_double(doc, item, "offset_adu", CFG_OPTIONAL, 0, 4294967295.0, &fx->offset,
                         err)) < 0 ||
        (rc = cfg_double(doc, item, "nonlinearity", CFG_OPTIONAL, 0, 0.4, &fx->nonlinearity,
                         err)) < 0 ||
        (rc = cfg_double(doc, item, "offset_spread_adu", CFG_OPTIONAL, 0, 4294967295.0,
                         &fx->offset_spread, err)) < 0)
        return rc;
    if (fx->offset_spread > fx->offset)
        return cfg_error(doc, cfg_get(doc, item, "offset_spread_adu"), "offset_spread_adu", err,
                         "%g ADU is more than the offset (%g ADU): an offset cannot go below 0",
                         fx->offset_spread, fx->offset);
    fx->bits = (int)bits;
    double full = ldexp(1.0, fx->bits) - 1;
    if (fx->offset + fx->offset_spread >= full / 2)
        return cfg_error(doc, cfg_get(doc, item, "offset_adu"), "offset_adu", err,
                         "%g ADU leaves less than half of the %d-bit range (%g) for the signal",
                         fx->offset, fx->bits, full);
    return 0;
}

/* The parameters of one effect item (a mapping with its name). */
static int parse_params(const struct cfg_doc *doc, const struct cfg_node *item,
                        struct sim_effect_spec *fx, struct gonio_err *err)
{
    int rc = 0;
    long l;
    switch (fx->kind) {
    case SIM_FX_LAMP_DRIFT:
        fx->tau_s = 600;
        if ((rc = cfg_double(doc, item, "sigma", CFG_REQUIRED, 0, 0.5, &fx->sigma, err)) < 0 ||
            (rc = cfg_double(doc, item, "tau_s", CFG_OPTIONAL, 1e-3, 1e9, &fx->tau_s, err)) < 0)
            return rc;
        break;
    case SIM_FX_STRAY_LIGHT:
        rc = cfg_double(doc, item, "floor", CFG_REQUIRED, 0, 1e3, &fx->level, err);
        break;
    case SIM_FX_DARK:
        rc = cfg_double(doc, item, "rate_e_per_s", CFG_REQUIRED, 0, 1e12, &fx->level, err);
        break;
    case SIM_FX_SHOT_NOISE:
        break;
    case SIM_FX_READ_NOISE:
        rc = cfg_double(doc, item, "sigma_e", CFG_REQUIRED, 0, 1e9, &fx->sigma, err);
        break;
    case SIM_FX_SATURATION:
        rc = cfg_double(doc, item, "full_well_e", CFG_REQUIRED, 1, 1e15, &fx->level, err);
        break;
    case SIM_FX_ADC:
        rc = parse_adc(doc, item, fx, err);
        break;
    case SIM_FX_LAMP_MONITOR:
        rc = cfg_double(doc, item, "rate_counts_per_s", CFG_REQUIRED, 1e-3, 1e12, &fx->level,
                        err);
        break;
    case SIM_FX_JITTER:
        if ((rc = cfg_double(doc, item, "sigma_deg", CFG_REQUIRED, 0, 10, &fx->sigma, err)) < 0)
            return rc;
        rc = parse_axes(doc, item, &fx->axes, err);
        break;
    case SIM_FX_BACKLASH:
        if ((rc = cfg_double(doc, item, "deg", CFG_REQUIRED, 0, 10, &fx->level, err)) < 0)
            return rc;
        rc = parse_axes(doc, item, &fx->axes, err);
        break;
    case SIM_FX_STALL:
    case SIM_FX_ALARM:
        /* AZ-series codes: 0x10 excessive position deviation (what a
         * stalled closed-loop motor reports), 0x30 overload. */
        l = fx->kind == SIM_FX_STALL ? 0x10 : 0x30;
        if ((rc = cfg_double(doc, item, "rate", CFG_OPTIONAL, 0, 1, &fx->rate, err)) < 0 ||
            (rc = parse_at_moves(doc, item, fx, err)) < 0 ||
            (rc = parse_axes(doc, item, &fx->axes, err)) < 0 ||
            (rc = cfg_int(doc, item, "code", CFG_OPTIONAL, 1, 0xFFFF, &l, err)) < 0)
            return rc;
        fx->code = (int)l;
        if (fx->rate == 0 && fx->n_at_moves == 0)
            return cfg_error(doc, item, "rate", err,
                             "%s needs a rate or at_moves (it would never happen)",
                             effect_names[fx->kind]);
        break;
    case SIM_FX_COMM_FAULTS:
        fx->timeout_s = 0.1;
        l = 3;
        if ((rc = cfg_double(doc, item, "drop", CFG_OPTIONAL, 0, 0.5, &fx->drop, err)) < 0 ||
            (rc = cfg_double(doc, item, "corrupt", CFG_OPTIONAL, 0, 0.5, &fx->corrupt, err)) < 0 ||
            (rc = cfg_double(doc, item, "late", CFG_OPTIONAL, 0, 0.5, &fx->late, err)) < 0 ||
            (rc = cfg_double(doc, item, "timeout_s", CFG_OPTIONAL, 0, 60, &fx->timeout_s,
                             err)) < 0 ||
            (rc = cfg_int(doc, item, "retries", CFG_OPTIONAL, 0, 20, &l, err)) < 0)
            return rc;
        fx->retries = (int)l;
        if (fx->drop + fx->corrupt + fx->late == 0)
            return cfg_error(doc, item, "drop", err,
                             "comm_faults needs a drop, corrupt or late rate above 0");
        /* One draw per exchange decides among the three (sim/effects.c): past
         * a sum of 1 the later rates would silently be less than written. */
        if (fx->drop + fx->corrupt + fx->late > 1)
            return cfg_error(doc, item, "drop", err,
                             "drop + corrupt + late is %g + %g + %g = %g, more than 1 (they "
                             "are shares of the same exchanges)",
                             fx->drop, fx->corrupt, fx->late,
                             fx->drop + fx->corrupt + fx->late);
        break;
    default:
        break;
    }
    return rc < 0 ? rc : 0;
}

static int parse_effects(const struct cfg_doc *doc, const struct cfg_node *root,
                         struct sim_scene *scene, struct gonio_err *err)
{
    const struct cfg_node *effects;
    int rc = cfg_seq(doc, root, "effects", CFG_OPTIONAL, &effects, err);
    if (rc < 0 || !effects)
        return rc < 0 ? rc : 0;
    size_t n = cfg_seq_len(doc, effects);
    if (n > SIM_SCENE_MAX_EFFECTS)
        return cfg_error(doc, effects, "effects", err, "%zu effects, at most %d", n,
                         SIM_SCENE_MAX_EFFECTS);
    int seen[SIM_FX_KINDS] = {0};
    for (size_t i = 0; i < n; i++) {
        const struct cfg_node *item = cfg_seq_item(doc, effects, i), *name_node;
        int kind = cfg_named_item(doc, item, "effects", "effect", effect_names, SIM_FX_KINDS,
                                  &name_node, err);
        if (kind < 0)
            return kind;
        const char *name = effect_names[kind];
        if (seen[kind]) {
            int line, col;
            cfg_mark(cfg_seq_item(doc, effects, (size_t)seen[kind] - 1), &line, &col);
            return cfg_error(doc, name_node, "name", err,
                             "effect '%s' named twice (first at line %d)", name, line);
        }
        seen[kind] = (int)i + 1;
        struct sim_effect_spec *fx = &scene->effects[i];
        memset(fx, 0, sizeof *fx);
        fx->kind = (enum sim_effect_kind)kind;
        fx->index = (int)i;
        if (cfg_is_map(doc, item)) {
            if ((rc = cfg_check_keys(doc, item, name, effect_keys(fx->kind), err)) < 0 ||
                (rc = parse_params(doc, item, fx, err)) < 0)
                return rc;
        } else if (effect_keys(fx->kind)[1]) {
            /* a bare name is enough only for effects without parameters */
            const char *first = fx->kind == SIM_FX_COMM_FAULTS ? "drop"
                                : (fx->kind == SIM_FX_STALL || fx->kind == SIM_FX_ALARM)
                                    ? "rate"
                                    : effect_keys(fx->kind)[1];
            return cfg_error(doc, item, first, err,
                             "effect '%s' needs parameters: write {name: %s, %s: ...}", name,
                             name, first);
        }
    }
    scene->n_effects = (int)n;
    if (seen[SIM_FX_ADC] && scene->detector == SIM_DETECTOR_SPECTRAL) {
        /* a spectral detector's counts leave in three bins as well (its
         * RGB): each must hold a band */
        int in_bin[3] = {0};
        for (int k = 0; k < scene->n_bands; k++)
            in_bin[sim_scene_count_bin(scene->bands_nm[k])]++;
        for (int c = 0; c < 3; c++)
            if (!in_bin[c]) {
                const struct cfg_node *adc =
                    cfg_seq_item(doc, effects, (size_t)seen[SIM_FX_ADC] - 1);
                const struct cfg_node *at = cfg_is_map(doc, adc) ? cfg_get(doc, adc, "name") : adc;
                return cfg_error(doc, at ? at : adc, "name", err,
                                 "effect 'adc' on a spectral detector needs bands on both sides "
                                 "of 495 and 595 nm (its counts' %s bin is empty)",
                                 c == 0 ? "595 nm and up" : c == 1 ? "495-595 nm" : "below 495 nm");
            }
    }
    return 0;
}

int sim_scene_count_bin(double nm)
{
    return nm >= 595 ? 0 : nm >= 495 ? 1 : 2;
}

/* bands: {first_nm, last_nm, step_nm} or a list of wavelengths. */
static int parse_bands(const struct cfg_doc *doc, const struct cfg_node *det,
                       struct sim_scene *scene, struct gonio_err *err)
{
    const struct cfg_node *b = cfg_get(doc, det, "bands");
    if (!b)
        return 0;
    if (cfg_is_seq(doc, b)) {
        double *v;
        size_t n;
        int rc = cfg_doubles(doc, det, "bands", CFG_REQUIRED, 360, 830, 3, SIM_SCENE_MAX_BANDS,
                             &v, &n, err);
        if (rc < 0)
            return rc;
        for (size_t i = 1; i < n; i++)
            if (!(v[i] > v[i - 1])) {
                free(v);
                return cfg_error(doc, b, "bands", err, "wavelengths must increase (%g after %g)",
                                 v[i], v[i - 1]);
            }
        memcpy(scene->bands_nm, v, n * sizeof *v);
        scene->n_bands = (int)n;
        free(v);
        return 0;
    }
    static const char *const keys[] = {"first_nm", "last_nm", "step_nm", NULL};
    double first, last, step;
    int rc;
    if ((rc = cfg_check_keys(doc, b, "bands", keys, err)) < 0 ||
        (rc = cfg_double(doc, b, "first_nm", CFG_REQUIRED, 360, 830, &first, err)) < 0 ||
        (rc = cfg_double(doc, b, "last_nm", CFG_REQUIRED, 360, 830, &last, err)) < 0 ||
        (rc = cfg_double(doc, b, "step_nm", CFG_REQUIRED, 1, 100, &step, err)) < 0)
        return rc;
    double count = (last - first) / step;
    if (!(last > first) || fabs(count - round(count)) > 1e-9 ||
        round(count) + 1 > SIM_SCENE_MAX_BANDS || round(count) + 1 < 3)
        return cfg_error(doc, b, "bands", err,
                         "%g..%g nm at %g nm is not 3 to %d whole steps", first, last, step,
                         SIM_SCENE_MAX_BANDS);
    scene->n_bands = (int)round(count) + 1;
    for (int i = 0; i < scene->n_bands; i++)
        scene->bands_nm[i] = first + step * i;
    return 0;
}

/* detector: rgb | spectral | {kind, bands, responsivity, target_e, spot,
 * solid_angle_sr, attenuator}. */
static int parse_detector(const struct cfg_doc *doc, const struct cfg_node *root,
                          struct sim_scene *scene, struct gonio_err *err)
{
    static const char *const kinds[] = {"rgb", "spectral", NULL};
    static const char *const keys[] = {"kind", "bands", "responsivity", "target_e", "spot",
                                       "solid_angle_sr", "attenuator", NULL};
    static const char *const spots[] = {"overfilled", "underfilled", NULL};
    const struct cfg_node *det = cfg_get(doc, root, "detector");
    int kind = SIM_DETECTOR_RGB, rc;
    if (det && cfg_is_map(doc, det)) {
        if ((rc = cfg_check_keys(doc, det, "detector", keys, err)) < 0 ||
            (rc = cfg_enum(doc, det, "spot", CFG_OPTIONAL, spots, &scene->underfilled,
                           err)) < 0 ||
            (rc = cfg_double(doc, det, "solid_angle_sr", CFG_OPTIONAL, 1e-9, 1,
                             &scene->solid_angle_sr, err)) < 0 ||
            (rc = cfg_double(doc, det, "attenuator", CFG_OPTIONAL, 1e-9, 1, &scene->attenuator,
                             err)) < 0 ||
            (rc = cfg_enum(doc, det, "kind", CFG_REQUIRED, kinds, &kind, err)) < 0 ||
            (rc = cfg_double(doc, det, "responsivity", CFG_OPTIONAL, 1e-6, 1e15,
                             &scene->responsivity, err)) < 0 ||
            (rc = cfg_double(doc, det, "target_e", CFG_OPTIONAL, 1, 1e15, &scene->target_e,
                             err)) < 0 ||
            (rc = parse_bands(doc, det, scene, err)) < 0)
            return rc;
        if (kind == SIM_DETECTOR_RGB && scene->n_bands)
            return cfg_error(doc, cfg_get(doc, det, "bands"), "bands", err,
                             "bands need kind: spectral");
    } else if ((rc = cfg_enum(doc, root, "detector", CFG_OPTIONAL, kinds, &kind, err)) < 0) {
        return rc;
    }
    scene->detector = (enum sim_detector_kind)kind;
    if (kind == SIM_DETECTOR_SPECTRAL && !scene->n_bands) {
        scene->n_bands = 31; /* the design's default: 400-700 nm at 10 nm */
        for (int i = 0; i < 31; i++)
            scene->bands_nm[i] = 400 + 10 * i;
    }
    /* Bands beyond a spectral material's data are refused here, before a
     * capture writes anything (a material that does not open is left for
     * the capture to report: it names the data file). */
    if (kind == SIM_DETECTOR_SPECTRAL && !strncmp(scene->material, "spectral:", 9)) {
        brdf_spectral *m = brdf_spectral_open(scene->material, NULL);
        double lo = 0, hi = 0;
        if (m)
            brdf_spectral_range(m, &lo, &hi);
        brdf_spectral_free(m);
        if (m && (scene->bands_nm[0] < lo || scene->bands_nm[scene->n_bands - 1] > hi)) {
            const struct cfg_node *at = cfg_get(doc, det, "bands");
            return cfg_error(doc, at ? at : det, at ? "bands" : "detector", err,
                             "%g-%g nm: %s is defined on %g-%g nm", scene->bands_nm[0],
                             scene->bands_nm[scene->n_bands - 1], scene->material, lo, hi);
        }
    }
    return 0;
}

void sim_scene_ideal(struct sim_scene *scene, const char *material)
{
    memset(scene, 0, sizeof *scene);
    snprintf(scene->name, sizeof scene->name, "ideal");
    snprintf(scene->material, sizeof scene->material, "%s", material ? material : "default");
    snprintf(scene->rig, sizeof scene->rig, "default");
    scene->seed = 1;
    scene->responsivity = DEFAULT_RESPONSIVITY;
    scene->target_e = DEFAULT_TARGET_E;
    scene->attenuator = 1;
}

int sim_scene_load(const char *path_or_name, struct sim_scene *scene, struct gonio_err *err)
{
    static const char *const keys[] = {"name", "description", "material", "rig", "detector",
                                       "seed", "effects", NULL};

    sim_scene_ideal(scene, NULL);
    scene->name[0] = '\0';
    if (gonio_config_path(path_or_name, "scenes", scene->path, sizeof scene->path) < 0)
        return gonio_err_set(err, ENAMETOOLONG, "%s: scene path too long", path_or_name);
    struct cfg_doc *doc;
    int rc = cfg_load(scene->path, &doc, err);
    if (rc < 0)
        return rc;
    const struct cfg_node *root = cfg_root(doc);
    long seed = 1;
    if ((rc = cfg_check_keys(doc, root, "scene", keys, err)) < 0 ||
        (rc = copy_string(doc, root, "name", CFG_OPTIONAL, scene->name, sizeof scene->name, err)) < 0 ||
        (rc = copy_string(doc, root, "material", CFG_REQUIRED, scene->material,
                          sizeof scene->material, err)) < 0 ||
        (rc = copy_string(doc, root, "rig", CFG_OPTIONAL, scene->rig, sizeof scene->rig, err)) < 0 ||
        (rc = parse_detector(doc, root, scene, err)) < 0 ||
        (rc = cfg_int(doc, root, "seed", CFG_OPTIONAL, 0, 4294967295L, &seed, err)) < 0 ||
        (rc = parse_effects(doc, root, scene, err)) < 0) {
        cfg_free(doc);
        return rc;
    }
    if (!scene->name[0]) {
        const char *base = strrchr(scene->path, '/');
        base = base ? base + 1 : scene->path;
        size_t len = strcspn(base, ".");
        if (len >= sizeof scene->name)
            len = sizeof scene->name - 1;
        memcpy(scene->name, base, len);
        scene->name[len] = '\0';
    }
    scene->seed = (unsigned long)seed;
    cfg_free(doc);
    return 0;
}
