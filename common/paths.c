#include "common/paths.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int is_dir(const char *path)
{
    struct stat st;
    return path && stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* The configs an installed binary was installed with: GONIO_CONFIG_FROM_BIN
 * from the executable's folder (/usr/bin/../../etc/gonio), when it exists.
 * Found from /proc/self/exe rather than compiled in as an absolute path, so
 * that a tree installed under DESTDIR or another prefix reads its own
 * configs; the build tree has none there. Per thread: goniod's worker asks
 * too. */
static const char *installed_config_dir(void)
{
    static _Thread_local char dir[4096];
    char exe[4096];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0)
        return NULL;
    exe[n] = '\0';
    *strrchr(exe, '/') = '\0';
    /* Each leading "../" takes a folder off, so messages name /etc/gonio,
     * not /usr/bin/../../etc/gonio. */
    const char *rel = GONIO_CONFIG_FROM_BIN;
    char *slash;
    while (!strncmp(rel, "../", 3) && (slash = strrchr(exe, '/'))) {
        *slash = '\0';
        rel += 3;
    }
    if (snprintf(dir, sizeof dir, "%s/%s", exe, rel) >= (int)sizeof dir)
        return NULL;
    return is_dir(dir) ? dir : NULL;
}

const char *gonio_shared_dir(void)
{
    const char *env = getenv("GONIO_SHARED");
    if (env && *env)
        return is_dir(env) ? env : NULL;
    /* An installed binary knows no source tree: the build's path compiled
     * in may name any folder on the machine it was built on. */
    if (installed_config_dir())
        return NULL;
    return is_dir(GONIO_SHARED_DEFAULT) ? GONIO_SHARED_DEFAULT : NULL;
}

const char *gonio_config_dir(void)
{
    const char *env = getenv("GONIO_CONFIG");
    if (env && *env)
        return env;
    const char *installed = installed_config_dir();
    return installed ? installed : GONIO_CONFIG_DEFAULT;
}

int gonio_ref_is_file(const char *ref)
{
    size_t n = strlen(ref);
    return strchr(ref, '/') || (n > 5 && !strcmp(ref + n - 5, ".yaml")) ||
           (n > 4 && !strcmp(ref + n - 4, ".yml"));
}

int gonio_config_path(const char *path_or_name, const char *sub, char *out, size_t size)
{
    int n = gonio_ref_is_file(path_or_name)
                ? snprintf(out, size, "%s", path_or_name)
                : snprintf(out, size, "%s/%s/%s.yaml", gonio_config_dir(), sub, path_or_name);
    return n < 0 || (size_t)n >= size ? -ENAMETOOLONG : 0;
}

int gonio_write_file_atomic(const char *path, const void *data, size_t len,
                            struct gonio_err *err)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return gonio_err_set(err, ENAMETOOLONG, "%s: path too long", path);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0)
        return gonio_err_set(err, errno, "%s: cannot create: %s", tmp, strerror(errno));
    const char *p = data;
    size_t left = len;
    while (left > 0) {
        ssize_t w = write(fd, p, left);
        if (w < 0 && errno == EINTR)
            continue;
        if (w < 0) {
            int e = errno;
            close(fd);
            unlink(tmp);
            return gonio_err_set(err, e, "%s: write failed: %s", path, strerror(e));
        }
        p += w;
        left -= (size_t)w;
    }
    if (fsync(fd) != 0 || close(fd) != 0) {
        int e = errno;
        unlink(tmp);
        return gonio_err_set(err, e, "%s: cannot flush: %s", path, strerror(e));
    }
    if (rename(tmp, path) != 0) {
        int e = errno;
        unlink(tmp);
        return gonio_err_set(err, e, "%s: cannot rename into place: %s", path, strerror(e));
    }
    return gonio_fsync_parent(path, err);
}

int gonio_fsync_parent(const char *path, struct gonio_err *err)
{
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1,
                 slash ? (slash == path ? "/" : path) : ".") >= (int)sizeof dir)
        return gonio_err_set(err, ENAMETOOLONG, "%s: path too long", path);
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return gonio_err_set(err, errno, "%s: cannot open directory: %s", dir, strerror(errno));
    int rc = fsync(fd) == 0 ? 0 : gonio_err_set(err, errno, "%s: cannot sync: %s", dir,
                                                strerror(errno));
    close(fd);
    return rc;
}

int gonio_mkdir_p(const char *path, struct gonio_err *err)
{
    char buf[4096];
    if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
        return gonio_err_set(err, ENAMETOOLONG, "%s: path too long", path);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = '\0';
        if (mkdir(buf, 0755) != 0 && errno != EEXIST)
            return gonio_err_set(err, errno, "%s: cannot create directory: %s", buf, strerror(errno));
        *p = '/';
    }
    if (mkdir(buf, 0755) != 0 && errno != EEXIST)
        return gonio_err_set(err, errno, "%s: cannot create directory: %s", buf, strerror(errno));
    return 0;
}
