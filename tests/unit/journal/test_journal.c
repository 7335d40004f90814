/* The sample journal: exact round trip, torn tails cut off, corruption and
 * foreign files refused. */
#include <fcntl.h>
#include <sys/stat.h>
#include <string.h>
#include <unistd.h>

#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "fit/fit.h"
#include "tests/gonio_test.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "journal");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static struct journal_sample make(int i)
{
    struct journal_sample s = {0};
    s.point = i;
    s.theta_i = 5.0 * i / 3.0; /* values with no short decimal form */
    s.theta_r = -80 + 0.1 * i;
    s.theta_o = fabs(s.theta_r);
    s.phi_o = s.theta_r >= 0 ? 180 : 0;
    s.s = s.theta_i;
    s.a = s.theta_i + s.theta_r;
    s.rgb[0] = 1.0 / (i + 3);
    s.rgb[1] = 1e4 * exp(-i);
    s.rgb[2] = 1e-300 * i;
    s.integration_s = 0.05;
    s.rig_time_s = 1.1 * i;
    s.flags = (unsigned)i & 1u;
    return s;
}

static void append_n(const char *path, int from, int to)
{
    struct journal_sample *old = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &old, &n, &err);
    assert_non_null(j);
    assert_int_equal(n, (size_t)from);
    for (int i = from; i < to; i++) {
        struct journal_sample s = make(i);
        assert_int_equal(journal_append(j, &s, &err), 0);
    }
    journal_close(j);
    free(old);
}

static void test_round_trip_is_exact(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/exact.csv", dir);
    append_n(path, 0, 50);
    append_n(path, 50, 60); /* reopened for appending: continues */
    struct journal_sample *s;
    size_t n;
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    assert_int_equal(n, 60);
    for (int i = 0; i < 60; i++) {
        struct journal_sample want = make(i);
        assert_int_equal(s[i].point, i);
        assert_memory_equal(s[i].rgb, want.rgb, sizeof want.rgb);
        assert_true(s[i].theta_i == want.theta_i && s[i].rig_time_s == want.rig_time_s);
        assert_int_equal(s[i].flags, want.flags);
    }
    free(s);
}

/* A lazy journal (gonio study) writes the same records, and a reopened one
 * continues it like a synced one. */
static void test_lazy_journal_reads_back(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/lazy.csv", dir);
    struct journal_sample *old = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &old, &n, &err);
    assert_non_null(j);
    journal_set_lazy(j);
    for (int i = 0; i < 20; i++) {
        struct journal_sample x = make(i);
        assert_int_equal(journal_append(j, &x, &err), 0);
    }
    journal_close(j);
    free(old);
    append_n(path, 20, 25);
    struct journal_sample *s;
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    assert_int_equal(n, 25);
    for (int i = 0; i < 25; i++) {
        struct journal_sample want = make(i);
        assert_int_equal(s[i].point, i);
        assert_memory_equal(s[i].rgb, want.rgb, sizeof want.rgb);
    }
    free(s);
}

static void test_torn_tail_is_cut(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/torn.csv", dir);
    append_n(path, 0, 10);
    /* A crash in the middle of the 11th write: half a record, no newline. */
    int fd = open(path, O_WRONLY | O_APPEND);
    assert_true(fd >= 0);
    const char *half = "10,16.666666666666668,-79,0,79,0,16.6";
    assert_int_equal(write(fd, half, strlen(half)), (ssize_t)strlen(half));
    close(fd);
    struct journal_sample *s;
    size_t n;
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    assert_int_equal(n, 10);
    free(s);
    append_n(path, 10, 12); /* open cuts the torn record, appends follow */
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    assert_int_equal(n, 12);
    assert_int_equal(s[10].point, 10);
    free(s);
}

/* A complete last line is no tear (a crash leaves a record without its
 * newline): one that does not continue the chain is refused, not cut. */
static void test_complete_line_with_bad_crc_at_end_is_refused(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/badlast.csv", dir);
    append_n(path, 0, 3);
    FILE *f = fopen(path, "a");
    fputs("3,1,2,0,2,180,1,3,0.1,0.1,0.1,0.05,4,0,brdf,,,,,,,,,,deadbeef\n", f);
    fclose(f);
    struct journal_sample *s = NULL;
    size_t n;
    struct gonio_err err = {0};
    assert_true(journal_read(path, &s, &n, &err) < 0);
    char where[400];
    snprintf(where, sizeof where, "%s:5: checksum does not continue the chain", path);
    assert_non_null(strstr(err.msg, where));
}

static void test_corrupt_middle_is_refused(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/corrupt.csv", dir);
    append_n(path, 0, 5);
    /* Flip one digit inside the second record. */
    FILE *f = fopen(path, "r+");
    char buf[4096];
    size_t len = fread(buf, 1, sizeof buf, f);
    char *second = memchr(memchr(buf, '\n', len) + 1, '\n', len) + 1;
    second[3] = second[3] == '1' ? '2' : '1';
    fseek(f, 0, SEEK_SET);
    fwrite(buf, 1, len, f);
    fclose(f);
    struct journal_sample *s = NULL;
    size_t n;
    struct gonio_err err = {0};
    assert_true(journal_read(path, &s, &n, &err) < 0);
    assert_int_equal(err.code, GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, path));
    char where[400]; /* the second record's line, after the header and the first */
    snprintf(where, sizeof where, "%s:3: ", path);
    assert_non_null(strstr(err.msg, where));
    /* and opening it for a resume refuses too, keeping the file as it is */
    assert_null(journal_open(path, &s, &n, &err));
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal((size_t)st.st_size, len);
}

static void test_foreign_file_is_refused(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/foreign.csv", dir);
    FILE *f = fopen(path, "w");
    fputs("name,value\nx,1\n", f);
    fclose(f);
    struct journal_sample *s = NULL;
    size_t n;
    struct gonio_err err = {0};
    assert_null(journal_open(path, &s, &n, &err));
    assert_non_null(strstr(err.msg, "not a gonio sample journal"));
}

static void test_sample_pair(void **state)
{
    (void)state;
    struct journal_sample s = make(3);
    struct brdf_pair got, want;
    journal_sample_pair(&s, &got);
    brdf_pair_inplane(s.theta_i, s.theta_r, &want);
    assert_memory_equal(&got, &want, sizeof got);
    s.phi_o = 100;
    journal_sample_pair(&s, &got);
    brdf_pair_spherical(s.theta_i, 0, s.theta_o, 100, &want);
    assert_memory_equal(&got, &want, sizeof got);
}

/* A fit sees every sample, in journal order; the saturated ones are counted. */
static void test_fit_samples_count_saturated(void **state)
{
    (void)state;
    struct journal_sample js[7];
    for (int i = 0; i < 7; i++)
        js[i] = make(i); /* odd points are flagged saturated */
    struct fit_sample fs[7] = {0};
    assert_int_equal(fit_journal_samples(js, 7, fs), 3);
    for (int k = 0; k < 7; k++) {
        struct brdf_pair want;
        journal_sample_pair(&js[k], &want);
        assert_memory_equal(&fs[k].g, &want, sizeof want);
        assert_memory_equal(fs[k].rgb, js[k].rgb, sizeof fs[k].rgb);
    }
    assert_int_equal(fit_journal_samples(js, 1, fs), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_is_exact),
        cmocka_unit_test(test_lazy_journal_reads_back),
        cmocka_unit_test(test_torn_tail_is_cut),
        cmocka_unit_test(test_complete_line_with_bad_crc_at_end_is_refused),
        cmocka_unit_test(test_corrupt_middle_is_refused),
        cmocka_unit_test(test_foreign_file_is_refused),
        cmocka_unit_test(test_sample_pair),
        cmocka_unit_test(test_fit_samples_count_saturated),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
