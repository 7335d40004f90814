/* The capture engine: runs a plan on a rig, journals every sample, fits the
 * model and writes the capture directory (DESIGN.md sections 7 and 8).
 *
 * The same engine serves `gonio capture --offline` (in-process simulated
 * rig) and goniod. Everything a capture reads (scene, rig profile, plan,
 * material) is validated before anything is written, so bad input leaves
 * no directory behind. */
#ifndef GONIO_DAEMON_CAPTURE_H
#define GONIO_DAEMON_CAPTURE_H

#include <stddef.h>

#include "brdf/abc.h"
#include "fit/fit.h"
#include "brdf/metrics.h"
#include "common/err.h"
#include "daemon/journal.h"
#include "planner/rig.h"

struct drv_axis;
struct drv_detector;
struct drv_clock;

struct capture_config {
    const char *plan;     /* name (ds2) or path */
    const char *scene;    /* name or path */
    const char *material; /* overrides the scene's material, or NULL */
    const char *rig;      /* overrides the scene's rig profile, or NULL */
    const char *model;    /* any RGB model of the registry (fit/models.h); the
                             streaming fit of --stop converge is ABC whatever it is */
    const char *out_dir;  /* the capture directory */
    const char *order;    /* overrides the plan's ordering, or NULL */
    const char *stop;     /* "all" or "converge": overrides the plan's stop rule, or NULL */
    int quiet;            /* no progress lines on stderr */
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
};

struct capture_summary {
    char plan[128], material[512], model[32];
    size_t samples;
    size_t saturated; /* samples the detector saturated (fitted at their clipped value) */
    double rig_time_s, move_s, settle_s, integration_s;
    double fit_time_s;
    int converged;
    int has_params;         /* abc, abc-prior: params and sd hold the ABC fit */
    struct brdf_abc params;
    char model_file[64];    /* the final fit's model file in the directory (NAME.model,
                               the name and format gonio fit writes), else "" */
    struct brdf_errors err_plan, err_inplane, err_full;
    int has_truth; /* inplane/full errors computed against the known material */
    char stop_reason[32]; /* "complete", "converged" (stop rule), "aborted" */
    struct fit_uncertainty sd; /* parameter sds of an ABC final fit (fit/fit.h) */
    char warning[256];         /* abc-prior: "too few samples" warning, or "" */
    struct fit_status status;  /* what the final fit can know (fit/fit_status.h) */
};

/* The devices a capture runs on. */
struct capture_devices {
    struct drv_axis *sample, *arm, *azimuth; /* azimuth may be NULL for in-plane rigs */
    struct drv_detector *detector;
    struct drv_clock *clock;
};

enum capture_control { CAPTURE_GO = 0, CAPTURE_ABORT = 1 };

/* What the engine is doing, for hosts that report it (goniod's phase log,
 * which the crash torture reads to know where each kill landed). MOVE
 * starts once the axes are commanded, ACQUIRE covers settle and
 * integration, JOURNAL the record's write and fdatasync, FIT the final fit
 * and its assessment; BETWEEN follows each of them. */
enum capture_phase {
    CAPTURE_PHASE_BETWEEN,
    CAPTURE_PHASE_MOVE,
    CAPTURE_PHASE_ACQUIRE,
    CAPTURE_PHASE_JOURNAL,
    CAPTURE_PHASE_FIT,
};

/* "between", "move", "acquire", "journal", "fit". */
const char *capture_phase_name(enum capture_phase phase);

/* How a host (gonio, goniod) takes part in a capture. Every member may be
 * NULL. */
struct capture_hooks {
    /* Open the rig's devices; NULL: the in-process simulated rig reading the
     * capture's material. */
    int (*open_devices)(void *user, const struct plan_rig *rig, struct capture_devices *dev,
                        struct gonio_err *err);
    void (*close_devices)(void *user, struct capture_devices *dev);
    /* Called once the inputs are resolved and the directory is ready. */
    void (*on_start)(void *user, const char *plan, size_t total, size_t already_done);
    /* Called after each sample is journalled. */
    void (*on_sample)(void *user, const struct journal_sample *s, size_t done, size_t total);
    /* Asked at every point boundary; a host pauses a capture by blocking
     * here, and aborts it by returning CAPTURE_ABORT. */
    enum capture_control (*control)(void *user);
    /* Called as the engine enters a phase (point: the plan index, -1 for
     * the final fit). The host may take its time here: the crash torture
     * widens phases this way. */
    void (*on_phase)(void *user, enum capture_phase phase, int point);
    void *user;
};

/* Run a capture: resolve and validate the inputs, prepare the directory
 * (or resume it), measure the points the journal lacks, fit and write
 * results.json. An aborted capture keeps its samples, stops the axes and
 * returns 0 with stop_reason "aborted" (no fit, no results.json). Returns
 * a negative code with err filled on failure (see gonio_exit_status). */
int capture_run(const struct capture_config *cfg, const struct capture_hooks *hooks,
                struct capture_summary *out, struct gonio_err *err);

/* capture_run on the in-process simulated rig, with progress lines on
 * stderr unless cfg->quiet. */
int capture_run_offline(const struct capture_config *cfg, struct capture_summary *out,
                        struct gonio_err *err);

#endif
