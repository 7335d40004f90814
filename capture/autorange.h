/* Inside capture/: auto-ranging a detector that gives counts, as a real
 * one can (docs/plans.md, "Auto-ranging").
 *
 * A point's reading is tried at an integration, read, and taken again
 * longer when its peak channel's signal (counts less the dark at that
 * integration, where a dark frame is known) is below AUTORANGE_FLOOR of
 * full scale, or shorter when it clipped (saturated): a saturated reading
 * is taken again short before it is kept, and only one still saturated at
 * the shortest integration is kept flagged. Integrations are rungs of a
 * ladder, the rig profile's fixed integration times powers of
 * AUTORANGE_STEP, held to its auto_min_s..auto_max_s; a reading too low
 * goes up as many rungs as its signal says (to about AUTORANGE_AIM of full
 * scale), a clipped one down one rung, and once a point has gone down it
 * does not go up again. Each point starts at the rung the point before it
 * ended on. Every try costs its rig time, which the point's
 * integration_total_s records. Where the detector has a shutter, a dark
 * frame is taken (shutter closed) the first time each rung is used, and
 * handed to the caller to journal. A detector that reports BRDF is read
 * once at the rig's fixed integration, as before. */
#ifndef GONIO_CAPTURE_AUTORANGE_H
#define GONIO_CAPTURE_AUTORANGE_H

#include <stddef.h>

#include "common/err.h"
#include "drivers/drivers.h"
#include "journal/journal.h"
#include "rig/rig.h"

#define AUTORANGE_FLOOR 0.02 /* of full scale: below it, a longer integration */
#define AUTORANGE_AIM 0.25   /* of full scale: where a longer one aims */
#define AUTORANGE_STEP 4.0   /* between rungs */
#define AUTORANGE_RUNGS 48   /* rungs whose dark frames it keeps */
#define AUTORANGE_TRIES 12   /* readings of one point at most */

struct autorange {
    double fixed_s, min_s, max_s;
    double next_s;        /* where the next point starts (0: the fixed integration) */
    int no_shutter;       /* the rig profile or the detector says it has none: no dark frames */
    size_t n_dark;
    double dark_s[AUTORANGE_RUNGS];
    double dark[AUTORANGE_RUNGS][3]; /* its counts per channel */
    size_t retakes;       /* readings taken again, this run */
    double full_scale;    /* the detector's, as its last reading of counts said; 0: none yet */
    double dark_total_s;  /* the dark frames' integrations, journalled ones included */
};

/* Ranging on rig's integration bounds. */
void autorange_init(struct autorange *a, const struct rig_profile *rig);

/* A journalled record of an earlier run: a dark frame is known (a resume
 * takes it again at no rung), a sample's integration is where the next
 * point starts. */
void autorange_note(struct autorange *a, const struct journal_sample *s);

/* What a point's reading cost: the one kept, the detector time of every
 * try (the kept one's included) and how many were taken. */
#define AUTORANGE_MAX_BANDS 64

struct autorange_take {
    struct drv_reading r;
    double total_s;
    int tries;
    /* r's bands, copied (the detector's are its next reading's once the
     * dark frame is taken): r.bands_nm and r.bands point here */
    double bands_nm[AUTORANGE_MAX_BANDS], bands[AUTORANGE_MAX_BANDS];
};

/* Take the dark frame reading r (shutter closed) of the point: the caller
 * journals it. 0 or a negative code with err. */
typedef int (*autorange_dark_fn)(void *user, const struct drv_reading *r,
                                 struct gonio_err *err);

/* One point's reading on d. */
int autorange_acquire(struct autorange *a, drv_detector *d, autorange_dark_fn dark,
                      void *user, struct autorange_take *out, struct gonio_err *err);

/* The ladder's rungs, shortest first, into out (room for max): their
 * count. What setup.json records of a detector of counts. */
size_t autorange_ladder(const struct autorange *a, double *out, size_t max);

/* The rung the ladder holds next above (dir 1) or below (dir -1) t, or t
 * itself (dir 0) snapped to the ladder; held to the bounds. */
double autorange_rung(const struct autorange *a, double t, int dir);

/* The peak channel's signal per second of a journalled sample of counts,
 * its dark at that integration taken off where known (a clipped one's is
 * a lower bound); NAN for a sample of BRDF or a dark frame. The material's
 * brightness at the point, whatever rung it was read on. */
double autorange_rate(const struct autorange *a, const struct journal_sample *s);

/* The ladder walked ahead, as autorange_acquire would walk it: the rung
 * it stands on and the rungs that have their dark frame. */
struct autorange_model {
    double t;
    size_t n_dark;
    double dark_s[AUTORANGE_RUNGS];
};

/* The walk from where a stands now. 0 (m unusable) until a reading of
 * counts has stated the full scale. */
int autorange_model_start(const struct autorange *a, struct autorange_model *m);

/* The detector time of the next point of the walk, a point whose signal
 * runs at rate (autorange_rate): every try and the dark frame of each
 * rung used the first time; m moves to the rung the point ends on. */
double autorange_model_point(const struct autorange *a, struct autorange_model *m, double rate);

#endif
