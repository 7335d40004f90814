/* Start and stop a gonio-sim process for a test: its binary is
 * $GONIO_BIN/gonio-sim; the pty path is the first line it prints, the TCP
 * port the second (with --tcp). */
#ifndef GONIO_TESTS_SIM_PROC_H
#define GONIO_TESTS_SIM_PROC_H

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <time.h>
#include <sys/wait.h>
#include <unistd.h>

#include "drivers/drv_modbus.h"
#include "tests/gonio_test.h"

struct sim_proc {
    pid_t pid;
    char pty[300];
    int port; /* 0 without --tcp */
};

/* args: NULL-terminated extra arguments. Returns 0, or -1 with a message
 * on stderr. */
static inline int sim_proc_start(struct sim_proc *p, const char *const *args)
{
    const char *bin = getenv("GONIO_BIN");
    char path[1024];
    snprintf(path, sizeof path, "%s/gonio-sim", bin ? bin : ".");
    const char *argv[32] = {path};
    int n = 1, tcp = 0;
    for (; args && *args && n < 31; args++) {
        tcp |= !strcmp(*args, "--tcp");
        argv[n++] = *args;
    }
    argv[n] = NULL;
    int fds[2];
    if (pipe(fds) < 0)
        return -1;
    memset(p, 0, sizeof *p);
    p->pid = gonio_test_fork();
    if (p->pid < 0)
        return -1;
    if (p->pid == 0) {
        dup2(fds[1], STDOUT_FILENO);
        close(fds[0]);
        close(fds[1]);
        execv(path, (char *const *)argv);
        _exit(127);
    }
    close(fds[1]);
    FILE *out = fdopen(fds[0], "r");
    char line[300];
    int ok = out && fgets(line, sizeof line, out) && line[0] == '/';
    if (ok) {
        line[strcspn(line, "\n")] = '\0';
        snprintf(p->pty, sizeof p->pty, "%s", line);
    }
    if (ok && tcp) {
        const char *colon;
        ok = fgets(line, sizeof line, out) && (colon = strrchr(line, ':')) != NULL;
        if (ok)
            p->port = atoi(colon + 1);
    }
    if (out)
        fclose(out);
    if (!ok) {
        fprintf(stderr, "sim_proc: %s did not start\n", path);
        kill(p->pid, SIGKILL);
        waitpid(p->pid, NULL, 0);
        p->pid = 0;
        return -1;
    }
    return 0;
}

/* Sleep ms milliseconds of wall time. */
static inline void sim_proc_nap(long ms)
{
    struct timespec ts = {.tv_sec = ms / 1000, .tv_nsec = (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

/* SIGTERM, and the exit status (0: a clean exit). */
/* A Modbus RTU bus on the simulator's pty at its time scale; NULL with a
 * message on stderr. No test provokes a timeout on it: its timeout (2 s,
 * stretched as the tests' time factor says) only bounds how long a
 * loaded host may take to answer, and an ordinary exchange was seen to
 * take over 0.2 s beside four busy loops under nice 19. */
static inline drv_modbus_bus *sim_proc_rtu(const struct sim_proc *p, double time_scale)
{
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = p->pty;
    cfg.time_scale = time_scale;
    cfg.timeout_s = 2.0 * gonio_test_time_factor();
    struct gonio_err err = {0};
    drv_modbus_bus *bus = drv_modbus_bus_new_rtu(&cfg, &err);
    if (!bus)
        fprintf(stderr, "%s\n", err.msg);
    return bus;
}

static inline int sim_proc_stop(struct sim_proc *p)
{
    int status = -1;
    if (p->pid <= 0)
        return -1;
    kill(p->pid, SIGTERM);
    waitpid(p->pid, &status, 0);
    p->pid = 0;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

#endif
