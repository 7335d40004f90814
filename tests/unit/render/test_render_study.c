/* A study's results become grids: per material the truth, then one cell per
 * finished row of the chosen capture scene in row order, labelled
 * PLAN/MODEL; failed fits and in-plane-only models are left out; a
 * model_file leaving the study and a malformed file are refused. */
#include <string.h>
#include <unistd.h>

#include "render/study.h"
#include "tests/gonio_test.h"

static char tmpdir[4096];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_render_study.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static void write_results(const char *rows)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/results.json", tmpdir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "{\"format\": \"gonio-study-1\", \"study\": {\"scenes\": [{\"name\": \"ideal\", \"spec\": \"ideal\"}, "
               "{\"name\": \"lab\", \"spec\": \"lab\"}]},"
               " \"rows\": [%s]}", rows);
    fclose(f);
}

#define ROW(mat, scene, plan, model, status, skipped, file)                                   \
    "{\"material\": \"" mat "\", \"material_spec\": \"nbrdf:" mat "\", \"scene\": \"" scene \
    "\", \"plan\": \"" plan "\", \"model\": \"" model "\", \"status\": \"" status            \
    "\", \"full_skipped\": " skipped ", \"model_file\": " file "}"

static void test_rows_to_grids(void **state)
{
    (void)state;
    write_results(ROW("nylon", "ideal", "ds1", "abc", "ok", "0", "\"jobs/nylon.ideal.ds1/abc.model\"") ","
                  ROW("nylon", "ideal", "ds1", "mlp", "ok", "889726", "\"jobs/nylon.ideal.ds1/mlp.model\"") ","
                  ROW("nylon", "lab", "ds1", "abc", "ok", "0", "\"jobs/nylon.lab.ds1/abc.model\"") ","
                  ROW("brass", "ideal", "ds1", "abc", "fit-failed", "null", "null") ","
                  ROW("brass", "ideal", "ds4", "latent", "ok", "null", "\"jobs/brass.ideal.ds4/latent.model\"") ","
                  ROW("nylon", "ideal", "ds4", "latent", "ok", "0", "\"jobs/nylon.ideal.ds4/latent.model\""));
    struct render_study_material *m;
    int n;
    struct gonio_err err = {0};
    int rc = render_study_read(tmpdir, NULL, &m, &n, &err); /* the first scene: ideal */
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(n, 2);
    assert_string_equal(m[0].name, "nylon");
    assert_string_equal(m[0].truth, "nbrdf:nylon");
    assert_int_equal(m[0].n, 2);
    assert_string_equal(m[0].cells[0].label, "ds1/abc");
    assert_string_equal(m[0].cells[1].label, "ds4/latent");
    char want[4400];
    snprintf(want, sizeof want, "model:%s/jobs/nylon.ideal.ds4/latent.model", tmpdir);
    assert_string_equal(m[0].cells[1].spec, want);
    assert_string_equal(m[1].name, "brass");
    assert_int_equal(m[1].n, 1);
    assert_string_equal(m[1].cells[0].label, "ds4/latent");
    render_study_free(m, n);

    assert_int_equal(render_study_read(tmpdir, "lab", &m, &n, &err), 0);
    assert_int_equal(n, 1);
    assert_int_equal(m[0].n, 1);
    snprintf(want, sizeof want, "model:%s/jobs/nylon.lab.ds1/abc.model", tmpdir);
    assert_string_equal(m[0].cells[0].spec, want);
    render_study_free(m, n);

    assert_int_equal(render_study_read(tmpdir, "bad-day", &m, &n, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "bad-day"));
}

static void test_bad_results(void **state)
{
    (void)state;
    struct render_study_material *m;
    int n;
    struct gonio_err err = {0};
    write_results(ROW("nylon", "ideal", "ds1", "abc", "ok", "0", "\"../../etc/abc.model\""));
    assert_int_equal(render_study_read(tmpdir, NULL, &m, &n, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "row 1: field 'model_file': '../../etc/abc.model'"));

    write_results(ROW("../x", "ideal", "ds1", "abc", "ok", "0", "\"jobs/a.model\""));
    assert_int_equal(render_study_read(tmpdir, NULL, &m, &n, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "field 'material': '../x'"));

    write_results("{\"material\": \"nylon\"}");
    assert_int_equal(render_study_read(tmpdir, NULL, &m, &n, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "row 1: field 'material_spec'"));

    char path[4200];
    snprintf(path, sizeof path, "%s/results.json", tmpdir);
    FILE *f = fopen(path, "w");
    fputs("{\"rows\": [", f);
    fclose(f);
    assert_int_equal(render_study_read(tmpdir, NULL, &m, &n, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, path));

    unlink(path);
    assert_int_equal(render_study_read(tmpdir, NULL, &m, &n, &err), -GONIO_ENOTFOUND);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rows_to_grids),
        cmocka_unit_test(test_bad_results),
    };
    return cmocka_run_group_tests(tests, setup_tmp, NULL);
}
