/* The capture engine: runs a plan on a rig, journals every sample, fits the
 * model and writes the capture directory (DESIGN.md sections 7 and 8).
 *
 * The engine takes its devices from the host as a rig source (struct
 * capture_rig): goniod's Modbus rig, or the in-process simulator a host
 * builds (sim_source/sim_source.h). It knows no simulator: what the rig
 * measures is known only when the source says (the simulator's material);
 * elsewhere errors against a material are computed when the request names
 * a reference (truth). Everything a capture reads is validated before
 * anything is written, so bad input leaves no directory behind. */
#ifndef GONIO_CAPTURE_CAPTURE_H
#define GONIO_CAPTURE_CAPTURE_H

#include <stddef.h>

#include "adaptive/adaptive.h"
#include "capture/checks.h"
#include "capture/isotropy_check.h"
#include "capture/oop_check.h"
#include "brdf/abc.h"
#include "fit/auto_evidence.h"
#include "fit/fit.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "common/err.h"
#include "journal/journal.h"
#include "drivers/drivers.h"
#include "planner/planner.h"
#include "rig/rig.h"

struct drv_axis;
struct drv_detector;
struct drv_clock;

struct capture_config {
    const char *plan;     /* name (ds2) or path */
    /* A detector's counts reduced to BRDF as they are measured: the
     * reference calibration `calibration` (an id; NULL: the newest valid
     * one for the rig and detector) in the folder `calibrations`
     * (capture/calibration.h). NULL calibrations: none. A calibration
     * that is missing, expired, of another rig or detector or without the
     * rig's integration is refused before anything moves. */
    const char *calibration, *calibrations;
    /* What the rig measures, as a label in setup.json and results.json
     * (NULL: unknown) when its source does not know it (capture_rig.material). */
    const char *material;
    const char *rig;      /* the rig profile; NULL: the source's (capture_rig.profile) */
    /* The operator's metadata, in setup.json and results.json (NULL or "":
     * not given): the sample's name, who ran the capture, a note. A resume
     * keeps what the capture began with. */
    const char *sample, *operator_name, *note;
    /* The reference for the in-plane and full-domain errors (a material
     * spec), labelled with it in results.json. NULL: what the rig source
     * says it measures; otherwise no such errors. */
    const char *truth;
    const char *model;    /* any RGB model of the registry (fit/models.h); the
                             streaming fit of --stop converge is ABC whatever it is */
    const char *out_dir;  /* the capture directory */
    const char *order;    /* overrides the plan's ordering, or NULL */
    const char *stop;     /* "all" or "converge": overrides the plan's stop rule, or NULL */
    /* The adaptive order (order "adaptive", or a plan that declares it):
     * the policy (adaptive/adaptive.h) chooses each next point from the
     * plan's pairs and predicts the error of `model`; it stops before the
     * rig time passes budget_min minutes, once its predicted full-domain
     * log error is at most stop_target, with stop converge once the
     * predicted gain per minute is below its tolerance, else when the pool
     * is exhausted. 0: no budget, no target. Refused in other orders. */
    double budget_min, stop_target;
    int quiet;            /* the host shows no progress (gonio capture --quiet) */
    /* gonio study: measure and journal only (no fit, no truth errors, no
     * results.json: the study fits its models itself), and journal without
     * fdatasync per sample (journal_set_lazy). */
    int measure_only;
    int lazy_journal;
    /* The truth errors' full domain: 0, all its ~924k nodes; N, a seeded
     * sample of N of them (brdf_domain_oop_random), which estimates the
     * same mean for hosts that cannot afford the full evaluation (goniod's
     * assess_nodes; the tests under valgrind). results.json gives the
     * count either way. */
    size_t assess_nodes;
    /* Run the streaming fit with stop: all too, for on_fit (goniod's
     * progress figures): a round when the sample count reaches 16, 32,
     * 64... (the cost of them all stays below twice the final fit's). */
    int progress_fit;
    /* A pre-scan (docs/plans.md, "Estimates on a real day"): this many of
     * the plan's points, spread over it, measured first, so that the ETA
     * counts the integration the detector chooses from early on. They are
     * journalled as any sample (the fit uses them) and the plan's order
     * skips them. 0: the default (on a host's rig CAPTURE_PRESCAN_DEFAULT
     * points, or one in CAPTURE_PRESCAN_SHARE of a smaller plan's, none
     * when that is fewer than 2; none on a rig whose source knows each
     * point's integration (capture_rig.integration_s), none in the adaptive
     * order); CAPTURE_PRESCAN_OFF: none; else
     * 1..CAPTURE_PRESCAN_MAX (refused in the adaptive order). */
    int prescan;
    /* The premise checks (capture/checks.h, docs/checks.md), CAPTURE_CHECK_*
     * bits: after the last point, the isotropy check (capture/isotropy_check.h)
     * on the rig's rotation axis; after the final fit, the in-plane
     * sufficiency check (capture/oop_check.h) on its azimuth axis. Refused
     * on a rig profile without the axis. */
    unsigned checks;
    /* A detector that gives counts is captured without a calibration: its
     * counts are journalled and nothing is fitted (results.json's
     * not_fitted says why). Without it such a capture is refused before
     * the first move (capture/calibration.h). */
    int uncalibrated;
    /* A calibrated capture reads its reference standard again after its
     * last point, at a few of the calibration's geometries, and reduces
     * its samples with the drift interpolated in rig time between the two
     * (capture/reference_after.h, docs/radiometry.md "Drift"). The
     * standard is mounted by the rig's sample changer (capture_rig.mount),
     * else the operator is asked (capture_hooks.ask). */
    int reference_after;
    /* Only the estimate is wanted (gonio plan --scene, capture_check): nothing
     * is measured, so a detector of counts needs no calibration. */
    int estimate_only;
};

#define CAPTURE_PRESCAN_OFF (-1)
#define CAPTURE_PRESCAN_DEFAULT 12
#define CAPTURE_PRESCAN_SHARE 25
#define CAPTURE_PRESCAN_MAX 64

struct capture_summary {
    char plan[128], model[32];
    char material[512]; /* what was measured, "" when unknown (hardware without a label) */
    char truth[512];    /* the reference of err_inplane/err_full, "" without one */
    size_t samples;
    size_t saturated; /* samples the detector saturated (fitted as fit_model_censors says) */
    double rig_time_s, move_s, settle_s, integration_s;
    /* Rig clock that ran while this run was paused: not in rig_time_s. */
    double paused_s;
    double fit_time_s;
    int converged;
    int has_params;         /* abc, abc-prior: params and sd hold the ABC fit */
    struct brdf_abc params;
    char model_file[64];    /* the final fit's model file in the directory (NAME.model,
                               the name and format gonio fit writes), else "" */
    struct brdf_errors err_plan, err_inplane, err_full;
    int has_truth; /* inplane/full errors computed against truth */
    /* "complete", "converged" (stop rule), "aborted"; the adaptive order's
     * policy also "target", "budget", "exhausted" */
    char stop_reason[32];
    struct fit_uncertainty sd; /* parameter sds of an ABC final fit (fit/fit.h) */
    int sd_measured; /* 1: sd from the samples' u and the shared systematic term */
    char warning[256];         /* abc-prior: "too few samples" warning, or "" */
    struct drv_axis_stats mech; /* this run's axis mechanics, all axes (drivers.h) */
    struct fit_status status;  /* what the final fit can know (fit/fit_status.h) */
    /* The adaptive order: its options, the policy's prediction at the stop
     * with every sample in, and the wall time of its decisions (each an
     * adaptive_add and an adaptive_next, made while the rig measured the
     * point before) and how long the engine waited for them after a point. */
    int adaptive;
    double budget_s, target; /* 0: none */
    int converge;
    struct adaptive_status policy;
    size_t decisions;
    double decision_mean_s, decision_max_s, decision_wait_s;
    int has_isotropy; /* the isotropy check ran: its verdict and rig time */
    struct iso_check_result isotropy;
    int has_oop; /* the in-plane sufficiency check ran: its verdict and rig time */
    struct oop_check_result oop;
    /* --model auto: the model it chose, what the checks' evidence decided
     * ("" when nothing) and the evidence (fit/auto_evidence.h; oop holds
     * the chosen model's check, its rig time that of every candidate's). */
    char auto_chosen[16];
    char auto_why[320];
    struct fit_auto_evidence auto_evidence;
    /* Why no model was fitted ("" when one was): counts not reduced. */
    char not_fitted[160];
    size_t darks;   /* dark frames journalled (auto-ranging) */
    size_t retakes; /* readings auto-ranging took again, this run */
};

/* The devices a capture runs on. */
struct capture_devices {
    struct drv_axis *sample, *arm, *azimuth; /* azimuth may be NULL for in-plane rigs */
    struct drv_axis *rotation; /* the sample about its normal; NULL on rigs without */
    struct drv_detector *detector;
    struct drv_clock *clock;
    /* 1: the detector said at open that it gives counts (a Modbus
     * detector's status RAW): the capture is refused before the first
     * move without a calibration or --uncalibrated, and a reading of BRDF
     * from it is a device fault. */
    int counts;
};

/* What a sample changer holds in the sample's place (docs/protocol-modbus.md,
 * "Sample changer"): the sample, the reference standard, a light trap (what
 * a stray-light calibration reads). The values are the changer's slots. */
enum capture_slot { CAPTURE_SLOT_SAMPLE = 0, CAPTURE_SLOT_STANDARD = 1, CAPTURE_SLOT_TRAP = 2 };

/* A rig source: the devices a host hands the engine, and what it knows of
 * them. open and close are required; every other member may be NULL. */
struct capture_rig {
    /* Open the devices for a capture on the rig profile rig (valid until
     * close) into the capture directory dir (where a backend may keep its
     * own records, the simulator's spectra.csv). */
    int (*open)(void *user, const struct rig_profile *rig, const char *dir,
                struct capture_devices *dev, struct gonio_err *err);
    void (*close)(void *user, struct capture_devices *dev);
    /* The integration the detector will choose at pt, known before it is
     * measured (the simulator meters its material): the estimate, the ETA
     * and the adaptive policy's costs count it, and no pre-scan is made by
     * default. NULL: the rig's fixed integration, then the journal's. */
    double (*integration_s)(void *user, const struct plan_point *pt);
    /* A resumed capture, after open: put the devices where the interrupted
     * run left them, the axes at at (sample, arm, azimuth) and the rig
     * clock at rig_time_s. NULL: a real rig's stay where they are. */
    void (*resume)(void *user, struct capture_devices *dev, const double at[3],
                   double rig_time_s);
    /* What setup.json records: the rig profile when the capture names
     * none, the driver kind and the detector (NULL: "unknown"), and
     * further members as a JSON object's text (the simulator's "scene"), compared on a resume as the rest is. */
    const char *profile, *driver, *detector, *setup_json;
    /* 1: the detector gives counts, known before the first reading (the
     * calibration check refuses before anything is written); 0: BRDF, or
     * not known, then checked at the first reading. */
    int counts;
    /* counts: what the detector states of its ADC (setup.json's "counts"):
     * the largest count, and its nonlinearity k (drivers.h). */
    double counts_full_scale, counts_nonlinearity;
    /* What the rig measures, when the source knows (the simulator): its
     * label, and the reference of the truth errors unless truth names one. */
    const brdf_material *material;
    /* Put slot in the sample's place: the rig's sample changer (the
     * standard: standard names it, as calibration.json has it). NULL: the
     * rig has none, the operator swaps them. */
    int (*mount)(void *user, struct capture_devices *dev, enum capture_slot slot,
                 const char *standard, struct gonio_err *err);
    void *user;
};

/* CAPTURE_PAUSED: go on, after the host held the capture paused; the rig
 * clock that ran meanwhile is paused time, not rig time. */
enum capture_control { CAPTURE_GO = 0, CAPTURE_ABORT = 1, CAPTURE_PAUSED = 2 };

/* What the engine is doing, for hosts that report it (goniod's phase log,
 * which the crash torture reads to know where each kill landed). MOVE
 * starts once the axes are commanded, ACQUIRE covers settle and
 * integration, JOURNAL the record's write and fdatasync, FIT a streaming
 * fit round the engine forces (point: the sample count) and the final fit
 * and its assessment (point -1); BETWEEN follows each of them. */
enum capture_phase {
    CAPTURE_PHASE_BETWEEN,
    CAPTURE_PHASE_MOVE,
    CAPTURE_PHASE_ACQUIRE,
    CAPTURE_PHASE_JOURNAL,
    CAPTURE_PHASE_FIT,
};

/* "between", "move", "acquire", "journal", "fit". */
const char *capture_phase_name(enum capture_phase phase);

/* Where a capture stands, for a host's progress display (on_progress). */
struct capture_progress {
    const char *plan;
    size_t done, total;  /* samples journalled (all runs), planned points */
    size_t already_done; /* journalled by earlier runs: this run resumed */
    double rig_time_s;   /* the rig clock so far, all runs, paused time excluded */
    /* The whole capture's rig time as estimated before the first move
     * (with the integration the rig source says its detector will choose,
     * capture_rig.integration_s; in the capture's order, a pre-scan's detours
     * included), and the rig time still to go: the points left with
     * the integration measured nearest each and the overhead per point the
     * journal shows (capture/eta.h). */
    double estimate_s, eta_s;
    double fit_log_error; /* the latest streaming fit round's, NAN before one */
    size_t prescan;       /* the points the pre-scan measures first, 0: none */
    /* The adaptive order's latest prediction, NULL in other orders; total
     * is then the pool's size, estimate_s the budget (NAN: none) and eta_s
     * the budget left. */
    const struct adaptive_status *policy;
};

/* How a host (gonio, goniod) takes part in a capture. Every member may be
 * NULL. */
struct capture_hooks {
    /* Called after each sample is journalled (and after the streaming fit
     * round it set off, so that the host's figures include it). */
    void (*on_sample)(void *user, const struct journal_sample *s, size_t done, size_t total);
    /* Asked once before anything is written (CAPTURE_ABORT there: an
     * aborted capture and no files) and at every point boundary; a host
     * pauses a capture by blocking here (then returning CAPTURE_PAUSED),
     * and aborts it by returning CAPTURE_ABORT. */
    enum capture_control (*control)(void *user);
    /* Called after each round of the streaming fit (stop: converge, or
     * progress_fit) with its in-sample errors over the samples so far. */
    void (*on_fit)(void *user, const struct brdf_errors *e, size_t samples);
    /* Called as the engine enters a phase (point: the plan index, -1 for
     * the final fit). The host may take its time here: the crash torture
     * widens phases this way. */
    void (*on_phase)(void *user, enum capture_phase phase, int point);
    /* Called once the inputs are resolved and the directory is ready (the
     * run's start: done = already_done) and after each sample (before
     * on_sample): what a progress display shows. */
    void (*on_progress)(void *user, const struct capture_progress *p);
    /* The operator must act before the engine goes on (mount the standard
     * on a rig without a sample changer): returns once they have (the host
     * holds the capture paused meanwhile), or CAPTURE_ABORT. NULL: nobody
     * to ask, and what needs one is refused before the first move. */
    enum capture_control (*ask)(void *user, const char *instruction);
    void *user;
};

/* A count of pre-scan points as an operator gives it (0: none) into
 * capture_config.prescan; -GONIO_EUSAGE naming opt (--prescan, goniod's
 * prescan field) outside 0..CAPTURE_PRESCAN_MAX. */
int capture_prescan_option(const char *opt, long long points, int *prescan,
                           struct gonio_err *err);

/* A prepared capture: its inputs resolved and validated once (plan, rig
 * profile, order, model, stop rule, adaptive options, pre-scan, material,
 * truth and the rig-time estimate), for the check a host makes before it
 * answers and for the run that follows. */
typedef struct capture_job capture_job;

/* Prepare a capture of cfg (copied) on the devices of rig (borrowed: it
 * must outlive the job), writing nothing: bad input is refused here, as
 * goniod refuses a bad request before it answers. Returns 0 with *job, or
 * a negative code with err filled (see gonio_exit_status). */
int capture_prepare(const struct capture_config *cfg, const struct capture_rig *rig,
                    capture_job **job, struct gonio_err *err);

/* The capture's rig-time estimate, before it runs. */
const struct plan_estimate *capture_job_estimate(const capture_job *job);

/* Run a prepared capture (once): prepare the directory (or resume it: the
 * same plan, rig description, material, detector and adaptive options
 * only, else -GONIO_EUSAGE naming the difference), holding its lock until
 * the end (another writer: EBUSY, nothing written), measure the points
 * the journal lacks (in the adaptive order: those the policy chooses,
 * capture/sequence.h), fit and write results.json. An aborted capture
 * keeps its samples, stops the axes and returns 0 with stop_reason
 * "aborted" (no fit, no results.json); so does one whose devices fail with
 * -ECANCELED (a host that cancels their waits, drv_modbus_bus_set_cancel),
 * journalling nothing of the point they interrupted. hooks may be NULL. Returns a
 * negative code with err filled on failure. */
int capture_job_run(capture_job *job, const struct capture_hooks *hooks,
                    struct capture_summary *out, struct gonio_err *err);

void capture_job_free(capture_job *job);

/* capture_prepare, capture_job_run and capture_job_free in one. */
int capture_run(const struct capture_config *cfg, const struct capture_rig *rig,
                const struct capture_hooks *hooks, struct capture_summary *out,
                struct gonio_err *err);

/* capture_prepare and the estimate (est, may be NULL), writing nothing. */
int capture_check(const struct capture_config *cfg, const struct capture_rig *rig,
                  struct plan_estimate *est, struct gonio_err *err);

/* gonio recalibrate: the raw counts journalled in capture DIR reduced
 * again with reference calibration ID of ROOT (capture/calibration.h), in
 * the capture's order and through the same per-record reduction, and
 * refitted with the capture's model, into the new directory OUT (plan.json,
 * setup.json naming ID and DIR, samples.csv, the model file, results.json
 * with the budget). DIR is only read. Refused (-GONIO_EBADCONFIG, naming
 * what differs) for a capture without raw counts or a calibration of
 * another rig or detector; -GONIO_EUSAGE when OUT already holds a capture.
 * The refit starts cold, as a capture with stop: all does. */
int capture_recalibrate(const char *dir, const char *root, const char *id, const char *out,
                        struct gonio_err *err);

/* The most rig time auto-ranging (a detector of counts) can add to an
 * estimate at rig's fixed integration over `points` points: each at the
 * longest rung instead, and a dark frame at every rung. An estimate
 * before the first move cannot know the material; this is its bound
 * (docs/plans.md, "Auto-ranging"). 0 where the rig cannot range longer. */
double capture_ranging_bound_s(const struct rig_profile *rig, size_t points);

#endif
