/* The files a capture request carries (docs/protocol.md, "Files sent with a
 * request"): an operator's own plan, rig profile or scene lies where the operator
 * can read it, not goniod (another user, another working directory, maybe
 * another machine), so gonio sends the file's text and goniod keeps a copy
 * in the capture directory, under the file's own name, which the plan's
 * name comes from when it declares none. The copy is what the capture
 * reads, now and on every resume; messages name the file as the operator
 * did. */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/cfg.h"
#include "common/paths.h"
#include "daemon/control_private.h"
#include "daemon/request.h"

/* The folder of the copies inside a capture directory, one subfolder per
 * field (request/plan/NAME, request/rig/NAME, request/scene/NAME). */
static const char sent_dir[] = "request";

static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

int control_sent_take(json_t *req, struct control_sent *s, struct gonio_err *err)
{
    static const char *const fields[CONTROL_SENT_MAX] = {"plan", "rig", "scene"};
    memset(s, 0, sizeof *s);
    for (int i = 0; i < CONTROL_SENT_MAX; i++) {
        char text_key[32];
        snprintf(text_key, sizeof text_key, "%s_text", fields[i]);
        json_t *text = json_object_get(req, text_key);
        if (!text)
            continue;
        const char *name = json_string_value(json_object_get(req, fields[i]));
        if (!name)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "capture: '%s' needs '%s', the name of the file it holds",
                                 text_key, fields[i]);
        /* JSON may hold a NUL that C text cannot: refused, not cut short. */
        if (strlen(json_string_value(text)) != json_string_length(text))
            return gonio_err_set(err, GONIO_EUSAGE, "%s '%.200s': the file holds a NUL byte",
                                 fields[i], name);
        const char *base = base_name(name);
        if (!control_valid_id(base))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s '%.200s': a file sent with the request is named with "
                                 "letters, digits, '.', '_' and '-', not starting with '.' or "
                                 "'-' (rename the file)",
                                 fields[i], name);
        struct control_sent_file *f = &s->files[s->n++];
        f->field = fields[i];
        f->name = name;
        f->base = base;
        f->text = json_string_value(text);
        f->len = json_string_length(text);
    }
    return 0;
}

const char *control_sent_path(const struct control_sent *s, const char *field)
{
    for (int i = 0; i < s->n; i++)
        if (!strcmp(s->files[i].field, field) && s->files[i].written)
            return s->files[i].path;
    return NULL;
}

/* A sent plan's progressive levels are plans too: goniod may open only
 * its own (names), never a path the sender chose. A file the parser
 * refuses is left to the plan loader, whose message says why. */
static int levels_are_names(const struct control_sent_file *f, struct gonio_err *err)
{
    struct cfg_doc *d = NULL;
    struct gonio_err ignored = {0};
    if (cfg_load(f->path, &d, &ignored) < 0)
        return 0;
    const struct cfg_node *seq = NULL;
    int rc = 0;
    if (cfg_is_map(d, cfg_root(d)) &&
        cfg_seq(d, cfg_root(d), "progressive", CFG_OPTIONAL, &seq, &ignored) > 0) {
        for (size_t i = 0; rc == 0 && i < cfg_seq_len(d, seq); i++) {
            const char *ref = NULL;
            if (cfg_node_string(d, cfg_seq_item(d, seq, i), "progressive", &ref, &ignored) > 0 &&
                gonio_ref_is_file(ref))
                rc = gonio_err_set(err, GONIO_EUSAGE,
                                   "plan '%.200s': field 'progressive' names the file '%.200s'; "
                                   "a plan sent with the request names its levels from "
                                   "goniod's plans (such as ds2)",
                                   f->name, ref);
        }
    }
    cfg_free(d);
    return rc;
}

/* A sent scene names its material and rig: goniod may open only its own
 * (names), never a file the sender chose, as for a plan's levels. A file
 * the parser refuses is left to the scene loader. */
static int scene_refs_are_names(const struct control_sent_file *f, struct gonio_err *err)
{
    struct cfg_doc *d = NULL;
    struct gonio_err ignored = {0};
    if (cfg_load(f->path, &d, &ignored) < 0)
        return 0;
    int rc = 0;
    static const char *const keys[] = {"material", "rig"};
    for (int k = 0; rc == 0 && k < 2 && cfg_is_map(d, cfg_root(d)); k++) {
        const char *v = NULL;
        if (cfg_string(d, cfg_root(d), keys[k], CFG_OPTIONAL, &v, &ignored) <= 0)
            continue;
        int file = k == 0 ? !strncmp(v, "merl:", 5) || strchr(v, '/') != NULL
                          : gonio_ref_is_file(v);
        if (file)
            rc = gonio_err_set(err, GONIO_EUSAGE,
                               "scene '%.200s': field '%s' names the file '%.200s'; a scene "
                               "sent with the request names its %s from goniod's (%s)",
                               f->name, keys[k], v, keys[k],
                               k == 0 ? "such as default or nbrdf:NAME" : "such as default");
    }
    cfg_free(d);
    return rc;
}

int control_sent_write(struct control_sent *s, const char *dir, struct gonio_err *err)
{
    for (int i = 0; i < s->n; i++) {
        struct control_sent_file *f = &s->files[i];
        char sub[2304];
        snprintf(sub, sizeof sub, "%s/%s/%s", dir, sent_dir, f->field);
        int n = snprintf(f->path, sizeof f->path, "%s/%s", sub, f->base);
        if (n < 0 || (size_t)n >= sizeof f->path)
            return gonio_err_set(err, GONIO_EUSAGE, "%s '%.200s': path too long", f->field,
                                 f->name);
        int rc = gonio_mkdir_p(sub, err);
        if (rc == 0)
            rc = gonio_write_file_atomic(f->path, f->text, f->len, err);
        if (rc < 0)
            return rc;
        f->written = 1;
        if (!strcmp(f->field, "plan") && (rc = levels_are_names(f, err)) < 0)
            return rc;
        if (!strcmp(f->field, "scene") && (rc = scene_refs_are_names(f, err)) < 0)
            return rc;
    }
    return 0;
}

void control_sent_discard(const struct control_sent *s, const char *dir)
{
    for (int i = 0; i < s->n; i++) {
        const struct control_sent_file *f = &s->files[i];
        char sub[2304];
        if (f->written)
            unlink(f->path);
        snprintf(sub, sizeof sub, "%s/%s/%s", dir, sent_dir, f->field);
        rmdir(sub);
    }
    char top[2304];
    snprintf(top, sizeof top, "%s/%s", dir, sent_dir);
    rmdir(top);
}

/* Replace every from in msg by to, within the message's size. */
static void replace_all(char *msg, size_t size, const char *from, const char *to)
{
    size_t nf = strlen(from), nt = strlen(to);
    char out[GONIO_ERR_MSG_MAX];
    size_t o = 0;
    for (const char *p = msg; *p && o + 1 < sizeof out;) {
        if (nf && !strncmp(p, from, nf) && o + nt + 1 < sizeof out) {
            memcpy(out + o, to, nt);
            o += nt;
            p += nf;
        } else {
            out[o++] = *p++;
        }
    }
    out[o] = 0;
    snprintf(msg, size, "%s", out);
}

void control_sent_rename(const struct control_sent *s, struct gonio_err *err)
{
    for (int i = 0; i < s->n; i++)
        if (s->files[i].path[0])
            replace_all(err->msg, sizeof err->msg, s->files[i].path, s->files[i].name);
}
