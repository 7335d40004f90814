/* goniod: the capture daemon. One poll loop serves the control socket
 * (daemon/control.h) and relays the capture worker's progress
 * (daemon/worker.h); signal handlers only write to a self-pipe. */
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <gsl/gsl_errno.h>

#include "common/clock.h"
#include "common/version.h"
#include "daemon/config.h"
#include "daemon/control.h"
#include "daemon/devices.h"
#include "daemon/lock.h"
#include "daemon/notify.h"
#include "daemon/worker.h"

static int signal_pipe[2] = {-1, -1};

static void on_signal(int sig)
{
    int saved = errno;
    unsigned char b = (unsigned char)sig;
    ssize_t n = write(signal_pipe[1], &b, 1);
    (void)n;
    errno = saved;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: goniod --config FILE [--check [--probe]]\n"
                 "       goniod --version\n"
                 "  --config FILE  the daemon's configuration (goniod.yaml(5))\n"
                 "  --check        validate FILE, print the resolved configuration and exit\n"
                 "                 (0 when valid, 2 with path:line:col: problem when not)\n"
                 "  --probe        with --check: open the bus and a USB spectrometer, ask\n"
                 "                 every device what it is (a line each); 2 naming the\n"
                 "                 first that did not answer\n"
                 "  --version      print the release and exit\n"
                 "Keys and the protocol: docs/goniod.md, docs/protocol.md.\n");
}

static int setup_signals(struct gonio_err *err)
{
    if (pipe(signal_pipe) < 0)
        return gonio_err_set(err, errno, "signal pipe: %s", strerror(errno));
    for (int i = 0; i < 2; i++) {
        fcntl(signal_pipe[i], F_SETFL, O_NONBLOCK);
        fcntl(signal_pipe[i], F_SETFD, FD_CLOEXEC);
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    signal(SIGPIPE, SIG_IGN); /* a vanished client is an error return, not a death */
    return 0;
}

/* Serve until a signal or a client asks to stop; a running capture is
 * aborted at its next point boundary and its stop document sent first. */
static int serve(const struct goniod_config *cfg)
{
    struct gonio_err err = {0};
    /* One daemon per capture root (daemon/lock.h), held until we exit;
     * the socket's own lock is control_new's. */
    int root_lock = goniod_lock_dir(cfg->capture_root, "capture root", &err);
    worker *w = root_lock >= 0 ? worker_new(cfg, &err) : NULL;
    control *c = w ? control_new(cfg, w, &err) : NULL;
    if (!c) {
        fprintf(stderr, "goniod: %s\n", err.msg);
        worker_free(w);
        if (root_lock >= 0)
            close(root_lock);
        return 1;
    }
    fprintf(stderr, "goniod: version %s, listening on %s (driver %s, captures in %s)\n",
            gonio_version(), cfg->socket_path, goniod_driver_name(cfg->driver), cfg->capture_root);
    notify_send("READY=1\nSTATUS=idle\nMAINPID=%ld", (long)getpid());

    unsigned long long wd_usec = notify_watchdog_usec();
    double wd_period = wd_usec ? (double)wd_usec / 2e6 : 0, wd_next = gonio_monotonic_s() + wd_period;
    char last_status[256] = "idle";
    int stopping = 0;
    size_t cap = (size_t)cfg->max_clients + 8;
    struct pollfd *pfd = calloc(cap + 2, sizeof *pfd);
    if (!pfd) {
        control_free(c);
        worker_free(w);
        close(root_lock);
        return 1;
    }
    for (;;) {
        if (!stopping && control_shutdown_requested(c))
            stopping = 1;
        if (stopping == 1) {
            fprintf(stderr, "goniod: shutting down\n");
            notify_send("STOPPING=1");
            worker_abort(w, "shutdown", NULL); /* refused when idle: fine */
            stopping = 2;
        }
        struct worker_status st;
        worker_get_status(w, &st);
        if (stopping && st.state == WORKER_IDLE) {
            control_dispatch(c, worker_take(w)); /* the stop document */
            break;
        }
        int timeout = control_tick(c);
        if (wd_period > 0) {
            double left = wd_next - gonio_monotonic_s();
            int ms = left <= 0 ? 0 : (int)(left * 1000) + 1;
            if (ms < timeout)
                timeout = ms;
        }
        if (stopping && timeout > 100)
            timeout = 100;
        pfd[0] = (struct pollfd){.fd = signal_pipe[0], .events = POLLIN};
        pfd[1] = (struct pollfd){.fd = worker_wake_fd(w), .events = POLLIN};
        size_t n = control_pollfds(c, pfd + 2, cap);
        int rc = poll(pfd, n + 2, timeout);
        if (rc < 0 && errno != EINTR) {
            fprintf(stderr, "goniod: poll: %s\n", strerror(errno));
            break;
        }
        if (rc > 0 && (pfd[0].revents & POLLIN)) {
            unsigned char sig;
            while (read(signal_pipe[0], &sig, 1) == 1) {
                if (sig == SIGHUP) {
                    fprintf(stderr, "goniod: SIGHUP ignored (logs go to stderr)\n");
                } else if (!stopping) {
                    fprintf(stderr, "goniod: signal %d\n", sig);
                    stopping = 1;
                }
            }
        }
        if (rc > 0 && (pfd[1].revents & POLLIN))
            control_dispatch(c, worker_take(w));
        if (rc > 0)
            control_handle(c, pfd + 2, n);
        if (wd_period > 0 && gonio_monotonic_s() >= wd_next) {
            notify_send("WATCHDOG=1");
            wd_next = gonio_monotonic_s() + wd_period;
        }
        char status[256];
        control_status_text(c, status, sizeof status);
        if (strcmp(status, last_status)) {
            notify_send("STATUS=%s", status);
            snprintf(last_status, sizeof last_status, "%s", status);
        }
    }
    control_flush(c, 1000);
    control_free(c);
    worker_free(w);
    free(pfd);
    close(root_lock);
    fprintf(stderr, "goniod: stopped\n");
    return 0;
}

/* --check --probe: after the resolved configuration, what each device
 * answered; 2 naming the first that did not. */
static int run_probe(const struct goniod_config *cfg)
{
    struct rig_profile rig;
    struct gonio_err err = {0};
    fflush(stdout);
    if (rig_profile_load(cfg->rig, &rig, &err) < 0 || goniod_probe(cfg, &rig, stdout, &err) < 0) {
        fflush(stdout);
        fprintf(stderr, "goniod: probe: %s\n", err.msg);
        return 2;
    }
    return 0;
}

int main(int argc, char **argv)
{
    static const struct option opts[] = {
        {"config", required_argument, NULL, 'c'},
        {"check", no_argument, NULL, 'k'},
        {"probe", no_argument, NULL, 'p'},
        {"help", no_argument, NULL, 'h'},
        {"version", no_argument, NULL, 'V'},
        {NULL, 0, NULL, 0},
    };
    const char *path = NULL;
    int check = 0, probe = 0, ch;
    while ((ch = getopt_long(argc, argv, "c:", opts, NULL)) != -1) {
        switch (ch) {
        case 'c': path = optarg; break;
        case 'k': check = 1; break;
        case 'p': probe = 1; break;
        case 'h': usage(stdout); return 0;
        case 'V': gonio_print_version(stdout, "goniod"); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (probe && !check) {
        fprintf(stderr, "goniod: --probe goes with --check\n");
        usage(stderr);
        return 2;
    }
    if (!path || optind != argc) {
        fprintf(stderr, "goniod: --config FILE is required\n");
        usage(stderr);
        return 2;
    }
    /* A fit that fails is a result to report, never an abort. */
    gsl_set_error_handler_off();
    struct goniod_config cfg;
    struct gonio_err err = {0};
    if (goniod_config_load(path, &cfg, &err) < 0) {
        fprintf(stderr, "goniod: %s\n", err.msg);
        return 2;
    }
    if (check) {
        goniod_config_print(stdout, &cfg);
        return probe ? run_probe(&cfg) : 0;
    }
    if (setup_signals(&err) < 0) {
        fprintf(stderr, "goniod: %s\n", err.msg);
        return 1;
    }
    setvbuf(stderr, NULL, _IOLBF, 0);
    return serve(&cfg);
}
