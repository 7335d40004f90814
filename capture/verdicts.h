/* A capture's premise checks (docs/checks.md) and --model auto's choice
 * as JSON, built once from the summary for every place that shows them:
 * results.json's `checks` and `auto`, goniod's stop document (the same
 * two members) and its event-model fit stream (capture_verdicts_flat: the
 * same figures as flat data keys, which event-model's dtypes require).
 * And read back (capture_verdicts_read) for `gonio fit --model auto DIR`,
 * which replays the capture's choice with the verdicts it recorded
 * (fit_auto_settle), so that the refit chooses as the capture did. */
#ifndef GONIO_CAPTURE_VERDICTS_H
#define GONIO_CAPTURE_VERDICTS_H

#include <jansson.h>

#include "capture/capture.h"
#include "common/err.h"

/* results.json's `auto`: the model chosen, why, the isotropy evidence and
 * the out-of-plane verdicts of the candidates checked; null for a capture
 * of another model. NULL when out of memory. */
json_t *capture_verdicts_auto(const struct capture_summary *s);

/* The checks' object (capture_files_checks) and auto's (capture_verdicts_auto,
 * or null) as flat members of data: `isotropy_KEY` and `oop_KEY` for each
 * member of a check, a nested object's members as `PREFIX_OBJECT_KEY`
 * (`isotropy_worst_theta_i`), arrays (`oop_error_full_interval`) as they
 * are; `auto_chosen`, `auto_why`, `auto_isotropy` and `auto_oop_MODEL`
 * for each candidate checked. */
void capture_verdicts_flat(json_t *checks, json_t *auto_doc, json_t *data);

/* The verdicts a capture directory's results.json recorded. */
struct capture_verdicts {
    int found; /* 1: results.json had a check's verdict */
    enum fit_auto_isotropy isotropy;
    size_t n; /* out-of-plane verdicts, by model */
    char model[FIT_AUTO_MAX_CANDIDATES][16], verdict[FIT_AUTO_MAX_CANDIDATES][16];
};

/* Read dir/results.json's verdicts into out (nothing found when it is
 * absent or has none). The out-of-plane check judged the model the capture
 * fitted last (auto's choice, else the capture's model): its verdict as
 * the check gave it; auto's earlier candidates' verdicts from `auto`.
 * 0, or -GONIO_EBADDATA with err naming the file and what is wrong when
 * it is not JSON or a member read is not of its type. */
int capture_verdicts_read(const char *dir, struct capture_verdicts *out, struct gonio_err *err);

/* The recorded out-of-plane verdict of model, "" when none. */
const char *capture_verdicts_oop(const struct capture_verdicts *v, const char *model);

#endif
