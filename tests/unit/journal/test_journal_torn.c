/* The journal under every tear and every damaged byte: a crash can stop a
 * record's write() at any byte, and a bad sector can change any byte. The
 * reader must then give back exactly the records that were whole, or
 * refuse the file; it must never hand a damaged record to a resume. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "journal/journal.h"
#include "tests/gonio_test.h"

#define RECORDS 4

static char dir[256];
static char *orig;      /* the intact journal's bytes */
static size_t orig_len;
static size_t ends[RECORDS + 1]; /* ends[0]: header end; ends[k]: end of record k */

static struct journal_sample make(int i)
{
    struct journal_sample s = {0};
    s.point = 3 * i + 1;
    s.theta_i = 10.0 * i / 7.0;
    s.theta_r = -60 + 1.0 / 3.0 * i;
    s.theta_o = fabs(s.theta_r);
    s.s = s.theta_i;
    s.a = s.theta_i + s.theta_r;
    s.rgb[0] = 0.1 / (i + 1);
    s.rgb[1] = 2.5e-3 * (i + 1);
    s.rgb[2] = 1.0 / 3.0;
    s.integration_s = 0.05;
    s.rig_time_s = 1.7 * (i + 1);
    s.flags = (unsigned)i & 1u;
    return s;
}

static void write_file(const char *path, const char *bytes, size_t len)
{
    /* Overwrite, then cut: ext4 flushes a file truncated to 0 and
     * rewritten on close (auto_da_alloc), thousands of times too slow. */
    int fd = open(path, O_WRONLY | O_CREAT, 0644);
    assert_true(fd >= 0);
    assert_int_equal(pwrite(fd, bytes, len, 0), (ssize_t)len);
    assert_int_equal(ftruncate(fd, (off_t)len), 0);
    close(fd);
}

static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return buf;
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/gonio-torn-XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    char path[300];
    snprintf(path, sizeof path, "%s/intact.csv", dir);
    struct journal_sample *old = NULL;
    size_t n = 0;
    journal *j = journal_open(path, &old, &n, NULL);
    if (!j)
        return -1;
    for (int i = 0; i < RECORDS; i++) {
        struct journal_sample s = make(i);
        if (journal_append(j, &s, NULL) != 0)
            return -1;
    }
    journal_close(j);
    free(old);
    orig = read_file(path, &orig_len);
    /* Record boundaries from the bytes themselves, not from the writer. */
    size_t k = 0;
    for (size_t i = 0; i < orig_len; i++)
        if (orig[i] == '\n')
            ends[k++] = i + 1;
    return k == RECORDS + 1 && ends[RECORDS] == orig_len ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    free(orig);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd);
}

/* The first n records read back are exactly those written. */
static void assert_prefix(const struct journal_sample *s, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        struct journal_sample want = make((int)i);
        assert_int_equal(s[i].point, want.point);
        assert_memory_equal(s[i].rgb, want.rgb, sizeof want.rgb);
        assert_true(s[i].theta_i == want.theta_i && s[i].theta_r == want.theta_r &&
                    s[i].s == want.s && s[i].a == want.a &&
                    s[i].rig_time_s == want.rig_time_s);
        assert_int_equal(s[i].flags, want.flags);
    }
}

/* Whole records within the first len bytes. */
static size_t whole_records(size_t len)
{
    size_t n = 0;
    while (n < RECORDS && ends[n + 1] <= len)
        n++;
    return n;
}

/* A crash may stop the file at any byte: the reader returns the records
 * that were whole, the writer's open cuts the tear off, and the next append
 * follows the last whole record as if the crash had never happened. */
static void test_every_tear(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/torn.csv", dir);
    for (size_t len = 0; len < orig_len; len++) {
        write_file(path, orig, len);
        size_t want = whole_records(len);
        struct journal_sample *s = NULL;
        size_t n = 99;
        struct gonio_err err = {0};
        if (journal_read(path, &s, &n, &err) != 0)
            fail_msg("a tear at byte %zu refused: %s", len, err.msg);
        assert_int_equal(n, want);
        assert_prefix(s, n);
        free(s);

        /* Resume: open cuts to the last whole record and the next append
         * follows it. Each append is fdatasync'd, so this half runs at the
         * record boundaries and every 5th byte (the reads above run at
         * every byte). */
        int at_edge = 0;
        for (size_t k = 0; k <= RECORDS; k++)
            at_edge |= len + 1 >= ends[k] && len <= ends[k] + 1;
        if (!at_edge && len % 5 != 0)
            continue;
        journal *j = journal_open(path, &s, &n, &err);
        if (!j)
            fail_msg("open after a tear at byte %zu: %s", len, err.msg);
        assert_int_equal(n, want);
        struct stat st;
        assert_int_equal(stat(path, &st), 0);
        assert_int_equal((size_t)st.st_size, want ? ends[want] : ends[0]);
        struct journal_sample r = make((int)want);
        assert_int_equal(journal_append(j, &r, NULL), 0);
        journal_close(j);
        free(s);
        size_t got_len;
        char *got = read_file(path, &got_len);
        assert_int_equal(got_len, ends[want + 1]);
        assert_memory_equal(got, orig, got_len);
        free(got);
    }
}

/* Damage one byte anywhere (a few kinds of damage, a newline among them):
 * the reader either refuses the journal or drops the damaged record as a
 * torn tail (only possible for the last one); it never returns a record
 * that differs from what was written. */
static void test_every_damaged_byte(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/damaged.csv", dir);
    static const unsigned char kinds[] = {0x01, 0x10, 0x80, 0xff};
    char *buf = malloc(orig_len);
    assert_non_null(buf);
    size_t dropped = 0, refused = 0;
    for (size_t at = 0; at < orig_len; at++) {
        for (size_t k = 0; k < sizeof kinds + 2; k++) {
            memcpy(buf, orig, orig_len);
            if (k < sizeof kinds)
                buf[at] = (char)(buf[at] ^ kinds[k]);
            else
                buf[at] = k == sizeof kinds ? '\n' : ',';
            if (buf[at] == orig[at])
                continue;
            write_file(path, buf, orig_len);
            struct journal_sample *s = NULL;
            size_t n = 0;
            struct gonio_err err = {0};
            int rc = journal_read(path, &s, &n, &err);
            if (rc < 0) {
                assert_int_equal(err.code, GONIO_EBADDATA);
                refused++;
                continue;
            }
            /* Accepted: only the damaged last record may be gone. */
            if (at < ends[RECORDS - 1])
                fail_msg("damage at byte %zu (before the last record) accepted with %zu "
                         "records", at, n);
            assert_int_equal(n, RECORDS - 1);
            assert_prefix(s, n);
            free(s);
            dropped++;
        }
    }
    free(buf);
    /* Both outcomes happen: damage in the last record is a torn tail. */
    assert_true(dropped > 0 && refused > 0);
}

/* A journal whose last record is whole but a later crash left a second,
 * partial copy of the next one: still only whole records come back. */
static void test_tear_after_a_crc_valid_prefix(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/prefix.csv", dir);
    /* The last record minus its newline: CRC text complete, line open. */
    write_file(path, orig, orig_len - 1);
    struct journal_sample *s = NULL;
    size_t n = 0;
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    assert_int_equal(n, RECORDS - 1);
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_tear),
        cmocka_unit_test(test_every_damaged_byte),
        cmocka_unit_test(test_tear_after_a_crc_valid_prefix),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
