#include "journal/journal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

#include "common/paths.h"

#define HEADER "point,theta_i,theta_r,phi_i,theta_o,phi_o,s,a,r,g,b,integration_s,rig_time_s,flags,crc32\n"
#define LINE_MAX_LEN 1024
#define RECORD_COMMAS 14 /* 15 fields a record, the CRC last */

struct journal {
    int fd;
    off_t end; /* length of the valid records: a failed append is cut back to it */
#ifdef GONIO_TEST_HOOKS
    double tear_s; /* crash torture only: pause between the halves of a record */
#endif
    int lazy;  /* journal_set_lazy: sync at close only */
    char path[4096];
};

#ifdef GONIO_TEST_HOOKS
/* GONIO_JOURNAL_TEAR_S (crash torture, journal.h): seconds, 0..10. */
static double tear_from_env(void)
{
    const char *v = getenv("GONIO_JOURNAL_TEAR_S");
    char *end;
    double s = v ? strtod(v, &end) : 0;
    return v && *v && !*end && s > 0 && s <= 10 ? s : 0;
}

static ssize_t write_record(const journal *j, const char *line, size_t len)
{
    if (!(j->tear_s > 0))
        return write(j->fd, line, len);
    /* Two writes with a pause between: a kill in the pause leaves half a
     * record on disk, the tear a power cut would leave. */
    size_t half = len / 2;
    ssize_t w = write(j->fd, line, half);
    if (w != (ssize_t)half)
        return w;
    struct timespec ts = {.tv_sec = (time_t)j->tear_s};
    ts.tv_nsec = (long)((j->tear_s - (double)ts.tv_sec) * 1e9);
    while (nanosleep(&ts, &ts) < 0 && errno == EINTR)
        ;
    ssize_t w2 = write(j->fd, line + half, len - half);
    return w2 < 0 ? w2 : w + w2;
}
#else
static ssize_t write_record(const journal *j, const char *line, size_t len)
{
    return write(j->fd, line, len);
}
#endif

static unsigned long line_crc(const char *text, size_t len)
{
    return crc32(crc32(0L, Z_NULL, 0), (const Bytef *)text, (uInt)len);
}

static int format_record(const struct journal_sample *s, char *buf, size_t size)
{
    /* %.17g keeps every double exactly, so a resumed fit sees the same data. */
    int n = snprintf(buf, size,
                     "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%u,",
                     s->point, s->theta_i, s->theta_r, s->phi_i, s->theta_o, s->phi_o, s->s, s->a,
                     s->rgb[0], s->rgb[1], s->rgb[2], s->integration_s, s->rig_time_s, s->flags);
    if (n < 0 || (size_t)n + 10 >= size)
        return -1;
    n += snprintf(buf + n, size - (size_t)n, "%08lx\n", line_crc(buf, (size_t)n));
    return n;
}

/* Parse one complete line (without its newline). 0 on success. */
static int parse_record(const char *line, size_t len, struct journal_sample *s)
{
    const char *comma = NULL;
    for (size_t i = len; i > 0; i--)
        if (line[i - 1] == ',') {
            comma = line + i - 1;
            break;
        }
    if (!comma || line + len - (comma + 1) != 8)
        return -1;
    char crc_text[9];
    memcpy(crc_text, comma + 1, 8);
    crc_text[8] = '\0';
    char *end;
    unsigned long crc = strtoul(crc_text, &end, 16);
    if (*end || crc != line_crc(line, (size_t)(comma + 1 - line)))
        return -1;
    /* sscanf on the journal buffer itself would measure the rest of the
     * file on every call (glibc takes strlen first): quadratic in the
     * journal's length. A record is short; scan a copy of it. */
    char rec[LINE_MAX_LEN];
    if (len >= sizeof rec)
        return -1;
    memcpy(rec, line, len);
    rec[len] = '\0';
    comma = rec + (comma - line);
    line = rec;
    int used = 0;
    int got = sscanf(line, "%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%u,%n", &s->point,
                     &s->theta_i, &s->theta_r, &s->phi_i, &s->theta_o, &s->phi_o, &s->s, &s->a,
                     &s->rgb[0], &s->rgb[1], &s->rgb[2], &s->integration_s, &s->rig_time_s,
                     &s->flags, &used);
    return got == 14 && line + used == comma + 1 ? 0 : -1;
}

/* Reads every valid record; *valid_len is the byte length of the valid
 * prefix (header included), so a torn tail can be cut off. */
static int read_all(const char *path, int fd, struct journal_sample **out, size_t *n,
                    off_t *valid_len, struct gonio_err *err)
{
    struct stat st;
    if (fstat(fd, &st) != 0)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    size_t size = (size_t)st.st_size;
    char *buf = malloc(size + 1);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    size_t got = 0;
    while (got < size) {
        ssize_t r = pread(fd, buf + got, size - got, (off_t)got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            free(buf);
            return gonio_err_set(err, errno ? errno : EIO, "%s: read failed", path);
        }
        got += (size_t)r;
    }
    buf[size] = '\0';

    *out = NULL;
    *n = 0;
    *valid_len = 0;
    size_t hlen = strlen(HEADER);
    if (size == 0) {
        free(buf);
        return 0;
    }
    if (size < hlen || memcmp(buf, HEADER, hlen) != 0) {
        /* A header cut short by a crash before the first sample is a torn
         * tail too; anything else is not a gonio journal. */
        int torn_header = size < hlen && memcmp(buf, HEADER, size) == 0;
        free(buf);
        if (torn_header)
            return 0;
        return gonio_err_set(err, GONIO_EBADDATA, "%s: not a gonio sample journal (bad header)",
                             path);
    }
    size_t cap = 0, pos = hlen;
    *valid_len = (off_t)hlen;
    while (pos < size) {
        char *nl = memchr(buf + pos, '\n', size - pos);
        struct journal_sample s;
        size_t len = nl ? (size_t)(nl - (buf + pos)) : size - pos;
        if (!nl || len >= LINE_MAX_LEN || parse_record(buf + pos, len, &s) != 0) {
            /* A crash tears at most the last record: a bad line before
             * another, or a last line with more fields than one record
             * (two records run together: a newline damaged), is not a
             * tear. One damaged byte may add a comma, hence the + 1. */
            size_t commas = 0;
            for (size_t i = 0; i < len; i++)
                commas += buf[pos + i] == ',';
            if ((nl && memchr(nl + 1, '\n', size - (size_t)(nl + 1 - buf))) ||
                commas > RECORD_COMMAS + 1) {
                free(buf);
                free(*out);
                *out = NULL;
                return gonio_err_set(err, GONIO_EBADDATA,
                                     "%s: corrupt record at byte %zu (CRC or format)", path, pos);
            }
            break; /* torn last record */
        }
        if (*n == cap) {
            cap = cap ? 2 * cap : 256;
            struct journal_sample *grown = realloc(*out, cap * sizeof **out);
            if (!grown) {
                free(buf);
                free(*out);
                *out = NULL;
                return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
            }
            *out = grown;
        }
        (*out)[(*n)++] = s;
        pos += len + 1;
        *valid_len = (off_t)pos;
    }
    free(buf);
    return 0;
}

int journal_read(const char *path, struct journal_sample **samples, size_t *n,
                 struct gonio_err *err)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : errno, "%s: %s", path,
                             strerror(errno));
    off_t valid;
    int rc = read_all(path, fd, samples, n, &valid, err);
    close(fd);
    return rc;
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
    off_t valid;
    if (read_all(path, j->fd, samples, n, &valid, err) != 0) {
        journal_close(j);
        return NULL;
    }
    int failed = ftruncate(j->fd, valid) != 0 || lseek(j->fd, 0, SEEK_END) < 0;
    /* A new journal: its header, then its name in the directory, durable
     * before the first sample is. */
    if (!failed && valid == 0)
        failed = write(j->fd, HEADER, strlen(HEADER)) != (ssize_t)strlen(HEADER) ||
                 fsync(j->fd) != 0 || gonio_fsync_parent(path, NULL) < 0;
    j->end = valid > 0 ? valid : (off_t)strlen(HEADER);
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
    char line[LINE_MAX_LEN];
    int len = format_record(s, line, sizeof line);
    if (len < 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: sample record too long", j->path);
    /* One write() per record: the record is torn only by a crash, and the
     * reader cuts a torn record off. fdatasync makes it durable. */
    errno = 0;
    ssize_t w = write_record(j, line, (size_t)len);
    if (w != len || (!j->lazy && fdatasync(j->fd) != 0)) {
        int e = errno ? errno : EIO;
        /* Leave no partial record behind for the next append to follow. */
        if (ftruncate(j->fd, j->end) != 0 || lseek(j->fd, j->end, SEEK_SET) < 0)
            e = errno;
        return gonio_err_set(err, e, "%s: cannot write sample: %s", j->path, strerror(e));
    }
    j->end += len;
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

void journal_sample_pair(const struct journal_sample *s, struct brdf_pair *p)
{
    if (s->phi_i == 0.0 && (s->phi_o == 0.0 || s->phi_o == 180.0))
        brdf_pair_inplane(s->theta_i, s->theta_r, p);
    else
        brdf_pair_spherical(s->theta_i, s->phi_i, s->theta_o, s->phi_o, p);
}
