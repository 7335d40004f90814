/* Journal samples for the slices plot (samples.h). */
#include "report/samples.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "brdf/angles.h"
#include "journal/journal.h"

int report_samples_read(const char *path, struct report_sample **out, size_t *n,
                        size_t *n_out_of_plane, size_t *n_without_value,
                        struct gonio_err *err)
{
    char buf[4200];
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        snprintf(buf, sizeof buf, "%.4000s/samples.csv", path);
        path = buf;
    }
    struct journal_sample *js = NULL;
    size_t m = 0;
    int rc = journal_read(path, &js, &m, err);
    if (rc < 0)
        return rc;
    struct report_sample *s = malloc((m ? m : 1) * sizeof *s);
    if (!s) {
        free(js);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: out of memory", path);
    }
    size_t k = 0, oop = 0, none = 0;
    for (size_t i = 0; i < m; i++) {
        if (!journal_sample_has_brdf(&js[i])) {
            none++;
            continue;
        }
        struct brdf_pair p;
        journal_sample_pair(&js[i], &p);
        double ti, tr;
        if (brdf_pair_to_inplane(&p, &ti, &tr)) {
            oop++;
            continue;
        }
        s[k].theta_i = ti;
        s[k].theta_r = tr;
        memcpy(s[k].rgb, js[i].rgb, sizeof s[k].rgb);
        k++;
    }
    free(js);
    *out = s;
    *n = k;
    if (n_out_of_plane)
        *n_out_of_plane = oop;
    if (n_without_value)
        *n_without_value = none;
    return 0;
}
