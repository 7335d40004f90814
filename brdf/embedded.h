/* Materials built into the library (published SGD fits of a few MERL
 * materials, see embedded.c for the citation): what `default` and
 * `builtin:NAME` open when there is no shared data folder. */
#ifndef GONIO_BRDF_EMBEDDED_H
#define GONIO_BRDF_EMBEDDED_H

#include <stddef.h>

#include "brdf/sgd.h"

/* The spec `default` stands for, "builtin:NAME". */
const char *brdf_embedded_default_spec(void);

/* The embedded names, space-separated (for messages). */
const char *brdf_embedded_names(void);

size_t brdf_embedded_count(void);
const char *brdf_embedded_name(size_t i); /* NULL past the end */

/* Copy the parameters of NAME; 0, or -1 when there is no such material. */
int brdf_embedded_sgd(const char *name, struct brdf_sgd *out);

#endif
