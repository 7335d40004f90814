/* Calibration directories: calibration.json and frames.csv written and read,
 * and the lookup that refuses a calibration a capture cannot use
 * (capture/calibration.h). */
#include "capture/calibration.h"

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "capture/calibration_private.h"
#include "common/paths.h"

#define FRAMES_HEADER CAL_FRAMES_HEADER

static const char *const kind_names[] = {"dark", "reference", "stray", "beam"};

const char *cal_kind_name(enum cal_kind k)
{
    return k >= CAL_DARK && k <= CAL_BEAM ? kind_names[k] : "?";
}

int cal_kind_parse(const char *name)
{
    for (int k = CAL_DARK; k <= CAL_BEAM; k++)
        if (strcmp(name, kind_names[k]) == 0)
            return k;
    return -1;
}

int cal_frame_line(const struct cal_frame *f, char *buf, size_t size)
{
    int len = snprintf(buf, size,
                       "%s,%.17g,%.17g,%.17g,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g",
                       cal_kind_name(f->kind), f->theta_i, f->theta_r,
                       f->integration_s, f->gain_state, f->counts[0], f->counts[1],
                       f->counts[2], f->monitor, f->full_scale, f->nonlinearity, f->rig_time_s);
    for (int k = 0; k < f->n_bands && len >= 0 && (size_t)len < size; k++)
        len += snprintf(buf + len, size - (size_t)len, "%s%.10g:%.17g", k ? " " : ",",
                        f->bands_nm[k], f->bands[k]);
    if (len >= 0 && (size_t)len < size)
        len += snprintf(buf + len, size - (size_t)len, "\n");
    return len;
}

/* The bands field of a frame line (after the twelfth comma), if any. */
static int parse_bands(const char *line, struct cal_frame *f)
{
    const char *p = line;
    f->n_bands = 0;
    for (int commas = 0; commas < 12; p++)
        if (!*p)
            return 0;
        else if (*p == ',')
            commas++;
    while (*p && *p != '\n') {
        char *end;
        if (f->n_bands == CAL_MAX_BANDS)
            return -1;
        f->bands_nm[f->n_bands] = strtod(p, &end);
        if (end == p || *end != ':')
            return -1;
        p = end + 1;
        f->bands[f->n_bands++] = strtod(p, &end);
        if (end == p || (*end != ' ' && *end != '\n' && *end))
            return -1;
        p = *end == ' ' ? end + 1 : end;
    }
    return 0;
}

static int write_frames(const char *path, const struct cal_frame *f, size_t n,
                        struct gonio_err *err)
{
    size_t cap = 128, len = 0;
    for (size_t k = 0; k < n; k++)
        cap += 256 + 56 * (size_t)f[k].n_bands;
    char *buf = malloc(cap);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    len += (size_t)snprintf(buf, cap, FRAMES_HEADER);
    for (size_t k = 0; k < n; k++)
        len += (size_t)cal_frame_line(&f[k], buf + len, cap - len);
    int rc = gonio_write_file_atomic(path, buf, len, err);
    free(buf);
    return rc;
}

int cal_frames_read(const char *path, struct cal_frame **out, size_t *n,
                    struct gonio_err *err)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : errno, "%s: %s", path,
                             strerror(errno));
    char line[CAL_FRAME_LINE_MAX];
    size_t cap = 0, lineno = 1;
    struct cal_frame *v = NULL;
    *n = 0;
    int rc = fgets(line, sizeof line, fp) && strcmp(line, FRAMES_HEADER) == 0
                 ? 0
                 : gonio_err_set(err, GONIO_EBADDATA, "%s:1: not a frames file", path);
    while (rc == 0 && fgets(line, sizeof line, fp)) {
        lineno++;
        if (*n == cap) {
            cap = cap ? 2 * cap : 256;
            struct cal_frame *nv = realloc(v, cap * sizeof *nv);
            if (!nv) {
                rc = gonio_err_set(err, ENOMEM, "%s: out of memory", path);
                break;
            }
            v = nv;
        }
        struct cal_frame *f = &v[*n];
        char kind[16];
        if (sscanf(line, "%15[a-z],%lf,%lf,%lf,%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf", kind,
                   &f->theta_i, &f->theta_r, &f->integration_s, &f->gain_state, &f->counts[0],
                   &f->counts[1], &f->counts[2], &f->monitor, &f->full_scale,
                   &f->nonlinearity, &f->rig_time_s) != 12 ||
            cal_kind_parse(kind) < 0 ||
            parse_bands(line, f) < 0) {
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s:%zu: not a frame record", path, lineno);
            break;
        }
        f->kind = (enum cal_kind)cal_kind_parse(kind);
        (*n)++;
    }
    fclose(fp);
    if (rc < 0) {
        free(v);
        return rc;
    }
    *out = v;
    return 0;
}

int cal_write(const char *root, const struct cal_meta *m, const struct cal_frame *frames,
              size_t n, struct gonio_err *err)
{
    char dir[4096], path[4200];
    snprintf(dir, sizeof dir, "%s/%s", root, m->id);
    int rc = gonio_mkdir_p(dir, err);
    if (rc < 0)
        return rc;
    snprintf(path, sizeof path, "%s/frames.csv", dir);
    if ((rc = write_frames(path, frames, n, err)) < 0)
        return rc;
    char when[32], until[32];
    struct tm tm;
    time_t exp = m->created + (time_t)m->valid_s;
    strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", gmtime_r(&m->created, &tm));
    strftime(until, sizeof until, "%Y-%m-%dT%H:%M:%SZ", gmtime_r(&exp, &tm));
    json_t *ints = json_array();
    for (size_t k = 0; k < m->n_integrations; k++)
        json_array_append_new(ints, json_real(m->integrations[k]));
    json_t *j = json_pack("{s:s, s:s, s:I, s:s, s:f, s:s, s:s, s:s, s:o, s:[i], s:f, s:I}",
                          "id", m->id, "kind", cal_kind_name(m->kind),
                          "created_unix", (json_int_t)m->created, "created", when,
                          "valid_s", m->valid_s, "expires", until, "rig", m->rig,
                          "detector", m->detector, "integrations_s", ints, "gain_states",
                          m->gain_state, "in_position_deg", m->in_position_deg, "frames",
                          (json_int_t)n);
    if (j)
        json_object_set_new(j, "spot", json_string(m->spot == RAD_SPOT_OVERFILLED
                                                       ? "overfilled" : "underfilled"));
    if (j && m->kind == CAL_REFERENCE)
        json_object_set_new(j, "standard", json_string(m->standard));
    if (j && m->kind != CAL_DARK)
        json_object_set_new(j, "dark", json_string(m->dark));
    if (j && (m->kind == CAL_REFERENCE || m->kind == CAL_BEAM) && m->stray[0])
        json_object_set_new(j, "stray", json_string(m->stray));
    if (j && m->kind == CAL_BEAM)
        json_object_set_new(j, "beam", json_pack("{s:f, s:f, s:f, s:f}", "solid_angle_sr",
                                                 m->beam.omega_sr, "solid_angle_relative_u",
                                                 m->beam.omega_rel_u, "attenuation",
                                                 m->beam.attenuation, "attenuation_relative_u",
                                                 m->beam.attenuation_rel_u));
    char *text = j ? json_dumps(j, JSON_INDENT(2) | JSON_REAL_PRECISION(12)) : NULL;
    json_decref(j);
    if (!text)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", dir);
    snprintf(path, sizeof path, "%s/calibration.json", dir);
    size_t len = strlen(text);
    text[len] = '\n';
    rc = gonio_write_file_atomic(path, text, len + 1, err);
    free(text);
    return rc;
}

static int meta_from_json(const char *path, json_t *j, struct cal_meta *m,
                          struct gonio_err *err)
{
    const char *id, *kind, *rig, *det, *std = "", *dark = "", *spot = "underfilled",
               *stray = "";
    json_int_t created;
    json_t *ints, *gains;
    double valid, band;
    if (json_unpack(j, "{s:s, s:s, s:I, s:F, s:s, s:s, s:o, s:o, s:F, s?s, s?s}", "id", &id,
                    "kind", &kind, "created_unix", &created, "valid_s", &valid, "rig", &rig,
                    "detector", &det, "integrations_s", &ints, "gain_states", &gains,
                    "in_position_deg", &band, "standard", &std, "dark", &dark) != 0 ||
        json_unpack(j, "{s?s, s?s}", "spot", &spot, "stray", &stray) != 0 ||
        cal_kind_parse(kind) < 0 || !json_is_array(ints) || !json_is_array(gains) ||
        json_array_size(gains) != 1)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: not a calibration (a member is missing "
                             "or of the wrong type)", path);
    memset(m, 0, sizeof *m);
    snprintf(m->id, sizeof m->id, "%s", id);
    m->kind = (enum cal_kind)cal_kind_parse(kind);
    m->created = (time_t)created, m->valid_s = valid, m->in_position_deg = band;
    m->spot = strcmp(spot, "overfilled") == 0 ? RAD_SPOT_OVERFILLED : RAD_SPOT_UNDERFILLED;
    snprintf(m->rig, sizeof m->rig, "%s", rig);
    snprintf(m->detector, sizeof m->detector, "%s", det);
    snprintf(m->standard, sizeof m->standard, "%s", std);
    snprintf(m->dark, sizeof m->dark, "%s", dark);
    snprintf(m->stray, sizeof m->stray, "%s", stray);
    for (size_t k = 0; k < json_array_size(ints) && k < CAL_MAX_INTEGRATIONS; k++)
        m->integrations[m->n_integrations++] = json_number_value(json_array_get(ints, k));
    m->gain_state = (int)json_integer_value(json_array_get(gains, 0));
    if (m->kind == CAL_BEAM &&
        json_unpack(j, "{s:{s:F, s:F, s:F, s:F}}", "beam", "solid_angle_sr", &m->beam.omega_sr,
                    "solid_angle_relative_u", &m->beam.omega_rel_u, "attenuation",
                    &m->beam.attenuation, "attenuation_relative_u",
                    &m->beam.attenuation_rel_u) != 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: a beam calibration without its beam "
                             "geometry (solid_angle_sr, attenuation and their u)", path);
    m->beam.on = m->kind == CAL_BEAM;
    return 0;
}

int cal_read(const char *root, const char *id, struct cal_meta *meta, struct cal_frame **frames,
             size_t *n, struct gonio_err *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s/calibration.json", root, id);
    json_error_t je;
    json_t *j = json_load_file(path, 0, &je);
    if (!j)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s: not found in %s (%s)", id,
                             root, je.text);
    int rc = meta_from_json(path, j, meta, err);
    json_decref(j);
    if (rc < 0 || !frames)
        return rc;
    snprintf(path, sizeof path, "%s/%s/frames.csv", root, id);
    return cal_frames_read(path, frames, n, err);
}

/* Why a calibration cannot serve the capture, in err; 0 when it can. */
static int check(const char *root, const struct cal_meta *m, const struct cal_need *need,
                 struct gonio_err *err)
{
    (void)root;
    time_t exp = m->created + (time_t)m->valid_s;
    if (need->now > exp) {
        char until[32];
        struct tm tm;
        strftime(until, sizeof until, "%Y-%m-%dT%H:%M:%SZ", gmtime_r(&exp, &tm));
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s expired at %s (valid %g h)",
                             m->id, until, m->valid_s / 3600);
    }
    if (strcmp(m->rig, need->rig) != 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is of rig '%s', the "
                             "capture's rig is '%s'", m->id, m->rig, need->rig);
    if (strcmp(m->detector, need->detector) != 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is of detector '%s', the "
                             "capture's detector is '%s'", m->id, m->detector, need->detector);
    if (need->gain_state >= 0 && m->gain_state != need->gain_state)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s covers gain state %d, not "
                             "the capture's %d", m->id, m->gain_state, need->gain_state);
    for (size_t k = 0; k < m->n_integrations; k++)
        if (fabs(m->integrations[k] - need->integration_s) <= 1e-9 * need->integration_s)
            return 0;
    char have[256] = "";
    for (size_t k = 0, len = 0; k < m->n_integrations && len < sizeof have - 32; k++)
        len += (size_t)snprintf(have + len, sizeof have - len, "%s%g s", k ? ", " : "",
                                m->integrations[k]);
    return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s does not cover integration "
                         "%g s (it has %s)", m->id, need->integration_s, have);
}

/* A reference calibration, its dark and its stray light all checked. */
static int check_pair(const char *root, const struct cal_meta *m, const struct cal_need *need,
                      struct gonio_err *err)
{
    if (m->kind != CAL_REFERENCE && m->kind != CAL_BEAM)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is a %s calibration: "
                             "name a reference or beam calibration (it brings its dark)",
                             m->id, cal_kind_name(m->kind));
    int rc = check(root, m, need, err);
    if (rc < 0)
        return rc;
    struct cal_meta d;
    if ((rc = cal_read(root, m->dark, &d, NULL, NULL, err)) < 0)
        return rc;
    struct gonio_err inner = {0};
    if (check(root, &d, need, &inner) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s: its dark: %s", m->id,
                             inner.msg);
    if (!m->stray[0])
        return 0;
    if ((rc = cal_read(root, m->stray, &d, NULL, NULL, err)) < 0)
        return rc;
    /* The stray light is read at the reference's integration only. */
    struct cal_need at_ref = *need;
    at_ref.integration_s = d.n_integrations ? d.integrations[0] : need->integration_s;
    if (check(root, &d, &at_ref, &inner) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s: its stray light: %s",
                             m->id, inner.msg);
    return 0;
}

/* The newest calibration of kind in root that serves need. */
static int newest(const char *root, enum cal_kind kind, const struct cal_need *need,
                  struct cal_meta *out, struct gonio_err *err)
{
    DIR *d = opendir(root);
    if (!d)
        return gonio_err_set(err, GONIO_EBADCONFIG, "no calibrations: %s: %s (run gonio "
                             "calibrate dark, then reference)", root, strerror(errno));
    struct cal_meta m, best = {0};
    char why[GONIO_ERR_MSG_MAX] = "";
    int found = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        struct gonio_err inner = {0};
        if (e->d_name[0] == '.' || cal_read(root, e->d_name, &m, NULL, NULL, &inner) < 0 ||
            m.kind != kind)
            continue;
        int bad = kind == CAL_REFERENCE ? check_pair(root, &m, need, &inner)
                                        : check(root, &m, need, &inner);
        if (bad < 0) {
            snprintf(why, sizeof why, "%s", inner.msg);
            continue;
        }
        if (!found || m.created > best.created ||
            (m.created == best.created && strcmp(m.id, best.id) > 0))
            best = m, found = 1;
    }
    closedir(d);
    if (!found)
        return gonio_err_set(err, GONIO_EBADCONFIG, "no valid %s calibration in %s for rig "
                             "'%s', detector '%s'%s%s", cal_kind_name(kind),
                             root, need->rig, need->detector, *why ? ": " : "", why);
    *out = best;
    return 0;
}

int cal_select(const char *root, const char *id, const struct cal_need *need,
               struct cal_meta *meta_out, struct gonio_err *err)
{
    struct cal_meta m;
    int rc;
    if (id) {
        if ((rc = cal_read(root, id, &m, NULL, NULL, err)) < 0 ||
            (rc = check_pair(root, &m, need, err)) < 0)
            return rc;
    } else if ((rc = newest(root, CAL_REFERENCE, need, &m, err)) < 0) {
        return rc;
    }
    if (meta_out)
        *meta_out = m;
    return 0;
}

int cal_select_stray(const char *root, const char *id, const char *dark,
                     const struct cal_need *need, struct cal_meta *meta_out,
                     struct gonio_err *err)
{
    struct cal_meta m;
    int rc;
    if (strcmp(id, "newest") != 0) {
        if ((rc = cal_read(root, id, &m, NULL, NULL, err)) < 0)
            return rc;
        if (m.kind != CAL_STRAY)
            return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is not a stray-light "
                                 "calibration", id);
        if ((rc = check(root, &m, need, err)) < 0)
            return rc;
    } else if ((rc = newest(root, CAL_STRAY, need, &m, err)) < 0) {
        return rc;
    }
    if (strcmp(m.dark, dark) != 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s was taken with dark %s, "
                             "not the reference's %s: take the stray light and the "
                             "reference with one dark", m.id, m.dark, dark);
    if (meta_out)
        *meta_out = m;
    return 0;
}

int cal_select_dark(const char *root, const char *id, const struct cal_need *need,
                    struct cal_meta *meta_out, struct gonio_err *err)
{
    struct cal_meta m;
    int rc;
    if (id) {
        if ((rc = cal_read(root, id, &m, NULL, NULL, err)) < 0)
            return rc;
        if (m.kind != CAL_DARK)
            return gonio_err_set(err, GONIO_EBADCONFIG, "calibration %s is not a dark "
                                 "calibration", id);
        if ((rc = check(root, &m, need, err)) < 0)
            return rc;
    } else if ((rc = newest(root, CAL_DARK, need, &m, err)) < 0) {
        return rc;
    }
    if (meta_out)
        *meta_out = m;
    return 0;
}
