#include "cli/progress.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <unistd.h>

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

/* "rig 0:29 of ~13:40  ETA 11:02  fit 0.0123", the parts the job has. */
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
            n += snprintf(buf + n, size - (size_t)n, " of ~%s estimated", b);
        }
    }
    if (isfinite(s->eta_s) && (size_t)n < size) {
        progress_hms(s->eta_s, a, sizeof a);
        n += snprintf(buf + n, size - (size_t)n, tty ? "  ETA %s" : ", ETA %s", a);
    }
    if (isfinite(s->fit_error) && (size_t)n < size)
        snprintf(buf + n, size - (size_t)n, tty ? "  fit %.4f" : ", fit error %.4f",
                 s->fit_error);
}

void progress_show(struct progress *p, const struct progress_state *s)
{
    if (p->quiet)
        return;
    char fig[160];
    figures(s, p->tty, fig, sizeof fig);
    if (!p->tty) {
        /* The first line, then one as each tenth begins (the last: done). */
        size_t tenth = s->total ? s->done * 10 / s->total : 10;
        if (tenth + 1 == p->last_tenth)
            return;
        p->last_tenth = tenth + 1;
        fprintf(stderr, "%s: %zu/%zu %s%s\n", p->label, s->done, s->total, s->unit, fig);
        return;
    }
    char bar[BAR_WIDTH + 1];
    size_t fill = s->total ? BAR_WIDTH * s->done / s->total : 0;
    for (size_t i = 0; i < BAR_WIDTH; i++)
        bar[i] = i < fill ? '#' : '.';
    bar[BAR_WIDTH] = '\0';
    char line[256];
    int n = snprintf(line, sizeof line, "%s [%s] %zu/%zu%s", p->label, bar, s->done, s->total,
                     fig);
    size_t len = n < 0 ? 0 : (size_t)n < sizeof line ? (size_t)n : sizeof line - 1;
    /* Redraw in place; spaces wipe what a longer line left. */
    fprintf(stderr, "\r%s%*s", line, p->drawn > len ? (int)(p->drawn - len) : 0, "");
    fflush(stderr);
    p->drawn = len;
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
