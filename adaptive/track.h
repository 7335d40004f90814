/* The latent model followed alongside the ABC ensemble (adaptive/track.c):
 * refitted each time the samples have grown by a quarter, so that the
 * policy can predict the latent fit's error and check that the decoder's
 * prior fits the material at all (docs/adaptive.md, "The policy", step 5). */
#ifndef GONIO_ADAPTIVE_TRACK_H
#define GONIO_ADAPTIVE_TRACK_H

#include <stddef.h>

#include "common/err.h"
#include "fit/fit.h"
#include "fit/latent.h"

struct track {
    latent_decoder *dec;
    size_t fitted;     /* samples in the latest fit (0: none yet) */
    double in_sample;  /* its log error on those samples */
};

/* Load the committed decoder. Returns 0 or a negative code with err
 * naming the file. */
int track_init(struct track *t, struct gonio_err *err);
void track_free(struct track *t);

/* Refit when n has grown by a quarter since the latest fit (and n >= 6).
 * Returns 1 when it refitted, 0 when not due, -GONIO_EFIT when the fit
 * failed (t->fitted then stays as it was). */
int track_update(struct track *t, const struct fit_sample *s, size_t n, uint64_t seed);

#endif
