#include "cli/progress.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "adaptive/adaptive.h"

#define BAR_WIDTH 24

void progress_init(struct progress *p, const char *label, int quiet)
{
    p->label = label;
    p->quiet = quiet;
    p->tty = isatty(STDERR_FILENO);
    p->last_tenth = 0;
    p->drawn = 0;
}

void progress_hms(double s, char *buf, size_t size)
{
    long t = lround(s > 0 ? s : 0);
    if (t >= 3600)
        snprintf(buf, size, "%ld:%02ld:%02ld", t / 3600, t / 60 % 60, t % 60);
    else
        snprintf(buf, size, "%ld:%02ld", t / 60, t % 60);
}

/* "rig 0:29 of ~13:40  ETA 11:02  fit 0.0123", the parts the job has;
 * an adaptive capture's "rig 0:29 of 2:00 budget ... predicted error now
 * 0.031, 0.025 in ~4 min". */
static void figures(const struct progress_state *s, int tty, char *buf, size_t size)
{
    char a[32], b[32];
    int n = 0;
    buf[0] = '\0';
    if (isfinite(s->rig_time_s)) {
        progress_hms(s->rig_time_s, a, sizeof a);
        n += snprintf(buf + n, size - (size_t)n, tty ? "  rig %s" : ", rig time %s", a);
        if (isfinite(s->estimate_s) && (size_t)n < size) {
            progress_hms(s->estimate_s, b, sizeof b);
            n += snprintf(buf + n, size - (size_t)n, s->pool ? " of %s budget" : " of ~%s estimated",
                          b);
        }
    }
    if (s->pool && isfinite(s->predicted) && (size_t)n < size) {
        n += snprintf(buf + n, size - (size_t)n, "%spredicted error now %.3f%s", tty ? "  " : ", ",
                      s->predicted,
                      adaptive_prediction_rough(s->done) ? " (rough: few samples)" : "");
        if (isfinite(s->predicted_next) && isfinite(s->predicted_next_s) && (size_t)n < size)
            n += snprintf(buf + n, size - (size_t)n, ", %.3f in ~%.0f min", s->predicted_next,
                          fmax(1, s->predicted_next_s / 60));
    }
    if (isfinite(s->eta_s) && (size_t)n < size) {
        progress_hms(s->eta_s, a, sizeof a);
        n += snprintf(buf + n, size - (size_t)n, tty ? "  ETA %s" : ", ETA %s", a);
    }
    if (isfinite(s->fit_error) && (size_t)n < size)
        snprintf(buf + n, size - (size_t)n, tty ? "  fit %.4f" : ", fit error %.4f",
                 s->fit_error);
}

/* Redraw the bar's line in place; spaces wipe what a longer line left. */
static void redraw(struct progress *p, const char *line)
{
    size_t len = strlen(line);
    fprintf(stderr, "\r%s%*s", line, p->drawn > len ? (int)(p->drawn - len) : 0, "");
    fflush(stderr);
    p->drawn = len;
}

void progress_show(struct progress *p, const struct progress_state *s)
{
    if (p->quiet)
        return;
    char fig[224];
    figures(s, p->tty, fig, sizeof fig);
    if (!p->tty && s->pool) {
        /* The first line, then one each ten points. */
        if (p->last_tenth && s->done % 10)
            return;
        p->last_tenth = 1;
        fprintf(stderr, "%s: %zu %s (pool of %zu)%s\n", p->label, s->done, s->unit, s->total,
                fig);
        return;
    }
    if (!p->tty) {
        /* The first line, then one as each tenth begins (the last: done). */
        size_t tenth = s->total ? s->done * 10 / s->total : 10;
        if (tenth + 1 == p->last_tenth)
            return;
        p->last_tenth = tenth + 1;
        fprintf(stderr, "%s: %zu/%zu %s%s\n", p->label, s->done, s->total, s->unit, fig);
        return;
    }
    if (s->pool) {
        char line[256];
        snprintf(line, sizeof line, "%s %zu %s%s", p->label, s->done, s->unit, fig);
        redraw(p, line);
        return;
    }
    char bar[BAR_WIDTH + 1];
    size_t fill = s->total ? BAR_WIDTH * s->done / s->total : 0;
    for (size_t i = 0; i < BAR_WIDTH; i++)
        bar[i] = i < fill ? '#' : '.';
    bar[BAR_WIDTH] = '\0';
    char line[256];
    snprintf(line, sizeof line, "%s [%s] %zu/%zu%s", p->label, bar, s->done, s->total, fig);
    redraw(p, line);
}

void progress_end(struct progress *p)
{
    if (p->drawn)
        fputc('\n', stderr);
    p->drawn = 0;
}

void progress_note(struct progress *p, const char *fmt, ...)
{
    if (p->quiet)
        return;
    progress_end(p);
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}
