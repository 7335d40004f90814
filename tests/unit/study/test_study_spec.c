/* The study's lists, job list and shards (study/study.h): bad entries are
 * refused naming the option and value, shards are disjoint and cover the
 * job list, and job ids follow the documented order; study.json keeps how
 * saturated readings are fitted, and results.csv's lists have no commas. */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <jansson.h>

#include "common/err.h"
#include "tests/gonio_test.h"
#include "study/study.h"
#include "study/study_private.h"

static struct study_spec *spec_new(void)
{
    struct study_spec *s = calloc(1, sizeof *s);
    struct gonio_err err = {0};
    assert_non_null(s);
    s->shard_i = s->shard_n = 1;
    assert_int_equal(study_spec_set(s, STUDY_MATERIALS, "default", &err), 0);
    assert_int_equal(study_spec_set(s, STUDY_SCENES, "ideal,lab", &err), 0);
    assert_int_equal(study_spec_set(s, STUDY_PLANS, "ds1,ds4,oop200k", &err), 0);
    assert_int_equal(study_spec_set(s, STUDY_MODELS, "abc,latent", &err), 0);
    return s;
}

static void refused(struct study_spec *s, enum study_list which, const char *list,
                    const char *needle)
{
    struct gonio_err err = {0};
    int rc = study_spec_set(s, which, list, &err);
    assert_int_equal(rc, -GONIO_EUSAGE);
    if (!strstr(err.msg, needle))
        fail_msg("message '%s' does not name '%s'", err.msg, needle);
}

static void test_bad_entries_are_refused(void **state)
{
    (void)state;
    struct study_spec *s = spec_new();
    refused(s, STUDY_PLANS, "ds1,ds9", "ds9");
    refused(s, STUDY_PLANS, "ds1,,ds2", "empty");
    refused(s, STUDY_PLANS, "ds1,ds1", "twice");
    refused(s, STUDY_MODELS, "abc,gpt", "gpt");
    refused(s, STUDY_MODELS, "mlp-spectral", "mlp-spectral"); /* registered, not RGB-studyable */
    refused(s, STUDY_MATERIALS, "builtin:no-such-material", "no-such-material");
    refused(s, STUDY_SCENES, "no-such-scene", "no-such-scene");
    refused(s, STUDY_SCENES, "", "empty");
    /* a refused list leaves the spec as it was */
    assert_int_equal(s->n_plans, 3);
    assert_string_equal(s->plans[2].name, "oop200k");
    free(s);
}

static void test_shard_parsing(void **state)
{
    (void)state;
    struct study_spec *s = spec_new();
    struct gonio_err err = {0};
    assert_int_equal(study_spec_set_shard(s, "2/4", &err), 0);
    assert_int_equal(s->shard_i, 2);
    assert_int_equal(s->shard_n, 4);
    const char *bad[] = {"0/4", "5/4", "1/0", "2", "a/b", "-1/3", "1/4x", "/4", "1/", "+1/2",
                         "1/100001"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(study_spec_set_shard(s, bad[i], &err), -GONIO_EUSAGE);
        assert_non_null(strstr(err.msg, bad[i]));
    }
    free(s);
}

static void test_shards_partition_the_jobs(void **state)
{
    (void)state;
    struct study_spec *s = spec_new();
    size_t n = study_job_count(s);
    assert_int_equal(n, 6);
    for (int shards = 1; shards <= 7; shards++) {
        int seen[6] = {0};
        for (int i = 1; i <= shards; i++) {
            s->shard_i = i;
            s->shard_n = shards;
            for (size_t k = 0; k < n; k++)
                seen[k] += study_job_in_shard(s, k);
        }
        for (size_t k = 0; k < n; k++)
            assert_int_equal(seen[k], 1);
    }
    free(s);
}

static void test_job_ids_in_documented_order(void **state)
{
    (void)state;
    struct study_spec *s = spec_new();
    const char *want[] = {"default.ideal.ds1", "default.ideal.ds4", "default.ideal.oop200k",
                          "default.lab.ds1",   "default.lab.ds4",   "default.lab.oop200k"};
    for (size_t k = 0; k < 6; k++) {
        struct study_job job;
        study_job_at(s, k, &job);
        assert_string_equal(job.id, want[k]);
        assert_int_equal(job.index, k);
    }
    /* big jobs weigh more, so they are started first */
    struct study_job a, b;
    study_job_at(s, 2, &a);
    study_job_at(s, 1, &b);
    assert_true(study_job_weight(s, &a) > study_job_weight(s, &b));
    free(s);
}

/* A study is resumed only with the same treatment of saturated readings
 * (each model's default unless one is forced); a study.json from before the
 * key is a clipped study, one with another value is refused by name. */
static void test_saturated_in_study_json(void **state)
{
    (void)state;
    char dir[] = "/tmp/gonio-studyjsonXXXXXX", path[200];
    assert_non_null(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/study.json", dir);
    struct study_spec *s = spec_new();
    struct gonio_err err = {0};
    assert_int_equal(s->saturated, FIT_SATURATED_DEFAULT);
    assert_int_equal(study_dir_prepare(s, dir, &err), 0);
    json_t *j = json_load_file(path, 0, NULL);
    assert_non_null(j);
    assert_string_equal(json_string_value(json_object_get(j, "saturated")), "default");
    s->saturated = FIT_SATURATED_CENSORED;
    assert_true(study_dir_prepare(s, dir, &err) < 0);
    struct study_spec *back = spec_new();
    assert_int_equal(study_spec_read(dir, back, &err), 0);
    assert_int_equal(back->saturated, FIT_SATURATED_DEFAULT);
    s->saturated = FIT_SATURATED_CLIPPED;
    /* the same file without the key */
    json_object_del(j, "saturated");
    assert_int_equal(json_dump_file(j, path, 0), 0);
    assert_int_equal(study_dir_prepare(s, dir, &err), 0);
    assert_int_equal(study_spec_read(dir, back, &err), 0);
    assert_int_equal(back->saturated, FIT_SATURATED_CLIPPED);
    s->saturated = FIT_SATURATED_DEFAULT;
    assert_true(study_dir_prepare(s, dir, &err) < 0);
    json_object_set_new(j, "saturated", json_string("sometimes"));
    assert_int_equal(json_dump_file(j, path, 0), 0);
    assert_true(study_spec_read(dir, back, &err) < 0);
    printf("%s\n", err.msg);
    assert_non_null(strstr(err.msg, "key 'saturated': 'sometimes'"));
    json_decref(j);
    free(back);
    unlink(path);
    rmdir(dir);
    free(s);
}

/* A row with two findings and two parameters at a bound: results.csv has
 * as many fields in that row as in its header. */
static void test_csv_lists_without_commas(void **state)
{
    (void)state;
    char dir[] = "/tmp/gonio-studycsvXXXXXX", path[4200], cmd[200];
    assert_non_null(mkdtemp(dir));
    struct study_spec *s = spec_new();
    struct gonio_err err = {0};
    assert_int_equal(study_dir_prepare(s, dir, &err), 0);
    struct study_job job;
    study_job_at(s, 0, &job);
    snprintf(cmd, sizeof cmd, "mkdir -p %s/jobs/%.100s", dir, job.id);
    assert_int_equal(system(cmd), 0);
    study_row_path(dir, job.id, s->models[0].name, path, sizeof path);
    json_t *row = json_pack("{s:s, s:s, s:s}", "row_id", "x", "fit_findings",
                            "underdetermined,at-bound", "fit_at_bound", "A_r,B");
    assert_int_equal(json_dump_file(row, path, 0), 0);
    json_decref(row);
    assert_int_equal(study_results_write(s, dir, NULL, &err), 0);
    snprintf(path, sizeof path, "%s/results.csv", dir);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[8192];
    int fields[2] = {1, 1};
    for (int k = 0; k < 2; k++) {
        assert_non_null(fgets(line, sizeof line, f));
        for (char *c = line; *c; c++)
            fields[k] += *c == ',';
    }
    fclose(f);
    assert_int_equal(fields[1], fields[0]);
    assert_non_null(strstr(line, "underdetermined;at-bound"));
    assert_non_null(strstr(line, "A_r;B"));
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_entries_are_refused),
        cmocka_unit_test(test_shard_parsing),
        cmocka_unit_test(test_shards_partition_the_jobs),
        cmocka_unit_test(test_job_ids_in_documented_order),
        cmocka_unit_test(test_saturated_in_study_json),
        cmocka_unit_test(test_csv_lists_without_commas),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
