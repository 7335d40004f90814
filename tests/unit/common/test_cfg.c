/* cfg: typed getters, key checks and the one error form
 * "path:line:col: key 'x': problem", on YAML files written to a temp dir. */
#include "tests/gonio_test.h"

#include <string.h>
#include <unistd.h>

#include "common/cfg.h"

static char dir[4096];

static int setup(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    char tmpl[4096];
    if (base && *base) {
        if (gonio_mkdir_p(base, NULL) < 0)
            return -1;
        snprintf(tmpl, sizeof tmpl, "%s/cfgXXXXXX", base);
    } else {
        snprintf(tmpl, sizeof tmpl, "/tmp/gonio-cfgXXXXXX");
    }
    if (!mkdtemp(tmpl))
        return -1;
    snprintf(dir, sizeof dir, "%s", tmpl);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* Write text to dir/name and return the path (static buffer). */
static const char *write_yaml(const char *name, const char *text)
{
    static char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return path;
}

static const char *const top_keys[] = {"speed", "name", "count", "on", "list", "mode",
                                       "sub", NULL};

static const char *good =
    "speed: 20.5\n"
    "name: sample arm\n"
    "count: 7\n"
    "on: true\n"
    "list: [1, 2.5, -3]\n"
    "mode: fast\n"
    "sub:\n"
    "  x: 1\n";

static void test_good_values(void **state)
{
    (void)state;
    const char *path = write_yaml("good.yaml", good);
    struct cfg_doc *d;
    struct gonio_err err = {0};
    assert_int_equal(cfg_load(path, &d, &err), 0);
    const struct cfg_node *r = cfg_root(d);
    assert_string_equal(cfg_path(d), path);
    assert_int_equal(cfg_check_keys(d, r, "top", top_keys, &err), 0);

    double v = -1;
    assert_int_equal(cfg_double(d, r, "speed", CFG_REQUIRED, 0, 100, &v, &err), 1);
    assert_close(v, 20.5, 0);
    /* absent optional key: 0 and the default untouched */
    v = 42;
    assert_int_equal(cfg_double(d, r, "absent", CFG_OPTIONAL, 0, 100, &v, &err), 0);
    assert_close(v, 42, 0);

    const char *s = NULL;
    assert_int_equal(cfg_string(d, r, "name", CFG_REQUIRED, &s, &err), 1);
    assert_string_equal(s, "sample arm");
    long n = 0;
    assert_int_equal(cfg_int(d, r, "count", CFG_REQUIRED, 1, 10, &n, &err), 1);
    assert_int_equal(n, 7);
    int b = 0;
    assert_int_equal(cfg_bool(d, r, "on", CFG_REQUIRED, &b, &err), 1);
    assert_int_equal(b, 1);
    double *list = NULL;
    size_t len = 0;
    assert_int_equal(cfg_doubles(d, r, "list", CFG_REQUIRED, -10, 10, 1, 5, &list, &len, &err),
                     1);
    assert_int_equal(len, 3);
    assert_close(list[0], 1, 0);
    assert_close(list[1], 2.5, 0);
    assert_close(list[2], -3, 0);
    free(list);
    static const char *const modes[] = {"slow", "fast", NULL};
    int m = -1;
    assert_int_equal(cfg_enum(d, r, "mode", CFG_REQUIRED, modes, &m, &err), 1);
    assert_int_equal(m, 1);
    const struct cfg_node *sub;
    assert_int_equal(cfg_map(d, r, "sub", CFG_REQUIRED, &sub, &err), 1);
    assert_true(cfg_is_map(d, sub));
    int line, col;
    cfg_mark(sub, &line, &col);
    assert_int_equal(line, 8); /* the mapping starts on the line after "sub:" */
    assert_int_equal(col, 3);
    cfg_free(d);
}

/* Load text, run one getter and check the message. */
enum which { W_DOUBLE, W_INT, W_BOOL, W_ENUM, W_KEYS, W_DOUBLES, W_STRING };

static void expect_error(const char *text, enum which w, const char *key, int line, int col,
                         const char *fragment)
{
    const char *path = write_yaml("bad.yaml", text);
    struct cfg_doc *d;
    struct gonio_err err = {0};
    assert_int_equal(cfg_load(path, &d, &err), 0);
    const struct cfg_node *r = cfg_root(d);
    double v;
    long n;
    int b;
    const char *s;
    double *list = NULL;
    size_t len;
    static const char *const modes[] = {"slow", "fast", NULL};
    int rc = 0;
    switch (w) {
    case W_DOUBLE: rc = cfg_double(d, r, key, CFG_REQUIRED, 0, 100, &v, &err); break;
    case W_INT: rc = cfg_int(d, r, key, CFG_REQUIRED, 0, 10, &n, &err); break;
    case W_BOOL: rc = cfg_bool(d, r, key, CFG_REQUIRED, &b, &err); break;
    case W_ENUM: rc = cfg_enum(d, r, key, CFG_REQUIRED, modes, &b, &err); break;
    case W_KEYS: rc = cfg_check_keys(d, r, "top", top_keys, &err); break;
    case W_DOUBLES:
        rc = cfg_doubles(d, r, key, CFG_REQUIRED, 0, 10, 2, 2, &list, &len, &err);
        break;
    case W_STRING: rc = cfg_string(d, r, key, CFG_REQUIRED, &s, &err); break;
    }
    assert_int_equal(rc, -GONIO_EBADCONFIG);
    assert_int_equal(err.code, GONIO_EBADCONFIG);
    char want[4400];
    snprintf(want, sizeof want, "%s:%d:%d: key '%s': ", path, line, col, key);
    if (strncmp(err.msg, want, strlen(want)) != 0 || !strstr(err.msg, fragment)) {
        print_error("message '%s'\nexpected to start '%s' and contain '%s'\n", err.msg, want,
                    fragment);
        fail();
    }
    assert_null(list);
    cfg_free(d);
}

static void test_errors(void **state)
{
    (void)state;
    expect_error("a: 1\nspeed: 120\n", W_DOUBLE, "speed", 2, 8,
                 "out of range (value '120', allowed 0..100)");
    expect_error("speed: fast\n", W_DOUBLE, "speed", 1, 8, "wrong type");
    expect_error("speed: '20'\n", W_DOUBLE, "speed", 1, 8, "wrong type");
    expect_error("speed: [1]\n", W_DOUBLE, "speed", 1, 8, "wrong type");
    expect_error("speed: nan\n", W_DOUBLE, "speed", 1, 8, "wrong type");
    expect_error("other: 1\n", W_DOUBLE, "speed", 1, 1, "missing required key");
    expect_error("count: 2.5\n", W_INT, "count", 1, 8, "wrong type");
    expect_error("count: 11\n", W_INT, "count", 1, 8, "allowed 0..10");
    expect_error("on: maybe\n", W_BOOL, "on", 1, 5, "true or false");
    expect_error("mode: medium\n", W_ENUM, "mode", 1, 7, "allowed slow, fast");
    expect_error("speed: 1\n\n  # comment\nsped: 2\n", W_KEYS, "sped", 4, 1, "unknown key");
    expect_error("speed: 1\nspeed: 2\n", W_KEYS, "speed", 2, 1, "duplicate key");
    expect_error("list: [1, 2, 3]\n", W_DOUBLES, "list", 1, 7, "wrong length");
    expect_error("list: [1, 20]\n", W_DOUBLES, "list", 1, 11, "out of range");
    expect_error("name: {a: 1}\n", W_STRING, "name", 1, 7, "wrong type");
}

static void test_load_errors(void **state)
{
    (void)state;
    struct cfg_doc *d = (struct cfg_doc *)1;
    struct gonio_err err = {0};
    const char *path = write_yaml("syntax.yaml", "a: [1, 2\nb: 3\n");
    assert_int_equal(cfg_load(path, &d, &err), -GONIO_EBADCONFIG);
    assert_null(d);
    char want[4400];
    snprintf(want, sizeof want, "%s:", path);
    assert_int_equal(strncmp(err.msg, want, strlen(want)), 0);
    assert_non_null(strstr(err.msg, "YAML syntax"));
    /* line and column are numbers after the path */
    int line = 0, col = 0;
    assert_int_equal(sscanf(err.msg + strlen(want), "%d:%d:", &line, &col), 2);
    assert_true(line >= 1 && col >= 1);

    path = write_yaml("empty.yaml", "# nothing\n");
    assert_int_equal(cfg_load(path, &d, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "empty document"));

    char missing[4200];
    snprintf(missing, sizeof missing, "%s/none.yaml", dir);
    assert_int_equal(cfg_load(missing, &d, &err), -GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, missing));
}

/* Write n copies of unit to dir/name and return the path (static buffer). */
static const char *write_repeated(const char *name, const char *unit, size_t n)
{
    static char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (size_t i = 0; i < n; i++)
        fputs(unit, f);
    fclose(f);
    return path;
}

/* Hostile files are refused with one error naming the file and the limit:
 * 40,000 nested flow sequences (3 s of libyaml's quadratic scanning before
 * the limit), block mappings one level too deep, and 2 MB of list items
 * (well-formed, so only the size refuses it). Nesting at the limit loads. */
static void test_limits(void **state)
{
    (void)state;
    struct cfg_doc *d = (struct cfg_doc *)1;
    struct gonio_err err = {0};
    const char *path = write_repeated("deep.yaml", "[", 40000);
    assert_int_equal(cfg_load(path, &d, &err), -GONIO_EBADCONFIG);
    assert_null(d);
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, ":1:65: nested deeper than 64 levels"));

    char text[4096] = "";
    for (int i = 0; i < 64; i++)
        snprintf(text + strlen(text), sizeof text - strlen(text), "%*sk:\n", i, "");
    path = write_yaml("block64.yaml", text);
    assert_int_equal(cfg_load(path, &d, &err), 0);
    cfg_free(d);
    snprintf(text + strlen(text), sizeof text - strlen(text), "%*sk: 1\n", 64, "");
    path = write_yaml("block65.yaml", text);
    assert_int_equal(cfg_load(path, &d, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, ":65:65: nested deeper than 64 levels"));

    path = write_repeated("big.yaml", "- 1\n", 2000000 / 4);
    assert_int_equal(cfg_load(path, &d, &err), -GONIO_EBADCONFIG);
    assert_null(d);
    char want[4400];
    snprintf(want, sizeof want, "%s: larger than 1048576 bytes, the limit for a YAML file",
             path);
    assert_string_equal(err.msg, want);
}

static void test_sequences(void **state)
{
    (void)state;
    const char *path = write_yaml("seq.yaml", "pairs:\n  - [30, -60]\n  - [30, 20]\n");
    struct cfg_doc *d;
    struct gonio_err err = {0};
    assert_int_equal(cfg_load(path, &d, &err), 0);
    const struct cfg_node *seq;
    assert_int_equal(cfg_seq(d, cfg_root(d), "pairs", CFG_REQUIRED, &seq, &err), 1);
    assert_int_equal(cfg_seq_len(d, seq), 2);
    assert_null(cfg_seq_item(d, seq, 2));
    const struct cfg_node *item = cfg_seq_item(d, seq, 1);
    double v;
    assert_int_equal(cfg_node_double(d, cfg_seq_item(d, item, 1), "theta_r", -90, 90, &v, &err),
                     1);
    assert_close(v, 20, 0);
    int line, col;
    cfg_mark(item, &line, &col);
    assert_int_equal(line, 3);
    assert_int_equal(col, 5);
    /* a sequence where a mapping is wanted */
    const struct cfg_node *m;
    assert_int_equal(cfg_map(d, cfg_root(d), "pairs", CFG_REQUIRED, &m, &err),
                     -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, ":2:3: key 'pairs': expected a mapping"));
    cfg_free(d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_good_values),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_load_errors),
        cmocka_unit_test(test_limits),
        cmocka_unit_test(test_sequences),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
