#include "daemon/lock.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include "common/paths.h"

/* The pid holding a flock on fd's file, from the kernel's table of locks
 * (/proc/locks: "1: FLOCK  ADVISORY  WRITE 1234 08:01:5678 0 EOF", device
 * numbers in hex; the lines of waiters hold "->"). 0 when it is not found:
 * no /proc, another pid namespace, a stacked file system whose device
 * numbers differ from stat's. */
static long holder_from_proc(int fd)
{
    struct stat st;
    if (fstat(fd, &st) != 0)
        return 0;
    FILE *f = fopen("/proc/locks", "re");
    if (!f)
        return 0;
    char line[256], kind[16];
    long pid = 0, p;
    unsigned maj, min;
    unsigned long long ino;
    while (!pid && fgets(line, sizeof line, f)) {
        if (strstr(line, "->"))
            continue;
        if (sscanf(line, "%*d: %15s %*s %*s %ld %x:%x:%llu", kind, &p, &maj, &min, &ino) == 5 &&
            !strcmp(kind, "FLOCK") && maj == major(st.st_dev) && min == minor(st.st_dev) &&
            ino == (unsigned long long)st.st_ino)
            pid = p;
    }
    fclose(f);
    return pid;
}

/* The pid a lock file's holder wrote into it; 0 when there is none. */
static long holder_from_file(int fd)
{
    char buf[32];
    ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
    if (n <= 0)
        return 0;
    buf[n] = '\0';
    char *end;
    long pid = strtol(buf, &end, 10);
    return pid > 0 && (*end == '\n' || *end == '\0') ? pid : 0;
}

/* flock fd, or fill err naming path, what and the holder. */
static int take(int fd, int is_file, const char *path, const char *what, struct gonio_err *err)
{
    if (flock(fd, LOCK_EX | LOCK_NB) == 0)
        return 0;
    int e = errno;
    if (e != EWOULDBLOCK)
        return gonio_err_set(err, e, "%s: cannot lock the %s: %s", path, what, strerror(e));
    long pid = holder_from_proc(fd);
    if (!pid && is_file)
        pid = holder_from_file(fd);
    if (pid)
        return gonio_err_set(err, EADDRINUSE,
                             "%s: locked by pid %ld: another goniod is using this %s; not "
                             "starting",
                             path, pid, what);
    return gonio_err_set(err, EADDRINUSE,
                         "%s: locked by another process: another goniod is using this %s; "
                         "not starting",
                         path, what);
}

int goniod_lock_file(const char *path, const char *what, struct gonio_err *err)
{
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0640);
    if (fd < 0)
        return gonio_err_set(err, errno, "%s: cannot open the %s's lock file: %s", path, what,
                             strerror(errno));
    int rc = take(fd, 1, path, what, err);
    if (rc < 0) {
        close(fd);
        return rc;
    }
    char pid[32];
    int n = snprintf(pid, sizeof pid, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) != 0 || pwrite(fd, pid, (size_t)n, 0) != n) {
        rc = gonio_err_set(err, errno, "%s: cannot write the pid: %s", path, strerror(errno));
        close(fd);
        return rc;
    }
    return fd;
}

int goniod_lock_dir(const char *dir, const char *what, struct gonio_err *err)
{
    int rc = gonio_mkdir_p(dir, err);
    if (rc < 0)
        return rc;
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return gonio_err_set(err, errno, "%s: cannot open the %s: %s", dir, what,
                             strerror(errno));
    if ((rc = take(fd, 0, dir, what, err)) < 0) {
        close(fd);
        return rc;
    }
    return fd;
}
