/* Scenes: what a simulated acquisition simulates. A scene file (YAML,
 * configs/scenes/, keys in docs/scenes.md) names the material, the rig
 * profile, the detector (RGB, or spectral with its bands) and the effects to
 * apply; only the named effects are computed (sim/effects.h builds them into
 * a pipeline), and a scene with none returns the material's exact values.
 *
 * Loading only parses and validates: every value is range-checked here, so
 * building the pipeline from a loaded scene cannot fail on bad parameters. */
#ifndef GONIO_SIM_SCENE_H
#define GONIO_SIM_SCENE_H

#include "common/err.h"

enum sim_detector_kind { SIM_DETECTOR_RGB, SIM_DETECTOR_SPECTRAL };

/* The effects a scene may name. The detector-side kinds are listed in the
 * order the pipeline applies them (light first, then the sensor), whatever
 * the order in the file. */
enum sim_effect_kind {
    SIM_FX_LAMP_DRIFT,  /* slow multiplicative drift of the source */
    SIM_FX_STRAY_LIGHT, /* additive floor, 1/sr */
    SIM_FX_DARK,        /* dark-current offset, electrons/s */
    SIM_FX_SHOT_NOISE,  /* Poisson photon (and dark) noise */
    SIM_FX_READ_NOISE,  /* Gaussian read noise, electrons */
    SIM_FX_SATURATION,  /* full-well clipping, flagged on the sample */
    SIM_FX_ADC,         /* electrons to raw counts: gain, offset, nonlinearity, clip */
    SIM_FX_LAMP_MONITOR, /* a second detector seeing the source: its counts */
    SIM_FX_JITTER,      /* axis positioning jitter */
    SIM_FX_BACKLASH,    /* gear slack on moves ending in the negative direction */
    SIM_FX_STALL,       /* motor stall: the axis stops short with an alarm */
    SIM_FX_ALARM,       /* a driver alarm at the start of a move */
    SIM_FX_COMM_FAULTS, /* dropped, corrupted, late replies */
    SIM_FX_STANDARD_DRAW, /* the mounted standard drawn from its certificate (sim/standard_draw.h) */
    SIM_FX_KINDS
};

#define SIM_SCENE_MAX_EFFECTS 16
#define SIM_SCENE_MAX_BANDS 64
#define SIM_EFFECT_MAX_MOVES 32
#define SIM_AXES_ALL 0x7u /* axis mask: sample, arm, azimuth (enum sim_axis_id bits) */

/* One effect as the scene states it; which fields a kind uses is listed in
 * docs/scenes.md (the others stay 0). */
struct sim_effect_spec {
    enum sim_effect_kind kind;
    int index;             /* position in the scene's list: part of its stream's seed */
    double sigma;          /* lamp_drift: relative; read_noise: e-; jitter: deg */
    double tau_s;          /* lamp_drift correlation time */
    double level;          /* stray_light 1/sr, dark e-/s, saturation full well e-, backlash
                            * deg, lamp_monitor counts/s */
    double gain;           /* adc: ADU per electron */
    double offset;         /* adc: ADU with no light and no dark */
    double offset_spread;  /* adc: each channel's offset departs from offset by up to this
                            * (a fixed pattern, as a spectrometer's pixels' do) */
    double nonlinearity;   /* adc: k, x ADU above the offset read x - k x^2 / full scale */
    int bits;              /* adc: resolution; counts clip at 2^bits - 1 */
    double rate;           /* stall/alarm: probability per move */
    long at_moves[SIM_EFFECT_MAX_MOVES]; /* stall/alarm: 1-based move numbers of the axis */
    int n_at_moves;
    unsigned axes;         /* jitter/backlash/stall/alarm: SIM_AXES_* mask of enum sim_axis_id */
    int code;              /* stall/alarm: the driver's alarm code */
    double drop, corrupt, late; /* comm_faults: rates per exchange */
    double timeout_s;      /* comm_faults: what a dropped or late reply costs */
    int retries;           /* comm_faults: attempts after the first */
};

struct sim_scene {
    char path[1024];
    char name[64];
    char material[512]; /* material spec, e.g. nbrdf:nylon (brdf/material.h) */
    char rig[512];      /* rig profile name or path */
    enum sim_detector_kind detector;
    unsigned long seed; /* seeds every effect's random stream */
    int n_effects;
    struct sim_effect_spec effects[SIM_SCENE_MAX_EFFECTS];
    /* Detector model (docs/scenes.md): electrons per second per 1/sr of
     * BRDF at normal incidence, and the auto-exposure target. */
    double responsivity;
    double target_e;
    /* How the detector sees the lit spot (docs/scenes.md): overfilled (0,
     * the default), the signal going with cos theta_i; underfilled (1),
     * with cos theta_r, the beam's whole flux seen. The direct beam (the
     * material "beam": sample removed, the arm facing the source) gives
     * responsivity * attenuator / solid_angle_sr electrons per second: the
     * detector's true solid angle and its beam attenuator's transmittance
     * (0 and 1 unless stated: no beam is seen). */
    int underfilled;
    double solid_angle_sr, attenuator;
    /* Spectral detector bands, nm (strictly increasing). */
    int n_bands;
    double bands_nm[SIM_SCENE_MAX_BANDS];
};

/* The effect's name in scene files ("shot_noise", ...), NULL if out of range. */
const char *sim_effect_name(enum sim_effect_kind kind);

/* Load a scene: a path, or a bare name resolved to
 * <gonio_config_dir()>/scenes/NAME.yaml. Errors: path:line:col: key: problem. */
int sim_scene_load(const char *path_or_name, struct sim_scene *scene, struct gonio_err *err);

/* A scene with no effects and the defaults (RGB detector, seed 1): for
 * callers that simulate without a file. */
void sim_scene_ideal(struct sim_scene *scene, const char *material);

/* The bin of a spectral detector's counts a band at nm falls in: 0 (R,
 * 595 nm and up), 1 (G, 495-595 nm), 2 (B, below 495 nm), the USB
 * spectrometer's bins (docs/usb-spectrometer.md). With an adc, the
 * reading's three channels are the rounded mean counts of each bin. */
int sim_scene_count_bin(double nm);

#endif
