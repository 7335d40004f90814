/* Canonical sample order (fit/sample_order.h). */
#include "fit/sample_order.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define KEY_DOUBLES 12 /* wi, wo, theta_h, theta_d, phi_d, rgb */

struct keyed {
    uint64_t key[KEY_DOUBLES];
    unsigned char flag;
    size_t i;
};

/* IEEE 754 totalOrder as an unsigned integer: negative values have their
 * bits flipped, positive ones their sign bit set. Unlike <, it orders NaN
 * and tells -0 from +0, so equal keys mean equal bits. */
static uint64_t total_order(double v)
{
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b >> 63 ? ~b : b | UINT64_C(1) << 63;
}

static int keyed_cmp(const void *a, const void *b)
{
    const struct keyed *x = a, *y = b;
    for (int k = 0; k < KEY_DOUBLES; k++)
        if (x->key[k] != y->key[k])
            return x->key[k] < y->key[k] ? -1 : 1;
    return (x->flag > y->flag) - (x->flag < y->flag);
}

int fit_samples_canonical(const struct fit_sample *s, const unsigned char *flags, size_t n,
                          struct fit_sample **sorted, unsigned char **sorted_flags)
{
    size_t m = n ? n : 1;
    struct keyed *k = malloc(m * sizeof *k);
    struct fit_sample *out = malloc(m * sizeof *out);
    unsigned char *fl = flags ? malloc(m) : NULL;
    if (!k || !out || (flags && !fl)) {
        free(k);
        free(out);
        free(fl);
        return -1;
    }
    for (size_t i = 0; i < n; i++) {
        const struct brdf_pair *g = &s[i].g;
        const double v[KEY_DOUBLES] = {g->wi[0], g->wi[1], g->wi[2], g->wo[0],
                                       g->wo[1], g->wo[2], g->theta_h, g->theta_d,
                                       g->phi_d, s[i].rgb[0], s[i].rgb[1], s[i].rgb[2]};
        for (int j = 0; j < KEY_DOUBLES; j++)
            k[i].key[j] = total_order(v[j]);
        k[i].flag = flags ? flags[i] != 0 : 0;
        k[i].i = i;
    }
    /* qsort is not stable, but ties are identical samples with equal flags */
    qsort(k, n, sizeof *k, keyed_cmp);
    for (size_t j = 0; j < n; j++) {
        out[j] = s[k[j].i];
        if (fl)
            fl[j] = k[j].flag;
    }
    free(k);
    *sorted = out;
    *sorted_flags = fl;
    return 0;
}
