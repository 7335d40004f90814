#include "common/duration.h"

#include <math.h>
#include <stdio.h>

/* Round once, then split: rounding each field apart is what printed 1199.9999 s
 * as 19:60. */
static long whole_seconds(double s)
{
    return isfinite(s) && s > 0 ? lround(s) : 0;
}

void gonio_duration_words(double s, char *buf, size_t size)
{
    long w = whole_seconds(s);
    if (w >= 3600)
        snprintf(buf, size, "%ld h %ld min %ld s", w / 3600, w / 60 % 60, w % 60);
    else if (w >= 60)
        snprintf(buf, size, "%ld min %ld s", w / 60, w % 60);
    else
        snprintf(buf, size, "%ld s", w);
}

void gonio_duration_hms(double s, char *buf, size_t size)
{
    long w = whole_seconds(s);
    snprintf(buf, size, "%ld:%02ld:%02ld", w / 3600, w / 60 % 60, w % 60);
}
