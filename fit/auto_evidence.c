/* How the premise checks steer --model auto (fit/auto_evidence.h). */
#include "fit/auto_evidence.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The candidates that predict out of plane, in the order a tie is broken;
 * the anisotropic one only for samples taken with the sample turned. */
static const char *const isotropic_models[] = {"abc", "abc-prior", "latent"};
#define N_ISOTROPIC (sizeof isotropic_models / sizeof *isotropic_models)
static const char anisotropic_model[] = "aniso-ggx";

enum fit_auto_isotropy fit_auto_isotropy_of(const char *verdict)
{
    if (verdict && !strcmp(verdict, "isotropic"))
        return FIT_AUTO_ISOTROPIC;
    if (verdict && !strcmp(verdict, "anisotropic"))
        return FIT_AUTO_ANISOTROPIC;
    return FIT_AUTO_ISOTROPY_UNKNOWN;
}

void fit_auto_evidence_oop(struct fit_auto_evidence *ev, const char *model, const char *verdict)
{
    enum fit_auto_oop v = !strcmp(verdict, "sufficient")     ? FIT_AUTO_OOP_SUFFICIENT
                          : !strcmp(verdict, "insufficient") ? FIT_AUTO_OOP_INSUFFICIENT
                                                             : FIT_AUTO_OOP_UNCHECKED;
    size_t k = 0;
    while (k < FIT_AUTO_MAX_CANDIDATES && ev->oop[k].model[0] && strcmp(ev->oop[k].model, model))
        k++;
    if (k == FIT_AUTO_MAX_CANDIDATES)
        return; /* more models than candidates: none of them a candidate */
    snprintf(ev->oop[k].model, sizeof ev->oop[k].model, "%s", model);
    ev->oop[k].verdict = v;
}

enum fit_auto_oop fit_auto_evidence_oop_of(const struct fit_auto_evidence *ev, const char *model)
{
    for (size_t k = 0; ev && k < FIT_AUTO_MAX_CANDIDATES && ev->oop[k].model[0]; k++)
        if (!strcmp(ev->oop[k].model, model))
            return ev->oop[k].verdict;
    return FIT_AUTO_OOP_UNCHECKED;
}

size_t fit_auto_candidates(int turned, const struct fit_auto_evidence *ev,
                           const char *names[FIT_AUTO_MAX_CANDIDATES], char *why, size_t len)
{
    enum fit_auto_isotropy iso = ev ? ev->isotropy : FIT_AUTO_ISOTROPY_UNKNOWN;
    why[0] = '\0';
    if (iso == FIT_AUTO_ANISOTROPIC && turned) {
        names[0] = anisotropic_model;
        snprintf(why, len, "isotropy check: anisotropic, samples at several sample azimuths: "
                           "%s only", anisotropic_model);
        return 1;
    }
    size_t n = 0;
    for (; n < N_ISOTROPIC; n++)
        names[n] = isotropic_models[n];
    if (iso == FIT_AUTO_ANISOTROPIC)
        snprintf(why, len, "isotropy check: anisotropic, but the samples are at one sample "
                           "azimuth: %s cannot be fitted (plan sample_azimuths), isotropic "
                           "candidates only",
                 anisotropic_model);
    else if (iso == FIT_AUTO_ISOTROPIC)
        snprintf(why, len, "isotropy check: isotropic: isotropic candidates only");
    else if (turned)
        names[n++] = anisotropic_model;
    return n;
}

/* 1 when candidate a ranks before b. */
static int before(const double *cv, const enum fit_auto_oop *v, size_t a, size_t b)
{
    int ia = v[a] == FIT_AUTO_OOP_INSUFFICIENT, ib = v[b] == FIT_AUTO_OOP_INSUFFICIENT;
    if (ia != ib)
        return ia < ib;
    return cv[a] < cv[b] || (cv[a] == cv[b] && a < b);
}

size_t fit_auto_rank(const char *const *model, const double *cv, const int *failed, size_t n,
                     const struct fit_auto_evidence *ev, char *why, size_t len)
{
    enum fit_auto_oop v[FIT_AUTO_MAX_CANDIDATES];
    size_t best = n, by_cv = n;
    why[0] = '\0';
    for (size_t c = 0; c < n && c < FIT_AUTO_MAX_CANDIDATES; c++) {
        v[c] = fit_auto_evidence_oop_of(ev, model[c]);
        if (failed[c] || !isfinite(cv[c]))
            continue;
        if (best == n || before(cv, v, c, best))
            best = c;
        if (by_cv == n || cv[c] < cv[by_cv])
            by_cv = c;
    }
    if (best == n)
        return n;
    if (best != by_cv)
        snprintf(why, len, "out-of-plane check: %s (cv %.4f) insufficient, %s (cv %.4f) %s",
                 model[by_cv], cv[by_cv], model[best], cv[best],
                 v[best] == FIT_AUTO_OOP_SUFFICIENT ? "sufficient" : "not yet checked");
    else if (v[best] != FIT_AUTO_OOP_UNCHECKED)
        snprintf(why, len, "out-of-plane check: %s %s", model[best],
                 v[best] == FIT_AUTO_OOP_SUFFICIENT ? "sufficient"
                                                    : "insufficient; no candidate sufficient");
    return best;
}

int fit_auto_settle(struct fit_auto_evidence *ev, char *chosen, char *why, size_t why_len,
                    const struct fit_auto_steps *steps, struct gonio_err *err)
{
    for (size_t checked = 0; chosen[0] && checked < FIT_AUTO_MAX_CANDIDATES; checked++) {
        char verdict[16] = "";
        int rc = steps->check(steps->user, chosen, verdict, sizeof verdict, err);
        if (rc < 0 || !verdict[0])
            return rc < 0 ? rc : 0;
        fit_auto_evidence_oop(ev, chosen, verdict);
        if (strcmp(verdict, "insufficient")) { /* the choice stands */
            size_t at = strlen(why);
            snprintf(why + at, why_len - at, "%sout-of-plane check: %.16s %.16s",
                     at ? "; " : "", chosen, verdict);
            return 0;
        }
        if ((rc = steps->fit(steps->user, err)) < 0)
            return rc;
        if (fit_auto_evidence_oop_of(ev, chosen) == FIT_AUTO_OOP_INSUFFICIENT)
            return 0; /* judged already: every better candidate insufficient too */
    }
    return 0;
}
