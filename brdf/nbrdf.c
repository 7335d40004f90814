#include "brdf/nbrdf.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/material_private.h"

#define NIN BRDF_NBRDF_NIN
#define NH BRDF_NBRDF_NHID
#define NOUT BRDF_NBRDF_NOUT

static float le_float(const unsigned char *b)
{
    /* Byte order is fixed by the file format, not by the host. */
    uint32_t u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                 (uint32_t)b[3] << 24;
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

void brdf_nbrdf_from_floats(const float w[BRDF_NBRDF_NWEIGHTS], struct brdf_nbrdf *net)
{
    size_t o = 0;
    for (size_t i = 0; i < NIN * NH; i++)
        net->w1[i] = w[o++];
    for (size_t i = 0; i < NH; i++)
        net->b1[i] = w[o++];
    for (size_t i = 0; i < NH * NH; i++)
        net->w2[i] = w[o++];
    for (size_t i = 0; i < NH; i++)
        net->b2[i] = w[o++];
    for (size_t i = 0; i < NH * NOUT; i++)
        net->w3[i] = w[o++];
    for (size_t i = 0; i < NOUT; i++)
        net->b3[i] = w[o++];
}

int brdf_nbrdf_load(const char *path, struct brdf_nbrdf *net, struct gonio_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        return gonio_err_set(err, e == ENOENT ? GONIO_ENOTFOUND : GONIO_EBADDATA,
                             "%s: cannot open NBRDF weights: %s", path, strerror(e));
    }
    /* Read one byte more than expected so a longer file is caught too. */
    unsigned char buf[BRDF_NBRDF_FILE_BYTES + 1];
    size_t got = fread(buf, 1, sizeof buf, f);
    int rerr = ferror(f);
    fclose(f);
    if (rerr)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: read error", path);
    if (got != BRDF_NBRDF_FILE_BYTES)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: NBRDF weight file must be exactly %d bytes (675 float32), "
                             "got %s%zu",
                             path, BRDF_NBRDF_FILE_BYTES,
                             got > BRDF_NBRDF_FILE_BYTES ? "more than " : "",
                             got > BRDF_NBRDF_FILE_BYTES ? (size_t)BRDF_NBRDF_FILE_BYTES : got);
    float w[BRDF_NBRDF_NWEIGHTS];
    for (size_t i = 0; i < BRDF_NBRDF_NWEIGHTS; i++) {
        w[i] = le_float(buf + 4 * i);
        if (!isfinite(w[i]))
            return gonio_err_set(err, GONIO_EBADDATA, "%s: weight %zu is not finite (%g)",
                                 path, i, (double)w[i]);
    }
    brdf_nbrdf_from_floats(w, net);
    return 0;
}

/* Pairs go through the network in blocks, stored [unit][pair] so that
 * every inner loop runs over BLOCK pairs with a fixed trip count and
 * vectorises; one pair at a time (21-wide rows) ran about 2x slower. */
#define BLOCK 32

static void eval_block(const struct brdf_nbrdf *net, const struct brdf_pair *p, size_t n,
                       double *rgb)
{
    double x[NIN][BLOCK], h1[NH][BLOCK], h2[NH][BLOCK], o[NOUT][BLOCK];
    for (size_t b = 0; b < BLOCK; b++) {
        if (b < n) {
            double st = sin(p[b].theta_h), ct = cos(p[b].theta_h);
            double sd = sin(p[b].theta_d), cd = cos(p[b].theta_d);
            double sp = sin(p[b].phi_d), cp = cos(p[b].phi_d);
            x[0][b] = st;
            x[1][b] = 0.0; /* phi_h = 0: the y component of the half vector */
            x[2][b] = ct;
            x[3][b] = sd * cp;
            x[4][b] = sd * sp;
            x[5][b] = cd;
        } else {
            for (int i = 0; i < NIN; i++)
                x[i][b] = 0.0; /* padding, discarded below */
        }
    }
    /* Each output unit accumulates over its inputs for 4 pairs at a time
     * in locals, so the sums stay in registers instead of memory. */
    for (int j = 0; j < NH; j++)
        for (size_t b = 0; b < BLOCK; b += 4) {
            double a0 = net->b1[j], a1 = a0, a2 = a0, a3 = a0;
            for (int i = 0; i < NIN; i++) {
                double w = net->w1[i * NH + j];
                a0 += x[i][b] * w;
                a1 += x[i][b + 1] * w;
                a2 += x[i][b + 2] * w;
                a3 += x[i][b + 3] * w;
            }
            h1[j][b] = a0 > 0 ? a0 : 0.0;
            h1[j][b + 1] = a1 > 0 ? a1 : 0.0;
            h1[j][b + 2] = a2 > 0 ? a2 : 0.0;
            h1[j][b + 3] = a3 > 0 ? a3 : 0.0;
        }
    for (int j = 0; j < NH; j++)
        for (size_t b = 0; b < BLOCK; b += 4) {
            double a0 = net->b2[j], a1 = a0, a2 = a0, a3 = a0;
            for (int i = 0; i < NH; i++) {
                double w = net->w2[i * NH + j];
                a0 += h1[i][b] * w;
                a1 += h1[i][b + 1] * w;
                a2 += h1[i][b + 2] * w;
                a3 += h1[i][b + 3] * w;
            }
            h2[j][b] = a0 > 0 ? a0 : 0.0;
            h2[j][b + 1] = a1 > 0 ? a1 : 0.0;
            h2[j][b + 2] = a2 > 0 ? a2 : 0.0;
            h2[j][b + 3] = a3 > 0 ? a3 : 0.0;
        }
    for (int c = 0; c < NOUT; c++)
        for (size_t b = 0; b < BLOCK; b += 4) {
            double a0 = net->b3[c], a1 = a0, a2 = a0, a3 = a0;
            for (int i = 0; i < NH; i++) {
                double w = net->w3[i * NOUT + c];
                a0 += h2[i][b] * w;
                a1 += h2[i][b + 1] * w;
                a2 += h2[i][b + 2] * w;
                a3 += h2[i][b + 3] * w;
            }
            o[c][b] = a0;
            o[c][b + 1] = a1;
            o[c][b + 2] = a2;
            o[c][b + 3] = a3;
        }
    for (size_t b = 0; b < n; b++)
        for (int c = 0; c < NOUT; c++) {
            double f = expm1(o[c][b]); /* exp(x) - 1 without cancellation near 0 */
            rgb[3 * b + c] = f > 0 ? f : 0.0;
        }
}

void brdf_nbrdf_eval(const struct brdf_nbrdf *net, const struct brdf_pair *pairs, size_t n,
                     double *rgb)
{
    for (size_t i = 0; i < n; i += BLOCK)
        eval_block(net, pairs + i, n - i < BLOCK ? n - i : BLOCK, rgb + 3 * i);
}

static void nbrdf_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                                double *rgb)
{
    brdf_nbrdf_eval(priv, pairs, n, rgb);
}

static const struct brdf_material_ops nbrdf_ops = {
    .kind = "nbrdf",
    .eval = nbrdf_material_eval,
    .free_priv = free,
};

brdf_material *brdf_nbrdf_open(const char *path, const char *name, struct gonio_err *err)
{
    struct brdf_nbrdf *net = malloc(sizeof *net);
    if (!net) {
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
        return NULL;
    }
    if (brdf_nbrdf_load(path, net, err) < 0) {
        free(net);
        return NULL;
    }
    brdf_material *m = brdf_material_new(&nbrdf_ops, net, name ? name : path);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    return m;
}
