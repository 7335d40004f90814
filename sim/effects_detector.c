#include "sim/effects_detector.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "brdf/spectral.h"
#include "brdf/standard.h"
#include "sim/exposure.h"
#include "sim/standard_draw.h"

struct sim_detector {
    const brdf_material *material;
    sim_effects *fx;
    struct sim_exposure exposure;
    int shutter_closed;
    int underfilled;            /* the scene's spot: the signal goes with cos theta_r */
    int beam;                   /* the material "beam": the sample removed */
    double beam_value;          /* what the direct beam reads as, attenuator / solid angle */
    int counts;                 /* the scene has an adc */
    struct sim_adc_info adc;
    /* spectral detectors only */
    brdf_spectral *spectral;
    int n_bands;
    double bands[SIM_SCENE_MAX_BANDS];
    double w[3 * SIM_SCENE_MAX_BANDS]; /* spectrum -> linear sRGB */
    double values[SIM_SCENE_MAX_BANDS];
    FILE *csv;
    long acquisitions;
};

static int open_spectral(sim_detector *d, const struct sim_scene *scene,
                         struct gonio_err *err)
{
    const char *name = brdf_material_name(d->material);
    struct brdf_standard std;
    if (strncmp(name, "spectral:", 9) == 0) {
        d->spectral = brdf_spectral_open(name, err);
    } else if (strncmp(name, "standard:", 9) == 0) {
        /* the standard per wavelength, as its certificate states it (which
         * the reduction of a spectral detector's bands uses), or the plaque
         * the scene draws from it */
        if (sim_standard_truth(scene, name + 9, &std, err) < 0)
            return -abs(err ? err->code : GONIO_EBADCONFIG);
        d->spectral = brdf_standard_spectral(&std, name, err);
    } else
        d->spectral = brdf_spectral_lift(d->material, err);
    if (!d->spectral)
        return -abs(err ? err->code : ENOMEM);
    d->n_bands = scene->n_bands;
    memcpy(d->bands, scene->bands_nm, (size_t)d->n_bands * sizeof *d->bands);
    double lo, hi;
    brdf_spectral_range(d->spectral, &lo, &hi);
    if (d->bands[0] < lo || d->bands[d->n_bands - 1] > hi)
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "%s: detector bands %g-%g nm: material %s is defined on %g-%g nm",
                             scene->path, d->bands[0], d->bands[d->n_bands - 1], name, lo, hi);
    return brdf_spectral_rgb_weights(d->bands, (size_t)d->n_bands, d->w, err);
}

/* spectra.csv: header once, then one row per band and acquisition. */
static int open_csv(sim_detector *d, const char *path, struct gonio_err *err)
{
    struct stat st;
    int fresh = stat(path, &st) != 0 || st.st_size == 0;
    d->csv = fopen(path, "a");
    if (!d->csv)
        return gonio_err_set(err, errno, "%s: cannot open for appending (%s)", path,
                             strerror(errno));
    if (fresh)
        fprintf(d->csv, "theta_i,theta_r,wavelength_nm,value,acquisition,integration_s,"
                        "saturated\n");
    return fflush(d->csv) == 0 ? 0 : gonio_err_set(err, EIO, "%s: write failed", path);
}

sim_detector *sim_detector_new(const struct rig_profile *rig, const brdf_material *material,
                               const struct sim_scene *scene, sim_effects *fx,
                               const char *spectra_csv, struct gonio_err *err)
{
    sim_detector *d = calloc(1, sizeof *d);
    if (!d) {
        gonio_err_set(err, ENOMEM, "simulated detector: out of memory");
        return NULL;
    }
    d->material = material;
    d->beam = strcmp(brdf_material_name(material), "beam") == 0;
    d->underfilled = scene->underfilled;
    d->beam_value = scene->solid_angle_sr > 0 ? scene->attenuator / scene->solid_angle_sr : 0;
    d->fx = fx;
    /* An ideal meter where the detector reduces its readings itself; a raw
     * detector integrates for the time the caller asks, as hardware does. */
    d->counts = fx && sim_effects_adc(fx, &d->adc);
    sim_exposure_init(&d->exposure, rig, scene, fx && !d->counts ? sim_effects_noisy(fx) : 0);
    int rc = 0;
    if (scene->detector == SIM_DETECTOR_SPECTRAL) {
        rc = open_spectral(d, scene, err);
        /* counts: the capture keeps and reduces the bands (its bands.csv) */
        if (rc == 0 && spectra_csv && !d->counts)
            rc = open_csv(d, spectra_csv, err);
    }
    if (rc < 0) {
        sim_detector_free(d);
        return NULL;
    }
    return d;
}

int sim_detector_mount(sim_detector *d, const brdf_material *material,
                       const struct sim_scene *scene, struct gonio_err *err)
{
    d->material = material;
    d->beam = strcmp(brdf_material_name(material), "beam") == 0;
    if (!d->n_bands)
        return 0;
    brdf_spectral_free(d->spectral);
    d->spectral = NULL;
    return open_spectral(d, scene, err);
}

void sim_detector_free(sim_detector *d)
{
    if (!d)
        return;
    if (d->csv)
        fclose(d->csv);
    brdf_spectral_free(d->spectral);
    free(d);
}

/* Within this of the source's direction the detector's aperture takes the
 * whole direct beam (the arm's errors are hundredths of a degree). */
#define BEAM_ACCEPT_DEG 1.0

/* What the detector's electrons go with besides the values: cos theta_i
 * with the spot overfilled (the irradiance of the area it sees), cos
 * theta_r underfilled (the whole lit spot seen from theta_r), 1 for the
 * direct beam. */
static double geometry(const sim_detector *d, const struct brdf_pair *p, double cos_i)
{
    if (d->beam)
        return 1.0;
    return d->underfilled ? fmax(p->wo[2], 1e-3) : cos_i;
}

/* The material's exact values at p: the bands of a spectral detector (into
 * d->values), else RGB (into rgb). Returns the channel count. With the
 * sample removed ("beam"), the direct beam where the arm faces the source:
 * per unit of the scene's responsivity (what 1/sr of BRDF gives through
 * the detector's solid angle), attenuator / solid_angle_sr, else nothing. */
static int signal_at(sim_detector *d, const struct brdf_pair *p, double rgb[3], double **v)
{
    *v = d->n_bands ? d->values : rgb;
    if (d->beam) {
        double dot = p->wi[0] * p->wo[0] + p->wi[1] * p->wo[1] + p->wi[2] * p->wo[2];
        double x = dot <= -cos(BEAM_ACCEPT_DEG * 3.14159265358979323846 / 180) ? d->beam_value
                                                                               : 0.0;
        int n = d->n_bands ? d->n_bands : 3;
        for (int k = 0; k < n; k++)
            (*v)[k] = x;
        return n;
    }
    if (d->n_bands)
        brdf_spectral_eval(d->spectral, p, d->bands, (size_t)d->n_bands, *v);
    else
        brdf_material_eval(d->material, p, 1, *v);
    return d->n_bands ? d->n_bands : 3;
}

double sim_detector_meter(sim_detector *d, const struct brdf_pair *p, double cos_i)
{
    if (!d->fx || !d->exposure.automatic)
        return d->exposure.fixed_s;
    double rgb[3], *v;
    int n = signal_at(d, p, rgb, &v);
    cos_i = geometry(d, p, cos_i);
    struct sim_signal s = {.v = v, .n = n, .cos_i = cos_i,
                           .responsivity = d->exposure.responsivity};
    sim_effects_light_mean(d->fx, &s);
    return sim_exposure_choose(&d->exposure, v, n, cos_i);
}

void sim_detector_shutter(sim_detector *d, int closed)
{
    d->shutter_closed = closed != 0;
}

/* The light stage, the exposure and the sensor stage on s. */
static void expose(sim_detector *d, struct sim_signal *s, double cos_i)
{
    sim_effects_light(d->fx, s);
    if (d->shutter_closed) {
        for (int k = 0; k < s->n; k++)
            s->v[k] = 0;
    } else if (d->exposure.automatic) {
        s->integration_s = sim_exposure_choose(&d->exposure, s->v, s->n, cos_i);
    }
    sim_effects_sensor(d->fx, s);
}

/* A spectral detector's counts as three channels: the mean counts of each
 * bin of bands (sim_scene_count_bin), rounded as an ADC's output is, so
 * that every transport carries the same integers. Colour weights would
 * mix counts with their offset and negative weights: a bin mean is what
 * a calibration can reduce, channel by channel. */
static void bin_counts(const sim_detector *d, const double *v, double rgb[3])
{
    double sum[3] = {0};
    int n[3] = {0};
    for (int k = 0; k < d->n_bands; k++) {
        int c = sim_scene_count_bin(d->bands[k]);
        sum[c] += v[k];
        n[c]++;
    }
    for (int c = 0; c < 3; c++)
        rgb[c] = n[c] ? nearbyint(sum[c] / n[c]) : NAN;
}

int sim_detector_read(sim_detector *d, const struct brdf_pair *p, double cos_i, double now_s,
                      double requested_s, double theta_i, double theta_r,
                      struct sim_reading *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    double *v;
    int n = signal_at(d, p, out->rgb, &v);
    cos_i = geometry(d, p, cos_i);
    struct sim_signal s = {.v = v,
                           .n = n,
                           .cos_i = cos_i,
                           .integration_s = requested_s,
                           .now_s = now_s,
                           .responsivity = d->exposure.responsivity,
                           .monitor = NAN};
    if (d->fx)
        expose(d, &s, cos_i);
    else if (d->shutter_closed)
        memset(v, 0, (size_t)n * sizeof *v);
    out->integration_s = s.integration_s;
    out->flags = s.flags;
    out->monitor = s.monitor;
    if (d->counts) {
        out->counts = 1;
        out->full_scale = d->adc.full_scale;
        out->nonlinearity = d->adc.nonlinearity;
    }
    if (!d->n_bands)
        return 0;
    if (d->counts)
        bin_counts(d, v, out->rgb);
    else
        for (int c = 0; c < 3; c++) {
            double sum = 0;
            for (int k = 0; k < n; k++)
                sum += d->w[3 * k + c] * v[k];
            out->rgb[c] = sum;
        }
    out->n_bands = n;
    out->bands_nm = d->bands;
    out->spectrum = v;
    d->acquisitions++;
    if (d->csv) {
        for (int k = 0; k < n; k++)
            fprintf(d->csv, "%.17g,%.17g,%g,%.17g,%ld,%.17g,%d\n", theta_i, theta_r, d->bands[k],
                    v[k], d->acquisitions, s.integration_s,
                    (s.flags & SIM_SIGNAL_SATURATED) ? 1 : 0);
        if (fflush(d->csv) != 0)
            return gonio_err_set(err, EIO, "spectra.csv: write failed");
    }
    return 0;
}
