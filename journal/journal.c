#include "journal/journal.h"

#include <errno.h>
#include <math.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "common/paths.h"
#include "journal/journal_record.h"

struct journal {
    int fd;
    struct journal_tail tail; /* where the valid records end: a failed append is cut back to it */
#ifdef GONIO_TEST_HOOKS
    double tear_s; /* crash torture only: pause between the halves of a record */
#endif
    int lazy;  /* journal_set_lazy: sync at close only */
    char path[4096];
};

/* Write all of buf. A write() that stops short says nothing of why (errno
 * is left as it was): writing the rest gets the cause (ENOSPC on a full
 * disk, EFBIG past the file size limit). 0, or -1 with errno set. */
static int write_fully(int fd, const char *buf, size_t len)
{
    while (len > 0) {
        ssize_t w = write(fd, buf, len);
        if (w < 0 && errno == EINTR)
            continue;
        if (w < 0)
            return -1;
        if (w == 0) {
            errno = ENOSPC;
            return -1;
        }
        buf += w;
        len -= (size_t)w;
    }
    return 0;
}

#ifdef GONIO_TEST_HOOKS
/* GONIO_JOURNAL_TEAR_S (crash torture, journal.h): seconds, 0..10. */
static double tear_from_env(void)
{
    const char *v = getenv("GONIO_JOURNAL_TEAR_S");
    char *end;
    double s = v ? strtod(v, &end) : 0;
    return v && *v && !*end && s > 0 && s <= 10 ? s : 0;
}

static int write_record(const journal *j, const char *line, size_t len)
{
    if (!(j->tear_s > 0))
        return write_fully(j->fd, line, len);
    /* Two writes with a pause between: a kill in the pause leaves half a
     * record on disk, the tear a power cut would leave. */
    size_t half = len / 2;
    if (write_fully(j->fd, line, half) < 0)
        return -1;
    struct timespec ts = {.tv_sec = (time_t)j->tear_s};
    ts.tv_nsec = (long)((j->tear_s - (double)ts.tv_sec) * 1e9);
    while (nanosleep(&ts, &ts) < 0 && errno == EINTR)
        ;
    return write_fully(j->fd, line + half, len - half);
}
#else
static int write_record(const journal *j, const char *line, size_t len)
{
    return write_fully(j->fd, line, len);
}
#endif

/* The record's text, its CRC last: over the text alone in the earliest
 * format, continuing the chain in the others. */
static int format_record(const struct journal_sample *s, const struct journal_tail *tail,
                         char *buf, size_t size, unsigned long *crc)
{
    int n = journal_format_fields(s, tail->format, buf, size);
    if (n < 0 || (size_t)n + 10 >= size)
        return -1;
    *crc = journal_crc(journal_format_chained(tail->format) ? tail->crc : 0, buf, (size_t)n);
    n += snprintf(buf + n, size - (size_t)n, "%08lx\n", *crc);
    return n;
}

int journal_read_info(const char *path, struct journal_sample **samples, size_t *n,
                      struct journal_info *info, struct gonio_err *err)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : errno, "%s: %s", path,
                             strerror(errno));
    struct journal_tail tail;
    struct stat st;
    int rc = journal_load(path, fd, samples, n, &tail, err);
    if (rc == 0 && info) {
        info->chained = journal_format_chained(tail.format);
        info->raw = tail.format == JOURNAL_RAW;
        info->torn_bytes = fstat(fd, &st) == 0 && st.st_size > tail.valid_len
                               ? (size_t)(st.st_size - tail.valid_len)
                               : 0;
    }
    close(fd);
    return rc;
}

int journal_read(const char *path, struct journal_sample **samples, size_t *n,
                 struct gonio_err *err)
{
    return journal_read_info(path, samples, n, NULL, err);
}

journal *journal_open(const char *path, struct journal_sample **samples, size_t *n,
                      struct gonio_err *err)
{
    struct journal *j = calloc(1, sizeof *j);
    if (!j) {
        gonio_err_set(err, ENOMEM, "out of memory");
        return NULL;
    }
    snprintf(j->path, sizeof j->path, "%s", path);
#ifdef GONIO_TEST_HOOKS
    j->tear_s = tear_from_env();
#endif
    j->fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (j->fd < 0) {
        gonio_err_set(err, errno, "%s: cannot open journal: %s", path, strerror(errno));
        free(j);
        return NULL;
    }
    if (journal_load(path, j->fd, samples, n, &j->tail, err) != 0) {
        journal_close(j);
        return NULL;
    }
    int failed = ftruncate(j->fd, j->tail.valid_len) != 0 || lseek(j->fd, 0, SEEK_END) < 0;
    /* A new journal: its header, then its name in the directory, durable
     * before the first sample is. */
    if (!failed && j->tail.valid_len == 0) {
        const char *h = JOURNAL_HEADER_RAW;
        failed = write_fully(j->fd, h, strlen(h)) < 0 || fsync(j->fd) != 0 ||
                 gonio_fsync_parent(path, NULL) < 0;
        j->tail.valid_len = (off_t)strlen(h);
    }
    if (failed) {
        gonio_err_set(err, errno, "%s: cannot prepare journal: %s", path, strerror(errno));
        free(*samples);
        *samples = NULL;
        journal_close(j);
        return NULL;
    }
    return j;
}

void journal_set_lazy(journal *j)
{
    j->lazy = 1;
}

int journal_append(journal *j, const struct journal_sample *s, struct gonio_err *err)
{
    /* What the reader would refuse is never written: a resume must read
     * back every record the capture reported. */
    char why[200];
    if (journal_record_check(s, &j->tail, why, sizeof why) != 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: sample of point %d not journalled: %s",
                             j->path, s->point, why);
    char line[JOURNAL_LINE_MAX];
    unsigned long crc;
    int len = format_record(s, &j->tail, line, sizeof line, &crc);
    if (len < 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: sample record too long", j->path);
    /* fdatasync makes the record durable before the next point is measured. */
    if (write_record(j, line, (size_t)len) < 0 || (!j->lazy && fdatasync(j->fd) != 0)) {
        int e = errno ? errno : EIO;
        /* Leave no partial record behind for the next append to follow. */
        if (ftruncate(j->fd, j->tail.valid_len) != 0 ||
            lseek(j->fd, j->tail.valid_len, SEEK_SET) < 0)
            e = errno;
        return gonio_err_set(err, e, "%s: cannot write sample: %s", j->path, strerror(e));
    }
    j->tail.valid_len += len;
    j->tail.crc = crc;
    j->tail.records++;
    j->tail.rig_time_s = s->rig_time_s;
    return 0;
}

void journal_close(journal *j)
{
    if (!j)
        return;
    if (j->fd >= 0) {
        if (j->lazy)
            (void)fdatasync(j->fd); /* best effort: a lost tail is measured again */
        close(j->fd);
    }
    free(j);
}

static double wrap360(double deg)
{
    double w = fmod(deg, 360.0);
    return w < 0 ? w + 360.0 : w;
}

void journal_sample_turn(struct journal_sample *s, double rotation_deg)
{
    s->phi_i = wrap360(s->phi_i - rotation_deg);
    s->phi_o = wrap360(s->phi_o - rotation_deg);
}

void journal_sample_pair(const struct journal_sample *s, struct brdf_pair *p)
{
    if (s->phi_i == 0.0 && (s->phi_o == 0.0 || s->phi_o == 180.0))
        brdf_pair_inplane(s->theta_i, s->theta_r, p);
    else
        brdf_pair_spherical(s->theta_i, s->phi_i, s->theta_o, s->phi_o, p);
}
