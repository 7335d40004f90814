#include "daemon/config.h"

#include <arpa/inet.h>
#include <errno.h>
#include <grp.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/cfg.h"
#include "common/paths.h"
#include "rig/rig.h"
#include "sim/scene.h"

static const char *const driver_names[] = {"sim", "modbus-rtu", "modbus-tcp", NULL};

const char *goniod_driver_name(enum goniod_driver d)
{
    return driver_names[d];
}

/* Copy a string value, failing on one that does not fit. */
static int copy_string(const struct cfg_doc *d, const struct cfg_node *map, const char *key,
                       enum cfg_need need, char *out, size_t size, struct gonio_err *err)
{
    const char *s;
    int rc = cfg_string(d, map, key, need, &s, err);
    if (rc <= 0)
        return rc;
    if (!s[0] || strlen(s) >= size)
        return cfg_error(d, cfg_get(d, map, key), key, err,
                         "must be 1..%zu characters (value '%.40s')", size - 1, s);
    snprintf(out, size, "%s", s);
    return 1;
}

/* A path value: relative paths are taken from the config file's folder,
 * made absolute (a config named relative to the working directory is read
 * from there), so that a config works whatever the daemon's working
 * directory and --check prints the paths the daemon opens. */
static int copy_path(const struct cfg_doc *d, const struct cfg_node *map, const char *key,
                     enum cfg_need need, char *out, size_t size, struct gonio_err *err)
{
    char raw[1024], cwd[PATH_MAX] = "";
    int rc = copy_string(d, map, key, need, raw, sizeof raw, err);
    if (rc <= 0)
        return rc;
    const char *cfgpath = cfg_path(d), *slash = strrchr(cfgpath, '/');
    if (raw[0] != '/' && cfgpath[0] != '/' && !getcwd(cwd, sizeof cwd))
        return cfg_error(d, cfg_get(d, map, key), key, err,
                         "cannot resolve '%.40s': working directory: %s", raw, strerror(errno));
    int dir_len = slash ? (int)(slash - cfgpath) : 0;
    int n;
    if (raw[0] == '/')
        n = snprintf(out, size, "%s", raw);
    else
        n = snprintf(out, size, "%s%s%.*s/%s", cwd, cwd[0] && dir_len ? "/" : "", dir_len,
                     cfgpath, raw);
    if (n < 0 || (size_t)n >= size)
        return cfg_error(d, cfg_get(d, map, key), key, err,
                         "path too long once resolved (at most %zu characters)", size - 1);
    return 1;
}

/* A rig profile or scene: a bare name (from the configs folder) stays as
 * it is; a file is resolved like every other path in the config. */
static int copy_ref(const struct cfg_doc *d, const struct cfg_node *map, const char *key,
                    char *out, size_t size, struct gonio_err *err)
{
    const char *s;
    int rc = cfg_string(d, map, key, CFG_OPTIONAL, &s, err);
    if (rc <= 0)
        return rc;
    return gonio_ref_is_file(s) ? copy_path(d, map, key, CFG_OPTIONAL, out, size, err)
                                : copy_string(d, map, key, CFG_OPTIONAL, out, size, err);
}

static int load_sim(const struct cfg_doc *d, const struct cfg_node *drv,
                    struct goniod_config *cfg, struct gonio_err *err)
{
    static const char *const keys[] = {"kind", "scene", "pace_s", NULL};
    int rc;
    if ((rc = cfg_check_keys(d, drv, "driver", keys, err)) < 0 ||
        (rc = copy_ref(d, drv, "scene", cfg->scene, sizeof cfg->scene, err)) < 0 ||
        (rc = cfg_double(d, drv, "pace_s", CFG_OPTIONAL, 0, 60, &cfg->pace_s, err)) < 0)
        return rc;
    /* The scene must load now, not at the first capture. */
    struct sim_scene scene;
    struct gonio_err e2 = {0};
    if (sim_scene_load(cfg->scene, &scene, &e2) < 0)
        return cfg_error(d, cfg_get(d, drv, "scene") ? cfg_get(d, drv, "scene") : drv,
                         "scene", err, "%s", e2.msg);
    return 0;
}

static int load_slaves(const struct cfg_doc *d, const struct cfg_node *drv,
                       struct goniod_config *cfg, struct gonio_err *err)
{
    static const char *const keys[] = {"sample", "arm", "azimuth", "detector", "sample_changer",
                                       "rotation", NULL};
    const struct cfg_node *m;
    /* Defaults: docs/protocol-modbus.md's map. */
    long s = 1, a = 2, det = 3, az = 0, ch = 0, rot = 0;
    int rc = cfg_map(d, drv, "slaves", CFG_OPTIONAL, &m, err);
    if (rc < 0)
        return rc;
    if (m && ((rc = cfg_check_keys(d, m, "slaves", keys, err)) < 0 ||
              (rc = cfg_int(d, m, "sample", CFG_OPTIONAL, 1, 247, &s, err)) < 0 ||
              (rc = cfg_int(d, m, "arm", CFG_OPTIONAL, 1, 247, &a, err)) < 0 ||
              (rc = cfg_int(d, m, "azimuth", CFG_OPTIONAL, 0, 247, &az, err)) < 0 ||
              (rc = cfg_int(d, m, "detector", CFG_OPTIONAL, 1, 247, &det, err)) < 0 ||
              (rc = cfg_int(d, m, "sample_changer", CFG_OPTIONAL, 0, 247, &ch, err)) < 0 ||
              (rc = cfg_int(d, m, "rotation", CFG_OPTIONAL, 0, 247, &rot, err)) < 0))
        return rc;
    if (s == a || s == det || a == det || (az && (az == s || az == a || az == det)) ||
        (ch && (ch == s || ch == a || ch == det || ch == az)) ||
        (rot && (rot == s || rot == a || rot == det || rot == az || rot == ch)))
        return cfg_error(d, m ? m : drv, "slaves", err,
                         "every device needs its own slave id (sample %ld, arm %ld, "
                         "azimuth %ld, detector %ld, sample_changer %ld, rotation %ld)",
                         s, a, az, det, ch, rot);
    cfg->slaves = (struct goniod_slaves){(int)s, (int)a, (int)az, (int)det, (int)ch, (int)rot};
    return 0;
}

/* A USB id: a number 0-0xffff, hex with 0x as lsusb prints them. */
static int usb_id(const struct cfg_doc *d, const struct cfg_node *map, const char *key, int *out,
                  struct gonio_err *err)
{
    const char *s = NULL;
    int rc = cfg_string(d, map, key, CFG_OPTIONAL, &s, err);
    if (rc < 0 || !s)
        return rc;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 0);
    if (end == s || *end || errno || v < 0 || v > 0xffff)
        return cfg_error(d, cfg_get(d, map, key), key, err,
                         "must be a USB id 0x0000-0xffff (value '%.40s')", s);
    *out = (int)v;
    return 0;
}

/* detector: {kind: modbus} (the detector slave) or {kind: usb-spectrometer,
 * vendor, product, serial, bands, scale, timeout_s}. */
static int load_detector(const struct cfg_doc *d, const struct cfg_node *drv,
                         struct goniod_config *cfg, struct gonio_err *err)
{
    static const char *const kinds[] = {"modbus", "usb-spectrometer", NULL};
    static const char *const bands[] = {"400-700", "390-730", NULL};
    static const char *const keys[] = {"kind",  "vendor", "product",   "serial",
                                       "bands", "scale",  "timeout_s", NULL};
    const struct cfg_node *m;
    int rc = cfg_map(d, drv, "detector", CFG_OPTIONAL, &m, err), kind = 0;
    if (rc < 0 || !m)
        return rc;
    if ((rc = cfg_enum(d, m, "kind", CFG_REQUIRED, kinds, &kind, err)) < 0)
        return rc;
    cfg->detector = (enum goniod_detector)kind;
    if (cfg->detector == GONIOD_DETECTOR_MODBUS)
        return cfg_check_keys(d, m, "detector", (const char *const[]){"kind", NULL}, err);
    if ((rc = cfg_check_keys(d, m, "detector", keys, err)) < 0 ||
        (rc = usb_id(d, m, "vendor", &cfg->usb.vendor, err)) < 0 ||
        (rc = usb_id(d, m, "product", &cfg->usb.product, err)) < 0 ||
        (rc = copy_string(d, m, "serial", CFG_OPTIONAL, cfg->usb.serial, sizeof cfg->usb.serial,
                          err)) < 0 ||
        (rc = cfg_enum(d, m, "bands", CFG_OPTIONAL, bands, &cfg->usb.bands_390, err)) < 0 ||
        (rc = cfg_double(d, m, "scale", CFG_OPTIONAL, 1e-30, 1e30, &cfg->usb.scale, err)) < 0 ||
        (rc = cfg_double(d, m, "timeout_s", CFG_OPTIONAL, 0.01, 60, &cfg->usb.timeout_s, err)) <
            0)
        return rc;
    for (const char *c = cfg->usb.serial; *c; c++) /* printed back quoted by --check */
        if (*c < 0x21 || *c > 0x7e || *c == '"' || *c == '\\')
            return cfg_error(d, cfg_get(d, m, "serial"), "serial", err,
                             "printable ASCII without spaces or quotes (value '%.40s')",
                             cfg->usb.serial);
    return 0;
}

static int load_modbus(const struct cfg_doc *d, const struct cfg_node *drv,
                       struct goniod_config *cfg, struct gonio_err *err)
{
    static const char *const rtu_keys[] = {"kind",     "device",        "baud",
                                           "parity",   "data_bits",     "stop_bits",
                                           "slaves",   "steps_per_deg", "time_scale",
                                           "timeout_s", "drain_s",     "retries",
                                           "detector", NULL};
    static const char *const tcp_keys[] = {"kind",          "host",       "port",
                                           "slaves",        "steps_per_deg",
                                           "time_scale",    "timeout_s",  "drain_s",
                                           "retries",       "detector",   NULL};
    static const char *const parities[] = {"none", "even", "odd", NULL};
    int rtu = cfg->driver == GONIOD_DRIVER_MODBUS_RTU, rc;
    long v;
    if ((rc = cfg_check_keys(d, drv, "driver", rtu ? rtu_keys : tcp_keys, err)) < 0 ||
        (rc = load_slaves(d, drv, cfg, err)) < 0 || (rc = load_detector(d, drv, cfg, err)) < 0 ||
        (rc = cfg_double(d, drv, "steps_per_deg", CFG_OPTIONAL, 1e-3, 1e7, &cfg->steps_per_deg,
                         err)) < 0 ||
        (rc = cfg_double(d, drv, "time_scale", CFG_OPTIONAL, 1e-3, 1e4, &cfg->time_scale,
                         err)) < 0 ||
        (rc = cfg_double(d, drv, "timeout_s", CFG_OPTIONAL, 0.01, 60, &cfg->timeout_s, err)) <
            0 ||
        (rc = cfg_double(d, drv, "drain_s", CFG_OPTIONAL, 0.001, 60, &cfg->drain_s, err)) < 0)
        return rc;
    v = cfg->retries;
    if ((rc = cfg_int(d, drv, "retries", CFG_OPTIONAL, 0, 10, &v, err)) < 0)
        return rc;
    cfg->retries = (int)v;
    if (!rtu) {
        v = cfg->port;
        if ((rc = copy_string(d, drv, "host", CFG_REQUIRED, cfg->host, sizeof cfg->host,
                              err)) < 0 ||
            (rc = cfg_int(d, drv, "port", CFG_OPTIONAL, 1, 65535, &v, err)) < 0)
            return rc;
        /* libmodbus's modbus_new_tcp takes an IPv4 address and resolves no
         * name: "localhost" would pass here and fail at the first capture. */
        struct in_addr addr;
        if (inet_pton(AF_INET, cfg->host, &addr) != 1)
            return cfg_error(d, cfg_get(d, drv, "host"), "host", err,
                             "not a numeric IPv4 address (value '%.40s'; libmodbus resolves no "
                             "names: use e.g. 127.0.0.1)", cfg->host);
        cfg->port = (int)v;
        return 0;
    }
    int parity = 0;
    long data = cfg->data_bits, stop = cfg->stop_bits;
    if ((rc = copy_string(d, drv, "device", CFG_REQUIRED, cfg->device, sizeof cfg->device,
                          err)) < 0 ||
        (rc = cfg_int(d, drv, "baud", CFG_OPTIONAL, 300, 4000000, &cfg->baud, err)) < 0 ||
        (rc = cfg_enum(d, drv, "parity", CFG_OPTIONAL, parities, &parity, err)) < 0 ||
        (rc = cfg_int(d, drv, "data_bits", CFG_OPTIONAL, 5, 8, &data, err)) < 0 ||
        (rc = cfg_int(d, drv, "stop_bits", CFG_OPTIONAL, 1, 2, &stop, err)) < 0)
        return rc;
    if (cfg->device[0] != '/')
        return cfg_error(d, cfg_get(d, drv, "device"), "device", err,
                         "must be an absolute device path (value '%.40s')", cfg->device);
    cfg->parity = "NEO"[parity];
    cfg->data_bits = (int)data;
    cfg->stop_bits = (int)stop;
    return 0;
}

static int load_socket(const struct cfg_doc *d, const struct cfg_node *root,
                       struct goniod_config *cfg, struct gonio_err *err)
{
    static const char *const keys[] = {"path", "group", "max_clients", "idle_timeout_s",
                                       "max_queue_kib", "rate_per_s", "burst", NULL};
    const struct cfg_node *m;
    int rc = cfg_map(d, root, "socket", CFG_REQUIRED, &m, err);
    long maxc = cfg->max_clients;
    if (rc < 0 || (rc = cfg_check_keys(d, m, "socket", keys, err)) < 0 ||
        (rc = copy_path(d, m, "path", CFG_REQUIRED, cfg->socket_path, sizeof cfg->socket_path,
                        err)) < 0 ||
        (rc = copy_string(d, m, "group", CFG_OPTIONAL, cfg->socket_group,
                          sizeof cfg->socket_group, err)) < 0 ||
        (rc = cfg_int(d, m, "max_clients", CFG_OPTIONAL, 1, 1000, &maxc, err)) < 0 ||
        (rc = cfg_double(d, m, "idle_timeout_s", CFG_OPTIONAL, 0.1, 86400, &cfg->idle_timeout_s,
                         err)) < 0 ||
        (rc = cfg_int(d, m, "max_queue_kib", CFG_OPTIONAL, 16, 1048576, &cfg->max_queue_kib,
                      err)) < 0 ||
        (rc = cfg_double(d, m, "rate_per_s", CFG_OPTIONAL, 0.01, 100000, &cfg->rate_per_s,
                         err)) < 0 ||
        (rc = cfg_int(d, m, "burst", CFG_OPTIONAL, 1, 100000, &cfg->burst, err)) < 0)
        return rc;
    /* Checked here, not only when the socket is made: --check passing a
     * config that goniod then refuses to start with would be a lie. */
    if (cfg->socket_group[0] && !getgrnam(cfg->socket_group))
        return cfg_error(d, cfg_get(d, m, "group"), "group", err,
                         "group '%.40s' does not exist (installed goniod creates 'gonio' "
                         "with systemd-sysusers; or groupadd it)", cfg->socket_group);
    cfg->max_clients = (int)maxc;
    return 0;
}

/* The first device the rig profile names that the driver cannot work: the
 * key of the config that would wire it, or NULL when there is none. */
static const char *rig_gap_key(const struct goniod_config *cfg, const struct rig_profile *rig)
{
    if (cfg->driver == GONIOD_DRIVER_SIM)
        return NULL;
    if (rig->sample_changer && !cfg->slaves.sample_changer)
        return "sample_changer";
    /* The USB spectrometer has no shutter to close (drv_usbspec.h): with a
     * profile that says it has one, a dark calibration would read the lit
     * scene as dark instead of asking the operator to cover the detector. */
    if (rig->shutter && cfg->detector == GONIOD_DETECTOR_USB)
        return "detector";
    if (rig->out_of_plane && !cfg->slaves.azimuth)
        return "azimuth";
    if (rig->has_rotation && !cfg->slaves.rotation)
        return "rotation";
    return NULL;
}

int goniod_config_rig_gap(const struct goniod_config *cfg, const struct rig_profile *rig,
                          const char *rig_ref, char *why, size_t size)
{
    const char *key = rig_gap_key(cfg, rig);
    if (!key)
        return 0;
    if (!strcmp(key, "sample_changer"))
        /* The profile says samples can be changed on this rig; a driver
         * that cannot reach the changer would find out at the first
         * change, with a sample under the beam that is not the one named. */
        snprintf(why, size,
                 "driver.slaves.sample_changer is %d (none), but rig profile '%s' has a "
                 "sample changer (sample_changer: true); set driver.slaves.sample_changer to "
                 "the changer's slave id, or name a rig profile without one",
                 cfg->slaves.sample_changer, rig_ref);
    else if (!strcmp(key, "detector"))
        snprintf(why, size,
                 "driver.detector.kind is usb-spectrometer, which has no shutter, but rig "
                 "profile '%s' has one (shutter: true, the default); name a rig profile with "
                 "shutter: false (the shipped usb-spectrometer), on which dark frames pause "
                 "for the operator to cover the detector or turn the lamp off", rig_ref);
    else if (!strcmp(key, "rotation"))
        /* Without the drive a plan's sample_azimuths and the isotropy check
         * would measure the unturned sample each time. */
        snprintf(why, size,
                 "driver.slaves.rotation is %d (none), but rig profile '%s' turns the sample "
                 "about its normal (axes.rotation); set driver.slaves.rotation to the rotation "
                 "drive's slave id (gonio-sim: 5), or name a rig profile without a rotation "
                 "axis", cfg->slaves.rotation, rig_ref);
    else
        /* Without the drive the engine would leave the azimuth where it is
         * and record in-plane samples as the out-of-plane pairs they were
         * planned as. */
        snprintf(why, size,
                 "driver.slaves.azimuth is %d (none), but rig profile '%s' is out of plane "
                 "(out_of_plane: true) and moves an azimuth axis; set driver.slaves.azimuth to "
                 "the azimuth drive's slave id, or name an in-plane rig profile",
                 cfg->slaves.azimuth, rig_ref);
    return -GONIO_EBADCONFIG;
}

int goniod_config_rig_check(const struct goniod_config *cfg, const char *rig_ref,
                            struct gonio_err *err)
{
    struct rig_profile rig;
    char why[1400];
    int rc = rig_profile_load(rig_ref, &rig, err);
    if (rc < 0)
        return rc;
    if ((rc = goniod_config_rig_gap(cfg, &rig, rig_ref, why, sizeof why)) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: %s", cfg->path, why);
    return 0;
}

int goniod_config_load(const char *path, struct goniod_config *cfg, struct gonio_err *err)
{
    static const char *const keys[] = {"rig",    "driver",       "capture_root",
                                       "socket", "assess_nodes", "calibration_root", NULL};
    memset(cfg, 0, sizeof *cfg);
    snprintf(cfg->path, sizeof cfg->path, "%s", path);
    snprintf(cfg->rig, sizeof cfg->rig, "default");
    snprintf(cfg->scene, sizeof cfg->scene, "ideal");
    cfg->baud = 115200;
    cfg->parity = 'N';
    cfg->data_bits = 8;
    cfg->stop_bits = 1;
    cfg->port = 502;
    cfg->steps_per_deg = 100;
    cfg->time_scale = 1;
    cfg->timeout_s = 0.5;
    cfg->retries = 4;
    cfg->usb = (struct goniod_usb_detector){.vendor = 0x2457, .product = 0x101e, .scale = 0,
                                            .timeout_s = 1};
    cfg->max_clients = 16;
    cfg->idle_timeout_s = 600;
    cfg->max_queue_kib = 4096;
    cfg->rate_per_s = 20;
    cfg->burst = 40;

    struct cfg_doc *d;
    int rc = cfg_load(path, &d, err);
    if (rc < 0)
        return rc;
    const struct cfg_node *root = cfg_root(d), *drv = NULL;
    int kind = 0;
    if ((rc = cfg_check_keys(d, root, "goniod config", keys, err)) < 0 ||
        (rc = copy_ref(d, root, "rig", cfg->rig, sizeof cfg->rig, err)) < 0 ||
        (rc = copy_path(d, root, "capture_root", CFG_REQUIRED, cfg->capture_root,
                        sizeof cfg->capture_root, err)) < 0 ||
        (rc = copy_path(d, root, "calibration_root", CFG_OPTIONAL, cfg->calibration_root,
                        sizeof cfg->calibration_root, err)) < 0 ||
        (rc = load_socket(d, root, cfg, err)) < 0 ||
        (rc = cfg_int(d, root, "assess_nodes", CFG_OPTIONAL, 0, 900000, &cfg->assess_nodes,
                      err)) < 0 ||
        (rc = cfg_map(d, root, "driver", CFG_REQUIRED, &drv, err)) < 0 ||
        (rc = cfg_enum(d, drv, "kind", CFG_REQUIRED, driver_names, &kind, err)) < 0)
        goto out;
    cfg->driver = (enum goniod_driver)kind;
    if (!cfg->calibration_root[0]) { /* beside the capture root */
        const char *slash = strrchr(cfg->capture_root, '/');
        int len = slash ? (int)(slash - cfg->capture_root) : 0;
        snprintf(cfg->calibration_root, sizeof cfg->calibration_root, "%.*s%scalibrations",
                 len, cfg->capture_root, slash ? "/" : "");
    }
    rc = cfg->driver == GONIOD_DRIVER_SIM ? load_sim(d, drv, cfg, err)
                                          : load_modbus(d, drv, cfg, err);
    if (rc < 0)
        goto out;
    struct rig_profile rig;
    struct gonio_err e2 = {0};
    if (rig_profile_load(cfg->rig, &rig, &e2) < 0) {
        const struct cfg_node *at = cfg_get(d, root, "rig");
        rc = cfg_error(d, at ? at : root, "rig", err, "%s", e2.msg);
        goto out;
    }
    char why[1400];
    if (goniod_config_rig_gap(cfg, &rig, cfg->rig, why, sizeof why) < 0) {
        /* where the file wires it: driver.detector.kind, or the slave */
        const char *key = rig_gap_key(cfg, &rig);
        int det = !strcmp(key, "detector");
        const struct cfg_node *map = cfg_get(d, drv, det ? "detector" : "slaves");
        const struct cfg_node *at = map ? cfg_get(d, map, det ? "kind" : key) : NULL;
        rc = cfg_error(d, at ? at : map ? map : drv, det ? "kind" : key, err, "%s", why);
        goto out;
    }
    rc = 0;
out:
    cfg_free(d);
    return rc < 0 ? rc : 0;
}

/* A string as YAML reads it back: plain when it is made of characters
 * with no YAML meaning (paths, names, hosts), else double-quoted, so a
 * value holding ': ', ' #', a leading '&' and the like prints as itself. */
static void put_str(FILE *out, const char *s)
{
    size_t plain = strspn(s, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                             "0123456789_./+-");
    if (s[0] && s[0] != '-' && !s[plain]) {
        fputs(s, out);
        return;
    }
    fputc('"', out);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            fprintf(out, "\\%c", *p);
        else if (*p < 0x20 || *p == 0x7f)
            fprintf(out, "\\x%02x", *p);
        else
            fputc(*p, out);
    }
    fputc('"', out);
}

void goniod_config_print(FILE *out, const struct goniod_config *c)
{
    fputs("# goniod configuration, resolved from ", out);
    for (const char *p = c->path; *p; p++) /* a comment ends at a newline */
        fputc((unsigned char)*p < 0x20 ? '?' : *p, out);
    fputs("\nrig: ", out);
    put_str(out, c->rig);
    fprintf(out, "\ndriver:\n  kind: %s\n", goniod_driver_name(c->driver));
    if (c->driver == GONIOD_DRIVER_SIM) {
        fputs("  scene: ", out);
        put_str(out, c->scene);
        fprintf(out, "\n  pace_s: %g\n", c->pace_s);
    } else {
        if (c->driver == GONIOD_DRIVER_MODBUS_RTU) {
            fputs("  device: ", out);
            put_str(out, c->device);
            fprintf(out, "\n  baud: %ld\n  parity: %s\n  data_bits: %d\n  stop_bits: %d\n",
                    c->baud, c->parity == 'E' ? "even" : c->parity == 'O' ? "odd" : "none",
                    c->data_bits, c->stop_bits);
        } else {
            fputs("  host: ", out);
            put_str(out, c->host);
            fprintf(out, "\n  port: %d\n", c->port);
        }
        fprintf(out, "  slaves:\n    sample: %d\n    arm: %d\n    azimuth: %d\n"
                     "    detector: %d\n",
                c->slaves.sample, c->slaves.arm, c->slaves.azimuth, c->slaves.detector);
        if (c->slaves.sample_changer)
            fprintf(out, "    sample_changer: %d\n", c->slaves.sample_changer);
        if (c->slaves.rotation)
            fprintf(out, "    rotation: %d\n", c->slaves.rotation);
        fprintf(out, "  steps_per_deg: %g\n  time_scale: %g\n  timeout_s: %g\n  retries: %d\n",
                c->steps_per_deg, c->time_scale, c->timeout_s, c->retries);
        if (c->drain_s > 0)
            fprintf(out, "  drain_s: %g\n", c->drain_s);
        if (c->detector == GONIOD_DETECTOR_USB) {
            fprintf(out, "  detector:\n    kind: usb-spectrometer\n    vendor: 0x%04x\n"
                         "    product: 0x%04x\n",
                    c->usb.vendor, c->usb.product);
            if (c->usb.serial[0])
                fprintf(out, "    serial: \"%s\"\n", c->usb.serial);
            fprintf(out, "    bands: %s\n", c->usb.bands_390 ? "390-730" : "400-700");
            if (c->usb.scale > 0) /* the BRDF shortcut, only where asked for */
                fprintf(out, "    scale: %.17g\n", c->usb.scale);
            fprintf(out, "    timeout_s: %g\n", c->usb.timeout_s);
        }
    }
    fputs("capture_root: ", out);
    put_str(out, c->capture_root);
    fputs("\ncalibration_root: ", out);
    put_str(out, c->calibration_root);
    fputs("\nsocket:\n  path: ", out);
    put_str(out, c->socket_path);
    fputc('\n', out);
    if (c->socket_group[0]) {
        fputs("  group: ", out);
        put_str(out, c->socket_group);
        fputc('\n', out);
    }
    fprintf(out, "  max_clients: %d\n  idle_timeout_s: %g\n  max_queue_kib: %ld\n",
            c->max_clients, c->idle_timeout_s, c->max_queue_kib);
    fprintf(out, "  rate_per_s: %g\n  burst: %ld\n", c->rate_per_s, c->burst);
    if (c->assess_nodes)
        fprintf(out, "assess_nodes: %ld\n", c->assess_nodes);
}
