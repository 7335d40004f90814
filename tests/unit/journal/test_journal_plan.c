/* A resume checks every journalled record against its plan point, and
 * `gonio journal check DIR` says the same without resuming: records whose
 * chain CRC a forger recomputed (so that the journal itself reads) are
 * refused when they name no plan point, a point twice, axes outside the
 * in-position band of their point, or angles their axes do not give. The
 * journal is left as it was. */
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "capture/journal_plan.h"
#include "journal/journal.h"
#include "tests/gonio_test.h"

#define MAX_LINES 256
#define FIELDS 15

static char dir[256], base[300];
static char lines[MAX_LINES][512];
static int n_lines;

static struct capture_config config(const char *out)
{
    return (struct capture_config){.plan = "ds3", .model = "abc",
                                   .out_dir = out, .quiet = 1, .measure_only = 1};
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static char buf[1 << 16];
    size_t len = fread(buf, 1, sizeof buf - 1, f);
    buf[len] = '\0';
    fclose(f);
    return buf;
}

static int setup(void **state)
{
    (void)state;
    if (gonio_test_dir_make(dir, sizeof dir, "jplan") != 0)
        return -1;
    snprintf(base, sizeof base, "%s/base", dir);
    struct capture_config cfg = config(base);
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture("ideal", &cfg, NULL, &sum, &err) != 0) {
        fprintf(stderr, "capture: %s\n", err.msg);
        return -1;
    }
    char path[400];
    snprintf(path, sizeof path, "%s/samples.csv", base);
    char *text = slurp(path);
    for (n_lines = 0; *text && n_lines < MAX_LINES; n_lines++) {
        char *nl = strchr(text, '\n');
        snprintf(lines[n_lines], sizeof lines[0], "%.*s", (int)(nl + 1 - text), text);
        text = nl + 1;
    }
    return n_lines > 10 ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* Field f of line (0-based) set to value. */
static void set_field(char *line, int f, const char *value)
{
    char *p = line;
    for (int c = 0; c < f; c++)
        p = strchr(p, ',') + 1;
    char out[1024];
    snprintf(out, sizeof out, "%.*s%s%s", (int)(p - line), line, value, strchr(p, ','));
    assert_true(strlen(out) < 512);
    memcpy(line, out, strlen(out) + 1);
}

static void get_field(const char *line, int f, char *out, size_t size)
{
    const char *p = line;
    for (int c = 0; c < f; c++)
        p = strchr(p, ',') + 1;
    snprintf(out, size, "%.*s", (int)(strchr(p, ',') - p), p);
}

/* Every CRC recomputed along the chain (docs/formats.md): the journal reads. */
static void rechain(char text[][512], int count)
{
    unsigned long c = crc32(0L, (const Bytef *)text[0], (uInt)strlen(text[0]));
    for (int k = 1; k < count; k++) {
        char *comma = strrchr(text[k], ',');
        c = crc32(c, (const Bytef *)text[k], (uInt)(comma + 1 - text[k]));
        snprintf(comma + 1, 16, "%08lx\n", c);
    }
}

/* A copy of the base capture named tag with the journal text given. */
static void make_case(const char *tag, char text[][512], int count, char *out, size_t size)
{
    snprintf(out, size, "%s/%s", dir, tag);
    char cmd[800];
    snprintf(cmd, sizeof cmd, "cp -a '%s' '%s'", base, out);
    assert_int_equal(system(cmd), 0);
    char path[400];
    snprintf(path, sizeof path, "%s/samples.csv", out);
    FILE *f = fopen(path, "wb");
    for (int k = 0; k < count; k++)
        fputs(text[k], f);
    fclose(f);
}

/* gonio journal check DIR: its exit status and its stderr's first line. */
static int journal_check(const char *capdir, char *line, size_t size)
{
    const char *bin = getenv("GONIO_BIN");
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "'%s/gonio' journal check '%s' 2>&1", bin ? bin : "bin", capdir);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    line[0] = '\0';
    if (!fgets(line, (int)size, p))
        line[0] = '\0';
    char rest[512];
    while (fgets(rest, sizeof rest, p))
        ;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* The resume refuses the edited journal naming line `line` and `what`, and
 * leaves it byte for byte; gonio journal check says the same, exit 2. */
static void expect_refused(const char *tag, char text[][512], int count, int line,
                           const char *what)
{
    char capdir[400], path[500], where[600];
    make_case(tag, text, count, capdir, sizeof capdir);
    snprintf(path, sizeof path, "%s/samples.csv", capdir);
    char *before = strdup(slurp(path));
    struct capture_config cfg = config(capdir);
    struct capture_summary sum;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &sum, &err), -GONIO_EBADDATA);
    snprintf(where, sizeof where, "%s:%d: ", path, line);
    if (strncmp(err.msg, where, strlen(where)) || !strstr(err.msg, what))
        fail_msg("resume: expected '%s...%s', got '%s'", where, what, err.msg);
    assert_string_equal(slurp(path), before);
    free(before);
    char out[1024];
    assert_int_equal(journal_check(capdir, out, sizeof out), 2);
    if (!strstr(out, where) || !strstr(out, what))
        fail_msg("journal check: expected '%s...%s', got '%s'", where, what, out);
}

static void copy_lines(char text[][512])
{
    memcpy(text, lines, sizeof lines);
}

static void test_intact_journal_resumes_and_checks(void **state)
{
    (void)state;
    char text[MAX_LINES][512], capdir[400], out[1024];
    copy_lines(text);
    make_case("intact", text, n_lines, capdir, sizeof capdir);
    assert_int_equal(journal_check(capdir, out, sizeof out), 0);
    assert_non_null(strstr(out, "checksums chained"));
    struct capture_config cfg = config(capdir);
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture("ideal", &cfg, NULL, &sum, &err) != 0)
        fail_msg("%s", err.msg);
    assert_int_equal(sum.samples, (size_t)(n_lines - 1));
}

/* theta_r = 77 written over one record's (the axes left as they were). */
static void test_angle_not_from_its_axes(void **state)
{
    (void)state;
    char text[MAX_LINES][512];
    copy_lines(text);
    set_field(text[7], 2, "77");
    rechain(text, n_lines);
    expect_refused("theta_r", text, n_lines, 8, "are not the ones its axes give");
}

/* A record moved, angles and axes, to another point's geometry. */
static void test_record_at_another_points_geometry(void **state)
{
    (void)state;
    char text[MAX_LINES][512];
    copy_lines(text);
    for (int f = 1; f <= 7; f++) { /* theta_i .. a */
        char v[64];
        get_field(text[20], f, v, sizeof v);
        set_field(text[9], f, v);
    }
    rechain(text, n_lines);
    expect_refused("geometry", text, n_lines, 10, "the plan puts it at");
}

static void test_point_not_in_plan(void **state)
{
    (void)state;
    char text[MAX_LINES][512], v[32];
    copy_lines(text);
    snprintf(v, sizeof v, "%d", n_lines - 1); /* one past the last point */
    set_field(text[5], 0, v);
    rechain(text, n_lines);
    expect_refused("range", text, n_lines, 6, "is not in the plan");
}

static void test_point_twice(void **state)
{
    (void)state;
    char text[MAX_LINES][512];
    copy_lines(text);
    /* The last record measured again: its copy appended, rig time later. */
    memcpy(text[n_lines], text[n_lines - 1], sizeof text[0]);
    set_field(text[n_lines], 12, "100000");
    rechain(text, n_lines + 1);
    char want[64];
    snprintf(want, sizeof want, "journalled again (first at line %d)", n_lines);
    expect_refused("twice", text, n_lines + 1, n_lines + 1, want);
}

/* The band: an axis 0.05 deg off its target is within the default rig's
 * 0.1 deg, 0.15 deg is not; the same for the azimuth. */
static void test_in_position_band(void **state)
{
    (void)state;
    char path[400];
    snprintf(path, sizeof path, "%s/plan.json", base);
    struct plan_point *pts;
    size_t count;
    struct gonio_err err = {0};
    assert_int_equal(journal_plan_read(path, &pts, &count, &err), 0);
    assert_int_equal(count, (size_t)(n_lines - 1));
    snprintf(path, sizeof path, "%s/samples.csv", base);
    struct journal_sample *s;
    size_t n;
    assert_int_equal(journal_read(path, &s, &n, &err), 0);
    struct journal_plan plan = {.points = pts, .count = count};
    assert_int_equal(journal_plan_check(path, s, n, &plan, 0.1, &err), 0);
    s[3].a += 0.05;
    s[3].theta_r += 0.05;
    s[3].theta_o = fabs(s[3].theta_r);
    assert_int_equal(journal_plan_check(path, s, n, &plan, 0.1, &err), 0);
    s[3].a += 0.1;
    s[3].theta_r += 0.1;
    s[3].theta_o = fabs(s[3].theta_r);
    assert_int_equal(journal_plan_check(path, s, n, &plan, 0.1, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, ":5: point"));
    assert_int_equal(journal_plan_check(path, s, n, &plan, 0.2, &err), 0);
    /* The azimuth phi_o implies, the short way round (0 and 360 agree). */
    s[4].phi_o = s[4].theta_r >= 0 ? 180.05 : 359.95;
    assert_int_equal(journal_plan_check(path, s, n, &plan, 0.2, &err), 0);
    s[4].phi_o = s[4].theta_r >= 0 ? 180.5 : 359.5;
    assert_int_equal(journal_plan_check(path, s, n, &plan, 0.2, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, ":6: point"));
    assert_non_null(strstr(err.msg, "azimuth"));
    free(s);
    free(pts);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_intact_journal_resumes_and_checks),
        cmocka_unit_test(test_angle_not_from_its_axes),
        cmocka_unit_test(test_record_at_another_points_geometry),
        cmocka_unit_test(test_point_not_in_plan),
        cmocka_unit_test(test_point_twice),
        cmocka_unit_test(test_in_position_band),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
