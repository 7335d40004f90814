/* A journal that cannot be forged by accident: every record's CRC continues
 * the one before it, so a record removed, moved, duplicated or edited (its
 * own CRC recomputed or not) is refused at its line, and the journal is
 * left as it was. Records whose chain CRC is recomputed too are refused
 * for impossible values. The earlier, unchained format still reads. */
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "journal/journal.h"
#include "tests/gonio_test.h"

#define N 6
#define COLUMNS "point,theta_i,theta_r,phi_i,theta_o,phi_o,s,a,r,g,b,integration_s,rig_time_s,flags,"
#define RAW_COLUMNS "unit,raw_r,raw_g,raw_b,integration_total_s,gain_state,monitor,u_r,u_g,u_b,"

static char dir[256];
static char lines[N + 1][512]; /* the intact journal, line by line (0: header) */

static struct journal_sample make(int i)
{
    struct journal_sample s = {0};
    s.point = 2 * i;
    s.theta_i = 10.0 + i / 3.0;
    s.theta_r = -40.0 + 7.0 * i;
    s.theta_o = fabs(s.theta_r);
    s.phi_o = s.theta_r >= 0 ? 180 : 0;
    s.s = s.theta_i;
    s.a = s.theta_i + s.theta_r;
    s.rgb[0] = 0.25 / (i + 1);
    s.rgb[1] = 0.125;
    s.rgb[2] = 1.0 / 3.0;
    s.integration_s = 0.05;
    s.rig_time_s = 1.5 * (i + 1);
    return s;
}

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static char buf[8192];
    *len = fread(buf, 1, sizeof buf - 1, f);
    buf[*len] = '\0';
    fclose(f);
    return buf;
}

static int setup(void **state)
{
    (void)state;
    if (gonio_test_dir_make(dir, sizeof dir, "chain") != 0)
        return -1;
    char path[300];
    snprintf(path, sizeof path, "%s/intact.csv", dir);
    struct journal_sample *old = NULL;
    size_t n = 0;
    journal *j = journal_open(path, &old, &n, NULL);
    if (!j)
        return -1;
    for (int i = 0; i < N; i++) {
        struct journal_sample s = make(i);
        if (journal_append(j, &s, NULL) != 0)
            return -1;
    }
    journal_close(j);
    free(old);
    size_t len;
    char *text = slurp(path, &len);
    for (int k = 0; k <= N; k++) {
        char *nl = strchr(text, '\n');
        if (!nl)
            return -1;
        snprintf(lines[k], sizeof lines[k], "%.*s", (int)(nl + 1 - text), text);
        text = nl + 1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* line with its CRC field replaced: over its own text alone (seed 0, the
 * earlier format's rule) or continuing the chain of the lines before it. */
static void recrc(char *line, size_t size, unsigned long seed)
{
    char *comma = strrchr(line, ',');
    size_t covered = (size_t)(comma + 1 - line);
    unsigned long crc = crc32(seed, (const Bytef *)line, (uInt)covered);
    snprintf(comma + 1, size - covered, "%08lx\n", crc);
}

/* The chain CRC after lines[0..k-1] of text (header included). */
static unsigned long chain_before(char text[][512], int k)
{
    unsigned long c = crc32(0L, (const Bytef *)text[0], (uInt)strlen(text[0]));
    for (int i = 1; i < k; i++)
        c = crc32(c, (const Bytef *)text[i], (uInt)(strrchr(text[i], ',') + 1 - text[i]));
    return c;
}

/* Write the lines, expect the reader and the writer's open to refuse them
 * naming line `line` and `what`, and the file to be left byte for byte. */
static void expect_refused(char text[][512], int count, int line, const char *what)
{
    char path[300], all[8192] = "";
    snprintf(path, sizeof path, "%s/edited.csv", dir);
    for (int k = 0; k < count; k++)
        strcat(all, text[k]);
    gonio_test_write_text(path, all);
    struct journal_sample *s = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    assert_true(journal_read(path, &s, &n, &err) < 0);
    assert_int_equal(err.code, GONIO_EBADDATA);
    char where[320];
    snprintf(where, sizeof where, "%s:%d: ", path, line);
    if (strncmp(err.msg, where, strlen(where)) || !strstr(err.msg, what))
        fail_msg("expected '%s...%s', got '%s'", where, what, err.msg);
    memset(&err, 0, sizeof err);
    assert_null(journal_open(path, &s, &n, &err));
    assert_non_null(strstr(err.msg, where));
    size_t len;
    assert_string_equal(slurp(path, &len), all);
}

static void copy_intact(char text[][512])
{
    memcpy(text, lines, sizeof lines);
}

/* A record of the current format as the earlier ones had it: without the
 * raw columns (the 10 fields after flags); its CRC left to recompute. */
static void drop_raw_columns(char *line)
{
    char *from = line;
    for (int c = 0; c < 14; c++)
        from = strchr(from, ',') + 1;
    char *to = from;
    for (int c = 0; c < 10; c++)
        to = strchr(to, ',') + 1;
    memmove(from, to, strlen(to) + 1);
}

static void test_header_marks_the_chained_format(void **state)
{
    (void)state;
    assert_string_equal(lines[0], COLUMNS RAW_COLUMNS "chain_crc32\n");
    /* The documented rule, computed here independently of the writer. */
    char text[N + 1][512];
    copy_intact(text);
    for (int k = 1; k <= N; k++) {
        recrc(text[k], sizeof text[k], chain_before(text, k));
        assert_string_equal(text[k], lines[k]);
    }
}

static void test_removed_record(void **state)
{
    (void)state;
    char text[N + 1][512];
    copy_intact(text);
    memmove(text[3], text[4], (size_t)(N - 3) * sizeof text[0]); /* line 4 (record 3) gone */
    expect_refused(text, N, 4, "chain");
}

static void test_swapped_records(void **state)
{
    (void)state;
    char text[N + 1][512], tmp[512];
    copy_intact(text);
    memcpy(tmp, text[2], sizeof tmp);
    memcpy(text[2], text[3], sizeof tmp);
    memcpy(text[3], tmp, sizeof tmp);
    expect_refused(text, N + 1, 3, "chain");
}

static void test_duplicated_record(void **state)
{
    (void)state;
    char text[N + 2][512];
    memcpy(text, lines, sizeof lines);
    memcpy(text[N + 1], text[N], sizeof text[0]); /* the last record twice */
    expect_refused(text, N + 2, N + 2, "chain");
}

/* An edited value with the record's own CRC recomputed (what the earlier
 * format accepted): r = 123456 in the middle, and in the last record, which
 * is complete and so not a tear to cut. */
static void test_edit_with_own_crc_recomputed(void **state)
{
    (void)state;
    for (int at = 2; at <= N; at += N - 2) {
        char text[N + 1][512];
        copy_intact(text);
        char *r = text[at];
        for (int c = 0; c < 8; c++)
            r = strchr(r, ',') + 1;
        char rest[512];
        snprintf(rest, sizeof rest, "%s", strchr(r, ','));
        snprintf(r, sizeof text[at] - (size_t)(r - text[at]), "123456%s", rest);
        recrc(text[at], sizeof text[at], 0);
        expect_refused(text, N + 1, at + 1, "chain");
    }
}

/* Impossible values even with the chain recomputed: not finite, negative,
 * a rig clock going back, unknown flags. */
static void test_impossible_values_with_chain_recomputed(void **state)
{
    (void)state;
    static const struct {
        int field;        /* 0-based column */
        const char *value, *what;
    } edits[] = {
        {8, "nan", "r nan is not a finite number"},
        {2, "inf", "theta_r inf is not a finite number"},
        {12, "-5", "rig_time_s -5 is negative"},
        {12, "1", "rig_time_s 1 is before the previous record's 3"},
        {11, "-0.05", "integration_s -0.05 is negative"},
        {0, "-1", "point -1 is negative"},
        {13, "6", "flags 6 has bits no sample carries"},
    };
    for (size_t e = 0; e < sizeof edits / sizeof *edits; e++) {
        char text[N + 1][512];
        copy_intact(text);
        int at = 3; /* record 2, after rig_time 1.5 and 3 */
        char *f = text[at];
        for (int c = 0; c < edits[e].field; c++)
            f = strchr(f, ',') + 1;
        char rest[512];
        snprintf(rest, sizeof rest, "%s", strchr(f, ','));
        snprintf(f, sizeof text[at] - (size_t)(f - text[at]), "%s%s", edits[e].value, rest);
        for (int k = at; k <= N; k++) /* a forger who knows the chain */
            recrc(text[k], sizeof text[k], chain_before(text, k));
        expect_refused(text, N + 1, at + 1, edits[e].what);
    }
}

/* A crash tears only the last record, which then has no newline: still cut. */
static void test_torn_tail_still_cut(void **state)
{
    (void)state;
    char path[300], all[8192] = "";
    snprintf(path, sizeof path, "%s/torn.csv", dir);
    for (int k = 0; k <= N; k++)
        strcat(all, lines[k]);
    all[strlen(all) - 20] = '\0';
    gonio_test_write_text(path, all);
    struct journal_sample *s = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &s, &n, &err);
    assert_non_null(j);
    assert_int_equal(n, N - 1);
    struct journal_sample again = make(N - 1);
    assert_int_equal(journal_append(j, &again, &err), 0);
    journal_close(j);
    free(s);
    size_t len;
    char want[8192] = "";
    for (int k = 0; k <= N; k++)
        strcat(want, lines[k]);
    assert_string_equal(slurp(path, &len), want);
}

/* The writer refuses what the reader would: nothing is written. */
static void test_writer_refuses_impossible_samples(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/writer.csv", dir);
    struct journal_sample *s = NULL;
    size_t n = 0, len;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &s, &n, &err);
    assert_non_null(j);
    struct journal_sample a = make(0), b = make(1), c = make(2);
    assert_int_equal(journal_append(j, &a, &err), 0);
    char before[8192];
    snprintf(before, sizeof before, "%s", slurp(path, &len));
    b.rgb[1] = NAN;
    assert_int_equal(journal_append(j, &b, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "g nan is not a finite number"));
    c.rig_time_s = a.rig_time_s - 0.001;
    assert_int_equal(journal_append(j, &c, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "before the previous record's"));
    assert_string_equal(slurp(path, &len), before);
    c.rig_time_s = a.rig_time_s; /* a clock standing still is possible */
    assert_int_equal(journal_append(j, &c, &err), 0);
    journal_close(j);
}

/* A capture directory of the earlier format reads, resumes in it, and keeps
 * its rules: a complete last line with a bad CRC is a tear there. */
static void test_earlier_format_still_reads(void **state)
{
    (void)state;
    char text[N + 1][512];
    copy_intact(text);
    snprintf(text[0], sizeof text[0], "%s", COLUMNS "crc32\n");
    char path[300], all[8192] = "";
    snprintf(path, sizeof path, "%s/v1.csv", dir);
    for (int k = 0; k <= N; k++) {
        if (k) {
            drop_raw_columns(text[k]);
            recrc(text[k], sizeof text[k], 0);
        }
        strcat(all, text[k]);
    }
    strcat(all, "9,1,2,0,2,180,1,3,0.1,0.1,0.1,0.05,40,0,deadbeef\n");
    gonio_test_write_text(path, all);
    struct journal_sample *s = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &s, &n, &err);
    if (!j)
        fail_msg("%s", err.msg);
    assert_int_equal(n, N);
    for (int i = 0; i < N; i++)
        assert_int_equal(s[i].point, make(i).point);
    struct journal_sample more = make(N);
    assert_int_equal(journal_append(j, &more, &err), 0);
    journal_close(j);
    free(s);
    /* The appended record is in the earlier format: its CRC over itself. */
    size_t len;
    char *got = slurp(path, &len);
    assert_true(!strncmp(got, COLUMNS "crc32\n", strlen(COLUMNS "crc32\n")));
    char *last = got + len - 1;
    while (last > got && last[-1] != '\n')
        last--;
    char mine[512];
    snprintf(mine, sizeof mine, "%s", last);
    char want[512];
    snprintf(want, sizeof want, "%s", mine);
    recrc(want, sizeof want, 0);
    assert_string_equal(mine, want);
    assert_int_equal(journal_read(path, &s, &n, &err), 0);
    assert_int_equal(n, N + 1);
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_header_marks_the_chained_format),
        cmocka_unit_test(test_removed_record),
        cmocka_unit_test(test_swapped_records),
        cmocka_unit_test(test_duplicated_record),
        cmocka_unit_test(test_edit_with_own_crc_recomputed),
        cmocka_unit_test(test_impossible_values_with_chain_recomputed),
        cmocka_unit_test(test_torn_tail_still_cut),
        cmocka_unit_test(test_writer_refuses_impossible_samples),
        cmocka_unit_test(test_earlier_format_still_reads),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
