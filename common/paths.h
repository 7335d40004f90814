/* Where gonio finds its data and configs, and how it writes result files. */
#ifndef GONIO_COMMON_PATHS_H
#define GONIO_COMMON_PATHS_H

#include <stddef.h>

#include "common/err.h"

/* The shared data folder: $GONIO_SHARED, else (a binary run from its build
 * tree, not an installed one) ../shared beside the source tree. Returns
 * NULL when the folder does not exist. */
const char *gonio_shared_dir(void);

/* The configs folder: $GONIO_CONFIG, else the configs an installed binary
 * was installed with (/etc/gonio for /usr/bin/gonio; docs/install.md), else
 * configs/ in the source tree. */
const char *gonio_config_dir(void);

/* Whether a plan, scene, rig or render reference names a file (it holds a
 * '/' or ends in .yaml or .yml) rather than a name in the configs folder.
 * One rule, so that the loaders (gonio_config_path), goniod's config and
 * goniod's requests agree on what a reference means. */
int gonio_ref_is_file(const char *ref);

/* The file a reference names: itself when it is a file, else
 * <config>/<sub>/NAME.yaml (sub: "plans", "rigs", "scenes", "render").
 * Returns 0, or -ENAMETOOLONG. */
int gonio_config_path(const char *path_or_name, const char *sub, char *out, size_t size);

/* Write len bytes to path atomically: a temporary file beside it, fsync,
 * rename, then fsync of the directory, so a reader never sees half a file,
 * a failure leaves no file behind, and the new name survives a power cut. */
int gonio_write_file_atomic(const char *path, const void *data, size_t len,
                            struct gonio_err *err);

/* fsync the directory holding path: what makes a file's creation or a
 * rename into it durable. */
int gonio_fsync_parent(const char *path, struct gonio_err *err);

/* Create a directory and its parents (mode 0755); existing ones are fine. */
int gonio_mkdir_p(const char *path, struct gonio_err *err);

#endif
