/* The study figures from rows built in memory: what is drawn follows from
 * the values (the Pareto front's filled markers, the bars' axis). */
#include <string.h>

#include "report/results.h"
#include "report/study_plots.h"
#include "tests/gonio_test.h"

static size_t count(const char *hay, const char *needle)
{
    size_t n = 0;
    for (const char *p = hay; (p = strstr(p, needle)); p += strlen(needle))
        n++;
    return n;
}

static void add_row(struct report_results *r, const char *plan, const char *model,
                    double rig_s, double err)
{
    struct report_row *w = &r->rows[r->n_rows++];
    memset(w, 0, sizeof *w);
    snprintf(w->material, sizeof w->material, "m");
    snprintf(w->scene, sizeof w->scene, "ideal");
    snprintf(w->plan, sizeof w->plan, "%s", plan);
    snprintf(w->model, sizeof w->model, "%s", model);
    snprintf(w->row_id, sizeof w->row_id, "m.ideal.%s.%s", plan, model);
    w->rig_time_s = rig_s;
    for (int d = 0; d < REPORT_N_DOMAINS; d++)
        for (int k = 0; k < REPORT_N_METRICS; k++)
            w->err[d][k] = err;
}

static void setup_lists(struct report_results *r)
{
    snprintf(r->materials.name[0], REPORT_NAME_MAX, "m");
    r->materials.n = 1;
    snprintf(r->scenes.name[0], REPORT_NAME_MAX, "ideal");
    r->scenes.n = 1;
    snprintf(r->plans.name[0], REPORT_NAME_MAX, "ds1");
    snprintf(r->plans.name[1], REPORT_NAME_MAX, "ds4");
    r->plans.n = 2;
    snprintf(r->models.name[0], REPORT_NAME_MAX, "abc");
    snprintf(r->models.name[1], REPORT_NAME_MAX, "latent");
    r->models.n = 2;
}

static void pareto_marks_the_front(void **state)
{
    (void)state;
    static struct report_results r;
    struct report_row rows[4];
    r.rows = rows;
    setup_lists(&r);
    add_row(&r, "ds1", "abc", 900, 0.02);    /* front */
    add_row(&r, "ds1", "latent", 900, 0.03); /* beaten by ds1/abc */
    add_row(&r, "ds4", "abc", 12, 0.09);     /* beaten by ds4/latent */
    add_row(&r, "ds4", "latent", 12, 0.05);  /* front */
    struct report_plot_opts o = {NULL, REPORT_FULL, REPORT_LOG, NULL};
    char *svg = NULL;
    size_t len = 0;
    assert_int_equal(report_plot_pareto(&r, &o, "p", &svg, &len, NULL), 0);
    assert_int_equal(count(svg, "(on the Pareto front)"), 2);
    assert_non_null(strstr(svg, "m.ideal.ds1.abc: 0 samples, rig time 900 s, log error 0.02 "
                                "(on the Pareto front)"));
    assert_non_null(strstr(svg, "m.ideal.ds4.latent: 0 samples, rig time 12 s, log error "
                                "0.05 (on the Pareto front)"));
    free(svg);
    /* no row of the asked scene: an error naming it */
    o.scene = "lab";
    struct gonio_err err = {0};
    assert_int_equal(report_plot_pareto(&r, &o, "p", &svg, &len, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "'lab'"));
}

static void bars_go_log_when_errors_span_decades(void **state)
{
    (void)state;
    static struct report_results r;
    struct report_row rows[4];
    r.rows = rows;
    setup_lists(&r);
    add_row(&r, "ds1", "abc", 900, 0.1);
    add_row(&r, "ds4", "abc", 12, 0.9);
    add_row(&r, "ds1", "latent", 900, NAN); /* no value: a dash, no bar */
    struct report_plot_opts o = {NULL, REPORT_FULL, REPORT_RRMSE, NULL};
    char *svg = NULL;
    size_t len = 0;
    assert_int_equal(report_plot_bars(&r, &o, "b", &svg, &len, NULL), 0);
    assert_null(strstr(svg, "(log axis)"));
    assert_int_equal(count(svg, ">–</text>"), 1);
    free(svg);
    rows[1].err[REPORT_FULL][REPORT_RRMSE] = 12.5; /* a factor 125 */
    assert_int_equal(report_plot_bars(&r, &o, "b", &svg, &len, NULL), 0);
    assert_non_null(strstr(svg, ">m (log axis)</text>"));
    free(svg);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(pareto_marks_the_front),
        cmocka_unit_test(bars_go_log_when_errors_span_decades),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
