/* What a capture's premise checks (docs/checks.md) tell `--model auto`
 * (fit/auto_model.h), and the rule by which they steer its choice.
 *
 * The cross-validation sees only the samples, and in-plane samples cannot
 * say whether the material is isotropic or whether a model that fits them
 * holds out of the plane; the checks measure exactly that. So:
 *
 * - Isotropy. "anisotropic": the isotropic models describe one slice of the
 *   material only, so when the samples were taken with the sample turned
 *   (the azimuths aniso-ggx needs) it is the only candidate; without turned
 *   samples nothing can fit the anisotropy and the isotropic candidates stay
 *   (the reason says the plan needs sample_azimuths). "isotropic": aniso-ggx
 *   is no candidate even for turned samples (its extra parameters would fit
 *   noise). Unknown or "undetermined": the candidates the samples allow.
 * - Out of plane. A candidate whose in-plane fit the out-of-plane check
 *   judged "insufficient" loses to every candidate not so judged, whatever
 *   their cross-validated errors; among equals the lowest CV error wins.
 *   The capture checks the chosen model and, while the choice is a model
 *   it has not checked, checks that one (capture/capture.c), so each
 *   candidate is measured at most once and only when it could win.
 *
 * Each decision is said in one line (fit_auto_cv.why, the model file's
 * auto_why, results.json's auto.why). */
#ifndef GONIO_FIT_AUTO_EVIDENCE_H
#define GONIO_FIT_AUTO_EVIDENCE_H

#include <stddef.h>

#include "common/err.h"

#define FIT_AUTO_MAX_CANDIDATES 4
#define FIT_AUTO_WHY_MAX 320

enum fit_auto_isotropy { FIT_AUTO_ISOTROPY_UNKNOWN, FIT_AUTO_ISOTROPIC, FIT_AUTO_ANISOTROPIC };
enum fit_auto_oop { FIT_AUTO_OOP_UNCHECKED, FIT_AUTO_OOP_SUFFICIENT, FIT_AUTO_OOP_INSUFFICIENT };

struct fit_auto_evidence {
    enum fit_auto_isotropy isotropy;
    /* The out-of-plane check's verdicts so far, by candidate name ("" ends;
     * a candidate not named is unchecked; "undetermined" is unchecked). */
    struct {
        char model[16];
        enum fit_auto_oop verdict;
    } oop[FIT_AUTO_MAX_CANDIDATES];
};

/* The isotropy check's verdict text as evidence ("isotropic",
 * "anisotropic"; anything else unknown). */
enum fit_auto_isotropy fit_auto_isotropy_of(const char *verdict);

/* Record the out-of-plane check's verdict text ("sufficient",
 * "insufficient"; anything else leaves the model unchecked) for model. */
void fit_auto_evidence_oop(struct fit_auto_evidence *ev, const char *model,
                           const char *verdict);

/* The verdict recorded for model (FIT_AUTO_OOP_UNCHECKED: none). */
enum fit_auto_oop fit_auto_evidence_oop_of(const struct fit_auto_evidence *ev,
                                           const char *model);

/* The candidates for samples that were (turned 1) or were not taken with
 * the sample turned, given ev (NULL: none), into names in tie-break order;
 * returns their count, and the isotropy's part of the reason in why
 * ("" when the isotropy said nothing). */
size_t fit_auto_candidates(int turned, const struct fit_auto_evidence *ev,
                           const char *names[FIT_AUTO_MAX_CANDIDATES], char *why, size_t len);

/* The chosen candidate among n: cv[c] its CV error (INFINITY or failed[c]
 * set: out), ev the out-of-plane verdicts (NULL: none). Not judged
 * insufficient beats judged insufficient, then lower cv, then the earlier
 * candidate. Returns n when every candidate is out; the out-of-plane part
 * of the reason into why ("" when no verdict decided anything). */
size_t fit_auto_rank(const char *const *model, const double *cv, const int *failed, size_t n,
                     const struct fit_auto_evidence *ev, char *why, size_t len);

/* The steps of --model auto with the out-of-plane check of each choice,
 * for fit_auto_settle: fit again with the evidence (the choice and its
 * reason into the buffers fit_auto_settle was given), and the check's
 * verdict text of the chosen model's fit into verdict ("" when there is
 * none to be had: the choice stands as it is). A capture measures the
 * check on its rig; `gonio fit --model auto` of a capture directory reads
 * the verdicts the capture recorded, and so makes the capture's choice. */
struct fit_auto_steps {
    int (*fit)(void *user, struct gonio_err *err);
    int (*check)(void *user, const char *model, char *verdict, size_t len,
                 struct gonio_err *err);
    void *user;
};

/* After an auto fit chose chosen (why its reason, "" none) with ev: check
 * the choice; while it is judged "insufficient", record that in ev and fit
 * again, checking a new choice in turn, until a choice is not judged
 * insufficient (its verdict appended to why), a choice was judged
 * insufficient already (every better candidate too: it stays, as
 * fit_auto_rank says) or a check gives no verdict. Each candidate is
 * checked at most once. Returns 0 or a step's negative error. */
int fit_auto_settle(struct fit_auto_evidence *ev, char *chosen, char *why, size_t why_len,
                    const struct fit_auto_steps *steps, struct gonio_err *err);

#endif
