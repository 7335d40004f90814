/* Durability of a capture directory's names: a new samples.csv and every
 * file renamed into place survive a power cut only once the directory that
 * holds their names is synced too. fsync is wrapped here (the executable's
 * definition is the one the engine's static libraries bind to) to see
 * which directories are synced, and whether the file was already there
 * under its name when they were. */
#define _GNU_SOURCE /* syscall */
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "common/paths.h"
#include "journal/journal.h"
#include "tests/gonio_test.h"

static char dir[256];
static const char *watch;  /* the file whose name a directory sync must cover */
static int dir_syncs_with_watch; /* directory syncs of watch's folder once it existed */

int fsync(int fd)
{
    struct stat st;
    if (watch && fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
        struct stat w, parent;
        char folder[512];
        snprintf(folder, sizeof folder, "%.*s", (int)(strrchr(watch, '/') - watch), watch);
        if (stat(folder, &parent) == 0 && parent.st_ino == st.st_ino &&
            parent.st_dev == st.st_dev && stat(watch, &w) == 0)
            dir_syncs_with_watch++;
    }
    return (int)syscall(SYS_fsync, fd);
}

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "durable");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static void test_atomic_write_syncs_the_directory_after_the_rename(void **state)
{
    (void)state;
    char path[400];
    snprintf(path, sizeof path, "%s/results.json", dir);
    watch = path;
    dir_syncs_with_watch = 0;
    struct gonio_err err = {0};
    assert_int_equal(gonio_write_file_atomic(path, "{}\n", 3, &err), 0);
    watch = NULL;
    assert_int_equal(dir_syncs_with_watch, 1);
}

static void test_new_journal_syncs_the_directory(void **state)
{
    (void)state;
    char path[400];
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    watch = path;
    dir_syncs_with_watch = 0;
    struct journal_sample *s = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &s, &n, &err);
    assert_non_null(j);
    assert_int_equal(dir_syncs_with_watch, 1);
    journal_close(j);
    /* Reopening an existing journal creates no name: nothing more to sync. */
    j = journal_open(path, &s, &n, &err);
    assert_non_null(j);
    journal_close(j);
    watch = NULL;
    assert_int_equal(dir_syncs_with_watch, 1);
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_atomic_write_syncs_the_directory_after_the_rename),
        cmocka_unit_test(test_new_journal_syncs_the_directory),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
