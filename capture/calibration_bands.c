/* A spectral detector's calibration band by band (capture/calibration_bands.h). */
#include "capture/calibration_bands.h"

#include "capture/reference_after.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int same_bands(const struct cal_frame *f, const struct cal_bands *b)
{
    if (f->n_bands != b->n_bands)
        return 0;
    for (int k = 0; k < f->n_bands; k++)
        if (fabs(f->bands_nm[k] - b->nm[k]) > 1e-6)
            return 0;
    return 1;
}

/* The band of group g's channel c (the last band repeated past the end). */
static int band_of(const struct cal_bands *b, int g, int c)
{
    int k = 3 * g + c;
    return k < b->n_bands ? k : b->n_bands - 1;
}

/* Frames as group g sees them: its three bands in the channels. */
static int group_frames(const struct cal_bands *b, int g, const struct cal_frame *f, size_t n,
                        const char *what, struct cal_frame **out, struct gonio_err *err)
{
    *out = malloc((n ? n : 1) * sizeof **out);
    if (!*out)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    for (size_t k = 0; k < n; k++) {
        if (!same_bands(&f[k], b)) {
            free(*out);
            *out = NULL;
            return gonio_err_set(err, GONIO_EBADDATA, "calibration: %s frame %zu holds %d "
                                 "bands, not the reference's %d bands %g-%g nm", what, k + 1,
                                 f[k].n_bands, b->n_bands, b->nm[0], b->nm[b->n_bands - 1]);
        }
        (*out)[k] = f[k];
        (*out)[k].n_bands = 0;
        for (int c = 0; c < 3; c++)
            (*out)[k].counts[c] = f[k].bands[band_of(b, g, c)];
    }
    return 0;
}

static int derive_group(struct cal_bands *b, int g, const struct cal_band_frames *f,
                        const struct cal_loaded *whole, struct gonio_err *err)
{
    struct cal_frame *gd = NULL, *gr = NULL, *gs = NULL;
    struct cal_loaded *cl = &b->group[g];
    int rc = group_frames(b, g, f->dark, f->n_dark, "dark", &gd, err);
    if (rc >= 0)
        rc = group_frames(b, g, f->ref, f->n_ref, "reference", &gr, err);
    if (rc >= 0)
        rc = cal_derive(gd, f->n_dark, gr, f->n_ref, cl, err);
    /* the stray light band by band, with the reference's dark per band */
    if (rc >= 0 && f->n_stray && (rc = group_frames(b, g, f->stray, f->n_stray, "stray-light",
                                                    &gs, err)) >= 0)
        rc = cal_derive_stray(gs, f->n_stray, cl, err);
    free(gd);
    free(gr);
    free(gs);
    if (rc < 0)
        return rc;
    cl->meta = whole->meta;
    cl->dark_meta = whole->dark_meta;
    cl->cal.standard = whole->cal.standard;
    for (int c = 0; c < 3; c++)
        brdf_standard_rho_at(&whole->cal.standard, b->nm[band_of(b, g, c)],
                             &cl->cal.standard.rho[c], &cl->cal.standard.u_rho[c]);
    cl->cal.setup.in_position_deg = whole->cal.setup.in_position_deg;
    cl->cal.setup.spot = whole->cal.setup.spot;
    return 0;
}

int cal_bands_derive(const struct cal_band_frames *f, const struct cal_loaded *whole,
                     struct cal_bands **out, struct gonio_err *err)
{
    *out = NULL;
    if (!f->n_ref || f->ref[0].n_bands < 1)
        return gonio_err_set(err, GONIO_EBADDATA, "calibration: no band counts to derive");
    struct cal_bands *b = calloc(1, sizeof *b);
    if (!b)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    b->n_bands = f->ref[0].n_bands;
    memcpy(b->nm, f->ref[0].bands_nm, (size_t)b->n_bands * sizeof *b->nm);
    int rc = 0;
    for (int g = 0; rc >= 0 && 3 * g < b->n_bands; g++) {
        rc = derive_group(b, g, f, whole, err);
        b->n_groups = g + 1;
    }
    if (rc < 0) {
        cal_bands_free(b);
        return rc;
    }
    *out = b;
    return 0;
}

void cal_bands_free(struct cal_bands *b)
{
    if (!b)
        return;
    for (int g = 0; g < b->n_groups; g++)
        cal_loaded_free(&b->group[g]);
    free(b);
}

int cal_bands_drift(struct cal_bands *b, const struct cal_frame *f, size_t n, double t_end_s,
                    struct gonio_err *err)
{
    int rc = 0;
    for (int g = 0; rc >= 0 && g < b->n_groups; g++) {
        struct cal_frame *gf = NULL;
        rc = group_frames(b, g, f, n, "reference-after", &gf, err);
        if (rc >= 0) /* the group's cal_loaded holds no bands: no recursion */
            rc = reference_after_derive(&b->group[g], gf, n, t_end_s, err);
        free(gf);
    }
    return rc;
}

int cal_bands_reduce(const struct cal_bands *b, const struct journal_plan *plan,
                     const struct cal_band_record *rec, size_t n, struct cal_band_value *out,
                     struct gonio_err *err)
{
    for (size_t i = 0; i < n; i++)
        if (rec[i].n_bands != b->n_bands ||
            (b->n_bands && fabs(rec[i].nm[0] - b->nm[0]) > 1e-6))
            return gonio_err_set(err, GONIO_EBADCONFIG, "record %zu (point %d): %d bands from "
                                 "%g nm, the calibration's %d from %g nm", i + 1,
                                 rec[i].s.point, rec[i].n_bands, rec[i].nm[0], b->n_bands,
                                 b->nm[0]);
    struct journal_sample *s = malloc((n ? n : 1) * sizeof *s);
    if (!s)
        return gonio_err_set(err, ENOMEM, "band reduction: out of memory");
    int rc = 0;
    for (int g = 0; rc >= 0 && g < b->n_groups; g++) {
        for (size_t i = 0; i < n; i++) {
            s[i] = rec[i].s;
            for (int c = 0; c < 3; c++)
                s[i].raw[c] = rec[i].counts[band_of(b, g, c)];
        }
        for (size_t i = 0; rc >= 0 && i < n; i++) {
            struct rad_value v;
            for (int c = 0; c < 3; c++)
                v.brdf[c] = v.u[c] = v.snr[c] = NAN; /* a dark frame, BRDF: nothing reduced */
            rc = cal_reduce_sample(&b->group[g], plan, s, i, &s[i], &v, err);
            for (int c = 0; rc >= 0 && c < 3 && 3 * g + c < b->n_bands; c++) {
                /* per band: a band that clipped has no value, the others keep theirs */
                out[i * (size_t)b->n_bands + 3 * g + c] =
                    (struct cal_band_value){v.brdf[c], v.u[c], v.snr[c]};
            }
        }
    }
    free(s);
    return rc;
}
