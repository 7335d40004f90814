/* gonio study merge: join the folders of a study's shards into one. */
#include "study/study.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <jansson.h>

#include "common/paths.h"
#include "study/study_private.h"

static int slurp(const char *path, char **buf, size_t *len, struct gonio_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    char *b = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n == cap) {
            cap = cap ? 2 * cap : 65536;
            char *g = realloc(b, cap);
            if (!g) {
                free(b);
                fclose(f);
                return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
            }
            b = g;
        }
        size_t r = fread(b + n, 1, cap - n, f);
        n += r;
        if (r == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(b);
        return gonio_err_set(err, EIO, "%s: read error", path);
    }
    *buf = b;
    *len = n;
    return 0;
}

/* Copy src to dst unless dst holds the same bytes; a different dst is a
 * conflict between two inputs. */
static int merge_file(const char *src, const char *dst, struct gonio_err *err)
{
    char *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    int rc = slurp(src, &a, &na, err);
    if (rc < 0)
        return rc;
    if (access(dst, F_OK) == 0) {
        if ((rc = slurp(dst, &b, &nb, err)) == 0 && (na != nb || memcmp(a, b, na) != 0))
            rc = gonio_err_set(err, GONIO_EUSAGE,
                               "%s and %s differ: the same job was run in two inputs", src, dst);
    } else {
        rc = gonio_write_file_atomic(dst, a, na, err);
    }
    free(a);
    free(b);
    return rc;
}

/* A file of a job folder worth carrying over: not the lock, not a
 * temporary file of an interrupted atomic write. */
static int wanted(const char *name)
{
    if (name[0] == '.' || !strcmp(name, "lock"))
        return 0;
    return strstr(name, ".tmp") == NULL;
}

static int merge_job(const char *in, const char *out, const char *id, struct gonio_err *err)
{
    char src_dir[4200], dst_dir[4200];
    snprintf(src_dir, sizeof src_dir, "%.4000s/jobs/%s", in, id);
    snprintf(dst_dir, sizeof dst_dir, "%.4000s/jobs/%s", out, id);
    DIR *d = opendir(src_dir);
    if (!d)
        return 0; /* not run in this input */
    int rc = gonio_mkdir_p(dst_dir, err);
    struct dirent *e;
    while (rc == 0 && (e = readdir(d))) {
        if (!wanted(e->d_name))
            continue;
        char src[4500], dst[4500];
        snprintf(src, sizeof src, "%s/%s", src_dir, e->d_name);
        snprintf(dst, sizeof dst, "%s/%s", dst_dir, e->d_name);
        struct stat st;
        if (stat(src, &st) != 0 || !S_ISREG(st.st_mode))
            continue;
        rc = merge_file(src, dst, err);
    }
    closedir(d);
    return rc;
}

int study_merge(const char *const *dirs, size_t n, const char *out, struct gonio_err *err)
{
    if (n == 0)
        return gonio_err_set(err, GONIO_EUSAGE, "merge: no input folders");
    struct study_spec *s = malloc(sizeof *s), *t = malloc(sizeof *t);
    if (!s || !t) {
        free(s);
        free(t);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    int rc = study_spec_read(dirs[0], s, err);
    json_t *ref = rc == 0 ? study_spec_json(s, 0) : NULL;
    for (size_t i = 1; rc == 0 && i < n; i++) {
        if ((rc = study_spec_read(dirs[i], t, err)) < 0)
            break;
        json_t *other = study_spec_json(t, 0);
        if (!json_equal(ref, other))
            rc = gonio_err_set(err, GONIO_EUSAGE,
                               "%s is a shard of another study than %s (materials, scenes, "
                               "plans or models differ)",
                               dirs[i], dirs[0]);
        json_decref(other);
    }
    json_decref(ref);
    if (rc == 0) {
        s->shard_i = s->shard_n = 1;
        rc = study_dir_prepare(s, out, err);
    }
    for (size_t i = 0; rc == 0 && i < n; i++)
        for (size_t k = 0; rc == 0 && k < study_job_count(s); k++) {
            struct study_job job;
            study_job_at(s, k, &job);
            rc = merge_job(dirs[i], out, job.id, err);
        }
    size_t missing = 0;
    if (rc == 0)
        rc = study_results_write(s, out, &missing, err);
    free(s);
    free(t);
    return rc < 0 ? rc : (int)missing;
}
