/* Reading samples.csv back (journal_record.h): every record checked for its
 * format, its checksum and its values, a torn tail left out, anything else
 * refused with the line and what is wrong. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "journal/journal_record.h"

unsigned long journal_crc(unsigned long seed, const char *text, size_t len)
{
    return crc32(seed, (const Bytef *)text, (uInt)len);
}

/* The raw columns' values: optional ones finite or none, a BRDF sample
 * with its value, a counts sample with its counts. */
static int raw_check(const struct journal_sample *s, char *why, size_t size)
{
    static const char *const ch[] = {"r", "g", "b"};
    int rgb_known = 0;
    for (int c = 0; c < 3; c++)
        rgb_known += isfinite(s->rgb[c]);
    for (int c = 0; c < 3; c++) {
        if ((!s->counts && !isfinite(s->rgb[c])) || isinf(s->rgb[c]))
            return snprintf(why, size, "%s %g is not a finite number%s", ch[c], s->rgb[c],
                            s->counts ? "" : " (a BRDF sample needs its value)"), -1;
        if (s->counts && !isfinite(s->raw[c]))
            return snprintf(why, size, "raw_%s %g: a counts sample needs its counts", ch[c],
                            s->raw[c]), -1;
        if (isinf(s->raw[c]) || isinf(s->u[c]))
            return snprintf(why, size, "raw_%s or u_%s is not a finite number", ch[c], ch[c]),
                   -1;
        if (s->u[c] < 0)
            return snprintf(why, size, "u_%s %g is negative", ch[c], s->u[c]), -1;
    }
    if (s->counts && rgb_known != 0 && rgb_known != 3)
        return snprintf(why, size, "r, g, b of a counts sample are all reduced or none"), -1;
    if (isinf(s->integration_total_s) || s->integration_total_s < 0)
        return snprintf(why, size, "integration_total_s %g is negative or not finite",
                        s->integration_total_s), -1;
    if (isinf(s->monitor))
        return snprintf(why, size, "monitor %g is not a finite number", s->monitor), -1;
    if (s->gain_state < JOURNAL_GAIN_NONE)
        return snprintf(why, size, "gain_state %d is negative", s->gain_state), -1;
    if ((s->flags & JOURNAL_FLAG_DARK) && !s->counts)
        return snprintf(why, size, "a dark frame is a counts sample"), -1;
    return 0;
}

int journal_record_check(const struct journal_sample *s, const struct journal_tail *prev,
                         char *why, size_t size)
{
    static const char *const names[] = {"theta_i", "theta_r", "phi_i", "theta_o", "phi_o",
                                        "s", "a", "integration_s", "rig_time_s"};
    const double v[] = {s->theta_i, s->theta_r, s->phi_i,         s->theta_o, s->phi_o,
                        s->s,       s->a,       s->integration_s, s->rig_time_s};
    for (size_t i = 0; i < sizeof v / sizeof *v; i++)
        if (!isfinite(v[i])) {
            snprintf(why, size, "%s %g is not a finite number", names[i], v[i]);
            return -1;
        }
    if (prev->format != JOURNAL_RAW && (s->counts || s->flags & JOURNAL_FLAG_DARK)) {
        snprintf(why, size, "a journal of the earlier format holds BRDF samples only "
                            "(capture counts into a new directory)");
        return -1;
    }
    if (!(s->flags & ~(JOURNAL_FLAG_SATURATED | JOURNAL_FLAG_DARK)) &&
        raw_check(s, why, size) != 0)
        return -1;
    if (s->point < 0)
        snprintf(why, size, "point %d is negative", s->point);
    else if (s->integration_s < 0)
        snprintf(why, size, "integration_s %g is negative", s->integration_s);
    else if (s->rig_time_s < 0)
        snprintf(why, size, "rig_time_s %g is negative", s->rig_time_s);
    else if (s->flags & ~(JOURNAL_FLAG_SATURATED | JOURNAL_FLAG_DARK))
        snprintf(why, size, "flags %u has bits no sample carries", s->flags);
    else if (journal_format_chained(prev->format) && prev->records > 0 &&
             s->rig_time_s < prev->rig_time_s)
        snprintf(why, size, "rig_time_s %g is before the previous record's %g",
                 s->rig_time_s, prev->rig_time_s);
    else
        return 0;
    return -1;
}

static int read_bytes(const char *path, int fd, char **out, size_t *size, struct gonio_err *err)
{
    struct stat st;
    if (fstat(fd, &st) != 0)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    *size = (size_t)st.st_size;
    char *buf = malloc(*size + 1);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    size_t got = 0;
    while (got < *size) {
        ssize_t r = pread(fd, buf + got, *size - got, (off_t)got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            free(buf);
            return gonio_err_set(err, errno ? errno : EIO, "%s: read failed", path);
        }
        got += (size_t)r;
    }
    buf[*size] = '\0';
    *out = buf;
    return 0;
}

/* The header: its format and length, 0 for an empty file or a header cut
 * short by a crash before the first sample (a torn tail too), -1 for a
 * file that is not a journal. */
static long header_format(const char *buf, size_t size, enum journal_format *format)
{
    static const struct {
        const char *text;
        enum journal_format format;
    } headers[] = {{JOURNAL_HEADER_RAW, JOURNAL_RAW},
                   {JOURNAL_HEADER_CHAINED, JOURNAL_CHAINED},
                   {JOURNAL_HEADER_PER_RECORD, JOURNAL_PER_RECORD}};
    *format = JOURNAL_RAW; /* what an empty journal is written in */
    int torn = 0;
    for (size_t i = 0; i < sizeof headers / sizeof *headers; i++) {
        size_t len = strlen(headers[i].text);
        if (size >= len && !memcmp(buf, headers[i].text, len)) {
            *format = headers[i].format;
            return (long)len;
        }
        torn |= size < len && !memcmp(buf, headers[i].text, size);
    }
    return torn ? 0 : -1;
}

/* A line the reader does not take. A crash tears at most the last record,
 * and only a record without its newline; the earlier format also took a
 * last line with a bad CRC for a tear. Anything else is an error: 1 when
 * the line is a torn tail, else -1 with err set. */
static int not_a_record(const char *path, size_t line_no, const char *line, size_t len,
                        int has_newline, int more_lines, enum journal_format format,
                        const char *what, struct gonio_err *err)
{
    /* A tear is a prefix of one record: a tail with the fields of two
     * (a newline damaged) is not. One damaged byte may add a comma. */
    size_t commas = 0;
    for (size_t i = 0; i < len; i++)
        commas += line[i] == ',';
    size_t most = format == JOURNAL_RAW ? JOURNAL_RAW_RECORD_COMMAS : JOURNAL_RECORD_COMMAS;
    int torn = !more_lines && commas <= most + 1 &&
               (!has_newline || format == JOURNAL_PER_RECORD);
    if (torn)
        return 1;
    return gonio_err_set(err, GONIO_EBADDATA, "%s:%zu: %s", path, line_no, what);
}

int journal_load(const char *path, int fd, struct journal_sample **out, size_t *n,
                 struct journal_tail *tail, struct gonio_err *err)
{
    char *buf = NULL;
    size_t size = 0;
    *out = NULL;
    *n = 0;
    int rc = read_bytes(path, fd, &buf, &size, err);
    if (rc < 0)
        return rc;
    memset(tail, 0, sizeof *tail);
    long hlen = header_format(buf, size, &tail->format);
    if (hlen < 0) {
        free(buf);
        return gonio_err_set(err, GONIO_EBADDATA, "%s:1: not a gonio sample journal (bad header)",
                             path);
    }
    if (journal_format_chained(tail->format)) /* the chain starts from the header */
        tail->crc = journal_crc(0, journal_header(tail->format), strlen(journal_header(tail->format)));
    tail->valid_len = (off_t)hlen;
    size_t cap = 0, pos = (size_t)hlen, line_no = 2;
    for (; hlen > 0 && pos < size && rc == 0; line_no++) {
        char *nl = memchr(buf + pos, '\n', size - pos);
        size_t len = nl ? (size_t)(nl - (buf + pos)) : size - pos;
        int more = nl && memchr(nl + 1, '\n', size - (size_t)(nl + 1 - buf)) != NULL;
        struct journal_sample s;
        unsigned long crc;
        size_t covered;
        char why[200];
        if (!nl || len >= JOURNAL_LINE_MAX || journal_parse_record(buf + pos, len, tail->format, &s, &crc, &covered)) {
            rc = not_a_record(path, line_no, buf + pos, len, nl != NULL, more, tail->format,
                              "not a sample record (fields or CRC text malformed)", err);
            break;
        }
        unsigned long want = journal_crc(journal_format_chained(tail->format) ? tail->crc : 0,
                                         buf + pos, covered);
        if (crc != want) {
            rc = not_a_record(path, line_no, buf + pos, len, 1, more, tail->format,
                              journal_format_chained(tail->format)
                                  ? "checksum does not continue the chain: this record, or "
                                    "one before it, was edited, removed, inserted or moved"
                                  : "corrupt record (CRC mismatch)",
                              err);
            break;
        }
        if (journal_record_check(&s, tail, why, sizeof why) != 0) {
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s:%zu: %s", path, line_no, why);
            break;
        }
        if (*n == cap) {
            cap = cap ? 2 * cap : 256;
            struct journal_sample *grown = realloc(*out, cap * sizeof **out);
            if (!grown) {
                rc = gonio_err_set(err, ENOMEM, "%s: out of memory", path);
                break;
            }
            *out = grown;
        }
        (*out)[(*n)++] = s;
        pos += len + 1;
        tail->crc = crc;
        tail->records = *n;
        tail->rig_time_s = s.rig_time_s;
        tail->valid_len = (off_t)pos;
    }
    free(buf);
    if (rc > 0) /* a torn tail: the records before it stand */
        rc = 0;
    if (rc < 0) {
        free(*out);
        *out = NULL;
        *n = 0;
    }
    return rc;
}
