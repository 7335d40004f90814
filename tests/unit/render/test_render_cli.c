/* gonio render as a user runs it: bad scenes, materials and options exit 2
 * with one line naming the file, the field and the value, and leave no
 * output directory; a good run's EXR opens in OpenEXR's own exrheader. */
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "tests/gonio_test.h"

static char tmpdir[4096], errfile[4200], outfile[4200];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_render_cli.XXXXXX", base);
    if (!mkdtemp(tmpdir))
        return -1;
    snprintf(errfile, sizeof errfile, "%s/stderr.txt", tmpdir);
    snprintf(outfile, sizeof outfile, "%s/stdout.txt", tmpdir);
    return 0;
}

/* Run path with argv (NULL-terminated), stdout and stderr to files; the
 * exit status, or -1. */
static int run(const char *path, const char *const *argv)
{
    pid_t pid = gonio_test_fork();
    if (pid < 0)
        return -1;
    if (pid == 0) {
        int e = open(errfile, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int o = open(outfile, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(e, STDERR_FILENO);
        dup2(o, STDOUT_FILENO);
        execv(path, (char *const *)argv);
        _exit(127);
    }
    int st;
    if (waitpid(pid, &st, 0) != pid || !WIFEXITED(st))
        return -1;
    return WEXITSTATUS(st);
}

static int gonio(const char *const *args)
{
    static char path[1024];
    const char *bin = getenv("GONIO_BIN");
    snprintf(path, sizeof path, "%s/gonio", bin ? bin : ".");
    const char *argv[32] = {path, "render"};
    int n = 2;
    for (; *args && n < 31; args++)
        argv[n++] = *args;
    argv[n] = NULL;
    return run(path, argv);
}

static char *slurp(const char *path)
{
    static char buf[8192];
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    if (f)
        fclose(f);
    buf[n] = '\0';
    return buf;
}

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static int exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

/* Exit 2, one stderr line containing every needle, no output directory. */
static void expect_bad(const char *const *args, const char *out, const char *n1, const char *n2,
                       const char *n3)
{
    int rc = gonio(args);
    const char *msg = slurp(errfile);
    if (rc != 2 || !strstr(msg, n1) || (n2 && !strstr(msg, n2)) || (n3 && !strstr(msg, n3))) {
        print_error("exit %d, stderr:\n%s\nwanted exit 2 and '%s' '%s' '%s'\n", rc, msg, n1,
                    n2 ? n2 : "", n3 ? n3 : "");
        fail();
    }
    assert_false(exists(out));
}

static void test_bad_input_exits_2(void **state)
{
    (void)state;
    char scene[4200], out[4200];
    snprintf(scene, sizeof scene, "%s/bad.yaml", tmpdir);
    snprintf(out, sizeof out, "%s/out-bad", tmpdir);

    write_file(scene, "effects:\n  - {name: direct}\n  - {name: ambient_occlusion}\n");
    const char *a1[] = {"--material", "default", "--scene", scene, "--out", out, NULL};
    expect_bad(a1, out, scene, "'name'", "ambient_occlusion");

    write_file(scene, "effects:\n  - {name: environment, samples: -3}\n");
    expect_bad(a1, out, scene, "'samples'", "-3");

    write_file(scene, "effects:\n  - {name: direct, irradiance: [1, 1, 1], spot: 4}\n");
    expect_bad(a1, out, scene, "'spot'", "unknown key");

    const char *a2[] = {"--material", "nosuch:thing", "--out", out, NULL};
    expect_bad(a2, out, "nosuch:thing", NULL, NULL);

    const char *a3[] = {"--material", "default", "--size", "3", "--out", out, NULL};
    expect_bad(a3, out, "--size", "3", NULL);

    const char *a4[] = {"--grid", "--truth", "default", "--out", out, NULL};
    expect_bad(a4, out, "--model", NULL, NULL);

    const char *a5[] = {"--material", "default", "--scene", "no-such-scene", "--out", out, NULL};
    expect_bad(a5, out, "no-such-scene", NULL, NULL);
}

static void test_output_opens_in_exrheader(void **state)
{
    (void)state;
    char out[4200], exr[4300], png[4300], grid[4300];
    snprintf(out, sizeof out, "%s/out", tmpdir);
    const char *args[] = {"--grid",  "--truth", "default", "--model", "builtin:nylon",
                          "--label", "same",    "--size",  "16",      "--scene",
                          "direct",  "--quiet", "--out",   out,       NULL};
    int rc = gonio(args);
    if (rc != 0) {
        print_error("exit %d: %s\n", rc, slurp(errfile));
        fail();
    }
    snprintf(exr, sizeof exr, "%s/same.exr", out);
    snprintf(png, sizeof png, "%s/same.png", out);
    snprintf(grid, sizeof grid, "%s/grid.exr", out);
    assert_true(exists(exr) && exists(png) && exists(grid));

    static const char *const candidates[] = {"/usr/bin/exrheader", "/usr/local/bin/exrheader"};
    const char *tool = NULL;
    for (size_t i = 0; i < 2 && !tool; i++)
        if (access(candidates[i], X_OK) == 0)
            tool = candidates[i];
    if (!tool) {
        gonio_test_skip("exrheader not installed (Debian package openexr)");
    }
    const char *argv[] = {tool, grid, NULL};
    assert_int_equal(run(tool, argv), 0);
    const char *text = slurp(outfile);
    /* 2 cells of 16 and a gap of 4: 36 x 16 */
    if (!strstr(text, "R, 32-bit floating-point") || !strstr(text, "(0 0) - (35 15)")) {
        print_error("exrheader said:\n%s\n", text);
        fail();
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_input_exits_2),
        cmocka_unit_test(test_output_opens_in_exrheader),
    };
    return cmocka_run_group_tests(tests, setup_tmp, NULL);
}
