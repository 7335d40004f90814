/* Spectral samples CSV (docs/models.md): the input of `gonio fit --model
 * mlp-spectral` until captures carry spectra. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fit/mlp.h"

int fit_spectral_samples_read(const char *path, struct fit_spectral_sample **out, size_t *n,
                              struct gonio_err *err)
{
    *out = NULL;
    *n = 0;
    FILE *fp = fopen(path, "r");
    if (!fp)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : errno,
                             "%s: cannot open spectral samples: %s", path, strerror(errno));
    char line[1024];
    int lineno = 1;
    if (!fgets(line, sizeof line, fp) ||
        strncmp(line, "theta_i,theta_r,wavelength_nm,value", 35) ||
        (line[35] != '\n' && line[35] != '\r' && line[35] != ',' && line[35] != 0)) {
        fclose(fp);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s:1: header must start theta_i,theta_r,wavelength_nm,value", path);
    }
    /* spectra.csv (docs/formats.md) names the saturated flag 7th */
    static const char sat_cols[] = ",acquisition,integration_s,saturated";
    int has_sat = !strncmp(line + 35, sat_cols, sizeof sat_cols - 1);
    size_t cap = 0, m = 0;
    struct fit_spectral_sample *s = NULL;
    int rc = 0;
    while (fgets(line, sizeof line, fp)) {
        lineno++;
        if (line[0] == '\n' || line[0] == '\r' || line[0] == '#')
            continue;
        if (!strchr(line, '\n') && !feof(fp)) {
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s:%d: line too long", path, lineno);
            break;
        }
        double v[4];
        char *p = line, *end;
        int k;
        for (k = 0; k < 4; k++) {
            errno = 0;
            v[k] = strtod(p, &end);
            if (end == p || errno == ERANGE || !isfinite(v[k]))
                break;
            if (k < 3 && *end != ',')
                break;
            p = end + 1;
        }
        if (k < 4 || (*end != ',' && *end != '\n' && *end != '\r' && *end)) {
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s:%d: expected four numbers "
                               "theta_i,theta_r,wavelength_nm,value", path, lineno);
            break;
        }
        int sat = 0;
        if (has_sat) { /* skip acquisition and integration_s, then 0 or 1 */
            char *q = end;
            for (int skip = 0; q && skip < 3; skip++)
                q = strchr(q + (skip > 0), ',');
            sat = q && (q[1] == '0' || q[1] == '1') && strchr(",\r\n", q[2]) ? q[1] - '0' : -1;
            if (sat < 0) {
                rc = gonio_err_set(err, GONIO_EBADDATA, "%s:%d: column saturated: expected 0 or 1",
                                   path, lineno);
                break;
            }
        }
        if (m == cap) {
            size_t nc = cap ? 2 * cap : 256;
            struct fit_spectral_sample *t = realloc(s, nc * sizeof *t);
            if (!t) {
                rc = gonio_err_set(err, ENOMEM, "%s: out of memory", path);
                break;
            }
            s = t;
            cap = nc;
        }
        s[m++] = (struct fit_spectral_sample){v[0], v[1], v[2], v[3], sat};
    }
    if (!rc && ferror(fp))
        rc = gonio_err_set(err, EIO, "%s: read error", path);
    fclose(fp);
    if (rc) {
        free(s);
        return rc;
    }
    *out = s;
    *n = m;
    return m > (size_t)0x7fffffff ? 0x7fffffff : (int)m;
}
