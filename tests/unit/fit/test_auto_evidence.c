/* --model auto with a capture's premise checks (fit/auto_evidence.h): the
 * isotropy verdict sets the candidates (anisotropic with turned samples:
 * aniso-ggx alone; anisotropic at one azimuth: the isotropic ones, saying
 * why; isotropic: never aniso-ggx), an out-of-plane verdict of
 * "insufficient" puts a candidate behind every other whatever its CV
 * error, and the choice and its reason reach the model file through the
 * cross-validation. fit_auto_settle checks each choice once, fits again
 * while the choice is judged insufficient and says what decided. */
#include <math.h>
#include <string.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "fit/auto_evidence.h"
#include "fit/auto_model.h"
#include "fit/model_file.h"
#include "fit/models.h"
#include "tests/gonio_test.h"

static int has(const char *const *names, size_t n, const char *name)
{
    for (size_t c = 0; c < n; c++)
        if (!strcmp(names[c], name))
            return 1;
    return 0;
}

static void test_isotropy_sets_the_candidates(void **state)
{
    (void)state;
    const char *names[FIT_AUTO_MAX_CANDIDATES];
    char why[FIT_AUTO_WHY_MAX];
    struct fit_auto_evidence ev = {.isotropy = FIT_AUTO_ISOTROPY_UNKNOWN};
    /* no verdict: what the samples allow, as without a check */
    assert_int_equal(fit_auto_candidates(1, &ev, names, why, sizeof why), 4);
    assert_true(has(names, 4, "aniso-ggx"));
    assert_string_equal(why, "");
    assert_int_equal(fit_auto_candidates(0, NULL, names, why, sizeof why), 3);
    assert_false(has(names, 3, "aniso-ggx"));
    /* anisotropic, turned samples: the anisotropic model alone */
    ev.isotropy = FIT_AUTO_ANISOTROPIC;
    assert_int_equal(fit_auto_candidates(1, &ev, names, why, sizeof why), 1);
    assert_string_equal(names[0], "aniso-ggx");
    assert_non_null(strstr(why, "anisotropic"));
    /* anisotropic at one azimuth: nothing can fit it; the reason says so */
    size_t n = fit_auto_candidates(0, &ev, names, why, sizeof why);
    assert_int_equal(n, 3);
    assert_false(has(names, n, "aniso-ggx"));
    assert_non_null(strstr(why, "sample_azimuths"));
    /* isotropic: never the anisotropic model, turned or not */
    ev.isotropy = FIT_AUTO_ISOTROPIC;
    n = fit_auto_candidates(1, &ev, names, why, sizeof why);
    assert_int_equal(n, 3);
    assert_false(has(names, n, "aniso-ggx"));
    assert_non_null(strstr(why, "isotropic"));
    /* the verdict texts of capture/isotropy_check.h */
    assert_int_equal(fit_auto_isotropy_of("anisotropic"), FIT_AUTO_ANISOTROPIC);
    assert_int_equal(fit_auto_isotropy_of("isotropic"), FIT_AUTO_ISOTROPIC);
    assert_int_equal(fit_auto_isotropy_of("undetermined"), FIT_AUTO_ISOTROPY_UNKNOWN);
}

static void test_insufficient_loses_to_sufficient(void **state)
{
    (void)state;
    const char *model[] = {"abc", "abc-prior", "latent"};
    const double cv[] = {0.010, 0.012, 0.030};
    const int failed[] = {0, 0, 0};
    char why[FIT_AUTO_WHY_MAX];
    struct fit_auto_evidence ev = {0};
    /* no verdict: the lowest CV error */
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, &ev, why, sizeof why), 0);
    assert_string_equal(why, "");
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, NULL, why, sizeof why), 0);
    /* judged sufficient: it stays, and the reason says so */
    fit_auto_evidence_oop(&ev, "abc", "sufficient");
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, &ev, why, sizeof why), 0);
    assert_non_null(strstr(why, "abc sufficient"));
    /* judged insufficient: the next by CV, not yet checked, goes before it */
    fit_auto_evidence_oop(&ev, "abc", "insufficient");
    assert_int_equal(fit_auto_evidence_oop_of(&ev, "abc"), FIT_AUTO_OOP_INSUFFICIENT);
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, &ev, why, sizeof why), 1);
    assert_non_null(strstr(why, "abc (cv 0.0100) insufficient"));
    assert_non_null(strstr(why, "not yet checked"));
    /* a worse CV error judged sufficient beats a better one judged insufficient */
    fit_auto_evidence_oop(&ev, "abc-prior", "insufficient");
    fit_auto_evidence_oop(&ev, "latent", "sufficient");
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, &ev, why, sizeof why), 2);
    assert_non_null(strstr(why, "latent (cv 0.0300) sufficient"));
    /* "undetermined" is no evidence: latent unchecked still goes before */
    fit_auto_evidence_oop(&ev, "latent", "undetermined");
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, &ev, why, sizeof why), 2);
    /* every one insufficient: the lowest CV error again, saying so */
    fit_auto_evidence_oop(&ev, "latent", "insufficient");
    assert_int_equal(fit_auto_rank(model, cv, failed, 3, &ev, why, sizeof why), 0);
    assert_non_null(strstr(why, "no candidate sufficient"));
    /* a failed candidate is never chosen, sufficient or not */
    const int latent_failed[] = {0, 0, 1};
    fit_auto_evidence_oop(&ev, "latent", "sufficient");
    assert_int_equal(fit_auto_rank(model, cv, latent_failed, 3, &ev, why, sizeof why), 0);
    const int all_failed[] = {1, 1, 1};
    assert_int_equal(fit_auto_rank(model, cv, all_failed, 3, &ev, why, sizeof why), 3);
}

/* In-plane pairs of an anisotropic GGX with the sample turned 0, 60 and
 * 120 degrees (a plan's sample_azimuths), 2 % apart from noise-free. */
static size_t turned_samples(struct fit_sample *s, size_t cap)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open("analytic:aniso-ggx?ax=0.1&ay=0.3&phi=30", &err);
    if (!m)
        fail_msg("%s", err.msg);
    size_t n = 0;
    int step = gonio_test_small() ? 8 : 4;
    for (int turn = 0; turn < 180; turn += 60)
        for (int ti = 10; ti <= 60; ti += 25)
            for (int tr = -70; tr <= 70; tr += step)
                if (abs(ti + tr) >= 5 && n < cap) {
                    brdf_pair_inplane(ti, tr, &s[n].g);
                    brdf_pair_rotate(&s[n].g, 360 - turn);
                    brdf_material_eval(m, &s[n].g, 1, s[n].rgb);
                    for (int ch = 0; ch < 3; ch++) {
                        s[n].rgb[ch] *= 1 + 0.02 * ((double)((n * 7 + ch) % 5) - 2) / 2;
                        s[n].u[ch] = NAN;
                    }
                    n++;
                }
    brdf_material_free(m);
    return n;
}

static void test_anisotropic_verdict_reaches_the_file(void **state)
{
    (void)state;
    struct fit_sample s[400];
    size_t n = turned_samples(s, 400);
    struct fit_auto_evidence ev = {.isotropy = FIT_AUTO_ANISOTROPIC};
    struct fit_data data = {.rgb = s, .n_rgb = n, .auto_evidence = &ev};
    struct fit_model_options opt = fit_model_default_options();
    struct gonio_err err = {0};
    struct fit_auto_cv cv;
    if (fit_auto_cross_validate(&data, &opt, &cv, &err) < 0)
        fail_msg("%s", err.msg);
    assert_int_equal(cv.n, 1);
    assert_string_equal(cv.model[cv.chosen], "aniso-ggx");
    assert_true(isfinite(cv.cv[0]));
    /* the registry row: the anisotropic model's file, with the reason */
    struct fit_model_file *f = NULL;
    struct fit_model_report rep = {0};
    if (fit_model_find("auto")->fit(&data, &opt, &f, &rep, &err) < 0)
        fail_msg("%s", err.msg);
    assert_string_equal(rep.auto_chosen, "aniso-ggx");
    assert_string_equal(fit_model_file_get(f, "auto_why"), cv.why);
    assert_string_equal(rep.auto_why, cv.why);
    assert_non_null(strstr(cv.why, "anisotropic"));
    fit_model_file_free(f);
}

/* fit_auto_settle's steps over fixed CV errors (abc best) and verdicts. */
struct fake {
    struct fit_auto_evidence ev;
    const char *verdict[3]; /* abc, abc-prior, latent */
    char chosen[16], why[FIT_AUTO_WHY_MAX];
    int fits, checks;
};
static const char *const fake_models[] = {"abc", "abc-prior", "latent"};

static int fake_fit(void *user, struct gonio_err *err)
{
    (void)err;
    struct fake *f = user;
    static const double cv[] = {0.01, 0.02, 0.03};
    static const int failed[3] = {0};
    size_t best = fit_auto_rank(fake_models, cv, failed, 3, &f->ev, f->why, sizeof f->why);
    snprintf(f->chosen, sizeof f->chosen, "%s", fake_models[best]);
    f->fits++;
    return 0;
}

static int fake_check(void *user, const char *model, char *verdict, size_t len,
                      struct gonio_err *err)
{
    (void)err;
    struct fake *f = user;
    f->checks++;
    for (size_t c = 0; c < 3; c++)
        if (!strcmp(model, fake_models[c]))
            snprintf(verdict, len, "%s", f->verdict[c] ? f->verdict[c] : "");
    return 0;
}

static void settle(struct fake *f)
{
    fake_fit(f, NULL);
    f->fits = 0;
    const struct fit_auto_steps steps = {fake_fit, fake_check, f};
    struct gonio_err err = {0};
    assert_int_equal(fit_auto_settle(&f->ev, f->chosen, f->why, sizeof f->why, &steps, &err),
                     0);
}

static void test_settle_checks_each_choice_once(void **state)
{
    (void)state;
    struct fake f = {.verdict = {"insufficient", "sufficient", "sufficient"}};
    settle(&f);
    assert_string_equal(f.chosen, "abc-prior");
    assert_int_equal(f.fits, 1);
    assert_int_equal(f.checks, 2);
    assert_string_equal(f.why, "out-of-plane check: abc (cv 0.0100) insufficient, abc-prior "
                               "(cv 0.0200) not yet checked; out-of-plane check: abc-prior "
                               "sufficient");
    /* every candidate insufficient: each checked once, the lowest CV stays */
    struct fake all = {.verdict = {"insufficient", "insufficient", "insufficient"}};
    settle(&all);
    assert_string_equal(all.chosen, "abc");
    assert_int_equal(all.checks, 3);
    assert_int_equal(all.fits, 3);
    assert_non_null(strstr(all.why, "no candidate sufficient"));
    /* no verdict to be had: the choice and its reason stand */
    struct fake none = {0};
    settle(&none);
    assert_string_equal(none.chosen, "abc");
    assert_int_equal(none.fits, 0);
    assert_string_equal(none.why, "");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_isotropy_sets_the_candidates),
        cmocka_unit_test(test_insufficient_loses_to_sufficient),
        cmocka_unit_test(test_anisotropic_verdict_reaches_the_file),
        cmocka_unit_test(test_settle_checks_each_choice_once),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
