#include "sim_source/sim_source.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "brdf/material.h"
#include "drivers/drv_sim.h"
#include "sim/effects.h"
#include "sim/effects_detector.h"
#include "sim/scene.h"
#include "sim/sim.h"
#include "sim/standard_draw.h"

struct sim_source {
    struct sim_scene scene;
    struct rig_profile rig;          /* the profile the meter and the description use */
    brdf_material *material;      /* what the rig measures; NULL for a description */
    sim_effects *fx;              /* the meter: the scene's effects and detector */
    sim_detector *meter;
    sim_rig *sim;                 /* the open capture's rig, NULL between captures */
    brdf_material *standard;      /* in the sample's place now (mount), else NULL */
    char *setup_json;             /* {"scene": {...}} */
};

/* "default" names the material actually used. */
static const char *material_spec(const char *spec)
{
    return strcmp(spec, "default") ? spec : brdf_material_default_spec();
}

/* setup.json's "scene" member: what identifies the simulation (the path
 * only says where it was read from). */
static char *scene_json(const struct sim_scene *sc)
{
    json_t *root = json_pack("{s:{s:s,s:s,s:s,s:s,s:I,s:i}}", "scene", "name", sc->name, "path",
                             sc->path, "material", sc->material, "detector",
                             sc->detector == SIM_DETECTOR_RGB ? "rgb" : "spectral", "seed",
                             (json_int_t)sc->seed, "effects", sc->n_effects);
    char *text = root ? json_dumps(root, JSON_COMPACT) : NULL;
    json_decref(root);
    return text;
}

static sim_source *load_scene(const char *scene, struct gonio_err *err)
{
    if (!scene) {
        gonio_err_set(err, GONIO_EUSAGE, "the simulated rig needs a scene (--scene NAME|FILE)");
        return NULL;
    }
    sim_source *src = calloc(1, sizeof *src);
    if (!src) {
        gonio_err_set(err, ENOMEM, "out of memory");
        return NULL;
    }
    if (sim_scene_load(scene, &src->scene, err) < 0) {
        free(src);
        return NULL;
    }
    if (!(src->setup_json = scene_json(&src->scene))) {
        gonio_err_set(err, ENOMEM, "out of memory");
        free(src);
        return NULL;
    }
    return src;
}

sim_source *sim_source_describe(const char *scene, struct gonio_err *err)
{
    return load_scene(scene, err);
}

sim_source *sim_source_new(const char *scene, const char *material, const char *rig,
                           struct gonio_err *err)
{
    sim_source *src = load_scene(scene, err);
    if (!src)
        return NULL;
    const char *spec = material_spec(material ? material : src->scene.material);
    if (rig_profile_load(rig ? rig : src->scene.rig, &src->rig, err) < 0 ||
        !(src->material = sim_material_open(&src->scene, spec, err)) ||
        !(src->fx = sim_effects_new(&src->scene, err)) ||
        !(src->meter = sim_detector_new(&src->rig, src->material, &src->scene, src->fx, NULL,
                                        err))) {
        sim_source_free(src);
        return NULL;
    }
    return src;
}

void sim_source_free(sim_source *src)
{
    if (!src)
        return;
    sim_rig_free(src->sim);
    brdf_material_free(src->standard);
    sim_detector_free(src->meter);
    sim_effects_free(src->fx);
    brdf_material_free(src->material);
    free(src->setup_json);
    free(src);
}

/* The detector's choice at the pair the planned axes give. */
static double integration_s(void *user, const struct plan_point *pt)
{
    sim_source *src = user;
    struct brdf_pair p;
    double cos_i;
    sim_axes_optics(pt->ax.s, pt->ax.a, pt->ax.az, &p, &cos_i);
    return sim_detector_meter(src->meter, &p, cos_i);
}

static void close_devices(void *user, struct capture_devices *d)
{
    sim_source *src = user;
    drv_axis_free(d->sample);
    drv_axis_free(d->arm);
    drv_axis_free(d->azimuth);
    drv_axis_free(d->rotation);
    drv_detector_free(d->detector);
    drv_clock_free(d->clock);
    memset(d, 0, sizeof *d);
    sim_rig_free(src->sim);
    src->sim = NULL;
}

/* Devices over a fresh sim_rig reading the source's material; a spectral
 * detector appends its spectra to dir/spectra.csv. */
static int open_devices(void *user, const struct rig_profile *rig, const char *dir,
                        struct capture_devices *d, struct gonio_err *err)
{
    sim_source *src = user;
    memset(d, 0, sizeof *d);
    sim_rig_free(src->sim);
    if (!(src->sim = sim_rig_new_scene(rig, src->material, &src->scene, dir, err)))
        return -abs(err ? err->code : ENOMEM);
    d->sample = drv_axis_new_sim(src->sim, SIM_AXIS_SAMPLE);
    d->arm = drv_axis_new_sim(src->sim, SIM_AXIS_ARM);
    d->azimuth = drv_axis_new_sim(src->sim, SIM_AXIS_AZIMUTH);
    if (rig->has_rotation && !(d->rotation = drv_axis_new_sim(src->sim, SIM_AXIS_ROTATION))) {
        close_devices(src, d);
        return gonio_err_set(err, ENOMEM, "simulated rig: out of memory");
    }
    d->detector = drv_detector_new_sim(src->sim);
    d->clock = drv_clock_new_sim(src->sim);
    if (!d->sample || !d->arm || !d->azimuth || !d->detector || !d->clock) {
        close_devices(src, d);
        return gonio_err_set(err, ENOMEM, "simulated rig: out of memory");
    }
    return 0;
}

/* A resumed capture's rig: its axes where the interrupted run left them,
 * as a real rig's stay, and its clock at the last sample's time (the
 * scene's drift runs on it), so the rig time goes on as it would have (an
 * adaptive capture's budget and convergence read it). An axis the rig's
 * fault effects stop keeps where it is. */
static void resume(void *user, struct capture_devices *d, const double at[3],
                   double rig_time_s)
{
    (void)d;
    sim_source *src = user;
    static const enum sim_axis_id axis[3] = {SIM_AXIS_SAMPLE, SIM_AXIS_ARM, SIM_AXIS_AZIMUTH};
    for (int i = 0; i < 3; i++)
        if (sim_rig_start_move(src->sim, axis[i], at[i], NULL) == 0 &&
            sim_rig_wait(src->sim, axis[i], NULL) < 0)
            sim_rig_reset_alarm(src->sim, axis[i]);
    sim_rig_advance(src->sim, fmax(0, rig_time_s - sim_rig_now(src->sim)));
}

/* The simulated rig's sample changer: the standard in the sample's
 * place (the material standard:NAME, as gonio calibrate reference mounts
 * it), a light trap (the material trap, as gonio calibrate stray does),
 * or the sample back. */
static int mount(void *user, struct capture_devices *d, enum capture_slot slot,
                 const char *standard, struct gonio_err *err)
{
    (void)d;
    sim_source *src = user;
    brdf_material *was = src->standard;
    src->standard = NULL;
    int rc = 0;
    if (slot != CAPTURE_SLOT_SAMPLE) {
        char spec[256];
        snprintf(spec, sizeof spec, "%s%s", slot == CAPTURE_SLOT_TRAP ? "trap" : "standard:",
                 slot == CAPTURE_SLOT_TRAP ? "" : standard ? standard : "");
        if (!(src->standard = sim_material_open(&src->scene, spec, err)))
            rc = -abs(err && err->code ? err->code : GONIO_EBADCONFIG);
    }
    if (rc == 0)
        rc = sim_rig_mount(src->sim, src->standard ? src->standard : src->material, &src->scene,
                           err);
    if (rc < 0) { /* what was mounted stays */
        brdf_material_free(src->standard);
        src->standard = was;
        return rc;
    }
    brdf_material_free(was);
    return 0;
}

void sim_source_rig(sim_source *src, struct capture_rig *out)
{
    memset(out, 0, sizeof *out);
    out->profile = src->scene.rig;
    out->detector = src->scene.detector == SIM_DETECTOR_RGB ? "rgb" : "spectral";
    out->setup_json = src->setup_json;
    if (!src->material)
        return; /* a description */
    out->open = open_devices;
    out->close = close_devices;
    /* A detector of counts integrates as auto-ranging asks: the meter knows
     * nothing of it, and the calibration check must know before it reads. */
    struct sim_adc_info adc = {0};
    out->counts = sim_effects_adc(src->fx, &adc);
    out->counts_full_scale = adc.full_scale;
    out->counts_nonlinearity = adc.nonlinearity;
    out->integration_s = out->counts ? NULL : integration_s;
    out->resume = resume;
    out->mount = mount;
    out->driver = "sim";
    out->material = src->material;
    out->user = src;
}

int sim_source_capture(const char *scene, const struct capture_config *cfg,
                       const struct capture_hooks *hooks, struct capture_summary *out,
                       struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    sim_source *src = sim_source_new(scene, cfg->material, cfg->rig, err);
    if (!src)
        return -abs(err ? err->code : ENOMEM);
    struct capture_rig rig;
    sim_source_rig(src, &rig);
    int rc = capture_run(cfg, &rig, hooks, out, err);
    sim_source_free(src);
    return rc;
}

int sim_source_check(const char *scene, const struct capture_config *cfg,
                     struct plan_estimate *est, struct gonio_err *err)
{
    sim_source *src = sim_source_new(scene, cfg->material, cfg->rig, err);
    if (!src)
        return -abs(err ? err->code : ENOMEM);
    struct capture_rig rig;
    sim_source_rig(src, &rig);
    int rc = capture_check(cfg, &rig, est, err);
    sim_source_free(src);
    return rc;
}
