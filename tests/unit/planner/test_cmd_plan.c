/* gonio plan (cli/cmd_plan.c, compiled in): the --json document of
 * DESIGN.md section 8, and bad input giving exit status 2, one stderr line
 * and an empty stdout. */
#include "tests/gonio_test.h"

#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include <jansson.h>

#include "cli/cmd_plan.c"

static int run(char **argv, int argc, char **out, char **errtext)
{
    return gonio_test_run_cli(cmd_plan, argv, argc, out, errtext);
}

static void test_json(void **state)
{
    (void)state;
    char *argv[] = {"plan", "ds2", "--json", "--order", "as-written", NULL};
    char *out, *errtext;
    assert_int_equal(run(argv, 5, &out, &errtext), 0);
    json_error_t jerr;
    json_t *doc = json_loads(out, 0, &jerr);
    if (!doc)
        print_error("JSON: %s\n%s\n", jerr.text, out);
    assert_non_null(doc);
    assert_string_equal(json_string_value(json_object_get(doc, "plan")), "ds2");
    assert_int_equal(json_integer_value(json_object_get(doc, "count")), 160);
    json_t *pairs = json_object_get(doc, "pairs");
    assert_int_equal(json_array_size(pairs), 160);
    /* as written: theta_i 0 first, theta_r ascending from -80 */
    json_t *first = json_array_get(pairs, 0);
    assert_close(json_number_value(json_object_get(first, "theta_i")), 0, 0);
    assert_close(json_number_value(json_object_get(first, "theta_r")), -80, 0);
    size_t i;
    json_t *pt;
    json_array_foreach(pairs, i, pt) {
        double ti = json_number_value(json_object_get(pt, "theta_i"));
        double tr = json_number_value(json_object_get(pt, "theta_r"));
        assert_close(json_number_value(json_object_get(pt, "s")), ti, 1e-9);
        assert_close(json_number_value(json_object_get(pt, "a")), ti + tr, 1e-9);
    }
    json_t *est = json_object_get(doc, "estimate");
    double total = json_number_value(json_object_get(est, "total_s"));
    double mv = json_number_value(json_object_get(est, "move_s"));
    double st = json_number_value(json_object_get(est, "settle_s"));
    double in = json_number_value(json_object_get(est, "integration_s"));
    assert_close(st, 160 * 0.3, 1e-6);
    assert_close(in, 160 * 0.05, 1e-6);
    assert_rel_close(total, mv + st + in, 1e-9);
    assert_true(mv > 0);
    assert_string_equal(errtext, "");
    json_decref(doc);
    free(out);
    free(errtext);
}

static void test_bad_input(void **state)
{
    (void)state;
    char tmpdir[] = "/tmp/gonio-badplanXXXXXX", path[64];
    assert_non_null(mkdtemp(tmpdir));
    snprintf(path, sizeof path, "%s/bad.yaml", tmpdir);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    static const char text[] = "pairs:\n  - [30, -28]\n";
    assert_int_equal(write(fd, text, sizeof text - 1), (ssize_t)(sizeof text - 1));
    close(fd);
    char *argv[] = {"plan", path, "--json", NULL};
    char *out, *errtext;
    assert_int_equal(run(argv, 3, &out, &errtext), 2);
    assert_string_equal(out, "");
    char want[256];
    snprintf(want, sizeof want, "gonio plan: %s:2:5: pair (theta_i 30, theta_r -28)", path);
    assert_int_equal(strncmp(errtext, want, strlen(want)), 0);
    /* one line */
    assert_non_null(strchr(errtext, '\n'));
    assert_string_equal(strchr(errtext, '\n'), "\n");
    free(out);
    free(errtext);
    unlink(path);
    rmdir(tmpdir);

    char *argv2[] = {"plan", "ds4", "--order", "sideways", NULL};
    assert_int_equal(run(argv2, 4, &out, &errtext), 2);
    assert_string_equal(out, "");
    free(out);
    free(errtext);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_json),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
