/* The journal's raw columns: every field of a sample reads back bit for
 * bit, none as none; what a counts detector gives (unreduced counts, a
 * dark frame) is a record like any other; impossible raw values are
 * refused by the writer and the reader alike; and journals of the earlier
 * chained format still read, resume in their format and refuse counts. */
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "tests/gonio_test.h"

#define COLUMNS "point,theta_i,theta_r,phi_i,theta_o,phi_o,s,a,r,g,b,integration_s,rig_time_s,flags,"

static char dir[256];

static struct journal_sample geometry(int i)
{
    struct journal_sample s;
    journal_sample_clear(&s);
    s.point = i;
    s.theta_i = 10.0 + i / 3.0;
    s.theta_r = -40.0 + 7.0 * i;
    s.theta_o = fabs(s.theta_r);
    s.phi_o = s.theta_r >= 0 ? 180 : 0;
    s.s = s.theta_i;
    s.a = s.theta_i + s.theta_r;
    s.integration_s = 0.05 * (i + 1);
    s.rig_time_s = 1.5 * (i + 1);
    return s;
}

/* One of each kind a capture journals. */
static void kinds(struct journal_sample out[5])
{
    out[0] = geometry(0); /* a BRDF sample with every optional field */
    for (int c = 0; c < 3; c++) {
        out[0].rgb[c] = 0.1 / (c + 3);
        out[0].u[c] = 1e-4 * (c + 1) / 3.0;
    }
    out[0].integration_total_s = 0.35;
    out[0].gain_state = 2;
    out[0].monitor = 41234.5;
    out[1] = geometry(1); /* counts, not reduced */
    out[1].counts = 1;
    out[1].raw[0] = 1234.0;
    out[1].raw[1] = 60001.25;
    out[1].raw[2] = 1.0 / 7.0;
    out[1].integration_total_s = 0.1 + 0.4 + 1.6;
    out[1].gain_state = 0;
    out[1].flags = JOURNAL_FLAG_SATURATED;
    out[2] = out[1]; /* its dark frame */
    out[2].flags = JOURNAL_FLAG_DARK;
    out[2].rig_time_s += 0.25;
    for (int c = 0; c < 3; c++)
        out[2].raw[c] = 100.0 + c;
    out[3] = geometry(3); /* counts reduced to BRDF, with a monitor */
    out[3].counts = 1;
    for (int c = 0; c < 3; c++) {
        out[3].raw[c] = 5e3 * (c + 1);
        out[3].rgb[c] = 0.02 * (c + 1);
        out[3].u[c] = 2e-4;
    }
    out[3].monitor = -3.5; /* an offset can leave a monitor below zero */
    out[4] = geometry(4); /* a BRDF sample with nothing optional */
    for (int c = 0; c < 3; c++)
        out[4].rgb[c] = 1.0 / 3.0;
}

static int same_double(double a, double b)
{
    return (isnan(a) && isnan(b)) || memcmp(&a, &b, sizeof a) == 0;
}

static void assert_same(const struct journal_sample *a, const struct journal_sample *b)
{
    const double x[] = {a->theta_i, a->theta_r, a->phi_i, a->theta_o, a->phi_o, a->s, a->a,
                        a->rgb[0], a->rgb[1], a->rgb[2], a->integration_s, a->rig_time_s,
                        a->raw[0], a->raw[1], a->raw[2], a->integration_total_s, a->monitor,
                        a->u[0], a->u[1], a->u[2]};
    const double y[] = {b->theta_i, b->theta_r, b->phi_i, b->theta_o, b->phi_o, b->s, b->a,
                        b->rgb[0], b->rgb[1], b->rgb[2], b->integration_s, b->rig_time_s,
                        b->raw[0], b->raw[1], b->raw[2], b->integration_total_s, b->monitor,
                        b->u[0], b->u[1], b->u[2]};
    for (size_t i = 0; i < sizeof x / sizeof *x; i++)
        if (!same_double(x[i], y[i]))
            fail_msg("point %d: value %zu wrote %.17g, read %.17g", a->point, i, x[i], y[i]);
    assert_int_equal(a->point, b->point);
    assert_int_equal(a->flags, b->flags);
    assert_int_equal(a->counts, b->counts);
    assert_int_equal(a->gain_state, b->gain_state);
}

static char *slurp(const char *path)
{
    static char buf[16384];
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    size_t len = fread(buf, 1, sizeof buf - 1, f);
    buf[len] = '\0';
    fclose(f);
    return buf;
}

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "jraw");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static void test_every_field_round_trips(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/kinds.csv", dir);
    struct journal_sample w[5], *r = NULL;
    kinds(w);
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &r, &n, &err);
    assert_non_null(j);
    for (int i = 0; i < 5; i++)
        if (journal_append(j, &w[i], &err) != 0)
            fail_msg("%s", err.msg);
    journal_close(j);
    free(r);
    struct journal_info info;
    assert_int_equal(journal_read_info(path, &r, &n, &info, &err), 0);
    assert_int_equal(n, 5);
    assert_true(info.raw && info.chained);
    for (int i = 0; i < 5; i++)
        assert_same(&w[i], &r[i]);
    free(r);
    /* none is an empty field: the unreduced sample has no r, g, b, the bare
     * BRDF sample nothing after its unit */
    const char *text = slurp(path);
    const char *l2 = strchr(strchr(text, '\n') + 1, '\n') + 1;
    assert_non_null(strstr(l2, ",,,,0.10000000000000001,3,1,counts,1234,"));
    const char *l5 = strrchr(text, ',');
    while (l5 > text && l5[-1] != '\n')
        l5--;
    assert_non_null(strstr(l5, ",brdf,,,,,,,,,,"));
}

static void test_has_brdf(void **state)
{
    (void)state;
    struct journal_sample w[5];
    kinds(w);
    const int want[5] = {1, 0, 0, 1, 1};
    for (int i = 0; i < 5; i++)
        assert_int_equal(journal_sample_has_brdf(&w[i]), want[i]);
    w[3].flags = JOURNAL_FLAG_DARK; /* reduced or not, a dark frame is no sample */
    assert_int_equal(journal_sample_has_brdf(&w[3]), 0);
}

/* A fit takes the records with a value, in order, and counts the rest;
 * records with none at all are refused, naming why. */
static void test_fit_data_leaves_out_records_without_value(void **state)
{
    (void)state;
    struct journal_sample w[5];
    kinds(w);
    struct fit_journal_data d;
    struct gonio_err err = {0};
    assert_int_equal(fit_data_from_journal(w, 5, &d, &err), 0);
    assert_int_equal(d.n, 3);
    assert_int_equal(d.without_value, 2);
    assert_int_equal(d.saturated, 0); /* the saturated one has no value */
    assert_null(d.lower);
    assert_true(d.rgb[1].rgb[2] == w[3].rgb[2] && d.rgb[2].rgb[0] == w[4].rgb[0]);
    fit_journal_data_free(&d);
    w[4].flags = JOURNAL_FLAG_SATURATED;
    assert_int_equal(fit_data_from_journal(w, 5, &d, &err), 0);
    assert_int_equal(d.saturated, 1);
    assert_non_null(d.lower);
    assert_int_equal(d.lower[2], 1);
    assert_int_equal(d.lower[1], 0);
    fit_journal_data_free(&d);
    assert_int_equal(fit_data_from_journal(&w[1], 2, &d, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "no sample has a BRDF value: 2 records"));
}

/* The writer refuses raw values the reader would: nothing is written. */
static void test_impossible_raw_values_refused(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/bad.csv", dir);
    struct journal_sample *r = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &r, &n, &err);
    assert_non_null(j);
    free(r);
    char before[16384];
    snprintf(before, sizeof before, "%s", slurp(path));
    static const struct {
        int kind;
        const char *what;
    } cases[] = {
        {1, "raw_g nan: a counts sample needs its counts"},
        {4, "r nan is not a finite number (a BRDF sample needs its value)"},
        {3, "r, g, b of a counts sample are all reduced or none"},
        {0, "u_b -1e-05 is negative"},
        {0, "monitor inf is not a finite number"},
        {0, "integration_total_s -0.1 is negative"},
        {4, "a dark frame is a counts sample"},
        {0, "gain_state -2 is negative"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof *cases; k++) {
        struct journal_sample w[5];
        kinds(w);
        struct journal_sample *s = &w[cases[k].kind];
        switch (k) {
        case 0: s->raw[1] = NAN; break;
        case 1: s->rgb[0] = NAN; break;
        case 2: s->rgb[2] = NAN; break;
        case 3: s->u[2] = -1e-5; break;
        case 4: s->monitor = INFINITY; break;
        case 5: s->integration_total_s = -0.1; break;
        case 6: s->flags = JOURNAL_FLAG_DARK; break;
        default: s->gain_state = -2; break;
        }
        assert_int_equal(journal_append(j, s, &err), -GONIO_EBADDATA);
        if (!strstr(err.msg, cases[k].what))
            fail_msg("case %zu: expected '%s', got '%s'", k, cases[k].what, err.msg);
    }
    journal_close(j);
    assert_string_equal(slurp(path), before);
}

/* The reader refuses the same in a record whose chain is right, and a unit
 * it does not know. */
static void test_reader_refuses_edited_raw_fields(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/kinds.csv", dir);
    char text[16384];
    snprintf(text, sizeof text, "%s", slurp(path));
    static const struct {
        const char *from, *to, *what;
    } edits[] = {
        {",counts,1234,", ",counts,,", "raw_r nan: a counts sample needs its counts"},
        {",counts,1234,", ",volts,1234,", "not a sample record"},
        {",counts,1234,", ",counts,1234 ,", "not a sample record"},
    };
    for (size_t e = 0; e < sizeof edits / sizeof *edits; e++) {
        char ed[16384];
        char *at = strstr(text, edits[e].from);
        assert_non_null(at);
        snprintf(ed, sizeof ed, "%.*s%s%s", (int)(at - text), text, edits[e].to,
                 at + strlen(edits[e].from));
        /* recompute the chain over the edited journal, as a forger would */
        char out[16384] = "";
        char *line = ed, *nl = strchr(line, '\n');
        unsigned long c = crc32(0L, (const Bytef *)line, (uInt)(nl + 1 - line));
        strncat(out, line, (size_t)(nl + 1 - line));
        for (line = nl + 1; (nl = strchr(line, '\n')); line = nl + 1) {
            size_t covered = (size_t)(nl - 8 - line);
            c = crc32(c, (const Bytef *)line, (uInt)covered);
            char rec[1024];
            snprintf(rec, sizeof rec, "%.*s%08lx\n", (int)covered, line, c);
            strcat(out, rec);
        }
        char edited[300];
        snprintf(edited, sizeof edited, "%s/edited.csv", dir);
        gonio_test_write_text(edited, out);
        struct journal_sample *r = NULL;
        size_t n = 0;
        struct gonio_err err = {0};
        assert_true(journal_read(edited, &r, &n, &err) < 0);
        char where[400];
        snprintf(where, sizeof where, "%s:3: ", edited);
        if (strncmp(err.msg, where, strlen(where)) || !strstr(err.msg, edits[e].what))
            fail_msg("edit %zu: expected '%s...%s', got '%s'", e, where, edits[e].what,
                     err.msg);
    }
}

/* A capture directory of the earlier chained format: its records read
 * with the raw fields none, a resume appends in its format, and a counts
 * sample, which it cannot hold, is refused. */
static void test_earlier_chained_format(void **state)
{
    (void)state;
    const char *header = COLUMNS "chain_crc32\n";
    const char *recs[] = {"0,10,-40,0,40,0,10,-30,0.25,0.125,0.5,0.05,1.5,0,",
                          "2,10.5,-33,0,33,0,10.5,-22.5,0.125,0.125,0.5,0.05,3,1,"};
    char text[4096];
    snprintf(text, sizeof text, "%s", header);
    unsigned long c = crc32(0L, (const Bytef *)header, (uInt)strlen(header));
    for (int i = 0; i < 2; i++) {
        c = crc32(c, (const Bytef *)recs[i], (uInt)strlen(recs[i]));
        char rec[256];
        snprintf(rec, sizeof rec, "%s%08lx\n", recs[i], c);
        strcat(text, rec);
    }
    char path[300];
    snprintf(path, sizeof path, "%s/v2.csv", dir);
    gonio_test_write_text(path, text);
    struct journal_sample *r = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    struct journal_info info;
    assert_int_equal(journal_read_info(path, &r, &n, &info, &err), 0);
    assert_int_equal(n, 2);
    assert_true(info.chained && !info.raw);
    assert_int_equal(r[1].point, 2);
    assert_int_equal(r[1].flags, JOURNAL_FLAG_SATURATED);
    assert_true(r[1].rgb[2] == 0.5);
    assert_int_equal(r[1].counts, 0);
    assert_true(isnan(r[1].raw[0]) && isnan(r[1].u[2]) && isnan(r[1].monitor));
    assert_true(isnan(r[1].integration_total_s));
    assert_int_equal(r[1].gain_state, JOURNAL_GAIN_NONE);
    free(r);
    journal *j = journal_open(path, &r, &n, &err);
    assert_non_null(j);
    free(r);
    struct journal_sample w[5];
    kinds(w);
    w[1].rig_time_s = w[0].rig_time_s = 4;
    assert_int_equal(journal_append(j, &w[1], &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "earlier format holds BRDF samples only"));
    assert_int_equal(journal_append(j, &w[0], &err), 0);
    journal_close(j);
    /* appended in that format: 15 fields, the chain continued */
    const char *got = slurp(path);
    assert_true(!strncmp(got, header, strlen(header)));
    const char *last = got + strlen(got) - 1;
    while (last > got && last[-1] != '\n')
        last--;
    size_t commas = 0;
    for (const char *p = last; *p; p++)
        commas += *p == ',';
    assert_int_equal(commas, 14);
    assert_int_equal(journal_read(path, &r, &n, &err), 0);
    assert_int_equal(n, 3);
    assert_true(r[2].rgb[0] == w[0].rgb[0]);
    assert_true(isnan(r[2].u[0])); /* what that format cannot hold is not kept */
    free(r);
}

/* A crash mid-record in the current format: the torn tail is cut. */
static void test_torn_raw_record_cut(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/kinds.csv", dir);
    char text[16384];
    snprintf(text, sizeof text, "%s", slurp(path));
    size_t len = strlen(text);
    char torn[300];
    snprintf(torn, sizeof torn, "%s/torn.csv", dir);
    for (size_t cut = 1; cut < 60; cut += 7) {
        text[len - cut] = '\0';
        gonio_test_write_text(torn, text);
        struct journal_sample *r = NULL;
        size_t n = 0;
        struct gonio_err err = {0};
        if (journal_read(torn, &r, &n, &err) != 0)
            fail_msg("cut %zu: %s", cut, err.msg);
        assert_int_equal(n, 4);
        free(r);
        snprintf(text, sizeof text, "%s", slurp(path));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_field_round_trips),
        cmocka_unit_test(test_has_brdf),
        cmocka_unit_test(test_fit_data_leaves_out_records_without_value),
        cmocka_unit_test(test_impossible_raw_values_refused),
        cmocka_unit_test(test_reader_refuses_edited_raw_fields),
        cmocka_unit_test(test_earlier_chained_format),
        cmocka_unit_test(test_torn_raw_record_cut),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
