/* The isotropy check (docs/checks.md): is the sample isotropic, as the
 * in-plane premise assumes? A few in-plane pairs where an anisotropy shows
 * most — the glossy lobe's peak and its steepest flanks at two incidences,
 * from the capture's own samples — are measured again with the sample
 * turned about its normal (ISO_CHECK_ROTATIONS) and once unturned; each
 * turned reading is compared with the capture's first reading of the pair,
 * in the units of the measurement noise that the unturned repeats show.
 *
 * The statistics: d = ln(turned) - ln(first), r = ln(repeat) - ln(first);
 * s^2 = max(floor^2, mean r^2) (n_pairs degrees of freedom); the largest
 * |d| / s is compared with Student's t at ISO_CHECK_ALPHA / (2 M), M the
 * comparisons made (Bonferroni: the nominal false-alarm rate over the
 * whole check is at most ISO_CHECK_ALPHA). Beyond it: "anisotropic".
 * Within it: "isotropic" when the check could have seen a deviation of
 * ISO_CHECK_SENSITIVITY, else "undetermined" (too noisy, or too few
 * pairs).
 *
 * No devices here: the host measures through a callback (the capture
 * engine moves its rig; the tests give readings). */
#ifndef GONIO_CAPTURE_ISOTROPY_CHECK_H
#define GONIO_CAPTURE_ISOTROPY_CHECK_H

#include <stddef.h>

#include "common/err.h"
#include "journal/journal.h"

#define ISO_CHECK_MAX_PAIRS 6
#define ISO_CHECK_ROTATIONS 2           /* 60 and 120 degrees */
#define ISO_CHECK_ALPHA 0.01            /* nominal false-alarm rate of a check */
#define ISO_CHECK_NOISE_FLOOR 0.01      /* log difference of two readings, at least */
#define ISO_CHECK_SENSITIVITY 0.223     /* ln 1.25: the deviation the check must see */

/* One pair the check re-measures, with the capture's reading of it. */
struct iso_check_pair {
    double theta_i, theta_r;
    double first; /* the capture's reading (mean of R, G, B) */
};

/* Up to ISO_CHECK_MAX_PAIRS pairs from the n journalled in-plane samples
 * (saturated and non-positive ones left out): at the two incidences
 * nearest 30 and 40 degrees among those with a glossy row, the row's peak
 * within 15 degrees of the mirror and the steepest sample on either side,
 * each no steeper than 0.5 per degree in |d ln f / d theta_r| to its row
 * neighbours (where the axes' repeatability still moves the reading less
 * than the noise; a peak narrower than the row's step is left out), sorted by incidence and theta_r (the
 * rig's shortest way through them). Returns the count (0: nothing
 * usable). */
size_t iso_check_choose(const struct journal_sample *s, size_t n, struct iso_check_pair *out);

/* The rotations of the check in the order it measures them: the turned
 * ones, then 0 (the repeat; the sample ends as it began). */
extern const double iso_check_rotation_deg[ISO_CHECK_ROTATIONS + 1];

/* A host's measurement: the reading (mean of R, G, B; NAN when unusable,
 * a saturated one) at the pair with the sample turned rotation_deg. */
typedef int (*iso_check_measure_fn)(void *user, const struct iso_check_pair *p,
                                    double rotation_deg, double *value, struct gonio_err *err);

struct iso_check_result {
    char verdict[16];       /* "isotropic", "anisotropic", "undetermined" */
    char why[160];          /* one line: what decided it */
    size_t pairs, measurements;
    struct iso_check_pair worst; /* the pair of the largest deviation */
    double worst_rotation_deg;
    double max_deviation;   /* its |ln turned - ln first| */
    double significance;    /* its |d| / s */
    double threshold;       /* the critical |d| / s */
    double noise;           /* s, the log noise of a difference of two readings */
    double detectable;      /* the smallest deviation beyond the threshold: s x threshold */
    double alpha;           /* the nominal false-alarm rate, ISO_CHECK_ALPHA */
    double rig_time_s;      /* filled by the host: what the check cost the rig */
};

/* The verdict from the readings: turned[j * ISO_CHECK_ROTATIONS + k] at
 * iso_check_rotation_deg[k], repeat[j] unturned, for the n pairs p. NAN
 * readings are left out. */
void iso_check_decide(const struct iso_check_pair *p, size_t n, const double *turned,
                      const double *repeat, struct iso_check_result *out);

/* Choose, measure (the pairs in snake order within each rotation, so that
 * the rig turns the sample once per rotation) and decide. Returns 0, or the
 * callback's failure. */
int iso_check_run(const struct journal_sample *s, size_t n, iso_check_measure_fn measure,
                  void *user, struct iso_check_result *out, struct gonio_err *err);

#endif
