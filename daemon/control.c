/* goniod's control socket: the listening socket's life cycle and what the
 * poll loop calls. Connections, commands, paths and the capture stream are
 * in the control_*.c files (see daemon/control_private.h). */
#include <errno.h>
#include <grp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "common/paths.h"
#include "daemon/control_private.h"
#include "daemon/lock.h"

/* A socket folder goniod creates is 0750 in the socket's group (gid, or
 * -1 for ours): only the operators can even reach the socket. An existing
 * folder is left as it is (systemd's RuntimeDirectory=, or a test's). */
static int socket_folder(const char *socket_path, gid_t gid, struct gonio_err *err)
{
    char dir[sizeof ((struct sockaddr_un *)0)->sun_path];
    snprintf(dir, sizeof dir, "%s", socket_path);
    char *slash = strrchr(dir, '/');
    struct stat st;
    if (!slash || slash == dir)
        return 0;
    *slash = '\0';
    if (stat(dir, &st) == 0)
        return 0;
    int rc = gonio_mkdir_p(dir, err);
    if (rc < 0)
        return rc;
    if (chmod(dir, 0750) < 0 || (gid != (gid_t)-1 && chown(dir, (uid_t)-1, gid) < 0))
        return gonio_err_set(err, errno, "%s: %s", dir, strerror(errno));
    return 0;
}

/* With the socket's lock held: remove a socket file nobody listens on (a
 * dead daemon's). Something that answers there, or whose backlog is full,
 * without the lock is not a goniod that locks, and not ours to replace;
 * neither is a file that is not a socket. */
static int replace_stale(const struct sockaddr_un *sa, struct gonio_err *err)
{
    struct stat st;
    if (lstat(sa->sun_path, &st) != 0)
        return 0;
    if (!S_ISSOCK(st.st_mode))
        return gonio_err_set(err, EEXIST, "%s: exists and is not a socket; not replacing it",
                             sa->sun_path);
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    int rc = fd < 0 ? -1 : connect(fd, (const struct sockaddr *)sa, sizeof *sa);
    int e = errno;
    if (fd >= 0)
        close(fd);
    if (rc == 0 || (e != ECONNREFUSED && e != ENOENT))
        return gonio_err_set(err, EADDRINUSE,
                             "%s: another goniod, or another program, is listening there (%s); "
                             "not replacing it",
                             sa->sun_path, rc == 0 ? "it answered" : strerror(e));
    unlink(sa->sun_path);
    return 0;
}

control *control_new(const struct goniod_config *cfg, worker *w, struct gonio_err *err)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    if (strlen(cfg->socket_path) >= sizeof sa.sun_path) {
        gonio_err_set(err, GONIO_EBADCONFIG, "%s: socket path too long", cfg->socket_path);
        return NULL;
    }
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", cfg->socket_path);
    gid_t gid = (gid_t)-1, allowed = getegid();
    if (cfg->socket_group[0]) {
        struct group *g = getgrnam(cfg->socket_group);
        if (!g) {
            gonio_err_set(err, GONIO_EBADCONFIG, "%s: socket group '%s' does not exist",
                          cfg->path, cfg->socket_group);
            return NULL;
        }
        gid = allowed = g->gr_gid;
    }
    if (socket_folder(cfg->socket_path, gid, err) < 0)
        return NULL;
    /* The socket's lock, held until control_free: while another goniod
     * holds it the socket is that daemon's, however long it takes to
     * answer; once it is ours, a socket file nobody listens on is a dead
     * daemon's and is replaced. */
    char lock_path[sizeof sa.sun_path + 8];
    snprintf(lock_path, sizeof lock_path, "%s.lock", cfg->socket_path);
    int lock_fd = goniod_lock_file(lock_path, "control socket", err);
    if (lock_fd < 0)
        return NULL;
    if (replace_stale(&sa, err) < 0) {
        close(lock_fd);
        return NULL;
    }
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    /* Created 0660 from the start (umask), so there is no moment in which
     * others could connect; chmod then makes the mode exact. */
    mode_t old_mask = umask(0117);
    int bound = fd >= 0 ? bind(fd, (struct sockaddr *)&sa, sizeof sa) : -1;
    umask(old_mask);
    if (fd < 0 || bound < 0 || chmod(cfg->socket_path, 0660) < 0 ||
        (gid != (gid_t)-1 && chown(cfg->socket_path, (uid_t)-1, gid) < 0) ||
        listen(fd, 16) < 0) {
        gonio_err_set(err, errno, "%s: %s", cfg->socket_path, strerror(errno));
        if (fd >= 0)
            close(fd);
        if (bound == 0)
            unlink(cfg->socket_path);
        close(lock_fd);
        return NULL;
    }
    control *c = calloc(1, sizeof *c);
    if (!c) {
        close(fd);
        unlink(cfg->socket_path);
        close(lock_fd);
        gonio_err_set(err, ENOMEM, "out of memory");
        return NULL;
    }
    c->cfg = cfg;
    c->w = w;
    c->listen_fd = fd;
    c->lock_fd = lock_fd;
    c->self_uid = geteuid();
    c->allowed_gid = allowed;
    return c;
}

void control_free(control *c)
{
    if (!c)
        return;
    control_refusals_flush(c);
    for (size_t i = 0; i < c->n_clients; i++)
        control_client_free(c->clients[i]);
    free(c->clients);
    close(c->listen_fd);
    unlink(c->cfg->socket_path);
    close(c->lock_fd); /* only now: the path is free for the next goniod */
    free(c->start_doc);
    free(c->descriptor_doc);
    json_decref(c->bringup_id);
    control_events_free(c);
    free(c);
}

size_t control_pollfds(control *c, struct pollfd *pfd, size_t max)
{
    control_reap(c);
    size_t n = 0;
    if (n < max)
        pfd[n++] = (struct pollfd){.fd = c->listen_fd, .events = POLLIN};
    for (size_t i = 0; i < c->n_clients && n < max; i++) {
        struct control_client *cl = c->clients[i];
        short ev = cl->closing ? 0 : POLLIN;
        if (cl->out_len)
            ev |= POLLOUT;
        pfd[n++] = (struct pollfd){.fd = cl->fd, .events = ev};
    }
    return n;
}

void control_handle(control *c, const struct pollfd *pfd, size_t n)
{
    for (size_t k = 0; k < n; k++) {
        if (!pfd[k].revents)
            continue;
        if (pfd[k].fd == c->listen_fd) {
            control_accept_clients(c);
            continue;
        }
        for (size_t i = 0; i < c->n_clients; i++) {
            struct control_client *cl = c->clients[i];
            if (cl->fd != pfd[k].fd || cl->dead)
                continue;
            if (pfd[k].revents & POLLOUT)
                control_client_try_write(cl);
            if (pfd[k].revents & (POLLIN | POLLHUP | POLLERR))
                control_client_read(c, cl);
            if ((pfd[k].revents & (POLLHUP | POLLERR)) && !(pfd[k].revents & POLLIN))
                cl->dead = 1;
        }
    }
    control_reap(c);
}

void control_flush(control *c, int timeout_ms)
{
    double end = gonio_monotonic_s() + timeout_ms / 1000.0;
    for (;;) {
        struct pollfd pfd[256];
        size_t n = 0;
        for (size_t i = 0; i < c->n_clients && n < 256; i++)
            if (!c->clients[i]->dead && c->clients[i]->out_len)
                pfd[n++] = (struct pollfd){.fd = c->clients[i]->fd, .events = POLLOUT};
        double left = end - gonio_monotonic_s();
        if (n == 0 || left <= 0)
            return;
        if (poll(pfd, n, (int)(left * 1000) + 1) <= 0)
            return;
        for (size_t i = 0; i < c->n_clients; i++)
            control_client_try_write(c->clients[i]);
    }
}

int control_shutdown_requested(const control *c)
{
    return c->shutdown;
}

void control_status_text(control *c, char *buf, size_t size)
{
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (st.state == WORKER_IDLE)
        snprintf(buf, size, "idle, %zu client(s)", c->n_clients);
    else
        snprintf(buf, size, "%s %s: %zu/%zu points, rig time %.0f s",
                 st.state == WORKER_PAUSED ? "paused" : "capturing", st.id, st.done, st.total,
                 st.rig_time_s);
}
