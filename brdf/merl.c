#include "brdf/merl.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "brdf/material_private.h"
#include "common/paths.h"

#define MERL_PI 3.14159265358979323846
/* Fraction of a bin added before floor(): a node computed in floating point
 * may sit 1e-14 bins below its own index; no real query is that close to a
 * boundary for it to matter. */
#define BIN_EPS 1e-9

const double brdf_merl_scale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

void brdf_merl_node(int i, int j, int k, double *theta_h, double *theta_d, double *phi_d)
{
    double u = (double)i / BRDF_MERL_NTH;
    *theta_h = u * u * (MERL_PI / 2);
    *theta_d = (double)j / BRDF_MERL_NTD * (MERL_PI / 2);
    *phi_d = (double)k / BRDF_MERL_NPD * MERL_PI;
}

static int bin(double x, int n)
{
    if (!(x > 0)) /* also catches NaN */
        return 0;
    double b = floor(x + BIN_EPS);
    return b >= n ? n - 1 : (int)b;
}

size_t brdf_merl_cell(double theta_h, double theta_d, double phi_d)
{
    int i = bin(sqrt(fmax(theta_h, 0.0) / (MERL_PI / 2)) * BRDF_MERL_NTH, BRDF_MERL_NTH);
    int j = bin(theta_d / (MERL_PI / 2) * BRDF_MERL_NTD, BRDF_MERL_NTD);
    /* Reciprocity: phi_d and phi_d + pi are the same cell. */
    if (phi_d < 0)
        phi_d += MERL_PI;
    int k = bin(phi_d / MERL_PI * BRDF_MERL_NPD, BRDF_MERL_NPD);
    return ((size_t)i * BRDF_MERL_NTD + (size_t)j) * BRDF_MERL_NPD + (size_t)k;
}

static int32_t le_i32(const unsigned char *b)
{
    uint32_t u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                 (uint32_t)b[3] << 24;
    int32_t v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static double le_f64(const unsigned char *b)
{
    uint64_t u = 0;
    for (int s = 7; s >= 0; s--)
        u = u << 8 | b[s];
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static void put_le_f64(unsigned char *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    for (int s = 0; s < 8; s++)
        b[s] = (unsigned char)(u >> (8 * s));
}

static void put_le_i32(unsigned char *b, int32_t v)
{
    uint32_t u = (uint32_t)v;
    for (int s = 0; s < 4; s++)
        b[s] = (unsigned char)(u >> (8 * s));
}

int brdf_merl_read(const char *path, double **data, struct gonio_err *err)
{
    *data = NULL;
    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        return gonio_err_set(err, e == ENOENT ? GONIO_ENOTFOUND : GONIO_EBADDATA,
                             "%s: cannot open MERL table: %s", path, strerror(e));
    }
    unsigned char hdr[12];
    if (fread(hdr, 1, sizeof hdr, f) != sizeof hdr) {
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: truncated MERL header (need 12 bytes)",
                             path);
    }
    int32_t n0 = le_i32(hdr), n1 = le_i32(hdr + 4), n2 = le_i32(hdr + 8);
    if (n0 != BRDF_MERL_NTH || n1 != BRDF_MERL_NTD || n2 != BRDF_MERL_NPD) {
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: MERL header is %d %d %d, expected 90 90 180", path, (int)n0,
                             (int)n1, (int)n2);
    }
    struct stat st;
    if (fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode) &&
        (size_t)st.st_size != BRDF_MERL_FILE_BYTES) {
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: MERL table is %lld bytes, expected %zu%s", path,
                             (long long)st.st_size, (size_t)BRDF_MERL_FILE_BYTES,
                             (size_t)st.st_size < BRDF_MERL_FILE_BYTES ? " (truncated)" : "");
    }
    size_t nval = 3 * (size_t)BRDF_MERL_CELLS;
    double *d = malloc(nval * sizeof *d);
    unsigned char *buf = malloc(65536 * 8);
    if (!d || !buf) {
        free(d);
        free(buf);
        fclose(f);
        return gonio_err_set(err, ENOMEM, "%s: out of memory for MERL table", path);
    }
    for (size_t done = 0; done < nval;) {
        size_t want = nval - done < 65536 ? nval - done : 65536;
        size_t got = fread(buf, 8, want, f);
        for (size_t t = 0; t < got; t++) {
            double v = le_f64(buf + 8 * t);
            if (!isfinite(v)) {
                size_t idx = done + t, cell = idx % BRDF_MERL_CELLS;
                int c = (int)(idx / BRDF_MERL_CELLS);
                free(d);
                free(buf);
                fclose(f);
                return gonio_err_set(err, GONIO_EBADDATA,
                                     "%s: value %zu (channel %c, cell i=%zu j=%zu k=%zu) is %s",
                                     path, idx, "RGB"[c], cell / (90 * 180), cell / 180 % 90,
                                     cell % 180, isnan(v) ? "NaN" : "infinite");
            }
            d[done + t] = v;
        }
        done += got;
        if (got < want) {
            free(d);
            free(buf);
            fclose(f);
            return gonio_err_set(err, GONIO_EBADDATA,
                                 "%s: truncated MERL table: %zu of %zu values", path, done,
                                 nval);
        }
    }
    /* Trailing bytes (when the size could not be checked above). */
    int extra = fgetc(f) != EOF;
    free(buf);
    fclose(f);
    if (extra) {
        free(d);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: MERL table longer than %zu bytes", path,
                             (size_t)BRDF_MERL_FILE_BYTES);
    }
    /* A cell with a negative channel was not measured (evaluated as NaN). A
     * table without one measured cell would be read as a material whose
     * every value is NaN, found only when the fit at the end of a capture
     * fails: refuse it here. */
    size_t valid = 0;
    for (size_t cell = 0; cell < BRDF_MERL_CELLS && !valid; cell++)
        valid = d[cell] >= 0 && d[BRDF_MERL_CELLS + cell] >= 0 &&
                d[2 * (size_t)BRDF_MERL_CELLS + cell] >= 0;
    if (!valid) {
        free(d);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: MERL table has no valid cell (every cell has a negative "
                             "channel, MERL's mark for not measured)",
                             path);
    }
    *data = d;
    return 0;
}

static void merl_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                               double *rgb)
{
    const double *d = priv;
    for (size_t p = 0; p < n; p++) {
        size_t cell = brdf_merl_cell(pairs[p].theta_h, pairs[p].theta_d, pairs[p].phi_d);
        double v[3];
        int missing = 0;
        for (int c = 0; c < 3; c++) {
            v[c] = d[(size_t)c * BRDF_MERL_CELLS + cell];
            missing |= v[c] < 0;
        }
        for (int c = 0; c < 3; c++)
            rgb[3 * p + c] = missing ? NAN : v[c] * brdf_merl_scale[c];
    }
}

static const struct brdf_material_ops merl_ops = {
    .kind = "merl",
    .eval = merl_material_eval,
    .free_priv = free,
};

brdf_material *brdf_merl_open(const char *path, const char *name, struct gonio_err *err)
{
    double *d;
    if (brdf_merl_read(path, &d, err) < 0)
        return NULL;
    brdf_material *m = brdf_material_new(&merl_ops, d, name ? name : path);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    return m;
}

int brdf_merl_export(const brdf_material *m, const char *path, struct gonio_err *err)
{
    const size_t row = (size_t)BRDF_MERL_NTD * BRDF_MERL_NPD; /* one theta_h slice */
    /* A MERL table has no phi_h: it would keep one azimuth's slice of an
     * anisotropic material and call it the whole. */
    if (!brdf_material_isotropic(m))
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s: %s is anisotropic; a MERL table holds isotropic materials "
                             "only (its cells have no phi_h)", path, brdf_material_name(m));
    unsigned char *out = malloc(BRDF_MERL_FILE_BYTES);
    struct brdf_pair *pairs = malloc(row * sizeof *pairs);
    double *rgb = malloc(3 * row * sizeof *rgb);
    if (!out || !pairs || !rgb) {
        free(out);
        free(pairs);
        free(rgb);
        return gonio_err_set(err, ENOMEM, "%s: out of memory for MERL export", path);
    }
    put_le_i32(out, BRDF_MERL_NTH);
    put_le_i32(out + 4, BRDF_MERL_NTD);
    put_le_i32(out + 8, BRDF_MERL_NPD);
    for (int i = 0; i < BRDF_MERL_NTH; i++) {
        for (int j = 0; j < BRDF_MERL_NTD; j++)
            for (int k = 0; k < BRDF_MERL_NPD; k++) {
                double th, td, pd;
                brdf_merl_node(i, j, k, &th, &td, &pd);
                brdf_pair_from_hd(th, td, pd, &pairs[(size_t)j * BRDF_MERL_NPD + k]);
            }
        brdf_material_eval(m, pairs, row, rgb);
        for (size_t t = 0; t < row; t++) {
            const struct brdf_pair *p = &pairs[t];
            int below = !(p->wi[2] > 0 && p->wo[2] > 0);
            /* No data, or a value the table cannot hold, becomes MERL's -1. */
            int missing = !isfinite(rgb[3 * t]) || !isfinite(rgb[3 * t + 1]) ||
                          !isfinite(rgb[3 * t + 2]);
            size_t cell = (size_t)i * row + t;
            for (int c = 0; c < 3; c++) {
                double v = below || missing ? -1.0 : rgb[3 * t + c] / brdf_merl_scale[c];
                put_le_f64(out + 12 + 8 * ((size_t)c * BRDF_MERL_CELLS + cell), v);
            }
        }
    }
    free(pairs);
    free(rgb);
    int rc = gonio_write_file_atomic(path, out, BRDF_MERL_FILE_BYTES, err);
    free(out);
    return rc;
}
