/* Calibration is a capture: dark frames and a reference standard measured
 * on the rig and written as a calibration directory, then looked up and
 * checked before a capture that reduces counts with it
 * (docs/radiometry.md, "Calibrations").
 *
 * A calibration directory ROOT/ID holds calibration.json (id, kind, when,
 * validity, rig, detector, the integrations and gain states covered, the
 * standard and the dark a reference was taken with) and frames.csv, every
 * raw reading taken. What the reduction needs (dark means and spreads,
 * reference means, the photon-transfer gain, the monitor's noise) is
 * derived from the frames when the calibration is loaded, so a better
 * derivation applies to old calibrations too. */
#ifndef GONIO_CAPTURE_CALIBRATION_H
#define GONIO_CAPTURE_CALIBRATION_H

#include <stddef.h>
#include <time.h>

#include "capture/capture.h"
#include "capture/journal_plan.h"
#include "common/err.h"
#include "planner/planner.h"
#include "radiometry/reduce.h"
#include "rig/rig.h"

#define CAL_MAX_INTEGRATIONS 16

/* dark: the shutter closed; reference: the standard in the sample's place;
 * stray: the sample removed (a light trap in its place), what the rig's
 * stray light puts into every reading with the light path open; beam: the
 * sample removed and the arm facing the source, the direct beam (the
 * absolute method, capture/calibration_beam.h). */
enum cal_kind { CAL_DARK = 0, CAL_REFERENCE = 1, CAL_STRAY = 2, CAL_BEAM = 3 };

/* "dark", "reference", "stray", "beam"; and back (-1: none of them). */
const char *cal_kind_name(enum cal_kind k);
int cal_kind_parse(const char *name);

struct cal_meta {
    char id[64];
    enum cal_kind kind;
    time_t created;   /* wall clock, UTC */
    double valid_s;   /* expires at created + valid_s */
    char rig[64], detector[32];
    char standard[128]; /* reference: the standard's name or file */
    char dark[64];      /* reference, stray: the dark calibration it was taken with */
    char stray[64];     /* reference: the stray calibration it subtracts ("": none) */
    double integrations[CAL_MAX_INTEGRATIONS];
    size_t n_integrations;
    int gain_state;     /* the gain state the frames were read at */
    double in_position_deg;
    enum rad_spot spot; /* how the rig's detector sees the lit spot */
    /* beam: the rig profile's geometry when it was read (rig/rig.h, beam) */
    struct rad_beam beam;
};

/* Add to m's integrations every rung of the rig's auto-ranging ladder
 * (capture/autorange.h) it lacks, as far as room allows: a dark over
 * them all lets a capture with this calibration range (docs/radiometry.md,
 * "The chain"). */
void cal_add_ladder(struct cal_meta *m, const struct rig_profile *rig);

#define CAL_MAX_BANDS 64

/* One raw reading of a calibration (a frames.csv row). */
struct cal_frame {
    enum cal_kind kind;
    double theta_i, theta_r, integration_s;
    int gain_state;
    double counts[3], monitor, full_scale, nonlinearity, rig_time_s;
    /* a spectral detector's band counts (drv_reading's), 0 bands: none */
    int n_bands;
    double bands_nm[CAL_MAX_BANDS], bands[CAL_MAX_BANDS];
};

/* Dark frames: the shutter closed (or the lamp off), frames readings at
 * each integration. *frames_out is malloc'd. -ENOTSUP from a detector
 * without a shutter is passed on (the operator must cover it). */
int cal_measure_dark(struct capture_devices *dev, const double *integrations, size_t n_int,
                     int frames, struct cal_frame **out, size_t *n_out, struct gonio_err *err);

/* The standard in the sample's place, read repeats times at each of the
 * plan's points (the shutter opened first). The standard's shape is known
 * in the plane of incidence only: for an out-of-plane plan it is read on
 * an in-plane grid every 5 deg covering the plan's theta_i and the
 * theta_r its points' instrument factor is taken at
 * (cal_instrument_theta_r), which serves them (docs/radiometry.md). */
int cal_measure_reference(struct capture_devices *dev, const struct rig_profile *rig,
                          const struct plan *plan, int repeats, struct cal_frame **out,
                          size_t *n_out, struct gonio_err *err);

/* A calibration run, journalled: what cal_run measures into ROOT/ID. */
struct cal_run {
    const char *root;
    const struct cal_meta *meta; /* id, kind, integrations (dark), standard */
    const struct rig_profile *rig; /* its shutter, settle and integration */
    const struct plan *plan;     /* reference, stray: the points */
    /* Instead of the plan's (points not NULL): the standard read again
     * after a capture (capture/reference_after.h) at these geometries. */
    const struct plan_point *points;
    size_t n_points;
    int per_point;               /* dark: frames per integration; else repeats */
};

/* How a host steers a run and hears from it. control is asked before each
 * frame (CAPTURE_ABORT stops it, the journal kept); ask, when the operator
 * must act first (cover the detector of a rig without a shutter, mount the
 * standard), returns once they have, or CAPTURE_ABORT; NULL ask: nobody
 * to ask (the in-process simulated rig mounts its standard itself, and a
 * dark without a shutter is refused). on_frame follows each frame, and
 * says first where the run stands (the journal's frames; rig time NAN when
 * there are none). mount, on a rig with a sample changer (capture_rig.mount,
 * called with mount_user), puts the standard (reference) or the light trap
 * (stray) in the sample's place instead of asking, and the sample back
 * once the run stops, however it stops; NULL: the operator swaps them. */
struct cal_hooks {
    enum capture_control (*control)(void *user);
    enum capture_control (*ask)(void *user, const char *instruction);
    void (*on_frame)(void *user, size_t done, size_t total, double rig_time_s);
    void *user;
    int (*mount)(void *mount_user, struct capture_devices *dev, enum capture_slot slot,
                 const char *standard, struct gonio_err *err);
    void *mount_user;
};

/* The frames a run takes. */
size_t cal_run_total(const struct cal_run *run);

/* Measure a run into ROOT/ID: each frame appended to ROOT/ID/journal.csv
 * and synced before the next, so that a run killed at any moment keeps
 * every frame it read; a journal already there is continued (its frames
 * checked against the run: kind, geometry, integration), a torn last line
 * dropped. A run through a sample changer (cal_hooks.mount) journals
 * the slot it puts in the sample's place (ROOT/ID/changer) before asking
 * for it, so that one killed anywhere puts the sample back when it is
 * started again, even with every frame read. *frames (malloc'd) is every
 * frame, the journal's first;
 * *aborted is 1 when control stopped it early. The caller writes the
 * calibration (cal_write) once the run is whole. */
int cal_run_measure(struct capture_devices *dev, const struct cal_run *run,
                    const struct cal_hooks *h, struct cal_frame **frames, size_t *n,
                    int *aborted, struct gonio_err *err);

/* Remove ROOT/ID's journal and the directory, when it holds nothing else. */
void cal_discard(const char *root, const char *id);

/* A new id, "dark-20261207T053500Z" (with a suffix when ROOT has it). */
void cal_new_id(const char *root, enum cal_kind kind, time_t now, char *id, size_t size);

/* Write ROOT/ID (meta->id) atomically: frames.csv, then calibration.json. */
int cal_write(const char *root, const struct cal_meta *meta, const struct cal_frame *frames,
              size_t n, struct gonio_err *err);

/* Read ROOT/ID's calibration.json (and frames when frames is not NULL). */
int cal_read(const char *root, const char *id, struct cal_meta *meta, struct cal_frame **frames,
             size_t *n, struct gonio_err *err);

/* What a capture asks of its calibration. */
struct cal_need {
    const char *rig, *detector;
    double integration_s;
    int gain_state; /* -1: not known yet (the detector says at its first reading) */
    time_t now;
};

/* The reference (or beam) calibration to reduce with: id (or, id NULL,
 * the newest reference in ROOT whose rig and detector match) with its dark, both
 * valid now and covering the integration. Refused before anything moves
 * with -GONIO_EBADCONFIG naming what differs: a missing calibration, one
 * expired (and when), of another rig or detector, or without the
 * integration or gain state. meta_out may be NULL. */
int cal_select(const char *root, const char *id, const struct cal_need *need,
               struct cal_meta *meta_out, struct gonio_err *err);

/* The dark calibration a reference is taken with: id, or the newest valid
 * one for the rig and detector covering the integration. */
int cal_select_dark(const char *root, const char *id, const struct cal_need *need,
                    struct cal_meta *meta_out, struct gonio_err *err);

/* The stray calibration a reference subtracts: id, or ("newest") the
 * newest valid one for the rig and detector; it must have been taken with
 * dark (the reference's dark, by which its frames are reduced). */
int cal_select_stray(const char *root, const char *id, const char *dark,
                     const struct cal_need *need, struct cal_meta *meta_out,
                     struct gonio_err *err);

/* The drift a capture's reference read again after its points shows
 * (capture/reference_after.h): the standard's response then over the
 * calibration's, per channel, and that ratio's relative standard
 * uncertainty; t_end_s, the capture's rig time where it stands (its last
 * sample's). The reduction interpolates it linearly in rig time from 1 at
 * the capture's start (docs/radiometry.md, "Drift"). on 0: none. */
struct cal_drift {
    int on;
    double t_end_s, q[3], u_q[3];
    size_t geometries, frames;
};

/* A loaded calibration: the reduction's inputs, owning their arrays. */
struct cal_bands;
struct cal_loaded {
    struct cal_meta meta, dark_meta;
    double full_scale, nonlinearity; /* the detector's, as its reference frames said */
    struct rad_dark *darks;
    struct rad_ref *refs;
    struct rad_ref *strays; /* NULL: the reference names no stray calibration */
    struct rad_calibration cal;
    /* a spectral detector's: the same per band (capture/calibration_bands.h);
     * NULL when its frames hold no bands */
    struct cal_bands *bands;
    struct cal_drift drift; /* a capture's, set once its reference is read again */
};

/* Load reference calibration id and its dark (and its stray light when it
 * names one), derive the reduction's inputs, and load its standard. */
int cal_load(const char *root, const char *id, struct cal_loaded *out, struct gonio_err *err);
void cal_loaded_free(struct cal_loaded *c);

/* results.json's "calibration" member: the calibration's id, dark,
 * standard and its warning, and the budget table, per term its kind
 * (systematic or per sample) and median relative u per channel over the
 * reduced values, with the combined one. A new JSON object (jansson's
 * json_t; NULL when out of memory). */
struct json_t;
struct json_t *cal_budget_json(const struct cal_loaded *cl, const struct rad_value *v,
                               size_t n);

/* Reduce a counts record of the capture (journal.h) as it is measured:
 * s->rgb and s->u from its raw counts at its plan point's angles, the
 * angle term's slopes from the records done so far on its lines; the
 * budget in *v. A record without counts, or a dark frame, is left as it
 * is. The capture and gonio recalibrate (capture_recalibrate) both reduce
 * through this, each
 * record with the records before it in the journal, so that the two agree
 * bit for bit. plan: the points the records index (a loaded plan, or a
 * capture directory's plan.json). */
struct journal_sample;
int cal_reduce_sample(const struct cal_loaded *cl, const struct journal_plan *plan,
                      const struct journal_sample *done, size_t n_done,
                      struct journal_sample *s, struct rad_value *v, struct gonio_err *err);

/* Reduce a reading taken at pt that is no record of the capture's plan
 * (a premise check's): as cal_reduce_sample, with the calibration's dark
 * at the reading's integration, and no neighbours (the angle term from the
 * standard's slopes alone). */
int cal_reduce_reading(const struct cal_loaded *cl, const struct plan_point *pt,
                       struct journal_sample *s, struct gonio_err *err);

/* The theta_r at which the reference's instrument factor is taken for a
 * reading at pt: its own in the plane; out of it, +theta_o, the in-plane
 * pair whose sample tilt and arm angle the rig's three-axis mapping
 * shares (planner/planner.h, plan_point_place: the azimuth turns the
 * detector's plane, not the arm). */
double cal_instrument_theta_r(const struct plan_point *pt);

/* Add the budget table (cal_budget_json) of the capture's counts records,
 * reduced together, to DIR/results.json as its "calibration" member. */
int cal_results_budget(const struct cal_loaded *cl, const struct journal_plan *plan,
                       const struct journal_sample *samples, size_t n, const char *dir,
                       struct gonio_err *err);

/* The derivation alone, from frames (tests, recalibration). */
int cal_derive(const struct cal_frame *dark, size_t n_dark, const struct cal_frame *ref,
               size_t n_ref, struct cal_loaded *out, struct gonio_err *err);

/* The stray readings' means per geometry from a stray calibration's frames,
 * into out (after cal_derive). */
int cal_derive_stray(const struct cal_frame *stray, size_t n, struct cal_loaded *out,
                     struct gonio_err *err);

#endif
