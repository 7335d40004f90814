/* A record's text and back (journal_record.h): the fields of the earlier
 * formats, and the current format's raw columns with none as an empty
 * field. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "journal/journal_record.h"

void journal_sample_clear(struct journal_sample *s)
{
    memset(s, 0, sizeof *s);
    for (int c = 0; c < 3; c++)
        s->rgb[c] = s->raw[c] = s->u[c] = NAN;
    s->integration_total_s = NAN;
    s->monitor = NAN;
    s->gain_state = JOURNAL_GAIN_NONE;
}

int journal_sample_has_brdf(const struct journal_sample *s)
{
    return !(s->flags & JOURNAL_FLAG_DARK) && isfinite(s->rgb[0]) && isfinite(s->rgb[1]) &&
           isfinite(s->rgb[2]);
}

const char *journal_header(enum journal_format format)
{
    switch (format) {
    case JOURNAL_PER_RECORD: return JOURNAL_HEADER_PER_RECORD;
    case JOURNAL_CHAINED: return JOURNAL_HEADER_CHAINED;
    default: return JOURNAL_HEADER_RAW;
    }
}

int journal_format_chained(enum journal_format format)
{
    return format != JOURNAL_PER_RECORD;
}

/* One optional value: %.17g (every double exactly), or nothing for none. */
static int put_opt(char *buf, size_t size, double v)
{
    return isnan(v) ? snprintf(buf, size, ",") : snprintf(buf, size, "%.17g,", v);
}

int journal_format_fields(const struct journal_sample *s, enum journal_format format, char *buf,
                          size_t size)
{
    size_t n = 0;
    const double opt_rgb[3] = {s->rgb[0], s->rgb[1], s->rgb[2]};
    int w = snprintf(buf, size, "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,", s->point,
                     s->theta_i, s->theta_r, s->phi_i, s->theta_o, s->phi_o, s->s, s->a);
    for (int c = 0; c < 3 && w >= 0 && (n += (size_t)w) < size; c++)
        w = put_opt(buf + n, size - n, opt_rgb[c]);
    if (w >= 0 && (n += (size_t)w) < size)
        w = snprintf(buf + n, size - n, "%.17g,%.17g,%u,", s->integration_s, s->rig_time_s,
                     s->flags);
    if (format == JOURNAL_RAW) {
        const double tail[] = {s->raw[0], s->raw[1], s->raw[2], s->integration_total_s};
        if (w >= 0 && (n += (size_t)w) < size)
            w = snprintf(buf + n, size - n, "%s,", s->counts ? "counts" : "brdf");
        for (size_t i = 0; i < 4 && w >= 0 && (n += (size_t)w) < size; i++)
            w = put_opt(buf + n, size - n, tail[i]);
        if (w >= 0 && (n += (size_t)w) < size)
            w = s->gain_state == JOURNAL_GAIN_NONE ? snprintf(buf + n, size - n, ",")
                                                   : snprintf(buf + n, size - n, "%d,",
                                                              s->gain_state);
        const double last[] = {s->monitor, s->u[0], s->u[1], s->u[2]};
        for (size_t i = 0; i < 4 && w >= 0 && (n += (size_t)w) < size; i++)
            w = put_opt(buf + n, size - n, last[i]);
    }
    if (w < 0 || (n += (size_t)w) >= size)
        return -1;
    return (int)n;
}

/* The next comma-ended field of *p (advanced past its comma) in f, NUL
 * ended. -1: no comma left, or the field too long for f. */
static int next_field(const char **p, const char *end, char *f, size_t size)
{
    const char *comma = memchr(*p, ',', (size_t)(end - *p));
    if (!comma || (size_t)(comma - *p) >= size)
        return -1;
    memcpy(f, *p, (size_t)(comma - *p));
    f[comma - *p] = '\0';
    *p = comma + 1;
    return 0;
}

/* A number field: all of its text a double (one not finite is left to
 * journal_record_check to name); empty is none (NAN) where optional. 0,
 * or -1. */
static int num_field(const char **p, const char *end, int optional, double *v)
{
    char f[64], *e;
    if (next_field(p, end, f, sizeof f) < 0)
        return -1;
    if (!f[0]) {
        *v = NAN;
        return optional ? 0 : -1;
    }
    if (f[0] == ' ' || f[0] == '+' || f[0] == '\t')
        return -1;
    *v = strtod(f, &e);
    return *e ? -1 : 0;
}

static int int_field(const char **p, const char *end, int optional, long lo, long *v)
{
    char f[32], *e;
    if (next_field(p, end, f, sizeof f) < 0)
        return -1;
    if (!f[0] && optional) {
        *v = JOURNAL_GAIN_NONE;
        return 0;
    }
    if (!f[0] || f[0] == ' ' || f[0] == '+')
        return -1;
    *v = strtol(f, &e, 10);
    return *e || *v < lo || *v > 0x7fffffffL ? -1 : 0;
}

/* The current format's fields up to the CRC (covered bytes of line). */
static int parse_raw_fields(const char *line, size_t covered, struct journal_sample *s)
{
    const char *p = line, *end = line + covered;
    long v;
    double *const angles[] = {&s->theta_i, &s->theta_r, &s->phi_i, &s->theta_o, &s->phi_o,
                              &s->s,       &s->a};
    if (int_field(&p, end, 0, -0x7fffffffL, &v) < 0) /* a negative one journal_record_check names */
        return -1;
    s->point = (int)v;
    for (size_t i = 0; i < 7; i++)
        if (num_field(&p, end, 0, angles[i]) < 0)
            return -1;
    for (int c = 0; c < 3; c++)
        if (num_field(&p, end, 1, &s->rgb[c]) < 0)
            return -1;
    if (num_field(&p, end, 0, &s->integration_s) < 0 ||
        num_field(&p, end, 0, &s->rig_time_s) < 0 || int_field(&p, end, 0, 0, &v) < 0)
        return -1;
    s->flags = (unsigned)v;
    char unit[16];
    if (next_field(&p, end, unit, sizeof unit) < 0)
        return -1;
    if (strcmp(unit, "counts") && strcmp(unit, "brdf"))
        return -1;
    s->counts = !strcmp(unit, "counts");
    for (int c = 0; c < 3; c++)
        if (num_field(&p, end, 1, &s->raw[c]) < 0)
            return -1;
    if (num_field(&p, end, 1, &s->integration_total_s) < 0 ||
        int_field(&p, end, 1, 0, &v) < 0)
        return -1;
    s->gain_state = (int)v;
    if (num_field(&p, end, 1, &s->monitor) < 0)
        return -1;
    for (int c = 0; c < 3; c++)
        if (num_field(&p, end, 1, &s->u[c]) < 0)
            return -1;
    return p == end ? 0 : -1;
}

/* The earlier formats' fields; the raw ones are none. */
static int parse_old_fields(const char *line, size_t covered, struct journal_sample *s)
{
    /* sscanf on the journal buffer itself would measure the rest of the
     * file on every call (glibc takes strlen first): quadratic in the
     * journal's length. A record is short; scan a copy of it. */
    char rec[JOURNAL_LINE_MAX];
    if (covered >= sizeof rec)
        return -1;
    memcpy(rec, line, covered);
    rec[covered] = '\0';
    int used = 0;
    int got = sscanf(rec, "%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%u,%n", &s->point,
                     &s->theta_i, &s->theta_r, &s->phi_i, &s->theta_o, &s->phi_o, &s->s, &s->a,
                     &s->rgb[0], &s->rgb[1], &s->rgb[2], &s->integration_s, &s->rig_time_s,
                     &s->flags, &used);
    return got == 14 && (size_t)used == covered ? 0 : -1;
}

int journal_parse_record(const char *line, size_t len, enum journal_format format,
                         struct journal_sample *s, unsigned long *crc, size_t *covered)
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
    *crc = strtoul(crc_text, &end, 16);
    if (*end || crc_text[0] == '-' || crc_text[0] == '+' || crc_text[0] == ' ')
        return -1;
    *covered = (size_t)(comma + 1 - line);
    journal_sample_clear(s);
    return format == JOURNAL_RAW ? parse_raw_fields(line, *covered, s)
                                 : parse_old_fields(line, *covered, s);
}
