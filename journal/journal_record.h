/* The record format of samples.csv, shared by the journal's writer
 * (journal.c) and reader (journal_read.c); private to journal/.
 *
 * Two formats, told apart by the header's last column. The current one
 * (JOURNAL_CHAINED) ends each record with `chain_crc32`: the CRC-32 of the
 * header line and of every record's text up to its CRC, this record's
 * included — each record's checksum continues the one before it, so a
 * record edited, removed, inserted or moved breaks the chain at that line.
 * The earlier one (JOURNAL_PER_RECORD, last column `crc32`) checks each
 * record alone; it is still read, and a resume of such a journal appends in
 * it. */
#ifndef GONIO_JOURNAL_JOURNAL_RECORD_H
#define GONIO_JOURNAL_JOURNAL_RECORD_H

#include <stddef.h>
#include <sys/types.h>

#include "common/err.h"
#include "journal/journal.h"

#define JOURNAL_COLUMNS \
    "point,theta_i,theta_r,phi_i,theta_o,phi_o,s,a,r,g,b,integration_s,rig_time_s,flags,"
#define JOURNAL_HEADER_PER_RECORD JOURNAL_COLUMNS "crc32\n"
#define JOURNAL_HEADER_CHAINED JOURNAL_COLUMNS "chain_crc32\n"
#define JOURNAL_LINE_MAX 1024
#define JOURNAL_RECORD_COMMAS 14 /* 15 fields a record, the CRC last */

enum journal_format { JOURNAL_PER_RECORD = 1, JOURNAL_CHAINED = 2 };

/* Where a journal's valid records end: what the next record continues. */
struct journal_tail {
    enum journal_format format;
    unsigned long crc;  /* the chain so far (JOURNAL_CHAINED) */
    size_t records;
    double rig_time_s;  /* the last record's, when records > 0 */
    off_t valid_len;    /* bytes of the header and the valid records */
};

/* CRC-32 (zlib) of text, continuing seed (0 for a fresh CRC). */
unsigned long journal_crc(unsigned long seed, const char *text, size_t len);

/* The values a record may hold, whoever wrote it: every number finite,
 * point, integration_s and rig_time_s not negative, only known flags, and
 * (JOURNAL_CHAINED) rig_time_s not before the previous record's. 0, or -1
 * with why = "rig_time_s -5 is negative". */
int journal_record_check(const struct journal_sample *s, const struct journal_tail *prev,
                         char *why, size_t size);

/* Read every valid record of the open journal fd (path names it in
 * errors) into *out (malloc'd) and *n, and say where they end (*tail). A
 * torn last record (no newline: a crash mid-write) is left out; anything
 * else wrong is an error naming the line: "path:LINE: what is wrong". */
int journal_load(const char *path, int fd, struct journal_sample **out, size_t *n,
                 struct journal_tail *tail, struct gonio_err *err);

#endif
