/* Elapsed time for durations, deadlines and fit timings. */
#ifndef GONIO_COMMON_CLOCK_H
#define GONIO_COMMON_CLOCK_H

/* CLOCK_MONOTONIC in seconds: unlike the wall clock it never steps (NTP, an
 * operator setting the date), so intervals measured with it are real. */
double gonio_monotonic_s(void);

#endif
