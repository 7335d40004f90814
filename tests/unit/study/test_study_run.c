/* gonio study end to end on a tiny study: every row of results.csv is
 * checked against an independent evaluation - the journal read back with
 * journal_read, the model file opened with fit_material_open, the errors
 * recomputed with brdf/metrics.h - and a rerun after losing a row redoes
 * that row only. Runs $GONIO_BIN/gonio; the embedded default material, so
 * no shared data is needed. */
#include <dirent.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "journal/journal.h"
#include "fit/model_file.h"
#include "tests/gonio_test.h"

#define MAX_ROWS 16
#define MAX_COLS 48

static char dir[1024];

struct csv {
    char *text;
    char *head[MAX_COLS];
    size_t n_cols;
    char *cell[MAX_ROWS][MAX_COLS];
    size_t n_rows;
};

static int run_gonio(const char *const *args)
{
    const char *bin = getenv("GONIO_BIN");
    char path[1024];
    snprintf(path, sizeof path, "%s/gonio", bin ? bin : ".");
    const char *argv[32] = {path};
    int n = 1;
    for (; *args && n < 31; args++)
        argv[n++] = *args;
    argv[n] = NULL;
    pid_t pid = gonio_test_fork();
    if (pid == 0) {
        execv(path, (char *const *)argv);
        _exit(127);
    }
    int status;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)n + 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    if (b)
        b[n] = '\0';
    fclose(f);
    return b;
}

/* Split results.csv (no quoting in this format: docs/study.md). */
static void csv_read(const char *path, struct csv *c)
{
    memset(c, 0, sizeof *c);
    c->text = slurp(path);
    assert_non_null(c->text);
    char *line = c->text, *next;
    for (int row = -1; line && *line; row++, line = next) {
        next = strchr(line, '\n');
        if (next)
            *next++ = '\0';
        assert_true(row < MAX_ROWS);
        size_t k = 0;
        for (char *f = line;; k++) {
            assert_true(k < MAX_COLS);
            char *comma = strchr(f, ',');
            if (comma)
                *comma = '\0';
            if (row < 0)
                c->head[k] = f;
            else
                c->cell[row][k] = f;
            if (!comma)
                break;
            f = comma + 1;
        }
        if (row < 0)
            c->n_cols = k + 1;
        else
            assert_int_equal(k + 1, c->n_cols);
        c->n_rows = (size_t)(row + 1);
    }
}

static const char *get(const struct csv *c, size_t row, const char *col)
{
    for (size_t k = 0; k < c->n_cols; k++)
        if (!strcmp(c->head[k], col))
            return c->cell[row][k];
    fail_msg("results.csv has no column '%s'", col);
    return NULL;
}

static double getd(const struct csv *c, size_t row, const char *col)
{
    return atof(get(c, row, col));
}

static const char *const study_args[] = {
    "study",    "--materials", "default", "--plans", "ds4,ds3", "--models", "abc,mlp",
    "--scenes", "ideal,lab",   "--jobs",  "2",       "--out",   dir,        NULL,
};

static int setup(void **state)
{
    (void)state;
    const char *tmp = getenv("GONIO_TMP");
    snprintf(dir, sizeof dir, "%s/study_run_%d", tmp ? tmp : "/tmp", (int)getpid());
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        return -1;
    return run_gonio(study_args) == 0 ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* Relative agreement at the 6 significant digits results.csv prints. */
static void assert_csv_value(double csv, double mine)
{
    assert_close(csv, mine, 1e-5 * fabs(mine) + 1e-300);
}

static void test_rows_match_independent_evaluation(void **state)
{
    (void)state;
    char path[1200];
    snprintf(path, sizeof path, "%s/results.csv", dir);
    struct csv c;
    csv_read(path, &c);
    assert_int_equal(c.n_rows, 8); /* 1 material x 2 scenes x 2 plans x 2 models */
    struct brdf_domain inplane, full;
    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_inplane(&inplane, &err), 0);
    assert_true(brdf_domain_full(&full, &err) >= 0);
    for (size_t r = 0; r < c.n_rows; r++) {
        assert_string_equal(get(&c, r, "status"), "ok");
        /* The samples: count and rig time straight from the journal. */
        snprintf(path, sizeof path, "%s/%s", dir, get(&c, r, "samples_file"));
        struct journal_sample *js = NULL;
        size_t n = 0;
        assert_int_equal(journal_read(path, &js, &n, &err), 0);
        /* A detector of counts journals its dark frames beside the
         * samples: no sample of the plan, nor of its integration. */
        double integ = 0, last = js[n - 1].rig_time_s;
        size_t m = 0, valued = 0;
        for (size_t i = 0; i < n; i++) {
            if (!(js[i].flags & JOURNAL_FLAG_DARK))
                m++, integ += js[i].integration_s;
            if (journal_sample_has_brdf(&js[i]))
                js[valued++] = js[i];
        }
        assert_int_equal((size_t)atol(get(&c, r, "samples")), m);
        n = valued;
        assert_int_equal(atol(get(&c, r, "plan_points")), !strcmp(get(&c, r, "plan"), "ds4") ? 6 : 52);
        assert_csv_value(getd(&c, r, "rig_time_s"), last);
        assert_csv_value(getd(&c, r, "integration_s"), integ);
        /* lab's detector gives counts: the job calibrated it first (a dark
         * and the standard at the plan's points), and says what it cost */
        if (!strcmp(get(&c, r, "scene"), "lab")) {
            char cal[1400];
            snprintf(cal, sizeof cal, "%s/jobs/%s.lab.%s/calibrations", dir,
                     get(&c, r, "material"), get(&c, r, "plan"));
            struct stat st;
            assert_int_equal(stat(cal, &st), 0);
            assert_true(getd(&c, r, "calibration_s") > 0);
            assert_true(n > 0 && isfinite(js[0].u[1]) && js[0].counts);
        } else {
            assert_string_equal(get(&c, r, "calibration_s"), "");
        }
        assert_close(getd(&c, r, "move_s") + getd(&c, r, "settle_s") + getd(&c, r, "integration_s"),
                     getd(&c, r, "rig_time_s"), 1e-3 * getd(&c, r, "rig_time_s"));

        /* The model as written, against the measured samples. */
        snprintf(path, sizeof path, "model:%s/%s", dir, get(&c, r, "model_file"));
        brdf_material *model = fit_material_open(path, &err);
        assert_non_null(model);
        struct brdf_pair *pairs = malloc(n * sizeof *pairs);
        double *meas = malloc(3 * n * sizeof *meas), *pred = malloc(3 * n * sizeof *pred);
        for (size_t i = 0; i < n; i++) {
            journal_sample_pair(&js[i], &pairs[i]);
            memcpy(meas + 3 * i, js[i].rgb, sizeof js[i].rgb);
        }
        brdf_material_eval(model, pairs, n, pred);
        struct brdf_errors e;
        brdf_errors_compute(pairs, meas, pred, n, &e);
        assert_csv_value(getd(&c, r, "plan_log"), e.log);
        assert_csv_value(getd(&c, r, "plan_rel_rmse"), e.rel_rmse);
        assert_int_equal((size_t)atol(get(&c, r, "plan_n")), e.n_used);

        /* The model against the true material on the reference domains. */
        brdf_material *truth = brdf_material_open(get(&c, r, "material_spec"), &err);
        assert_non_null(truth);
        assert_int_equal(brdf_errors_material(truth, model, &inplane, &e, &err), 0);
        assert_csv_value(getd(&c, r, "inplane_log"), e.log);
        assert_csv_value(getd(&c, r, "inplane_rel_rmse"), e.rel_rmse);
        assert_int_equal((size_t)atol(get(&c, r, "inplane_n")), e.n_used);
        /* The full domain (923,870 nodes) for the ds4 rows only: the costly
         * check, and the one-model-file path it tests is the same. */
        if (strcmp(get(&c, r, "plan"), "ds4") != 0) {
            brdf_material_free(truth);
            brdf_material_free(model);
            free(pairs);
            free(meas);
            free(pred);
            free(js);
            continue;
        }
        assert_int_equal(brdf_errors_material(truth, model, &full, &e, &err), 0);
        assert_int_equal((size_t)atol(get(&c, r, "full_n")), e.n_used);
        assert_int_equal((size_t)atol(get(&c, r, "full_skipped")), e.n_skipped);
        if (!strcmp(get(&c, r, "model"), "mlp")) {
            /* in-plane only: no full-domain error is claimed for it */
            assert_true(e.n_skipped > 0);
            assert_string_equal(get(&c, r, "full_log"), "");
        } else {
            assert_int_equal(e.n_skipped, 0);
            assert_csv_value(getd(&c, r, "full_log"), e.log);
            assert_csv_value(getd(&c, r, "full_rel_rmse"), e.rel_rmse);
        }
        brdf_material_free(truth);
        brdf_material_free(model);
        free(pairs);
        free(meas);
        free(pred);
        free(js);
    }
    /* The noise of the lab scene reaches the samples: its rows differ. */
    assert_true(strcmp(get(&c, 0, "plan_log"), get(&c, 4, "plan_log")) != 0);
    brdf_domain_free(&inplane);
    brdf_domain_free(&full);
    free(c.text);
}

/* Losing a row file and rerunning redoes that row and nothing else. */
static void test_resume_redoes_only_missing_rows(void **state)
{
    (void)state;
    char lost[1200], kept[1200];
    snprintf(lost, sizeof lost, "%s/jobs/default.lab.ds3/mlp.row.json", dir);
    snprintf(kept, sizeof kept, "%s/jobs/default.lab.ds3/abc.row.json", dir);
    char *lost_before = slurp(lost), *kept_before = slurp(kept);
    assert_non_null(lost_before);
    assert_non_null(kept_before);
    /* Fit times differ between two fits of the same row: a redone row is
     * told apart from a kept one by its bytes. */
    assert_int_equal(unlink(lost), 0);
    assert_int_equal(run_gonio(study_args), 0);
    char *lost_after = slurp(lost), *kept_after = slurp(kept);
    assert_non_null(lost_after);
    assert_string_equal(kept_after, kept_before);
    /* The redone row has the same results, time columns aside. */
    char *t1 = strstr(lost_before, "\"fit_wall_s\""), *t2 = strstr(lost_after, "\"fit_wall_s\"");
    char *e1 = strstr(lost_before, "\"fit_converged\""), *e2 = strstr(lost_after, "\"fit_converged\"");
    assert_non_null(t1);
    assert_non_null(e1);
    assert_non_null(t2);
    assert_non_null(e2);
    assert_memory_equal(lost_before, lost_after, (size_t)(t1 - lost_before));
    assert_string_equal(e1, e2);
    snprintf(lost, sizeof lost, "%s/results.csv", dir);
    struct csv c;
    csv_read(lost, &c);
    assert_int_equal(c.n_rows, 8);
    free(c.text);
    free(lost_before);
    free(kept_before);
    free(lost_after);
    free(kept_after);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rows_match_independent_evaluation),
        cmocka_unit_test(test_resume_redoes_only_missing_rows),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
