/* From a calibration's frames to the reduction's inputs
 * (capture/calibration.h): dark means and spreads per integration, the
 * reference's means per geometry, the photon-transfer gain from the
 * reference's repeats, and the lamp monitor's noise. */
#include "capture/calibration.h"
#include "capture/calibration_bands.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Stated nonlinearity coefficients are taken as good to 10 %, and the
 * sample's placement against the standard's to 0.1 % in solid angle
 * (0.05 mm at 100 mm): what a rig profile will state once it knows. */
#define NONLINEARITY_REL_U 0.1
#define GEOMETRY_REL_U 0.001

static int same(double a, double b)
{
    return fabs(a - b) <= 1e-9 * fmax(1.0, fabs(a));
}

static int derive_darks(const struct cal_frame *f, size_t n, struct cal_loaded *out,
                        struct gonio_err *err)
{
    out->darks = calloc(n ? n : 1, sizeof *out->darks);
    if (!out->darks)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    size_t nd = 0;
    for (size_t k = 0; k < n; k++) {
        size_t j = 0;
        while (j < nd && !(same(out->darks[j].integration_s, f[k].integration_s) &&
                           out->darks[j].gain_state == f[k].gain_state))
            j++;
        if (j == nd) {
            out->darks[nd].integration_s = f[k].integration_s;
            out->darks[nd++].gain_state = f[k].gain_state;
        }
        struct rad_dark *d = &out->darks[j];
        d->n++;
        /* Welford: mean and the sum of squares about it. */
        for (int c = 0; c < 3; c++) {
            double delta = f[k].counts[c] - d->mean[c];
            d->mean[c] += delta / d->n;
            d->sd[c] += delta * (f[k].counts[c] - d->mean[c]);
        }
    }
    for (size_t j = 0; j < nd; j++)
        for (int c = 0; c < 3; c++)
            out->darks[j].sd[c] = out->darks[j].n > 1 ? sqrt(out->darks[j].sd[c] /
                                                             (out->darks[j].n - 1))
                                                      : 0.0;
    out->cal.darks = out->darks, out->cal.n_darks = nd;
    return nd ? 0 : gonio_err_set(err, GONIO_EBADDATA, "calibration: no dark frames");
}

/* Reference (or stray) readings are grouped by consecutive runs at one
 * geometry, into *refs (malloc'd) and *n_refs. */
static int group_readings(const struct cal_frame *f, size_t n, struct rad_ref **refs,
                          size_t *n_refs, double var_sum[][3], double *mon_rel_var,
                          size_t *mon_groups, struct gonio_err *err)
{
    struct rad_ref *out = *refs = calloc(n ? n : 1, sizeof *out);
    if (!out)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    size_t nr = 0;
    for (size_t k = 0; k < n;) {
        size_t e = k;
        while (e < n && f[e].theta_i == f[k].theta_i && f[e].theta_r == f[k].theta_r &&
               same(f[e].integration_s, f[k].integration_s) && f[e].gain_state == f[k].gain_state)
            e++;
        for (size_t j = k; j < e; j++)
            for (int c = 0; c < 3; c++)
                if (f[j].full_scale > 0 && f[j].counts[c] >= f[j].full_scale)
                    return gonio_err_set(err, GONIO_EBADDATA, "calibration: the %s at "
                                         "(%g, %g) deg clipped (%g counts, full scale %g): "
                                         "calibrate at a shorter integration",
                                         cal_kind_name(f[j].kind), f[j].theta_i,
                                         f[j].theta_r, f[j].counts[c], f[j].full_scale);
        struct rad_ref *r = &out[nr];
        r->theta_i = f[k].theta_i, r->theta_r = f[k].theta_r;
        r->integration_s = f[k].integration_s, r->gain_state = f[k].gain_state;
        r->n = (int)(e - k);
        double m = 0, m2 = 0;
        for (size_t j = k; j < e; j++) {
            for (int c = 0; c < 3; c++)
                r->counts[c] += f[j].counts[c] / r->n;
            m += f[j].monitor / r->n;
        }
        for (size_t j = k; j < e; j++) {
            for (int c = 0; c < 3; c++)
                var_sum[nr][c] += (f[j].counts[c] - r->counts[c]) *
                                  (f[j].counts[c] - r->counts[c]) / fmax(1, r->n - 1);
            m2 += (f[j].monitor - m) * (f[j].monitor - m) / fmax(1, r->n - 1);
        }
        r->monitor = isfinite(m) ? m : NAN;
        if (isfinite(m) && m > 0 && r->n > 1)
            *mon_rel_var += m2 / (m * m), (*mon_groups)++;
        nr++;
        k = e;
    }
    *n_refs = nr;
    return 0;
}

static int derive_refs(const struct cal_frame *f, size_t n, struct cal_loaded *out,
                       double var_sum[][3], double *mon_rel_var, size_t *mon_groups,
                       struct gonio_err *err)
{
    int rc = group_readings(f, n, &out->refs, &out->cal.n_refs, var_sum, mon_rel_var,
                            mon_groups, err);
    out->cal.refs = out->refs;
    if (rc >= 0 && !out->cal.n_refs)
        rc = gonio_err_set(err, GONIO_EBADDATA, "calibration: no reference readings");
    return rc;
}

int cal_derive_stray(const struct cal_frame *stray, size_t n, struct cal_loaded *out,
                     struct gonio_err *err)
{
    double (*var)[3] = calloc(n ? n : 1, sizeof *var);
    if (!var)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    double mon_rel_var = 0;
    size_t mon_groups = 0;
    int rc = group_readings(stray, n, &out->strays, &out->cal.n_strays, var, &mon_rel_var,
                            &mon_groups, err);
    free(var);
    out->cal.strays = out->strays;
    if (rc >= 0 && !out->cal.n_strays)
        rc = gonio_err_set(err, GONIO_EBADDATA, "calibration: no stray-light readings");
    return rc;
}

int cal_derive(const struct cal_frame *dark, size_t n_dark, const struct cal_frame *ref,
               size_t n_ref, struct cal_loaded *out, struct gonio_err *err)
{
    double (*var)[3] = calloc(n_ref ? n_ref : 1, sizeof *var);
    if (!var)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    double mon_rel_var = 0;
    size_t mon_groups = 0;
    int rc = derive_darks(dark, n_dark, out, err);
    if (rc >= 0)
        rc = derive_refs(ref, n_ref, out, var, &mon_rel_var, &mon_groups, err);
    struct rad_setup *su = &out->cal.setup;
    /* Photon transfer: a repeat's variance is g x + sd_dark^2, so g is the
     * least-squares slope of (variance - sd_dark^2) on x through 0. */
    double knl = n_ref ? ref[0].nonlinearity : 0, fsc = n_ref ? ref[0].full_scale : 0;
    out->nonlinearity = knl, out->full_scale = fsc;
    for (int c = 0; rc >= 0 && c < 3; c++) {
        double num = 0, den = 0;
        for (size_t k = 0; k < out->cal.n_refs; k++) {
            const struct rad_ref *r = &out->refs[k];
            const struct rad_dark *d = rad_find_dark(&out->cal, r->integration_s, r->gain_state);
            if (!d || r->n < 2)
                continue;
            /* On the linear scale: the nonlinearity's slope 1 - 2 k x / fs
             * shrinks the spread the readings show. */
            double x = rad_linearise(r->counts[c] - d->mean[c], knl, fsc);
            double slope = fsc > 0 ? 1.0 - 2.0 * knl * x / fsc : 1.0;
            num += (var[k][c] / (slope * slope) - d->sd[c] * d->sd[c]) * x;
            den += x * x;
        }
        su->adu_per_electron[c] = den > 0 ? fmax(0.0, num / den) : 0.0;
    }
    free(var);
    su->monitor_rel_sd = mon_groups ? sqrt(mon_rel_var / (double)mon_groups) : 0.0;
    su->nonlinearity_rel_u = NONLINEARITY_REL_U;
    su->geometry_rel_u = GEOMETRY_REL_U;
    su->spot = RAD_SPOT_UNDERFILLED;
    return rc;
}

void cal_loaded_free(struct cal_loaded *c)
{
    cal_bands_free(c->bands);
    free(c->darks);
    free(c->refs);
    free(c->strays);
    memset(c, 0, sizeof *c);
}

/* The stray calibration a reference names, reduced with the reference's
 * dark (which it must have been taken with); its frames in *sf (malloc'd),
 * for the bands. */
static int load_stray(const char *root, const struct cal_meta *ref, struct cal_loaded *out,
                      struct cal_frame **sf, size_t *ns, struct gonio_err *err)
{
    struct cal_meta sm;
    int rc = cal_read(root, ref->stray, &sm, sf, ns, err);
    if (rc >= 0 && sm.kind != CAL_STRAY)
        rc = gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s: its stray light %s is a "
                           "%s calibration", ref->id, sm.id, cal_kind_name(sm.kind));
    if (rc >= 0 && strcmp(sm.dark, ref->dark) != 0)
        rc = gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s: its stray light %s was "
                           "taken with dark %s, the reference with %s", ref->id, sm.id,
                           sm.dark, ref->dark);
    if (rc >= 0)
        rc = cal_derive_stray(*sf, *ns, out, err);
    return rc;
}

int cal_load(const char *root, const char *id, struct cal_loaded *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    struct cal_frame *rf = NULL, *df = NULL, *sf = NULL;
    size_t nr = 0, nd = 0, ns = 0;
    int rc = cal_read(root, id, &out->meta, &rf, &nr, err);
    int beam = out->meta.kind == CAL_BEAM;
    if (rc >= 0 && out->meta.kind != CAL_REFERENCE && !beam)
        rc = gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is a %s calibration: name "
                           "a reference or beam calibration (it brings its dark)", id,
                           cal_kind_name(out->meta.kind));
    if (rc >= 0 && beam && nr && rf[0].n_bands)
        rc = gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is a beam calibration of a "
                           "spectral detector (its frames hold bands): a beam calibration has "
                           "no per-band reduction; name a reference calibration", id);
    if (rc >= 0)
        rc = cal_read(root, out->meta.dark, &out->dark_meta, &df, &nd, err);
    if (rc >= 0)
        rc = cal_derive(df, nd, rf, nr, out, err);
    if (rc >= 0 && out->meta.stray[0])
        rc = load_stray(root, &out->meta, out, &sf, &ns, err);
    if (rc >= 0 && !beam)
        rc = brdf_standard_load(out->meta.standard, &out->cal.standard, err);
    if (beam) /* the absolute method: the beam and the rig's geometry, no standard */
        snprintf(out->cal.standard.name, sizeof out->cal.standard.name, "none (beam)");
    out->cal.beam = out->meta.beam;
    out->cal.setup.in_position_deg = out->meta.in_position_deg;
    out->cal.setup.spot = out->meta.spot;
    struct cal_band_frames bf = {.dark = df, .ref = rf, .stray = sf, .n_dark = nd,
                                 .n_ref = nr, .n_stray = ns};
    if (rc >= 0 && nr && rf[0].n_bands && !beam) /* a spectral detector's: per band too */
        rc = cal_bands_derive(&bf, out, &out->bands, err);
    free(sf);
    free(rf);
    free(df);
    if (rc < 0)
        cal_loaded_free(out);
    return rc;
}
