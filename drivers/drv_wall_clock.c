/* The rig clock of hardware whose detector keeps no time of its own (the
 * USB spectrometer): the monotonic wall clock, from the clock's creation.
 * Its sleeps (the settle) ask the host's cancel check every 50 ms, as the
 * Modbus bus's waits do. */
#include <errno.h>
#include <stdlib.h>
#include <time.h>

#include "common/clock.h"
#include "drivers/drivers_private.h"

struct wall_clock {
    double t0;
    int (*cancelled)(void *user);
    void *user;
};

static double wall_now(void *priv)
{
    return gonio_monotonic_s() - ((struct wall_clock *)priv)->t0;
}

static int wall_sleep(void *priv, double seconds)
{
    struct wall_clock *c = priv;
    double end = gonio_monotonic_s() + seconds;
    for (double left = seconds; left > 0; left = end - gonio_monotonic_s()) {
        if (c->cancelled && c->cancelled(c->user))
            return -ECANCELED;
        double slice = left < 0.05 ? left : 0.05;
        struct timespec ts = {(time_t)slice, (long)((slice - (time_t)slice) * 1e9)};
        while (nanosleep(&ts, &ts) < 0)
            if (errno != EINTR)
                return -errno;
    }
    return 0;
}

static const struct drv_clock_ops wall_clock_ops = {
    .name = "wall",
    .now = wall_now,
    .sleep = wall_sleep,
    .free_priv = free,
};

drv_clock *drv_clock_new_wall(int (*cancelled)(void *user), void *user)
{
    struct wall_clock *c = malloc(sizeof *c);
    if (!c)
        return NULL;
    *c = (struct wall_clock){.t0 = gonio_monotonic_s(), .cancelled = cancelled, .user = user};
    return drv_clock_alloc(&wall_clock_ops, c);
}
