#include "cli/output_path.h"

#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

const char *output_path(const char *cmd, const char *out, const char *dir, const char *name,
                        char *buf, size_t size)
{
    struct stat st;
    if (out && !(stat(out, &st) == 0 && S_ISDIR(st.st_mode))) {
        snprintf(buf, size, "%s", out);
        return buf;
    }
    if (out) {
        snprintf(buf, size, "%s/%s", out, name);
        return buf;
    }
    /* access() also says EROFS for a read-only mount, which root meets too. */
    if (!dir || access(dir, W_OK | X_OK) == 0) {
        snprintf(buf, size, "%s/%s", dir ? dir : ".", name);
        return buf;
    }
    snprintf(buf, size, "./%s", name);
    fprintf(stderr, "%s: %s is not writable here; writing %s in the current directory (-o "
                    "chooses)\n",
            cmd, dir, name);
    return buf;
}
