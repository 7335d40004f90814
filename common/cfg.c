#include "common/cfg.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <yaml.h>

struct cfg_doc {
    yaml_document_t doc;
    char *path;
};

/* A cfg_node is a libyaml node; the cast keeps yaml.h out of the header. */
static const yaml_node_t *yn(const struct cfg_node *n)
{
    return (const yaml_node_t *)n;
}

static const struct cfg_node *cn(const yaml_node_t *n)
{
    return (const struct cfg_node *)n;
}

static const yaml_node_t *node_at(const struct cfg_doc *doc, int index)
{
    return yaml_document_get_node((yaml_document_t *)&doc->doc, index);
}

/* Every YAML input is outside input, and libyaml is quadratic in the nesting
 * depth (its scanner rechecks every open flow level at each token): 40,000
 * levels of '[' took 3 s and a 2 MB file over ten minutes. Real files are
 * under 1 KiB and a few levels deep, so a file is refused when it is larger
 * than CFG_MAX_BYTES (before parsing) or nested deeper than CFG_MAX_DEPTH
 * (while parsing, by events, so the scanner never gets far past the limit):
 * linear time for any input. */
#define CFG_MAX_BYTES (1 << 20)
#define CFG_MAX_DEPTH 64

/* Read all of f into a new buffer, refusing more than CFG_MAX_BYTES. */
static int read_limited(FILE *f, const char *path, unsigned char **out, size_t *len,
                        struct gonio_err *err)
{
    unsigned char *buf = malloc(CFG_MAX_BYTES + 1);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    size_t n = fread(buf, 1, CFG_MAX_BYTES + 1, f);
    if (ferror(f)) {
        free(buf);
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: cannot read", path);
    }
    if (n > CFG_MAX_BYTES) {
        free(buf);
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "%s: larger than %d bytes, the limit for a YAML file", path,
                             CFG_MAX_BYTES);
    }
    *out = buf;
    *len = n;
    return 0;
}

static int syntax_error(const yaml_parser_t *parser, const char *path, struct gonio_err *err)
{
    /* libyaml marks are 0-based; people and editors count from 1. */
    return gonio_err_set(err, GONIO_EBADCONFIG, "%s:%zu:%zu: YAML syntax: %s%s%s", path,
                         parser->problem_mark.line + 1, parser->problem_mark.column + 1,
                         parser->problem ? parser->problem : "parse error",
                         parser->context ? " " : "", parser->context ? parser->context : "");
}

/* Walk the events of text, refusing nesting deeper than CFG_MAX_DEPTH. */
static int check_depth(const unsigned char *text, size_t len, const char *path,
                       struct gonio_err *err)
{
    yaml_parser_t parser;
    if (!yaml_parser_initialize(&parser))
        return gonio_err_set(err, ENOMEM, "%s: cannot initialise the YAML parser", path);
    yaml_parser_set_input_string(&parser, text, len);
    int depth = 0, rc = 0;
    for (;;) {
        yaml_event_t ev;
        if (!yaml_parser_parse(&parser, &ev)) {
            rc = syntax_error(&parser, path, err);
            break;
        }
        yaml_event_type_t type = ev.type;
        if (type == YAML_SEQUENCE_START_EVENT || type == YAML_MAPPING_START_EVENT)
            depth++;
        else if (type == YAML_SEQUENCE_END_EVENT || type == YAML_MAPPING_END_EVENT)
            depth--;
        if (depth > CFG_MAX_DEPTH)
            rc = gonio_err_set(err, GONIO_EBADCONFIG,
                               "%s:%zu:%zu: nested deeper than %d levels, the limit for a "
                               "YAML file",
                               path, ev.start_mark.line + 1, ev.start_mark.column + 1,
                               CFG_MAX_DEPTH);
        yaml_event_delete(&ev);
        if (rc < 0 || type == YAML_STREAM_END_EVENT)
            break;
    }
    yaml_parser_delete(&parser);
    return rc;
}

int cfg_load(const char *path, struct cfg_doc **out, struct gonio_err *err)
{
    *out = NULL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : GONIO_EBADCONFIG,
                             "%s: cannot open: %s", path, strerror(errno));
    unsigned char *text = NULL;
    size_t len = 0;
    int rc = read_limited(f, path, &text, &len, err);
    fclose(f);
    if (rc < 0)
        return rc;
    if ((rc = check_depth(text, len, path, err)) < 0) {
        free(text);
        return rc;
    }
    struct cfg_doc *d = calloc(1, sizeof *d);
    if (!d || !(d->path = strdup(path))) {
        free(d);
        free(text);
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    }
    yaml_parser_t parser;
    if (!yaml_parser_initialize(&parser)) {
        free(d->path);
        free(d);
        free(text);
        return gonio_err_set(err, ENOMEM, "%s: cannot initialise the YAML parser", path);
    }
    yaml_parser_set_input_string(&parser, text, len);
    if (!yaml_parser_load(&parser, &d->doc)) {
        rc = syntax_error(&parser, path, err);
    } else if (!yaml_document_get_root_node(&d->doc)) {
        yaml_document_delete(&d->doc);
        rc = gonio_err_set(err, GONIO_EBADCONFIG, "%s:1:1: empty document", path);
    }
    yaml_parser_delete(&parser);
    free(text);
    if (rc < 0) {
        free(d->path);
        free(d);
        return rc;
    }
    *out = d;
    return 0;
}

void cfg_free(struct cfg_doc *doc)
{
    if (!doc)
        return;
    yaml_document_delete(&doc->doc);
    free(doc->path);
    free(doc);
}

const char *cfg_path(const struct cfg_doc *doc)
{
    return doc->path;
}

const struct cfg_node *cfg_root(const struct cfg_doc *doc)
{
    return cn(yaml_document_get_root_node((yaml_document_t *)&doc->doc));
}

int cfg_is_map(const struct cfg_doc *doc, const struct cfg_node *node)
{
    (void)doc;
    return node && yn(node)->type == YAML_MAPPING_NODE;
}

int cfg_is_seq(const struct cfg_doc *doc, const struct cfg_node *node)
{
    (void)doc;
    return node && yn(node)->type == YAML_SEQUENCE_NODE;
}

int cfg_is_scalar(const struct cfg_doc *doc, const struct cfg_node *node)
{
    (void)doc;
    return node && yn(node)->type == YAML_SCALAR_NODE;
}

void cfg_mark(const struct cfg_node *node, int *line, int *col)
{
    *line = node ? (int)yn(node)->start_mark.line + 1 : 1;
    *col = node ? (int)yn(node)->start_mark.column + 1 : 1;
}

int cfg_error(const struct cfg_doc *doc, const struct cfg_node *node, const char *key,
              struct gonio_err *err, const char *fmt, ...)
{
    if (err) {
        int line, col;
        cfg_mark(node, &line, &col);
        char detail[GONIO_ERR_MSG_MAX];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(detail, sizeof detail, fmt, ap);
        va_end(ap);
        if (key)
            gonio_err_set(err, GONIO_EBADCONFIG, "%s:%d:%d: key '%s': %s", doc->path, line,
                          col, key, detail);
        else
            gonio_err_set(err, GONIO_EBADCONFIG, "%s:%d:%d: %s", doc->path, line, col,
                          detail);
    }
    return -GONIO_EBADCONFIG;
}

static const char *scalar(const struct cfg_node *node)
{
    return (const char *)yn(node)->data.scalar.value;
}

static const char *shape_name(const struct cfg_node *node)
{
    switch (yn(node)->type) {
    case YAML_MAPPING_NODE: return "a mapping";
    case YAML_SEQUENCE_NODE: return "a sequence";
    case YAML_SCALAR_NODE: return "a scalar";
    default: return "nothing";
    }
}

const struct cfg_node *cfg_get(const struct cfg_doc *doc, const struct cfg_node *map,
                               const char *key)
{
    if (!cfg_is_map(doc, map))
        return NULL;
    const yaml_node_t *m = yn(map);
    for (yaml_node_pair_t *p = m->data.mapping.pairs.start; p < m->data.mapping.pairs.top;
         p++) {
        const yaml_node_t *k = node_at(doc, p->key);
        if (k && k->type == YAML_SCALAR_NODE && !strcmp((const char *)k->data.scalar.value, key))
            return cn(node_at(doc, p->value));
    }
    return NULL;
}

int cfg_check_keys(const struct cfg_doc *doc, const struct cfg_node *map, const char *what,
                   const char *const *allowed, struct gonio_err *err)
{
    if (!cfg_is_map(doc, map))
        return cfg_error(doc, map, what, err, "expected a mapping, found %s",
                         map ? shape_name(map) : "nothing");
    const yaml_node_t *m = yn(map);
    for (yaml_node_pair_t *p = m->data.mapping.pairs.start; p < m->data.mapping.pairs.top;
         p++) {
        const yaml_node_t *k = node_at(doc, p->key);
        if (!k || k->type != YAML_SCALAR_NODE)
            return cfg_error(doc, cn(k), NULL, err, "%s: keys must be plain names", what);
        const char *name = (const char *)k->data.scalar.value;
        int known = 0;
        for (const char *const *a = allowed; *a; a++)
            known |= !strcmp(*a, name);
        if (!known) {
            char list[256] = "";
            size_t used = 0;
            for (const char *const *a = allowed; *a && used < sizeof list; a++)
                used += (size_t)snprintf(list + used, sizeof list - used, "%s%s",
                                         a == allowed ? "" : ", ", *a);
            return cfg_error(doc, cn(k), name, err, "unknown key in %s (allowed %s)", what,
                             list);
        }
        for (yaml_node_pair_t *q = m->data.mapping.pairs.start; q < p; q++) {
            const yaml_node_t *k2 = node_at(doc, q->key);
            if (k2 && k2->type == YAML_SCALAR_NODE &&
                !strcmp((const char *)k2->data.scalar.value, name))
                return cfg_error(doc, cn(k), name, err, "duplicate key in %s", what);
        }
    }
    return 0;
}

/* The child under key, or the missing-key error; 0 when optional and absent. */
static int child(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
                 enum cfg_need need, const struct cfg_node **out, struct gonio_err *err)
{
    *out = cfg_get(doc, map, key);
    if (*out)
        return 1;
    if (need == CFG_REQUIRED)
        return cfg_error(doc, map, key, err, "missing required key");
    return 0;
}

int cfg_map(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
            enum cfg_need need, const struct cfg_node **out, struct gonio_err *err)
{
    int rc = child(doc, map, key, need, out, err);
    if (rc == 1 && !cfg_is_map(doc, *out))
        return cfg_error(doc, *out, key, err, "expected a mapping, found %s", shape_name(*out));
    return rc;
}

int cfg_seq(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
            enum cfg_need need, const struct cfg_node **out, struct gonio_err *err)
{
    int rc = child(doc, map, key, need, out, err);
    if (rc == 1 && !cfg_is_seq(doc, *out))
        return cfg_error(doc, *out, key, err, "expected a sequence, found %s",
                         shape_name(*out));
    return rc;
}

size_t cfg_seq_len(const struct cfg_doc *doc, const struct cfg_node *seq)
{
    if (!cfg_is_seq(doc, seq))
        return 0;
    return (size_t)(yn(seq)->data.sequence.items.top - yn(seq)->data.sequence.items.start);
}

const struct cfg_node *cfg_seq_item(const struct cfg_doc *doc, const struct cfg_node *seq,
                                    size_t i)
{
    if (i >= cfg_seq_len(doc, seq))
        return NULL;
    return cn(node_at(doc, yn(seq)->data.sequence.items.start[i]));
}

/* Numbers and booleans are plain scalars: a quoted "5" is a string, and
 * accepting it would hide a typo in a hand-written file. */
static int plain_scalar(const struct cfg_doc *doc, const struct cfg_node *node,
                        const char *key, const char *type, struct gonio_err *err)
{
    if (!cfg_is_scalar(doc, node))
        return cfg_error(doc, node, key, err, "wrong type: expected %s, found %s", type,
                         shape_name(node));
    if (yn(node)->data.scalar.style != YAML_PLAIN_SCALAR_STYLE)
        return cfg_error(doc, node, key, err, "wrong type: expected %s (value '%.40s')",
                         type, scalar(node));
    return 0;
}

int cfg_node_double(const struct cfg_doc *doc, const struct cfg_node *node, const char *key,
                    double lo, double hi, double *out, struct gonio_err *err)
{
    int rc = plain_scalar(doc, node, key, "a number", err);
    if (rc < 0)
        return rc;
    const char *s = scalar(node);
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end || errno == ERANGE || !isfinite(v))
        return cfg_error(doc, node, key, err, "wrong type: expected a number (value '%.40s')",
                         s);
    if (!(v >= lo && v <= hi))
        return cfg_error(doc, node, key, err, "out of range (value '%.40s', allowed %g..%g)",
                         s, lo, hi);
    *out = v;
    return 1;
}

int cfg_node_string(const struct cfg_doc *doc, const struct cfg_node *node, const char *key,
                    const char **out, struct gonio_err *err)
{
    if (!cfg_is_scalar(doc, node))
        return cfg_error(doc, node, key, err, "wrong type: expected a string, found %s",
                         shape_name(node));
    *out = scalar(node);
    return 1;
}

int cfg_double(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
               enum cfg_need need, double lo, double hi, double *out, struct gonio_err *err)
{
    const struct cfg_node *n;
    int rc = child(doc, map, key, need, &n, err);
    if (rc <= 0)
        return rc;
    return cfg_node_double(doc, n, key, lo, hi, out, err);
}

int cfg_int(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
            enum cfg_need need, long lo, long hi, long *out, struct gonio_err *err)
{
    const struct cfg_node *n;
    int rc = child(doc, map, key, need, &n, err);
    if (rc <= 0)
        return rc;
    if ((rc = plain_scalar(doc, n, key, "an integer", err)) < 0)
        return rc;
    const char *s = scalar(n);
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (end == s || *end || errno == ERANGE)
        return cfg_error(doc, n, key, err, "wrong type: expected an integer (value '%.40s')",
                         s);
    if (v < lo || v > hi)
        return cfg_error(doc, n, key, err, "out of range (value '%.40s', allowed %ld..%ld)", s,
                         lo, hi);
    *out = v;
    return 1;
}

int cfg_bool(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
             enum cfg_need need, int *out, struct gonio_err *err)
{
    const struct cfg_node *n;
    int rc = child(doc, map, key, need, &n, err);
    if (rc <= 0)
        return rc;
    if ((rc = plain_scalar(doc, n, key, "true or false", err)) < 0)
        return rc;
    const char *s = scalar(n);
    if (!strcmp(s, "true"))
        *out = 1;
    else if (!strcmp(s, "false"))
        *out = 0;
    else
        return cfg_error(doc, n, key, err,
                         "wrong type: expected true or false (value '%.40s')", s);
    return 1;
}

int cfg_string(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
               enum cfg_need need, const char **out, struct gonio_err *err)
{
    const struct cfg_node *n;
    int rc = child(doc, map, key, need, &n, err);
    if (rc <= 0)
        return rc;
    return cfg_node_string(doc, n, key, out, err);
}

int cfg_enum(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
             enum cfg_need need, const char *const *names, int *out, struct gonio_err *err)
{
    const char *s = NULL;
    int rc = cfg_string(doc, map, key, need, &s, err);
    if (rc <= 0)
        return rc;
    for (int i = 0; names[i]; i++) {
        if (!strcmp(names[i], s)) {
            *out = i;
            return 1;
        }
    }
    char list[256] = "";
    size_t used = 0;
    for (int i = 0; names[i] && used < sizeof list; i++)
        used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "",
                                 names[i]);
    return cfg_error(doc, cfg_get(doc, map, key), key, err,
                     "unknown value (value '%.40s', allowed %s)", s, list);
}

int cfg_doubles(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
                enum cfg_need need, double lo, double hi, size_t min_len, size_t max_len,
                double **out, size_t *n, struct gonio_err *err)
{
    const struct cfg_node *seq;
    int rc = cfg_seq(doc, map, key, need, &seq, err);
    if (rc <= 0)
        return rc;
    size_t len = cfg_seq_len(doc, seq);
    if (len < min_len || len > max_len)
        return cfg_error(doc, seq, key, err, "wrong length (value %zu items, allowed %zu..%zu)",
                         len, min_len, max_len);
    double *v = malloc((len ? len : 1) * sizeof *v);
    if (!v)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", doc->path);
    for (size_t i = 0; i < len; i++) {
        rc = cfg_node_double(doc, cfg_seq_item(doc, seq, i), key, lo, hi, &v[i], err);
        if (rc < 0) {
            free(v);
            return rc;
        }
    }
    *out = v;
    *n = len;
    return 1;
}

int cfg_named_item(const struct cfg_doc *doc, const struct cfg_node *item, const char *list_key,
                   const char *what, const char *const *names, int n,
                   const struct cfg_node **name_node, struct gonio_err *err)
{
    const struct cfg_node *node = item;
    if (cfg_is_map(doc, item)) {
        node = cfg_get(doc, item, "name");
        if (!node)
            return cfg_error(doc, item, list_key, err, "%s without a 'name'", what);
    }
    const char *name;
    int rc = cfg_node_string(doc, node, "name", &name, err);
    if (rc < 0)
        return rc;
    *name_node = node;
    for (int k = 0; k < n; k++)
        if (!strcmp(name, names[k]))
            return k;
    char known[GONIO_ERR_MSG_MAX] = "";
    size_t len = 0;
    for (int k = 0; k < n && len < sizeof known; k++)
        len += (size_t)snprintf(known + len, sizeof known - len, "%s%s", k ? ", " : "", names[k]);
    return cfg_error(doc, node, "name", err, "unknown %s '%s' (known: %s)", what, name, known);
}
