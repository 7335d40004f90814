/* A spectral detector's bands in a capture on counts: each record's band
 * counts kept beside the journal in DIR/bands.csv as the record is
 * journalled (the raw record, as samples.csv keeps the three bins'), and
 * reduced band by band with the capture's calibration into
 * DIR/spectra.csv (docs/scenes.md, "spectra.csv"), which the spectral
 * fits read. */
#ifndef GONIO_CAPTURE_CAPTURE_BANDS_H
#define GONIO_CAPTURE_CAPTURE_BANDS_H

#include "capture/calibration.h"
#include "drivers/drivers.h"
#include "journal/journal.h"

/* The bands of the reading a record was taken from (copied: the
 * detector's own are valid until its next reading only). */
struct capture_bands_reading {
    int n;
    double nm[CAL_MAX_BANDS], counts[CAL_MAX_BANDS];
};

/* Keep r's bands (none unless it is counts from a spectral detector). */
void capture_bands_take(struct capture_bands_reading *b, const struct drv_reading *r);

/* Append s's bands to DIR/bands.csv, synced (nothing without bands). */
int capture_bands_append(const char *dir, const struct journal_sample *s,
                         const struct capture_bands_reading *b, struct gonio_err *err);

/* Reduce the bands of the capture's records (samples, as journalled) with
 * cl into DIR/spectra.csv, written whole; nothing when DIR has no
 * bands.csv. A record with no bands row, or a calibration without bands,
 * fails naming it. */
int capture_bands_reduce(const struct cal_loaded *cl, const struct journal_plan *plan,
                         const struct journal_sample *samples, size_t n, const char *dir,
                         struct gonio_err *err);

#endif
