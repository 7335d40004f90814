#include "brdf/published.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/paths.h"

#define PUB_PI 3.14159265358979323846
#define MAX_COLS 48
#define LINE_MAX_LEN 4096

void brdf_published_abc_convert(const struct brdf_abc_published *pub, struct brdf_abc *out)
{
    for (int c = 0; c < 3; c++) {
        out->kd[c] = pub->kd[c];
        out->A[c] = pub->A[c] / PUB_PI;
    }
    out->B = pub->B;
    out->C = pub->C;
    out->eta = pub->ior;
}

/* Split a CSV line in place (no quoting in these tables). */
static int split(char *line, char **cols)
{
    int n = 0;
    line[strcspn(line, "\r\n")] = '\0';
    for (char *p = line;;) {
        if (n == MAX_COLS)
            return -1;
        cols[n++] = p;
        char *c = strchr(p, ',');
        if (!c)
            break;
        *c = '\0';
        p = c + 1;
    }
    return n;
}

/* Find the row whose first column (or, when alt_col is set, the column
 * named alt_col) is NAME; fill vals[k] with the columns named fields[k]. */
static int read_row(const char *path, const char *name, const char *alt_col,
                    const char *const *fields, int nfields, double *vals,
                    struct gonio_err *err)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        int e = errno;
        return gonio_err_set(err, e == ENOENT ? GONIO_ENOTFOUND : GONIO_EBADDATA,
                             "%s: cannot open: %s", path, strerror(e));
    }
    char line[LINE_MAX_LEN];
    char *cols[MAX_COLS];
    int idx[MAX_COLS], alt = -1, rc;
    if (!fgets(line, sizeof line, f)) {
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: empty file", path);
    }
    int ncols = split(line, cols);
    if (ncols < 0) {
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: line 1: too many columns", path);
    }
    for (int k = 0; k < nfields; k++) {
        idx[k] = -1;
        for (int c = 0; c < ncols; c++)
            if (strcmp(cols[c], fields[k]) == 0)
                idx[k] = c;
        if (idx[k] < 0) {
            fclose(f);
            return gonio_err_set(err, GONIO_EBADDATA, "%s: header has no column '%s'", path,
                                 fields[k]);
        }
    }
    for (int c = 0; alt_col && c < ncols; c++)
        if (strcmp(cols[c], alt_col) == 0)
            alt = c;

    /* An exact name wins over another row's alternative name, wherever
     * the two rows are; the first alternative match is kept until EOF. */
    char hit[LINE_MAX_LEN], alt_hit[LINE_MAX_LEN];
    int lineno = 1, found = 0, alt_lineno = 0;
    while (!found && fgets(line, sizeof line, f)) {
        lineno++;
        char copy[LINE_MAX_LEN];
        memcpy(copy, line, strlen(line) + 1);
        int n = split(line, cols);
        if (n <= 0 || !*cols[0])
            continue;
        if (strcmp(cols[0], name) == 0) {
            found = lineno;
            memcpy(hit, copy, strlen(copy) + 1);
        } else if (!alt_lineno && alt >= 0 && alt < n && *cols[alt] &&
                   strcmp(cols[alt], name) == 0) {
            alt_lineno = lineno;
            memcpy(alt_hit, copy, strlen(copy) + 1);
        }
    }
    rc = ferror(f);
    fclose(f);
    if (rc)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: read error", path);
    if (!found && alt_lineno) {
        found = alt_lineno;
        memcpy(hit, alt_hit, strlen(alt_hit) + 1);
    }
    if (!found)
        return gonio_err_set(err, GONIO_ENOTFOUND, "%s: no material named '%s'", path, name);
    int n = split(hit, cols);
    if (n != ncols)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: line %d (%s): %d columns, header has %d",
                             path, found, name, n, ncols);
    for (int k = 0; k < nfields; k++) {
        char *end;
        vals[k] = strtod(cols[idx[k]], &end);
        if (end == cols[idx[k]] || *end || !isfinite(vals[k]))
            return gonio_err_set(err, GONIO_EBADDATA,
                                 "%s: line %d (%s): column %s: '%s' is not a finite number", path,
                                 found, name, fields[k], cols[idx[k]]);
    }
    return 0;
}

int brdf_published_abc_read(const char *path, const char *name, struct brdf_abc_published *out,
                            struct gonio_err *err)
{
    static const char *const fields[] = {"kd_r", "kd_g", "kd_b", "A_r", "A_g", "A_b",
                                         "B",    "C",    "ior"};
    double v[9];
    int rc = read_row(path, name, NULL, fields, 9, v, err);
    if (rc < 0)
        return rc;
    for (int c = 0; c < 3; c++) {
        out->kd[c] = v[c];
        out->A[c] = v[3 + c];
    }
    out->B = v[6];
    out->C = v[7];
    out->ior = v[8];
    return 0;
}

int brdf_published_sgd_read(const char *path, const char *name, struct brdf_sgd *out,
                            struct gonio_err *err)
{
    static const char *const groups[] = {"rhoD", "rhoS",   "alpha", "p", "f0",    "f1",
                                         "kap",  "lambda", "c",     "k", "theta0"};
    static const char *const rgb[] = {"_r", "_g", "_b"};
    enum { NG = sizeof groups / sizeof groups[0] };
    char names[NG * 3][16];
    const char *fields[NG * 3];
    for (int g = 0; g < NG; g++)
        for (int c = 0; c < 3; c++) {
            snprintf(names[3 * g + c], sizeof names[0], "%s%s", groups[g], rgb[c]);
            fields[3 * g + c] = names[3 * g + c];
        }
    double v[NG * 3];
    int rc = read_row(path, name, "other_name", fields, NG * 3, v, err);
    if (rc < 0)
        return rc;
    double *dst[NG] = {out->rho_d, out->rho_s, out->alpha, out->p,  out->f0,    out->f1,
                       out->kap,   out->lambda, out->c,    out->k, out->theta0};
    for (int g = 0; g < NG; g++)
        for (int c = 0; c < 3; c++)
            dst[g][c] = v[3 * g + c];
    for (int c = 0; c < 3; c++)
        if (!(out->alpha[c] > 0))
            return gonio_err_set(err, GONIO_EBADDATA, "%s: %s: alpha%s = %g must be > 0", path,
                                 name, rgb[c], out->alpha[c]);
    return 0;
}

static int fits_path(const char *file, char *path, size_t size, struct gonio_err *err)
{
    const char *shared = gonio_shared_dir();
    if (!shared)
        return gonio_err_set(err, GONIO_ENOTFOUND,
                             "%s: shared data folder not found (set GONIO_SHARED)", file);
    if (snprintf(path, size, "%s/data/merl/fits/%s", shared, file) >= (int)size)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: path too long", file);
    return 0;
}

int brdf_published_abc(const char *name, struct brdf_abc *out, struct gonio_err *err)
{
    char path[4096];
    struct brdf_abc_published pub;
    int rc = fits_path("abc_low2012_merl.csv", path, sizeof path, err);
    if (rc == 0)
        rc = brdf_published_abc_read(path, name, &pub, err);
    if (rc == 0)
        brdf_published_abc_convert(&pub, out);
    return rc;
}

int brdf_published_sgd(const char *name, struct brdf_sgd *out, struct gonio_err *err)
{
    char path[4096];
    int rc = fits_path("sgd_bagher2012_merl.csv", path, sizeof path, err);
    if (rc == 0)
        rc = brdf_published_sgd_read(path, name, out, err);
    return rc;
}
