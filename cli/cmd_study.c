/* gonio study: run a study's jobs in worker processes, show progress, and
 * gather the rows; gonio study merge: join shard folders (docs/study.md). */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli/commands.h"
#include "cli/interrupt.h"
#include "capture/checks.h"
#include "cli/progress.h"
#include "common/clock.h"
#include "rig/rig.h"
#include "render/scene.h"
#include "render/study.h"
#include "report/page.h"
#include "study/study.h"

/* Pixels a side of each sphere a complete study renders (gonio render
 * --study draws them at any size). */
#define STUDY_RENDER_SIZE 96

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio study [--quick] [--materials LIST] [--plans LIST] [--models LIST]\n"
            "                   [--scenes LIST] [--jobs N] [--shard I/N] [--list] [--quiet]\n"
            "                   [--check LIST] [--rig NAME]\n"
            "                   --out DIR\n"
            "       gonio study merge DIR... --out DIR\n"
            "  Every material x scene x plan x model on the in-process simulated rig; one\n"
            "  row per combination in DIR/results.csv and DIR/results.json. LISTs are\n"
            "  comma-separated:\n"
            "    --materials  MERL names of ../shared (nylon,...), default, or specs (abc:NAME)\n"
            "    --plans      ds1,ds2,ds3,ds4,progressive,inplane-full,oop200k, or plan files\n"
            "                 (a path, or NAME.yaml: named by the file, as the file declares)\n"
            "    --models     abc,abc-prior,mlp,latent\n"
            "    --scenes     scene names or files (ideal,lab)\n"
            "  --quick: 3 materials, plans ds1,ds2,ds4,progressive, models abc,latent.\n"
            "  --saturated censored|clipped: fit saturated readings as lower bounds or at\n"
            "  their clipped values; default: each model's (docs/fitting.md).\n"
            "  --jobs N: worker processes (default: the number of cores). --shard I/N: run\n"
            "  only share I of N (merge the shares with gonio study merge). --list: print\n"
            "  the job ids and exit. Rerunning on DIR resumes: finished rows are kept.\n"
            "  --quiet: no progress display (the summary lines and errors stay).\n"
            "  --check isotropy,out-of-plane: the premise checks on every job's capture\n"
            "  (docs/checks.md), on the rig profile --rig NAME (default: the default rig);\n"
            "  their verdicts and rig time are the rows' isotropy and oop columns.\n"
            "  A complete study (or merge) also writes DIR/renders/, DIR/plots/ and\n"
            "  DIR/report.html (gonio render --study, gonio report; docs/report.md).\n");
}

/* The renderings, figures and HTML page of a complete study (render/study.h,
 * report/page.h). Renderings are a view of the rows: when they cannot be
 * drawn (no model that predicts out of plane), the page says so and the
 * study still succeeds. */
static int write_report(const char *dir)
{
    char plots[4096];
    snprintf(plots, sizeof plots, "%s/plots", dir);
    struct gonio_err err = {0};
    struct render_scene sc;
    if (render_scene_load("default", &sc, &err) < 0 ||
        render_study_write(dir, NULL, &sc, STUDY_RENDER_SIZE, 0, NULL, NULL, &err) < 0)
        fprintf(stderr, "gonio study: renderings left out: %s\n", err.msg);
    memset(&err, 0, sizeof err);
    if (report_write_page(dir, &(struct report_page_opts){.plots_dir = plots, .quiet = 1},
                          &err) < 0) {
        fprintf(stderr, "gonio study: report: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    fprintf(stderr, "study: %s/report.html, figures in %s\n", dir, plots);
    return 0;
}

static double cpu_children_s(void)
{
    struct rusage ru;
    getrusage(RUSAGE_CHILDREN, &ru);
    return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
           (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec;
}

static int cmd_study_merge(int argc, char **argv)
{
    static const struct option opts[] = {
        {"out", required_argument, NULL, 'o'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *out = NULL;
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'o': out = optarg; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (!out || optind >= argc) {
        fprintf(stderr, "gonio study merge: at least one DIR and --out are required\n");
        return 2;
    }
    struct gonio_err err = {0};
    int rc = study_merge((const char *const *)argv + optind, (size_t)(argc - optind), out, &err);
    if (rc < 0) {
        fprintf(stderr, "gonio study merge: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    if (rc > 0) {
        fprintf(stderr, "gonio study merge: %s: %d rows missing (listed in results.json)\n", out,
                rc);
        return 1;
    }
    printf("merged %d folders into %s\n", argc - optind, out);
    return write_report(out);
}

struct running {
    pid_t pid;
    size_t job; /* index into the pending list */
    double t0;
};

/* Run one job in this (child) process and exit. */
static void child_run(const struct study_spec *s, const struct study_job *job, const char *dir)
{
    /* Die with the parent: an orphaned worker would hold its job's lock. */
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() == 1)
        _exit(1);
    struct gonio_err err = {0};
    int rc = study_job_run(s, job, dir, interrupt_signal, &err);
    if (rc == -EINTR)
        _exit(INTERRUPT_EXIT); /* the parent says what to do */
    if (rc < 0) {
        fprintf(stderr, "gonio study: %s\n", err.msg);
        fflush(stderr);
        _exit(gonio_exit_status(err.code));
    }
    _exit(0);
}

struct pending {
    struct study_job job;
    double weight;
};

/* Material by material, and within a material the big jobs first: an
 * interrupted study then holds whole materials, and no long job of a
 * material starts last. */
static int by_weight(const void *a, const void *b)
{
    const struct pending *x = a, *y = b;
    if (x->job.material != y->job.material)
        return x->job.material < y->job.material ? -1 : 1;
    if (x->weight != y->weight)
        return x->weight > y->weight ? -1 : 1;
    return x->job.index < y->job.index ? -1 : x->job.index > y->job.index;
}

/* Pass a signal only the parent got (SIGTERM from a service manager) on
 * to the workers, once: each ends its job at the next point boundary. */
static void pass_on_interrupt(const struct running *run, int n_workers, int *passed)
{
    if (!interrupt_signal() || *passed)
        return;
    *passed = 1;
    for (int w = 0; w < n_workers; w++)
        if (run[w].pid > 0)
            kill(run[w].pid, SIGTERM);
}

/* One run of a study's jobs: the jobs of the shard still to run, the
 * workers running them, and the counts the progress and the summary
 * report. */
struct study_run {
    const struct study_spec *s;
    const char *dir;
    int n_workers;
    struct pending *p; /* the jobs to run, in by_weight order */
    size_t n;
    size_t total;    /* jobs in the shard */
    size_t finished; /* of those, done before this run */
    size_t started;  /* of those to run, interrupted before (journal kept) */
    double weight_all, weight_done;
    struct running *run; /* a slot per worker; pid 0 when free */
    struct progress bar;
    double t_start;
    size_t next, done, failed, stopped;
    int active, passed;
};

/* The shard's jobs still to run into r->p, heaviest first per material
 * (by_weight), counting those finished and started before. Returns 0, or
 * -1 when out of memory. */
static int list_pending(struct study_run *r)
{
    const struct study_spec *s = r->s;
    struct pending *p = malloc((study_job_count(s) + 1) * sizeof *p);
    if (!p)
        return -1;
    for (size_t k = 0; k < study_job_count(s); k++) {
        if (!study_job_in_shard(s, k))
            continue;
        r->total++;
        study_job_at(s, k, &p[r->n].job);
        if (study_job_rows_done(s, &p[r->n].job, r->dir) == s->n_models) {
            r->finished++;
            continue;
        }
        p[r->n].weight = study_job_weight(s, &p[r->n].job);
        char journal[4200];
        struct stat st;
        snprintf(journal, sizeof journal, "%s/jobs/%s/samples.csv", r->dir, p[r->n].job.id);
        r->started += stat(journal, &st) == 0; /* an interrupted job: its capture resumes */
        r->n++;
    }
    qsort(p, r->n, sizeof *p, by_weight);
    for (size_t i = 0; i < r->n; i++)
        r->weight_all += p[i].weight;
    r->p = p;
    return 0;
}

/* Fork workers for the next jobs while a worker is free and no
 * interrupt came. */
static void start_workers(struct study_run *r)
{
    while (r->active < r->n_workers && r->next < r->n && !interrupt_signal()) {
        fflush(stdout);
        fflush(stderr);
        pid_t pid = fork();
        if (pid < 0) {
            fprintf(stderr, "gonio study: fork: %s\n", strerror(errno));
            break;
        }
        if (pid == 0)
            child_run(r->s, &r->p[r->next].job, r->dir);
        for (int w = 0; w < r->n_workers; w++)
            if (r->run[w].pid == 0) {
                r->run[w] = (struct running){pid, r->next, gonio_monotonic_s()};
                break;
            }
        r->active++;
        r->next++;
    }
}

/* Worker pid ended with status: count its job done, failed or stopped
 * (interrupted), and show the progress. */
static void job_ended(struct study_run *r, pid_t pid, int status)
{
    for (int w = 0; w < r->n_workers; w++) {
        if (r->run[w].pid != pid)
            continue;
        const struct pending *q = &r->p[r->run[w].job];
        int ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
        r->run[w].pid = 0;
        r->active--;
        if (WIFEXITED(status) && WEXITSTATUS(status) == INTERRUPT_EXIT) {
            r->stopped++; /* its journal is kept: the rerun resumes it */
            continue;
        }
        r->done++;
        r->failed += !ok;
        r->weight_done += q->weight;
        double elapsed = gonio_monotonic_s() - r->t_start;
        if (!ok)
            progress_note(&r->bar, "study: %s %s after %.1f s", q->job.id,
                          WIFSIGNALED(status) ? "killed" : "FAILED",
                          gonio_monotonic_s() - r->run[w].t0);
        /* Wall time: the jobs' relative weights, scaled by the time
         * the finished ones took. */
        progress_show(&r->bar,
                      &(struct progress_state){
                          .done = r->finished + r->done, .total = r->total, .unit = "jobs",
                          .rig_time_s = NAN, .estimate_s = NAN,
                          .eta_s = elapsed * (r->weight_all - r->weight_done) / r->weight_done,
                          .fit_error = NAN});
    }
}

/* Keep n_workers jobs running until all are done, a fork or wait fails,
 * or an interrupt lets the running ones stop. */
static void run_workers(struct study_run *r)
{
    r->t_start = gonio_monotonic_s();
    while (r->done < r->n) {
        start_workers(r);
        if (r->active == 0) { /* fork failed, or interrupted, with nothing running */
            if (!interrupt_signal())
                r->failed += r->n - r->done;
            break;
        }
        int status;
        pid_t pid = wait(&status);
        pass_on_interrupt(r->run, r->n_workers, &r->passed);
        if (pid < 0) {
            if (errno == EINTR)
                continue;
            fprintf(stderr, "gonio study: wait: %s\n", strerror(errno));
            break;
        }
        job_ended(r, pid, status);
    }
}

static int run_jobs(const struct study_spec *s, const char *dir, int n_workers, int quiet)
{
    struct study_run r = {.s = s, .dir = dir, .n_workers = n_workers};
    if (list_pending(&r) < 0) {
        fprintf(stderr, "gonio study: out of memory\n");
        return 1;
    }
    fprintf(stderr,
            "study: %zu jobs (%zu rows) in shard %d/%d: %zu finished, %zu to run on %d "
            "workers\n",
            r.total, r.total * s->n_models, s->shard_i, s->shard_n, r.finished, r.n, n_workers);
    if (r.finished || r.started)
        fprintf(stderr, "study: resuming: %zu of %zu jobs done, %zu started (their journals are "
                        "resumed) in %s\n",
                r.finished, r.total, r.started, dir);
    progress_init(&r.bar, "study", quiet);
    progress_show(&r.bar, &(struct progress_state){.done = r.finished, .total = r.total,
                                                   .unit = "jobs", .rig_time_s = NAN,
                                                   .estimate_s = NAN, .eta_s = NAN,
                                                   .fit_error = NAN});
    r.run = calloc((size_t)n_workers, sizeof *r.run);
    if (!r.run) {
        free(r.p);
        fprintf(stderr, "gonio study: out of memory\n");
        return 1;
    }
    run_workers(&r);
    progress_end(&r.bar);
    free(r.run);
    free(r.p);
    if (interrupt_signal()) {
        fprintf(stderr,
                "study: %s: %zu of %zu jobs done, %zu stopped at a point with their journals "
                "kept; run the same command again to resume\n",
                interrupt_signal() == SIGTERM ? "SIGTERM" : "SIGINT", r.finished + r.done,
                r.total, r.stopped);
        return INTERRUPT_EXIT;
    }
    return r.failed ? 1 : 0;
}

/* --check and --rig into the spec: the rig profile must have the axes the
 * checks need (refused before any job runs, as gonio capture refuses). */
static int study_checks(struct study_spec *s, unsigned checks, const char *rig,
                        struct gonio_err *err)
{
    s->checks = checks;
    snprintf(s->rig, sizeof s->rig, "%s", rig ? rig : "");
    if (!checks)
        return 0;
    struct rig_profile rp;
    int rc = rig_profile_load(rig ? rig : "default", &rp, err);
    return rc < 0 ? rc : capture_checks_rig("--check", checks, &rp, rig ? rig : "default", err);
}

/* --list: the shard's job ids, one a line. */
static void list_jobs(const struct study_spec *s)
{
    for (size_t k = 0; k < study_job_count(s); k++) {
        if (!study_job_in_shard(s, k))
            continue;
        struct study_job job;
        study_job_at(s, k, &job);
        printf("%s\n", job.id);
    }
}

/* results.csv from the jobs' results, a line on what it holds, and the
 * report when the whole study is there: the exit status, given the run's. */
static int write_results(const struct study_spec *s, const char *out, double t0, int status)
{
    struct gonio_err err = {0};
    size_t missing = 0;
    if (study_results_write(s, out, &missing, &err) < 0) {
        fprintf(stderr, "gonio study: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    size_t rows = 0;
    for (size_t k = 0; k < study_job_count(s); k++)
        rows += study_job_in_shard(s, k) ? s->n_models : 0;
    fprintf(stderr, "study: %s/results.csv: %zu rows, %zu missing; wall %.1f s, worker CPU "
                    "%.1f s\n",
            out, rows - missing, missing, gonio_monotonic_s() - t0, cpu_children_s());
    if (missing && !status)
        status = 1;
    if (!missing && !status && s->shard_n == 1)
        status = write_report(out);
    return status;
}

int cmd_study(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "merge"))
        return cmd_study_merge(argc - 1, argv + 1);
    static const struct option opts[] = {
        {"quick", no_argument, NULL, 'q'},       {"materials", required_argument, NULL, 'M'},
        {"plans", required_argument, NULL, 'p'}, {"models", required_argument, NULL, 'm'},
        {"scenes", required_argument, NULL, 's'}, {"jobs", required_argument, NULL, 'j'},
        {"shard", required_argument, NULL, 'S'}, {"out", required_argument, NULL, 'o'},
        {"list", no_argument, NULL, 'l'},        {"help", no_argument, NULL, 'h'},
        {"saturated", required_argument, NULL, 'T'}, {"quiet", no_argument, NULL, 'Q'},
        {"check", required_argument, NULL, 'C'}, {"rig", required_argument, NULL, 'R'},
        {NULL, 0, NULL, 0},
    };
    const char *lists[4] = {NULL, NULL, NULL, NULL}, *shard = NULL, *out = NULL,
               *saturated = "default", *rig = NULL;
    unsigned checks = 0;
    struct gonio_err cerr = {0};
    long n_workers = sysconf(_SC_NPROCESSORS_ONLN);
    int quick = 0, list = 0, quiet = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        char *end;
        switch (c) {
        case 'q': quick = 1; break;
        case 'M': lists[STUDY_MATERIALS] = optarg; break;
        case 's': lists[STUDY_SCENES] = optarg; break;
        case 'p': lists[STUDY_PLANS] = optarg; break;
        case 'm': lists[STUDY_MODELS] = optarg; break;
        case 'S': shard = optarg; break;
        case 'o': out = optarg; break;
        case 'l': list = 1; break;
        case 'Q': quiet = 1; break;
        case 'T': saturated = optarg; break;
        case 'R': rig = optarg; break;
        case 'C':
            if (capture_checks_parse("--check", optarg, &checks, &cerr) < 0) {
                fprintf(stderr, "gonio study: %s\n", cerr.msg);
                return 2;
            }
            break;
        case 'j':
            errno = 0;
            n_workers = strtol(optarg, &end, 10);
            if (end == optarg || *end || errno || n_workers < 1 || n_workers > 64) {
                fprintf(stderr, "gonio study: --jobs '%s': use a number of workers 1..64\n",
                        optarg);
                return 2;
            }
            break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc) {
        fprintf(stderr, "gonio study: unexpected argument '%s'\n", argv[optind]);
        usage(stderr);
        return 2;
    }
    if (!out && !list) {
        fprintf(stderr, "gonio study: --out DIR is required\n");
        usage(stderr);
        return 2;
    }
    if (n_workers < 1)
        n_workers = 1;
    struct study_spec *s = malloc(sizeof *s);
    if (!s) {
        fprintf(stderr, "gonio study: out of memory\n");
        return 1;
    }
    struct gonio_err err = {0};
    int rc = study_spec_default(s, quick, &err);
    for (int i = 0; rc == 0 && i < 4; i++)
        if (lists[i])
            rc = study_spec_set(s, (enum study_list)i, lists[i], &err);
    if (rc == 0 && shard)
        rc = study_spec_set_shard(s, shard, &err);
    if (rc == 0)
        rc = study_checks(s, checks, rig, &err);
    if (rc == 0 && fit_saturated_parse(saturated, &s->saturated) < 0)
        rc = gonio_err_set(&err, GONIO_EUSAGE, "--saturated '%s': use censored or clipped",
                           saturated);
    if (rc < 0) {
        fprintf(stderr, "gonio study: %s\n", err.msg);
        free(s);
        return gonio_exit_status(err.code);
    }
    if (list) {
        list_jobs(s);
        free(s);
        return 0;
    }
    if ((rc = study_dir_prepare(s, out, &err)) < 0) {
        fprintf(stderr, "gonio study: %s\n", err.msg);
        free(s);
        return gonio_exit_status(err.code);
    }
    double t0 = gonio_monotonic_s();
    interrupt_catch();
    int status = run_jobs(s, out, (int)n_workers, quiet);
    if (status == INTERRUPT_EXIT) {
        free(s);
        return status;
    }
    status = write_results(s, out, t0, status);
    free(s);
    return status;
}
