#include "rig/rig.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/cfg.h"
#include "common/paths.h"

void rig_profile_default(struct rig_profile *rig)
{
    memset(rig, 0, sizeof *rig);
    snprintf(rig->name, sizeof rig->name, "default");
    rig->sample = (struct rig_axis){20, 40, -90, 90};
    rig->arm = (struct rig_axis){15, 30, -170, 170};
    rig->azimuth = (struct rig_axis){30, 60, -180, 180};
    rig->out_of_plane = 1;
    rig->blind_deg = 5;
    rig->settle_s = 0.3;
    rig->integration_s = 0.05;
    rig->auto_min_s = 0.001;
    rig->auto_max_s = 2;
    rig->shutter = 1;
    rig->mech = (struct rig_mechanics){.in_position_deg = 0.1, .approach = 1,
                                        .move_retries = 3};
}

static int load_axis(const struct cfg_doc *d, const struct cfg_node *axes, const char *key,
                     double limit, struct rig_axis *ax, struct gonio_err *err)
{
    static const char *const keys[] = {"speed", "accel", "min", "max", NULL};
    const struct cfg_node *m;
    int rc = cfg_map(d, axes, key, CFG_OPTIONAL, &m, err);
    if (rc <= 0)
        return rc;
    if ((rc = cfg_check_keys(d, m, key, keys, err)) < 0 ||
        (rc = cfg_double(d, m, "speed", CFG_REQUIRED, 0.01, 1000, &ax->speed, err)) < 0 ||
        (rc = cfg_double(d, m, "accel", CFG_REQUIRED, 0.01, 10000, &ax->accel, err)) < 0 ||
        (rc = cfg_double(d, m, "min", CFG_REQUIRED, -limit, limit, &ax->min, err)) < 0 ||
        (rc = cfg_double(d, m, "max", CFG_REQUIRED, -limit, limit, &ax->max, err)) < 0)
        return rc;
    if (ax->min >= ax->max)
        return cfg_error(d, cfg_get(d, m, "max"), "max", err,
                         "must exceed min (value '%g', allowed %g..%g)", ax->max, ax->min,
                         limit);
    return 1;
}

/* The optional mechanics section (defaults: rig_profile_default). */
static int load_mechanics(const struct cfg_doc *d, const struct cfg_node *root,
                          struct rig_mechanics *m, struct gonio_err *err)
{
    static const char *const keys[] = {"in_position_deg", "backlash_deg", "approach",
                                       "move_retries", NULL};
    static const char *const sides[] = {"positive", "negative", NULL};
    const struct cfg_node *map;
    int side = m->approach > 0 ? 0 : 1;
    long retries = m->move_retries;
    int rc = cfg_map(d, root, "mechanics", CFG_OPTIONAL, &map, err);
    if (rc <= 0)
        return rc;
    if ((rc = cfg_check_keys(d, map, "mechanics", keys, err)) < 0 ||
        (rc = cfg_double(d, map, "in_position_deg", CFG_OPTIONAL, 0.001, 5,
                         &m->in_position_deg, err)) < 0 ||
        (rc = cfg_double(d, map, "backlash_deg", CFG_OPTIONAL, 0, 10, &m->backlash_deg,
                         err)) < 0 ||
        (rc = cfg_enum(d, map, "approach", CFG_OPTIONAL, sides, &side, err)) < 0 ||
        (rc = cfg_int(d, map, "move_retries", CFG_OPTIONAL, 0, 20, &retries, err)) < 0)
        return rc;
    m->approach = side == 0 ? 1 : -1;
    m->move_retries = (int)retries;
    return 0;
}

double rig_beam_omega(const struct rig_beam *b, double *rel_u)
{
    double ua = b->aperture_u_mm2 / b->aperture_mm2, ur = 2.0 * b->distance_u_mm / b->distance_mm;
    if (rel_u)
        *rel_u = sqrt(ua * ua + ur * ur);
    return b->aperture_mm2 / (b->distance_mm * b->distance_mm);
}

/* The optional beam section: the absolute method's geometry. The aperture
 * is given by its diameter or its area (one of them), each with its
 * standard uncertainty; a diameter's carries twice into the area. */
static int load_beam(const struct cfg_doc *d, const struct cfg_node *root,
                     struct rig_profile *rig, struct gonio_err *err)
{
    static const char *const keys[] = {"aperture_diameter_mm", "aperture_diameter_u_mm",
                                       "aperture_area_mm2", "aperture_area_u_mm2",
                                       "distance_mm", "distance_u_mm", "arm_deg",
                                       "attenuator", "attenuator_u", NULL};
    struct rig_beam *b = &rig->beam;
    const struct cfg_node *m;
    double dia = NAN, dia_u = 0;
    int rc = cfg_map(d, root, "beam", CFG_OPTIONAL, &m, err);
    if (rc <= 0)
        return rc;
    b->aperture_mm2 = NAN, b->arm_deg = 180, b->attenuation = 1;
    if ((rc = cfg_check_keys(d, m, "beam", keys, err)) < 0 ||
        (rc = cfg_double(d, m, "aperture_diameter_mm", CFG_OPTIONAL, 1e-3, 1e3, &dia, err)) < 0 ||
        (rc = cfg_double(d, m, "aperture_diameter_u_mm", CFG_OPTIONAL, 0, 10, &dia_u, err)) < 0 ||
        (rc = cfg_double(d, m, "aperture_area_mm2", CFG_OPTIONAL, 1e-6, 1e6, &b->aperture_mm2,
                         err)) < 0 ||
        (rc = cfg_double(d, m, "aperture_area_u_mm2", CFG_OPTIONAL, 0, 1e4, &b->aperture_u_mm2,
                         err)) < 0 ||
        (rc = cfg_double(d, m, "distance_mm", CFG_REQUIRED, 1, 1e5, &b->distance_mm, err)) < 0 ||
        (rc = cfg_double(d, m, "distance_u_mm", CFG_OPTIONAL, 0, 100, &b->distance_u_mm,
                         err)) < 0 ||
        (rc = cfg_double(d, m, "arm_deg", CFG_OPTIONAL, -360, 360, &b->arm_deg, err)) < 0 ||
        (rc = cfg_double(d, m, "attenuator", CFG_OPTIONAL, 1e-9, 1, &b->attenuation, err)) < 0 ||
        (rc = cfg_double(d, m, "attenuator_u", CFG_OPTIONAL, 0, 1, &b->attenuation_u, err)) < 0)
        return rc;
    if (isnan(dia) == isnan(b->aperture_mm2))
        return cfg_error(d, m, "beam", err, "give the aperture by aperture_diameter_mm or by "
                         "aperture_area_mm2 (one of them)");
    const char *stray = !isnan(dia) && cfg_get(d, m, "aperture_area_u_mm2")
                            ? "aperture_area_u_mm2"
                        : isnan(dia) && cfg_get(d, m, "aperture_diameter_u_mm")
                            ? "aperture_diameter_u_mm" : NULL;
    if (stray)
        return cfg_error(d, cfg_get(d, m, stray), stray, err, "the aperture is given by %s: "
                         "give its uncertainty as %s", isnan(dia) ? "aperture_area_mm2" :
                         "aperture_diameter_mm", isnan(dia) ? "aperture_area_u_mm2" :
                         "aperture_diameter_u_mm");
    if (!isnan(dia)) {
        b->aperture_mm2 = 3.14159265358979323846 * dia * dia / 4;
        b->aperture_u_mm2 = b->aperture_mm2 * 2 * dia_u / dia;
    }
    if (b->arm_deg < rig->arm.min || b->arm_deg > rig->arm.max)
        return cfg_error(d, cfg_get(d, m, "arm_deg") ? cfg_get(d, m, "arm_deg") : m, "arm_deg",
                         err, "the arm cannot face the source there (value '%g', the arm "
                         "reaches %g..%g)", b->arm_deg, rig->arm.min, rig->arm.max);
    b->on = 1;
    return 0;
}

int rig_profile_load(const char *path_or_name, struct rig_profile *rig, struct gonio_err *err)
{
    /* driver/drivers/detector belong to the drivers and the simulator, which
     * check them; the planner only reads motion and timing. */
    static const char *const top_keys[] = {"name", "description", "out_of_plane", "blind_deg",
                                           "settle_s", "integration", "axes", "driver",
                                           "drivers", "detector", "mechanics", "shutter",
                                           "sample_changer", "beam", NULL};
    static const char *const int_keys[] = {"fixed_s", "auto_min_s", "auto_max_s", NULL};
    static const char *const axis_keys[] = {"sample", "arm", "azimuth", "rotation", NULL};
    char path[4096];
    if (gonio_config_path(path_or_name, "rigs", path, sizeof path) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: path too long", path_or_name);
    rig_profile_default(rig);
    struct cfg_doc *d;
    int rc = cfg_load(path, &d, err);
    if (rc < 0)
        return rc;
    const struct cfg_node *root = cfg_root(d), *integ, *axes;
    const char *name = NULL;
    int has_az = 0;
    if ((rc = cfg_check_keys(d, root, "rig profile", top_keys, err)) < 0 ||
        (rc = cfg_string(d, root, "name", CFG_OPTIONAL, &name, err)) < 0 ||
        (rc = cfg_bool(d, root, "out_of_plane", CFG_REQUIRED, &rig->out_of_plane, err)) < 0 ||
        (rc = cfg_double(d, root, "blind_deg", CFG_REQUIRED, 0, 45, &rig->blind_deg, err)) < 0 ||
        (rc = cfg_double(d, root, "settle_s", CFG_REQUIRED, 0, 60, &rig->settle_s, err)) < 0 ||
        (rc = cfg_map(d, root, "integration", CFG_REQUIRED, &integ, err)) < 0 ||
        (rc = cfg_check_keys(d, integ, "integration", int_keys, err)) < 0 ||
        (rc = cfg_double(d, integ, "fixed_s", CFG_REQUIRED, 1e-6, 60, &rig->integration_s,
                         err)) < 0 ||
        (rc = cfg_double(d, integ, "auto_min_s", CFG_REQUIRED, 1e-6, 60, &rig->auto_min_s,
                         err)) < 0 ||
        (rc = cfg_double(d, integ, "auto_max_s", CFG_REQUIRED, 1e-6, 600, &rig->auto_max_s,
                         err)) < 0 ||
        (rc = cfg_map(d, root, "axes", CFG_REQUIRED, &axes, err)) < 0 ||
        (rc = cfg_check_keys(d, axes, "axes", axis_keys, err)) < 0 ||
        (rc = load_axis(d, axes, "sample", 180, &rig->sample, err)) < 0 ||
        (rc = load_axis(d, axes, "arm", 360, &rig->arm, err)) < 0 ||
        (rc = has_az = load_axis(d, axes, "azimuth", 360, &rig->azimuth, err)) < 0 ||
        (rc = rig->has_rotation = load_axis(d, axes, "rotation", 360, &rig->rotation, err)) < 0 ||
        (rc = load_mechanics(d, root, &rig->mech, err)) < 0 ||
        (rc = cfg_bool(d, root, "shutter", CFG_OPTIONAL, &rig->shutter, err)) < 0 ||
        (rc = cfg_bool(d, root, "sample_changer", CFG_OPTIONAL, &rig->sample_changer, err)) < 0 ||
        (rc = load_beam(d, root, rig, err)) < 0)
        goto out;
    if (!cfg_get(d, axes, "sample") || !cfg_get(d, axes, "arm")) {
        rc = cfg_error(d, axes, cfg_get(d, axes, "sample") ? "arm" : "sample", err,
                       "missing required key");
        goto out;
    }
    if (rig->out_of_plane && !has_az) {
        rc = cfg_error(d, cfg_get(d, root, "out_of_plane"), "out_of_plane", err,
                       "true needs an axes.azimuth entry");
        goto out;
    }
    if (rig->auto_min_s > rig->auto_max_s) {
        rc = cfg_error(d, cfg_get(d, integ, "auto_max_s"), "auto_max_s", err,
                       "below auto_min_s (value '%g', allowed %g..600)", rig->auto_max_s,
                       rig->auto_min_s);
        goto out;
    }
    if (name)
        snprintf(rig->name, sizeof rig->name, "%s", name);
    rc = 0;
out:
    cfg_free(d);
    return rc;
}
