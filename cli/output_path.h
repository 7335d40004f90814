/* Where a command writes its file, so that an operator who may not write
 * into a capture directory (goniod's, docs/install.md) still gets it. */
#ifndef GONIO_CLI_OUTPUT_PATH_H
#define GONIO_CLI_OUTPUT_PATH_H

#include <stddef.h>

/* The file's path into buf: -o `out` as given, or out/NAME when out is an
 * existing directory; without -o (out NULL) dir/NAME when dir is writable
 * (NULL dir: the current directory), else ./NAME, which a line on stderr
 * starting with `cmd` says. Returns buf. */
const char *output_path(const char *cmd, const char *out, const char *dir, const char *name,
                        char *buf, size_t size);

#endif
