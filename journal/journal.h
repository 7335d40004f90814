/* The capture journal: an append-only sample log, one CSV record a sample,
 * written and fsync'd before the next point is measured, so a capture
 * interrupted at any instant resumes without losing or repeating a sample.
 *
 * Each record ends with a CRC-32 that continues the previous record's
 * (journal_record.h), so an edited, removed, inserted or moved record
 * breaks the chain at its line. The reader accepts a record only when its
 * CRC continues the chain, its newline is there and its values are
 * possible (finite, rig time not negative and never going back); a torn
 * last record (no newline: power cut mid-write) is cut off on open, any
 * other bad line is an error "path:LINE: what is wrong". Journals of the
 * earlier unchained format are still read, and appended to in it. */
#ifndef GONIO_JOURNAL_JOURNAL_H
#define GONIO_JOURNAL_JOURNAL_H

#include <stddef.h>

#include "brdf/angles.h"
#include "common/err.h"

struct journal_sample {
    int point;            /* index of the point in the resolved plan */
    double theta_i, theta_r;            /* in-plane angles (theta_r = a - s), degrees */
    double phi_i, theta_o, phi_o;       /* the pair in spherical angles */
    double s, a;          /* axis positions measured at acquisition, degrees */
    double rgb[3];        /* BRDF, 1/sr; NAN: not reduced (a counts sample) */
    double integration_s; /* detector integration time of the reading kept */
    double rig_time_s;    /* rig clock when the sample was taken */
    unsigned flags;       /* JOURNAL_FLAG_* */
    /* The raw record (journals of the earlier formats read them as none). */
    int counts;           /* 1: the detector gave counts, raw[] holds them */
    double raw[3];        /* counts (ADU) per channel, dark offset included; NAN: none */
    double integration_total_s; /* all detector time spent on the point, retakes
                                 * included; NAN: not recorded */
    int gain_state;       /* the detector's gain setting; JOURNAL_GAIN_NONE: none */
    double monitor;       /* the lamp monitor's counts; NAN: no monitor */
    double u[3];          /* standard uncertainty of rgb, 1/sr; NAN: none */
};

#define JOURNAL_FLAG_SATURATED 0x1u
/* A dark frame (shutter closed) at the integration of the point it was
 * taken for: the data to subtract dark with, not a sample of the plan. */
#define JOURNAL_FLAG_DARK 0x2u
#define JOURNAL_GAIN_NONE (-1)

/* Clear *s to a sample of nothing: zeros, with every optional field none
 * (rgb, raw, integration_total_s, monitor, u NAN; gain_state
 * JOURNAL_GAIN_NONE; counts 0). */
void journal_sample_clear(struct journal_sample *s);

/* 1 when s is a sample of the plan with a BRDF value (not a dark frame,
 * not an unreduced counts sample): what a fit can take. */
int journal_sample_has_brdf(const struct journal_sample *s);

/* The direction pair a sample was measured at: in-plane samples (phi_i = 0,
 * phi_o = 0 or 180) from theta_i, theta_r exactly, others from the
 * spherical angles. */
void journal_sample_pair(const struct journal_sample *s, struct brdf_pair *p);

/* Record s, measured in the plane of incidence with the sample turned
 * rotation_deg about its normal (a plan's sample_azimuths), as the pair the
 * turned sample's frame sees: phi_i and phi_o less rotation_deg, in
 * [0, 360) (brdf_pair_rotate's convention), so that journal_sample_pair
 * gives the pair on the sample. theta_i, theta_r and the axes stay the
 * rig's. */
void journal_sample_turn(struct journal_sample *s, double rotation_deg);

typedef struct journal journal;

/* Open (creating if needed) the journal at path for appending. Records
 * already there are read back into *samples (malloc'd, caller frees) and
 * counted in *n; a torn last record is truncated away. */
journal *journal_open(const char *path, struct journal_sample **samples, size_t *n,
                      struct gonio_err *err);

/* Stop syncing every record: appends are still one write() each (a crash
 * tears at most the last record, which the reader cuts off), but durable
 * only at journal_close. For gonio study, where a sample lost to a power cut
 * is simply measured again and fdatasync per sample would dominate the cost. */
void journal_set_lazy(journal *j);

/* Append one record and make it durable before returning (unless lazy).
 * A sample the reader would refuse (journal_record.h's checks) is not
 * written: -GONIO_EBADDATA. A write that fails names its cause (a full
 * disk: "No space left on device"). In
 * the test build (GONIO_TEST_HOOKS, goniod-test), GONIO_JOURNAL_TEAR_S=SECONDS
 * in the environment (the crash torture, docs/torture.md) sends the record
 * out in two write()s with that pause between them, so a kill can tear it. */
int journal_append(journal *j, const struct journal_sample *s, struct gonio_err *err);

/* Close; a lazy journal is fdatasync'd first. */
void journal_close(journal *j);

/* Read a journal without opening it for writing (torn tail ignored); the
 * same checks and errors as journal_open. */
int journal_read(const char *path, struct journal_sample **samples, size_t *n,
                 struct gonio_err *err);

/* What journal_read_info says of a journal besides its records. */
struct journal_info {
    int chained;       /* a chained format (0: the earliest, unchained one) */
    int raw;           /* the current format, with the raw columns (0: an earlier one) */
    size_t torn_bytes; /* bytes of a torn last record, which journal_open cuts */
};

/* journal_read, and the format and torn tail found (gonio journal check). */
int journal_read_info(const char *path, struct journal_sample **samples, size_t *n,
                      struct journal_info *info, struct gonio_err *err);

#endif
