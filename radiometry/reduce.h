/* Detector counts to BRDF by the relative method, with a GUM-style
 * uncertainty budget per sample (docs/radiometry.md).
 *
 * For a sample read S counts (offset and dark included) at integration t_s,
 * the dark frame D_s taken at the same integration and gain state, and the
 * reference standard read R at the same geometry (dark D_r), per channel:
 *
 *   x_s = NL^-1(S - D_s)   x_r = NL^-1(R - D_r)     (nonlinearity undone)
 *   BRDF = (x_s / x_r) * (m_r / m_s) * f_ref(theta_i, theta_r)
 *
 * and, where the calibration has stray-light readings (the rig with the
 * sample removed), x_s and x_r less the stray rate at their geometry times
 * their monitor counts (or integration).
 *
 * where m is the lamp monitor's counts when both readings have one (the
 * drift correction), else the integration time, and f_ref the standard's
 * BRDF (brdf/standard.h). Where the reference was not taken at the
 * sample's geometry, its response divided by f_ref and by the spot's
 * geometric factor (cos theta_r underfilled, cos theta_i overfilled) is
 * interpolated from the nearest reference geometries.
 *
 * The budget's terms are relative standard uncertainties (k = 1) of the
 * BRDF; the reference certificate and the geometry are systematic: one
 * error shared by every sample reduced against the same calibration.
 *
 * The absolute method (struct rad_beam) reduces against the direct beam
 * instead of a standard: the reference term is 0, the reference noise is
 * the beam reading's, and the solid angle and the attenuator are two more
 * systematic terms. */
#ifndef GONIO_RADIOMETRY_REDUCE_H
#define GONIO_RADIOMETRY_REDUCE_H

#include <stddef.h>

#include "brdf/standard.h"
#include "common/err.h"

/* A dark frame set: the mean of n readings at one integration and gain
 * state, with the spread of one reading (read noise and dark shot noise). */
struct rad_dark {
    double integration_s;
    int gain_state;
    double mean[3], sd[3];
    int n;
};

/* The standard read at one geometry: the mean of n readings. */
struct rad_ref {
    double theta_i, theta_r;
    double integration_s;
    int gain_state;
    double counts[3];
    int n;
    double monitor; /* mean lamp monitor counts, NAN: none */
};

enum rad_spot { RAD_SPOT_UNDERFILLED = 0, RAD_SPOT_OVERFILLED = 1 };

/* What the budget needs besides the frames: the detector's noise and the
 * rig's mechanics, measured at calibration or stated by the rig profile. */
struct rad_setup {
    double adu_per_electron[3]; /* shot noise: a signal of x counts has variance g x */
    double monitor_rel_sd;      /* one monitor reading's relative noise (0: none seen) */
    double drift_rel_u;         /* drift the monitor does not follow (the end reference) */
    double nonlinearity_rel_u;  /* relative uncertainty of the detector's stated k */
    double in_position_deg;     /* the axes' in-position band (uniform within it) */
    double geometry_rel_u;      /* sample vs standard placement (distance, solid angle) */
    enum rad_spot spot;
};

/* The absolute method (docs/radiometry.md): the direct beam read with no
 * sample, the arm facing the source, through an attenuator of
 * transmittance attenuation; the detector's aperture subtends omega_sr
 * from the sample (spot underfilled). With on set, refs holds the beam's
 * reading (its own geometry, one per gain state), the standard is not
 * used, and per channel
 *   f = (x_s / m_s) / ((x_b / m_b) / attenuation * cos(theta_r) * omega)
 * with x_b the beam's linearised counts above its dark. */
struct rad_beam {
    int on;
    double omega_sr, omega_rel_u;           /* from the aperture and distance */
    double attenuation, attenuation_rel_u;  /* 1 and 0: no attenuator */
};

struct rad_calibration {
    struct brdf_standard standard;
    const struct rad_dark *darks;
    size_t n_darks;
    const struct rad_ref *refs;
    size_t n_refs;
    /* Stray light: the rig read with the sample removed (a light trap in
     * its place), at the reference's geometries, dark from the reference's
     * set. Its rate (linearised counts above the dark per monitor count,
     * or per second) interpolated at a reading's geometry is subtracted
     * from the sample's and the standard's readings alike. None: n 0. */
    const struct rad_ref *strays;
    size_t n_strays;
    struct rad_setup setup;
    struct rad_beam beam; /* on: the absolute method, refs the beam's readings */
};

/* One sample's raw reading as the journal keeps it. */
struct rad_raw {
    double theta_i, theta_r;
    double counts[3];
    double integration_s;
    int gain_state;
    double full_scale;   /* the ADC's largest count (0: unknown, no clip check) */
    double nonlinearity; /* k: x above the offset reads x - k x^2 / full_scale */
    double monitor;      /* NAN: none */
    /* The reference's drift at the reading's time, interpolated between the
     * calibration and the standard read again after the capture's points
     * (capture/reference_after.h): its response then over the
     * calibration's, less 1 (0: none), and that ratio's relative standard
     * uncertainty (0: none), which joins the drift term; per channel. */
    double drift_rel[3], drift_u[3];
};

enum rad_term {
    RAD_U_COUNTING,     /* the sample's shot and read noise */
    RAD_U_DARK,         /* the dark frames' means */
    RAD_U_REFERENCE,    /* the standard's certificate and shape (systematic) */
    RAD_U_REF_NOISE,    /* the reference readings' noise */
    RAD_U_DRIFT,        /* monitor noise and drift it does not follow */
    RAD_U_NONLINEARITY, /* the stated nonlinearity's uncertainty */
    RAD_U_ANGLE,        /* in-position band times the local slopes */
    RAD_U_GEOMETRY,     /* placement, the sample against the standard (systematic) */
    RAD_U_STRAY,        /* the stray-light readings' noise (0 without them) */
    RAD_U_SOLID_ANGLE,  /* absolute method: omega from the aperture and distance (systematic) */
    RAD_U_ATTENUATOR,   /* absolute method: the beam attenuator's certificate (systematic) */
    RAD_N_TERMS
};

/* "counting", "dark", ... for tables and CSV headers. */
const char *rad_term_name(enum rad_term t);
/* 1 for the terms shared by all samples of a capture. */
int rad_term_systematic(enum rad_term t);

/* Per channel, the root sum of squares of the systematic terms' relative
 * standard uncertainties, which are the same for every sample of a capture
 * reduced with cal (the standard's certificate and shape, the placement):
 * the shared part of each value's u, what a fit propagates as one error. */
void rad_systematic_rel_u(const struct rad_calibration *cal, double out[3]);

struct rad_value {
    double brdf[3];             /* 1/sr; NAN where the reading clipped */
    double u[3];                /* combined standard uncertainty, 1/sr */
    double rel[RAD_N_TERMS][3]; /* each term's relative standard uncertainty */
    double snr[3];              /* x_s over its counting noise */
};

/* A dark set for the integration and gain state, or NULL. */
const struct rad_dark *rad_find_dark(const struct rad_calibration *cal, double integration_s,
                                     int gain_state);

/* 0 when the calibration can reduce readings at this integration and gain
 * state (a dark frame and reference readings exist for them), else
 * -GONIO_EBADCONFIG naming what is missing. */
int rad_covers(const struct rad_calibration *cal, double integration_s, int gain_state,
               struct gonio_err *err);

/* The signal above the offset with the nonlinearity undone: the x whose
 * reading is y = x - k x^2 / full_scale (y itself when k or full_scale is 0). */
double rad_linearise(double y, double k, double full_scale);

/* Reduce n readings (one capture: the angle term's slopes come from the
 * neighbouring samples). Fails naming the sample and what the calibration
 * lacks. */
int rad_reduce(const struct rad_calibration *cal, const struct rad_raw *raw, size_t n,
               struct rad_value *out, struct gonio_err *err);

#endif
