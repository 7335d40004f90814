#include "fit/model_run.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/clock.h"
#include "fit/model_file.h"

/* mf written atomically to path and, when material is not NULL, opened
 * back (`model:PATH`) into *material: what a reader of the file gets. */
static int write_open(const struct fit_model_file *mf, const char *path,
                      brdf_material **material, struct gonio_err *err)
{
    if (material)
        *material = NULL;
    int rc = fit_model_file_write(mf, path, err);
    if (rc < 0 || !material)
        return rc;
    char spec[4200];
    if ((size_t)snprintf(spec, sizeof spec, "model:%s", path) >= sizeof spec)
        return gonio_err_set(err, GONIO_EUSAGE, "%.64s...: model file path too long", path);
    *material = fit_material_open(spec, err);
    return *material ? 0 : -abs(err && err->code ? err->code : GONIO_EBADDATA);
}

static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int fit_model_run(const struct fit_model_kind *kind, const struct fit_data *data,
                  const struct fit_model_options *opt, const char *path,
                  struct fit_model_report *rep, brdf_material **material,
                  struct gonio_err *err)
{
    struct fit_model_file *mf = NULL;
    struct fit_model_report r = {0};
    if (material)
        *material = NULL;
    double t0 = gonio_monotonic_s(), c0 = cpu_s();
    int rc = kind->fit(data, opt, &mf, &r, err);
    r.fit_s = gonio_monotonic_s() - t0;
    r.cpu_s = cpu_s() - c0;
    r.fitted = rc >= 0;
    if (rep)
        *rep = r;
    if (rc < 0)
        return rc;
    rc = write_open(mf, path, material, err);
    fit_model_file_free(mf);
    return rc;
}

int fit_sample_errors(const brdf_material *m, const struct fit_sample *s, size_t n,
                      struct brdf_errors *out, struct gonio_err *err)
{
    struct brdf_pair *pairs = malloc((n ? n : 1) * sizeof *pairs);
    double *meas = malloc(3 * (n ? n : 1) * sizeof *meas),
           *pred = malloc(3 * (n ? n : 1) * sizeof *pred);
    int rc = 0;
    if (!pairs || !meas || !pred) {
        rc = gonio_err_set(err, ENOMEM, "out of memory");
    } else {
        for (size_t i = 0; i < n; i++) {
            pairs[i] = s[i].g;
            memcpy(meas + 3 * i, s[i].rgb, sizeof s[i].rgb);
        }
        brdf_material_eval(m, pairs, n, pred);
        brdf_errors_compute(pairs, meas, pred, n, out);
    }
    free(pairs);
    free(meas);
    free(pred);
    return rc;
}
