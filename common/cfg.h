/* Reading gonio's YAML files (plans, rigs, scenes, daemon configs).
 *
 * A file is loaded whole into a document (libyaml's node API); values are
 * then read by key with typed getters that check the type and the range.
 * Every error has ONE form, built from the node's position in the file:
 *
 *     path:line:col: key 'x': problem (value 'v', allowed a..b)
 *
 * Unknown keys are errors (cfg_check_keys), missing required keys are errors
 * naming the key. Getters return 1 when the key was present and its value
 * stored, 0 when an optional key is absent (the output is left untouched, so
 * callers preset defaults), and a negative gonio code (GONIO_EBADCONFIG) on
 * failure with err filled. libyaml stays behind this header. */
#ifndef GONIO_COMMON_CFG_H
#define GONIO_COMMON_CFG_H

#include <stddef.h>

#include "common/err.h"

struct cfg_doc;  /* a loaded file */
struct cfg_node; /* a node inside it; valid while the document lives */

enum cfg_need { CFG_OPTIONAL = 0, CFG_REQUIRED = 1 };

/* Load and parse path. A syntax error, an empty file, an unreadable file, a
 * file over 1 MiB or nested deeper than 64 levels fails with
 * GONIO_EBADCONFIG (GONIO_ENOTFOUND when the file does not exist), the
 * message giving path:line:col (path alone for the size). */
int cfg_load(const char *path, struct cfg_doc **out, struct gonio_err *err);
void cfg_free(struct cfg_doc *doc);

const char *cfg_path(const struct cfg_doc *doc);
const struct cfg_node *cfg_root(const struct cfg_doc *doc);

/* Node shape and position (1-based line and column). */
int cfg_is_map(const struct cfg_doc *doc, const struct cfg_node *node);
int cfg_is_seq(const struct cfg_doc *doc, const struct cfg_node *node);
int cfg_is_scalar(const struct cfg_doc *doc, const struct cfg_node *node);
void cfg_mark(const struct cfg_node *node, int *line, int *col);

/* Fill err with "path:line:col: key 'key': <fmt>" at node (key may be
 * NULL, then the "key '...': " part is left out) and return
 * -GONIO_EBADCONFIG. The one way every module reports a config error. */
int cfg_error(const struct cfg_doc *doc, const struct cfg_node *node, const char *key,
              struct gonio_err *err, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

/* An item of a list of named things (a scene's effects): a bare name or a
 * mapping with a 'name'. Returns the index of the name in names[0..n) and
 * sets *name_node; an item without a name, or an unknown name (the message
 * lists the known ones, calling them `what`), is refused. */
int cfg_named_item(const struct cfg_doc *doc, const struct cfg_node *item, const char *list_key,
                   const char *what, const char *const *names, int n,
                   const struct cfg_node **name_node, struct gonio_err *err);

/* The value under key in a mapping, or NULL when map is not a mapping or
 * has no such key. */
const struct cfg_node *cfg_get(const struct cfg_doc *doc, const struct cfg_node *map,
                               const char *key);

/* map must be a mapping (what names it in the message) whose keys are all
 * in the NULL-terminated list allowed; duplicate keys are errors too. */
int cfg_check_keys(const struct cfg_doc *doc, const struct cfg_node *map, const char *what,
                   const char *const *allowed, struct gonio_err *err);

/* A required mapping/sequence child: fails naming key when it is missing
 * (need = CFG_REQUIRED) or of the wrong shape; *out is NULL when absent. */
int cfg_map(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
            enum cfg_need need, const struct cfg_node **out, struct gonio_err *err);
int cfg_seq(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
            enum cfg_need need, const struct cfg_node **out, struct gonio_err *err);

/* Sequence length and items (NULL past the end). */
size_t cfg_seq_len(const struct cfg_doc *doc, const struct cfg_node *seq);
const struct cfg_node *cfg_seq_item(const struct cfg_doc *doc, const struct cfg_node *seq,
                                    size_t i);

/* Typed getters by key in a mapping. Numbers and booleans must be plain
 * (unquoted) scalars; lo..hi is inclusive. */
int cfg_double(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
               enum cfg_need need, double lo, double hi, double *out, struct gonio_err *err);
int cfg_int(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
            enum cfg_need need, long lo, long hi, long *out, struct gonio_err *err);
int cfg_bool(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
             enum cfg_need need, int *out, struct gonio_err *err);
/* *out points into the document (valid until cfg_free). */
int cfg_string(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
               enum cfg_need need, const char **out, struct gonio_err *err);
/* names is NULL-terminated; *out is the index of the matching name. */
int cfg_enum(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
             enum cfg_need need, const char *const *names, int *out, struct gonio_err *err);
/* A sequence of numbers, each in lo..hi, of min_len..max_len items;
 * *out is malloc'd (free it), *n its length. */
int cfg_doubles(const struct cfg_doc *doc, const struct cfg_node *map, const char *key,
                enum cfg_need need, double lo, double hi, size_t min_len, size_t max_len,
                double **out, size_t *n, struct gonio_err *err);

/* The same checks on a node itself (sequence items, say); key only names it
 * in messages. */
int cfg_node_double(const struct cfg_doc *doc, const struct cfg_node *node, const char *key,
                    double lo, double hi, double *out, struct gonio_err *err);
int cfg_node_string(const struct cfg_doc *doc, const struct cfg_node *node, const char *key,
                    const char **out, struct gonio_err *err);

#endif
