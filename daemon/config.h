/* goniod's configuration file (YAML, keys in docs/goniod.md): the rig
 * profile, the drivers (the in-process simulator or a Modbus RTU/TCP bus),
 * the capture root and the control socket. Every key is checked; errors
 * read path:line:col: key 'x': problem. */
#ifndef GONIO_DAEMON_CONFIG_H
#define GONIO_DAEMON_CONFIG_H

#include <stdio.h>

#include "common/err.h"
#include "rig/rig.h"

enum goniod_driver { GONIOD_DRIVER_SIM, GONIOD_DRIVER_MODBUS_RTU, GONIOD_DRIVER_MODBUS_TCP };

struct goniod_slaves {
    int sample, arm, azimuth, detector; /* Modbus slave ids; azimuth 0: none */
    int sample_changer;                 /* the sample changer's drive; 0: none */
    int rotation;                       /* the sample's turn about its normal; 0: none */
};

/* The detector of a Modbus rig: the detector slave on the bus, or a USB
 * spectrometer (drivers/drv_usbspec.h; docs/usb-spectrometer.md). */
enum goniod_detector { GONIOD_DETECTOR_MODBUS, GONIOD_DETECTOR_USB };

struct goniod_usb_detector {
    int vendor, product;     /* USB ids */
    char serial[64];         /* "" : the first device with these ids */
    int bands_390;           /* 1: 35 bands 390-730 nm; 0: 31 bands 400-700 nm */
    double scale;            /* 0: counts; > 0: the BRDF shortcut, 1/sr per count per second */
    double timeout_s;        /* per USB transfer beyond the integration */
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
    enum goniod_detector detector;
    struct goniod_usb_detector usb;
    double steps_per_deg, time_scale, timeout_s;
    int retries; /* attempts after the first for a request that failed */
    /* files and socket */
    char capture_root[1024];
    /* gonio calibrate's directories (calibration_root; default: beside
     * the capture root, DIR/calibrations for DIR/captures) */
    char calibration_root[1024];
    char socket_path[108];   /* sizeof sockaddr_un.sun_path */
    char socket_group[64];   /* "" keeps the daemon's group */
    int max_clients;
    double idle_timeout_s;   /* idle clients that do not watch are closed */
    long max_queue_kib;      /* a client with more output queued is dropped */
    double rate_per_s;       /* requests a client may send per second, on average */
    long burst;              /* ... and at once */
    /* truth errors over a sample of this many full-domain nodes; 0: all
     * (capture_config.assess_nodes) */
    long assess_nodes;
};

/* Load and check path. Relative paths inside the file are taken relative
 * to the file's folder. Returns 0, or -GONIO_EBADCONFIG / -GONIO_ENOTFOUND
 * with err filled. */
int goniod_config_load(const char *path, struct goniod_config *cfg, struct gonio_err *err);

/* Whether the driver has every device the rig profile names: the sim
 * driver has all of them; a Modbus rig has an azimuth drive only where
 * driver.slaves.azimuth names its slave, a sample changer only where
 * driver.slaves.sample_changer does, and a rotation axis (axes.rotation)
 * only where driver.slaves.rotation does. 0 when it does; else
 * -GONIO_EBADCONFIG with why (size bytes) saying what is missing, the
 * field of the config that would wire it (driver.slaves.azimuth,
 * driver.slaves.sample_changer, driver.slaves.rotation) and its value,
 * and the fix; rig_ref names the profile in it. */
int goniod_config_rig_gap(const struct goniod_config *cfg, const struct rig_profile *rig,
                          const char *rig_ref, char *why, size_t size);

/* goniod_config_rig_gap for the rig profile rig_ref (a name or a path):
 * loaded, then checked; err reads "CONFIG: driver.slaves.azimuth is ...". */
int goniod_config_rig_check(const struct goniod_config *cfg, const char *rig_ref,
                            struct gonio_err *err);

/* The resolved configuration as YAML goniod would accept (--check). */
void goniod_config_print(FILE *out, const struct goniod_config *cfg);

const char *goniod_driver_name(enum goniod_driver d);

#endif
