/* The capture journal, samples.csv (journal/journal.h): read back on every
 * resume and by `gonio fit`, after power cuts and disk faults. */
#include <stdlib.h>
#include <string.h>

#include "journal/journal.h"
#include "fuzz/fuzz.h"

/* Field by field: the structs' padding is not part of the record. */
static int same(const struct journal_sample *a, const struct journal_sample *b, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        const struct journal_sample *x = &a[i], *y = &b[i];
        double u[13] = {x->theta_i, x->theta_r, x->phi_i, x->theta_o, x->phi_o, x->s, x->a,
                        x->rgb[0], x->rgb[1], x->rgb[2], x->integration_s, x->rig_time_s, 0};
        double v[13] = {y->theta_i, y->theta_r, y->phi_i, y->theta_o, y->phi_o, y->s, y->a,
                        y->rgb[0], y->rgb[1], y->rgb[2], y->integration_s, y->rig_time_s, 0};
        if (x->point != y->point || x->flags != y->flags || memcmp(u, v, sizeof u))
            return 0;
    }
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("samples.csv", data, size);
    struct gonio_err err = {0};
    struct journal_sample *s1 = NULL, *s2 = NULL, *s3 = NULL;
    size_t n1 = 0, n2 = 0, n3 = 0;
    int rc1 = journal_read(path, &s1, &n1, &err);
    if (rc1 < 0)
        FUZZ_CHECK(err.msg[0]);
    /* Opening for append cuts a torn tail: what it keeps is exactly what
     * the reader accepted, and reading after it gives the same again. */
    journal *j = journal_open(path, &s2, &n2, &err);
    FUZZ_CHECK(!j == (rc1 < 0));
    if (j) {
        journal_close(j);
        FUZZ_CHECK(n2 == n1 && same(s1, s2, n1));
        FUZZ_CHECK(journal_read(path, &s3, &n3, &err) == 0);
        FUZZ_CHECK(n3 == n1 && same(s1, s3, n1));
    }
    free(s1);
    free(s2);
    free(s3);
    return 0;
}
