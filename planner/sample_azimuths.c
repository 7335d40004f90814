/* A plan's sample_azimuths (docs/plans.md): every in-plane pair measured
 * with the sample turned to each of a few azimuths on the rig's rotation
 * axis, so that a model of an anisotropic material (fit/aniso_ggx_model.h)
 * sees the lobe along more than one direction of the sample. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/cfg.h"
#include "planner/plan_private.h"

#define MAX_AZIMUTHS 36

/* The azimuths asked for: a count K (K azimuths 180/(K + 1) apart from 0,
 * within the half turn that holds every view of a lobe, which is the same
 * turned 180 degrees; not 180/K: two turns 90 apart are refused, below) or
 * a list of degrees. */
static int read_azimuths(const struct cfg_doc *d, const struct cfg_node *root, double **az,
                         size_t *k, struct gonio_err *err)
{
    if (!cfg_is_scalar(d, cfg_get(d, root, "sample_azimuths")))
        return cfg_doubles(d, root, "sample_azimuths", CFG_REQUIRED, -180, 180, 1,
                           MAX_AZIMUTHS, az, k, err);
    long n;
    int rc = cfg_int(d, root, "sample_azimuths", CFG_REQUIRED, 1, MAX_AZIMUTHS, &n, err);
    if (rc < 0)
        return rc;
    if (!(*az = malloc((size_t)n * sizeof **az)))
        return gonio_err_set(err, ENOMEM, "%s: out of memory", cfg_path(d));
    for (long i = 0; i < n; i++)
        (*az)[i] = 180.0 * (double)i / (double)(n + 1);
    *k = (size_t)n;
    return 0;
}

static int check_azimuths(const struct cfg_doc *d, const struct cfg_node *node,
                          const struct rig_profile *rig, const struct plan *p, const double *az,
                          size_t k, struct gonio_err *err)
{
    if (!rig->has_rotation)
        return cfg_error(d, node, "sample_azimuths", err,
                         "rig '%s' has no rotation axis (axes.rotation) to turn the sample "
                         "about its normal; use a rig profile with one (configs/rigs/"
                         "rotating.yaml)", rig->name);
    if (p->out_of_plane)
        return cfg_error(d, node, "sample_azimuths", err,
                         "only an in-plane plan turns the sample (out-of-plane pairs name "
                         "their own azimuths)");
    for (size_t i = 0; i < k; i++) {
        if (az[i] < rig->rotation.min - 1e-9 || az[i] > rig->rotation.max + 1e-9)
            return cfg_error(d, node, "sample_azimuths", err,
                             "%g deg is beyond rig '%s' rotation limits %g..%g", az[i],
                             rig->name, rig->rotation.min, rig->rotation.max);
        for (size_t j = 0; j < i; j++)
            if (fabs(az[i] - az[j]) < 1e-9)
                return cfg_error(d, node, "sample_azimuths", err, "%g deg is given twice",
                                 az[i]);
    }
    /* A reflection of the sample about either turn maps both slices onto
     * themselves: a grain at +phi and one at -phi read alike. Three turns,
     * or two not 90 apart, tell them apart. */
    if (k == 2 && fabs(fmod(fabs(az[1] - az[0]), 180.0) - 90.0) < 1e-9)
        return cfg_error(d, node, "sample_azimuths", err,
                         "two turns 90 deg apart (%g, %g) cannot tell a grain at +phi from "
                         "one at -phi; turn the second less (60) or add a third", az[0], az[1]);
    return 0;
}

int plan_load_sample_azimuths(const struct cfg_doc *d, const struct cfg_node *root,
                              const struct rig_profile *rig, struct plan *p,
                              struct gonio_err *err)
{
    const struct cfg_node *node = cfg_get(d, root, "sample_azimuths");
    if (!node)
        return 0;
    double *az = NULL;
    size_t k = 0;
    int rc = read_azimuths(d, root, &az, &k, err);
    if (rc > 0) /* cfg_doubles' count */
        rc = 0;
    if (rc == 0)
        rc = check_azimuths(d, node, rig, p, az, k, err);
    struct plan_point *pts = rc == 0 ? malloc((p->n > 0 ? p->n * k : 1) * sizeof *pts) : NULL;
    if (rc == 0 && !pts)
        rc = gonio_err_set(err, ENOMEM, "%s: out of memory", cfg_path(d));
    if (rc < 0) {
        free(az);
        return rc;
    }
    for (size_t a = 0; a < k; a++)
        for (size_t i = 0; i < p->n; i++) {
            pts[a * p->n + i] = p->pts[i];
            pts[a * p->n + i].rotation = az[a];
        }
    free(p->pts);
    free(az);
    p->pts = pts;
    p->n *= k;
    p->sample_azimuths = k;
    return 0;
}
