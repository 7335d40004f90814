/* The simulated detector: the material at the pair the optics actually see,
 * through the scene's light effects, the exposure, the sensor effects, and
 * (spectral detectors) the radiometry -> photometry conversion to RGB.
 *
 * A spectral detector evaluates a spectral material at its bands: the
 * material itself when it is "spectral:NAME", otherwise the RGB material
 * lifted to spectra (brdf/spectral.h). Its reading carries the spectrum and
 * the linear sRGB of that spectrum under D65; every spectrum can also be
 * appended to spectra.csv (docs/formats.md, docs/scenes.md). */
#ifndef GONIO_SIM_EFFECTS_DETECTOR_H
#define GONIO_SIM_EFFECTS_DETECTOR_H

#include "brdf/material.h"
#include "common/err.h"
#include "rig/rig.h"
#include "sim/effects.h"
#include "sim/scene.h"

struct sim_reading {
    double rgb[3];          /* BRDF, 1/sr (linear sRGB of the spectrum when spectral);
                             * counts (ADU) when counts is set */
    double integration_s;   /* the integration actually used */
    unsigned flags;         /* SIM_SIGNAL_SATURATED */
    int n_bands;            /* 0 for an RGB detector */
    const double *bands_nm; /* valid until the next reading */
    const double *spectrum;
    int counts;             /* the scene has an adc: rgb holds raw counts */
    double full_scale;      /* counts: the ADC's largest count; else 0 */
    double nonlinearity;    /* counts: the ADC's k (sim/effects.h struct sim_adc_info) */
    double monitor;         /* the lamp monitor's counts; NAN without lamp_monitor */
};

typedef struct sim_detector sim_detector;

/* fx is borrowed (may be NULL: no effects); material too. spectra_csv:
 * where to append the spectra of a spectral detector, or NULL. */
sim_detector *sim_detector_new(const struct rig_profile *rig, const brdf_material *material,
                               const struct sim_scene *scene, sim_effects *fx,
                               const char *spectra_csv, struct gonio_err *err);
void sim_detector_free(sim_detector *d);

/* Read at pair p (what the optics see) lit at cos_i; now_s is the rig clock
 * at the start of the integration; theta_i, theta_r the angles the axes'
 * encoders report (written to spectra.csv). requested_s is the caller's
 * integration, used when the detector does not auto-expose. */
int sim_detector_read(sim_detector *d, const struct brdf_pair *p, double cos_i, double now_s,
                      double requested_s, double theta_i, double theta_r,
                      struct sim_reading *out, struct gonio_err *err);

/* Close (1) or open (0) the shutter in front of the detector: closed, it
 * sees no light, only its dark signal and offset through the sensor
 * effects, and integrates for the time asked (no auto-exposure); the
 * lamp still drifts and its monitor still sees it. Open at creation. */
void sim_detector_shutter(sim_detector *d, int closed);

/* The integration the detector will choose at p, from the material's
 * noise-free signal through the light effects' expected values: the
 * auto-exposure of a noisy scene, else (no noise, or an adc: a real
 * detector cannot know the peak before reading it) the rig's fixed
 * integration. No
 * reading is made (nothing changes, spectra.csv gets nothing). */
double sim_detector_meter(sim_detector *d, const struct brdf_pair *p, double cos_i);

/* Another material in the sample's place (a sample changer's slot): read
 * from now on; the effects' state (the lamp's drift) goes on. scene: the
 * detector's, for a spectral one's bands. The material is borrowed. */
int sim_detector_mount(sim_detector *d, const brdf_material *material,
                       const struct sim_scene *scene, struct gonio_err *err);

#endif
