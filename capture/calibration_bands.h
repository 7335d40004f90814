/* A spectral detector's calibration band by band: the dark, the reference
 * and the photon-transfer gain of each band derived from the band counts
 * its frames keep, and the standard's reflectance at each band's
 * wavelength (brdf_standard_rho_at), so that every band is reduced as an
 * RGB detector's channel is (radiometry/reduce.h), with its own dark and
 * its own instrument factor (and its own stray light, where the reference
 * names a stray calibration). The reduction takes three bands at a time,
 * as the three channels it is written for; channels never mix in it, so
 * each band's value is exactly what a reduction of that band alone gives. */
#ifndef GONIO_CAPTURE_CALIBRATION_BANDS_H
#define GONIO_CAPTURE_CALIBRATION_BANDS_H

#include "capture/calibration.h"
#include "journal/journal.h"

#define CAL_BAND_GROUPS ((CAL_MAX_BANDS + 2) / 3)

struct cal_bands {
    int n_bands;
    double nm[CAL_MAX_BANDS];
    int n_groups;                          /* bands 3g, 3g+1, 3g+2 (the last repeated) */
    struct cal_loaded group[CAL_BAND_GROUPS];
};

/* The frames a band calibration is derived from: the reference's, its
 * dark's and (n_stray 0: none) its stray light's, all holding the same
 * bands. */
struct cal_band_frames {
    const struct cal_frame *dark, *ref, *stray;
    size_t n_dark, n_ref, n_stray;
};

/* Derive *out (malloc'd) from f; whole is the calibration loaded from them
 * (its standard, placement and spot). Each band subtracts its own stray
 * light where f has some. -GONIO_EBADDATA naming the frame when the bands
 * differ or the dark holds none. */
int cal_bands_derive(const struct cal_band_frames *f, const struct cal_loaded *whole,
                     struct cal_bands **out, struct gonio_err *err);
void cal_bands_free(struct cal_bands *b);

/* One capture record's band counts: the journal record it belongs to, and
 * its bands (counts, offset included). */
struct cal_band_record {
    struct journal_sample s;
    int n_bands;
    double nm[CAL_MAX_BANDS], counts[CAL_MAX_BANDS];
};

/* Reduce n records band by band, each with the records before it as the
 * angle term's neighbours (cal_reduce_sample, as the capture reduces its
 * records): out is n * n_bands (record-major), brdf NAN where a band
 * clipped. Fails naming the record whose bands are not the calibration's. */
struct cal_band_value {
    double brdf, u, snr; /* 1/sr; its standard uncertainty; counting signal-to-noise */
};
int cal_bands_reduce(const struct cal_bands *b, const struct journal_plan *plan,
                     const struct cal_band_record *rec, size_t n, struct cal_band_value *out,
                     struct gonio_err *err);

/* Each band's drift (its group's cal_loaded.drift) from the standard's
 * readings after the capture (capture/reference_after.h), as the
 * channels' is taken: the reduction of each band then interpolates its
 * own ratio. -GONIO_EBADDATA naming the reading whose bands are not the
 * calibration's. */
int cal_bands_drift(struct cal_bands *b, const struct cal_frame *f, size_t n, double t_end_s,
                    struct gonio_err *err);

#endif
