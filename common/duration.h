/* Durations as an operator reads them: rig time runs from seconds to days,
 * so minutes alone ("2092 min 58 s") or a rounded seconds field ("19:60")
 * would be wrong or unreadable. */
#ifndef GONIO_COMMON_DURATION_H
#define GONIO_COMMON_DURATION_H

#include <stddef.h>

/* "58 s", "13 min 40 s", "34 h 52 min 58 s": rounded to the second first. */
void gonio_duration_words(double s, char *buf, size_t size);

/* "0:20:00", "34:52:58": h:mm:ss, rounded to the second first. */
void gonio_duration_hms(double s, char *buf, size_t size);

#endif
