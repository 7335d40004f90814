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

/* One pair through the network. The loops run over the output index with
 * the [in][out] weight rows contiguous, so the compiler vectorises them. */
static void eval_one(const struct brdf_nbrdf *net, const struct brdf_pair *p, double out[3])
{
    double st = sin(p->theta_h), ct = cos(p->theta_h);
    double sd = sin(p->theta_d), cd = cos(p->theta_d);
    double sp = sin(p->phi_d), cp = cos(p->phi_d);
    const double x[NIN] = {st, 0.0, ct, sd * cp, sd * sp, cd};

    double h1[NH], h2[NH];
    memcpy(h1, net->b1, sizeof h1);
    for (int i = 0; i < NIN; i++) {
        if (x[i] == 0.0)
            continue;
        const double *row = net->w1 + i * NH;
        for (int j = 0; j < NH; j++)
            h1[j] += x[i] * row[j];
    }
    memcpy(h2, net->b2, sizeof h2);
    for (int i = 0; i < NH; i++) {
        double a = h1[i] > 0 ? h1[i] : 0.0;
        if (a == 0.0)
            continue; /* ReLU zeros contribute nothing */
        const double *row = net->w2 + i * NH;
        for (int j = 0; j < NH; j++)
            h2[j] += a * row[j];
    }
    double o[NOUT] = {net->b3[0], net->b3[1], net->b3[2]};
    for (int i = 0; i < NH; i++) {
        double a = h2[i] > 0 ? h2[i] : 0.0;
        const double *row = net->w3 + i * NOUT;
        o[0] += a * row[0];
        o[1] += a * row[1];
        o[2] += a * row[2];
    }
    for (int c = 0; c < NOUT; c++) {
        double f = expm1(o[c]);
        out[c] = f > 0 ? f : 0.0;
    }
}

void brdf_nbrdf_eval(const struct brdf_nbrdf *net, const struct brdf_pair *pairs, size_t n,
                     double *rgb)
{
    for (size_t i = 0; i < n; i++)
        eval_one(net, &pairs[i], rgb + 3 * i);
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
