/* The release every gonio executable reports (--version, goniod's startup
 * line, gonio status): the project version of the top-level CMakeLists.txt,
 * so that one number is changed in one place. */
#ifndef GONIO_COMMON_VERSION_H
#define GONIO_COMMON_VERSION_H

#include <stdio.h>

const char *gonio_version(void);

/* "PROGRAM VERSION\n" on out: the --version line of every executable. */
void gonio_print_version(FILE *out, const char *program);

#endif
