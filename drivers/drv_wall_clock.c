/* The rig clock of hardware whose detector keeps no time of its own (the
 * USB spectrometer): the monotonic wall clock, from the clock's creation. */
#include <errno.h>
#include <stdlib.h>
#include <time.h>

#include "common/clock.h"
#include "drivers/drivers_private.h"

static double wall_now(void *priv)
{
    return gonio_monotonic_s() - *(double *)priv;
}

static int wall_sleep(void *priv, double seconds)
{
    (void)priv;
    if (!(seconds > 0))
        return 0;
    struct timespec ts = {(time_t)seconds, (long)((seconds - (time_t)seconds) * 1e9)};
    while (nanosleep(&ts, &ts) < 0)
        if (errno != EINTR)
            return -errno;
    return 0;
}

static const struct drv_clock_ops wall_clock_ops = {
    .name = "wall",
    .now = wall_now,
    .sleep = wall_sleep,
    .free_priv = free,
};

drv_clock *drv_clock_new_wall(void)
{
    double *t0 = malloc(sizeof *t0);
    if (!t0)
        return NULL;
    *t0 = gonio_monotonic_s();
    return drv_clock_alloc(&wall_clock_ops, t0);
}
