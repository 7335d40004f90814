/* goniod's configuration file (YAML, keys in docs/goniod.md): the rig
 * profile, the drivers (the in-process simulator or a Modbus RTU/TCP bus),
 * the capture root and the control socket. Every key is checked; errors
 * read path:line:col: key 'x': problem. */
#ifndef GONIO_DAEMON_CONFIG_H
#define GONIO_DAEMON_CONFIG_H

#include <stdio.h>

#include "common/err.h"

enum goniod_driver { GONIOD_DRIVER_SIM, GONIOD_DRIVER_MODBUS_RTU, GONIOD_DRIVER_MODBUS_TCP };

struct goniod_slaves {
    int sample, arm, azimuth, detector; /* Modbus slave ids; azimuth 0: none */
};

struct goniod_config {
    char path[1024];
    char rig[1024];          /* rig profile name or path */
    enum goniod_driver driver;
    /* sim */
    char scene[1024];        /* scene captures default to */
    double pace_s;           /* wall seconds slept per point (0: run at full speed) */
    /* modbus-rtu */
    char device[256];
    long baud;
    char parity;             /* 'N', 'E', 'O' */
    int data_bits, stop_bits;
    /* modbus-tcp */
    char host[256];
    int port;
    /* both Modbus kinds */
    struct goniod_slaves slaves;
    double steps_per_deg, time_scale, timeout_s;
    /* files and socket */
    char capture_root[1024];
    char socket_path[108];   /* sizeof sockaddr_un.sun_path */
    char socket_group[64];   /* "" keeps the daemon's group */
    int max_clients;
    double idle_timeout_s;   /* idle clients that do not watch are closed */
    long max_queue_kib;      /* a client with more output queued is dropped */
};

/* Load and check path. Relative paths inside the file are taken relative
 * to the file's folder. Returns 0, or -GONIO_EBADCONFIG / -GONIO_ENOTFOUND
 * with err filled. */
int goniod_config_load(const char *path, struct goniod_config *cfg, struct gonio_err *err);

/* The resolved configuration as YAML goniod would accept (--check). */
void goniod_config_print(FILE *out, const struct goniod_config *cfg);

const char *goniod_driver_name(enum goniod_driver d);

#endif
