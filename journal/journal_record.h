/* The record format of samples.csv, shared by the journal's writer
 * (journal.c) and reader (journal_read.c); private to journal/.
 *
 * Three formats, told apart by the header. The current one (JOURNAL_RAW)
 * adds the raw columns (unit, counts per channel, the integration spent in
 * all, gain state, lamp monitor, standard uncertainties) after the
 * earlier chained format's fields, so a reader of those finds them where
 * they were; an empty field is none. Both chained formats end each record
 * with `chain_crc32`: the CRC-32 of the header line and of every record's
 * text up to its CRC, this record's included — each record's checksum
 * continues the one before it, so a record edited, removed, inserted or
 * moved breaks the chain at that line. The earliest (JOURNAL_PER_RECORD,
 * last column `crc32`) checks each record alone. The earlier formats are
 * still read, and a resume of such a journal appends in its format, which
 * holds BRDF samples only. */
#ifndef GONIO_JOURNAL_JOURNAL_RECORD_H
#define GONIO_JOURNAL_JOURNAL_RECORD_H

#include <stddef.h>
#include <sys/types.h>

#include "common/err.h"
#include "journal/journal.h"

#define JOURNAL_COLUMNS \
    "point,theta_i,theta_r,phi_i,theta_o,phi_o,s,a,r,g,b,integration_s,rig_time_s,flags,"
#define JOURNAL_RAW_COLUMNS \
    "unit,raw_r,raw_g,raw_b,integration_total_s,gain_state,monitor,u_r,u_g,u_b,"
#define JOURNAL_HEADER_PER_RECORD JOURNAL_COLUMNS "crc32\n"
#define JOURNAL_HEADER_CHAINED JOURNAL_COLUMNS "chain_crc32\n"
#define JOURNAL_HEADER_RAW JOURNAL_COLUMNS JOURNAL_RAW_COLUMNS "chain_crc32\n"
#define JOURNAL_LINE_MAX 1024
#define JOURNAL_RECORD_COMMAS 14     /* 15 fields a record, the CRC last */
#define JOURNAL_RAW_RECORD_COMMAS 24 /* JOURNAL_RAW: 25 */

enum journal_format { JOURNAL_PER_RECORD = 1, JOURNAL_CHAINED = 2, JOURNAL_RAW = 3 };

/* Where a journal's valid records end: what the next record continues. */
struct journal_tail {
    enum journal_format format;
    unsigned long crc;  /* the chain so far (JOURNAL_CHAINED, JOURNAL_RAW) */
    size_t records;
    double rig_time_s;  /* the last record's, when records > 0 */
    off_t valid_len;    /* bytes of the header and the valid records */
};

/* A chained format's header, and whether format is one. */
const char *journal_header(enum journal_format format);
int journal_format_chained(enum journal_format format);

/* CRC-32 (zlib) of text, continuing seed (0 for a fresh CRC). */
unsigned long journal_crc(unsigned long seed, const char *text, size_t len);

/* The values a record may hold, whoever wrote it: every number finite
 * (the optional ones finite or none: r, g, b of a counts sample, its raw
 * counts of a BRDF one, the rest of the raw columns), point, integration_s,
 * integration_total_s and rig_time_s not negative, uncertainties not
 * negative, a BRDF sample with its r, g, b, a counts sample with its raw
 * counts and r, g, b all or none, only known flags, a dark frame a counts
 * sample, and (chained formats) rig_time_s not before the previous
 * record's. 0, or -1 with why = "rig_time_s -5 is negative". */
int journal_record_check(const struct journal_sample *s, const struct journal_tail *prev,
                         char *why, size_t size);

/* The record's fields in format, up to and including the comma before
 * its CRC, into buf: the length, or -1 when it does not fit. */
int journal_format_fields(const struct journal_sample *s, enum journal_format format, char *buf,
                          size_t size);

/* Parse one complete line (without its newline) of format into *s and
 * the CRC it carries; *covered is the length the CRC covers. 0, or -1:
 * not a record. */
int journal_parse_record(const char *line, size_t len, enum journal_format format,
                         struct journal_sample *s, unsigned long *crc, size_t *covered);

/* Read every valid record of the open journal fd (path names it in
 * errors) into *out (malloc'd) and *n, and say where they end (*tail). A
 * torn last record (no newline: a crash mid-write) is left out; anything
 * else wrong is an error naming the line: "path:LINE: what is wrong". */
int journal_load(const char *path, int fd, struct journal_sample **out, size_t *n,
                 struct journal_tail *tail, struct gonio_err *err);

#endif
