/* The budget is honest through the simulated lab chain: REPEATS seeded
 * repeats of what an operator runs on the raw `lab` rig, each with its own
 * noise and its own plaque (the scene's standard_draw: the standard's true
 * reflectance and shape drawn from its certificate, which the engine never
 * sees, sim/standard_draw.h): `gonio calibrate dark --ladder`, `gonio
 * calibrate stray` and `gonio calibrate reference --stray newest` (the
 * real commands), then a capture of a glossy sample reduced with that
 * calibration and fitted with ABC (capture/, radiometry/). Over every
 * reduced value with signal (u at most 10 % of the value: all of DS3's on
 * this sample) the z-scores (measured - true) / u, the truth the material
 * at the angles the rig recorded, have a standard deviation in 0.85-1.15
 * and the k = 2 intervals cover 92-98 %; each repeat's shared error is
 * the plaque's departure from its certificate; and the fit's reported
 * parameter sds (results.json's uncertainty, from the values' u) are
 * within 25 % of the parameters' spread over the repeats, for all nine
 * (the glossy lobe determines them all on DS3). docs/radiometry.md,
 * "Honesty", has the figures (scripts/radiometry_lab_honesty.sh). */
#include <jansson.h>
#include <math.h>
#include <string.h>
#include <stdlib.h>

#include "brdf/material.h"
#include "capture/capture.h"
#include "common/paths.h"
#include "sim/scene.h"
#include "sim/standard_draw.h"
#include "sim_source/sim_source.h"
#include "tests/gonio_test.h"

#define PLAN "ds3"
#define MATERIAL "analytic:plastic-ggx"
#define STANDARD "spectralon-99"
#define MAX_REPEATS 100
#define N_PARAMS 9

static const char *const param_names[N_PARAMS] = {"log kd_r", "log kd_g", "log kd_b",
                                                  "log A_r",  "log A_g",  "log A_b",
                                                  "log B",    "log C",    "eta"};

static char dir[64];

/* On a tmpfs where there is one: the calibrations and the capture sync
 * their journals at every frame, which on a loaded disk costs more than
 * all the simulation, and this test is about the budget, not durability. */
static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/dev/shm/gonio-honesty-XXXXXX");
    if (mkdtemp(dir))
        return 0;
    return gonio_test_dir_make(dir, sizeof dir, "honesty");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

struct tally {
    double z_sum, z2_sum;
    long n, covered;
    int repeats;
    double est[MAX_REPEATS][N_PARAMS], sd[MAX_REPEATS][N_PARAMS];
    double shared[MAX_REPEATS], drawn[MAX_REPEATS]; /* a repeat's mean error; the plaque's */
};

/* The lab scene at seed, with the plaque drawn, written to path. */
static void write_scene(const char *path, unsigned long seed)
{
    char src[4096], line[512], text[8192] = "";
    gonio_config_path("lab", "scenes", src, sizeof src);
    FILE *f = fopen(src, "r");
    assert_non_null(f);
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "seed:", 5) == 0)
            snprintf(line, sizeof line, "seed: %lu\n", seed);
        strncat(text, line, sizeof text - strlen(text) - 1);
    }
    fclose(f);
    strncat(text, "  - standard_draw\n", sizeof text - strlen(text) - 1);
    gonio_test_write_text(path, text);
}

/* gonio calibrate KIND --offline ... into root; its id into id. */
static void calibrate(const char *root, const char *scene, const char *args, char *id,
                      size_t size)
{
    const char *bin = getenv("GONIO_BIN");
    char cmd[4096], out[256] = "";
    snprintf(cmd, sizeof cmd, "'%s/gonio' calibrate %s --offline --scene '%s' --out '%s'",
             bin ? bin : "build/bin", args, scene, root);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    if (!fgets(out, sizeof out, p))
        out[0] = '\0';
    if (pclose(p) != 0) {
        print_error("failed: %s\n", cmd);
        fail();
    }
    out[strcspn(out, "\n")] = '\0';
    snprintf(id, size, "%s", out);
}

/* Splits a CSV line in place into at most max fields (empty ones kept). */
static int split(char *line, char **field, int max)
{
    int n = 0;
    line[strcspn(line, "\r\n")] = '\0';
    for (char *at = line; n < max;) {
        field[n++] = at;
        char *comma = strchr(at, ',');
        if (!comma)
            break;
        *comma = '\0';
        at = comma + 1;
    }
    return n;
}

static int column(char **field, int n, const char *name)
{
    for (int k = 0; k < n; k++)
        if (strcmp(field[k], name) == 0)
            return k;
    print_error("samples.csv: no column %s\n", name);
    fail();
    return -1;
}

/* The capture's reduced values against the material: z-scores into t,
 * the mean relative error (the repeat's shared error) returned. */
static double tally_samples(const char *cap, const brdf_material *mat, struct tally *t)
{
    char path[256], line[4096], *f[64];
    snprintf(path, sizeof path, "%s/samples.csv", cap);
    FILE *in = fopen(path, "r");
    assert_non_null(in);
    assert_non_null(fgets(line, sizeof line, in));
    int nf = split(line, f, 64);
    int c_ti = column(f, nf, "theta_i"), c_tr = column(f, nf, "theta_r");
    int c_v[3] = {column(f, nf, "r"), column(f, nf, "g"), column(f, nf, "b")};
    int c_u[3] = {column(f, nf, "u_r"), column(f, nf, "u_g"), column(f, nf, "u_b")};
    double rel_sum = 0;
    long used = 0;
    while (fgets(line, sizeof line, in)) {
        if (split(line, f, 64) != nf || !*f[c_u[0]])
            continue; /* a dark frame's record, or a clipped reading */
        struct brdf_pair p;
        brdf_pair_inplane(atof(f[c_ti]), atof(f[c_tr]), &p);
        double truth[3];
        brdf_material_eval(mat, &p, 1, truth);
        for (int c = 0; c < 3; c++) {
            double v = atof(f[c_v[c]]), u = atof(f[c_u[c]]);
            if (!*f[c_v[c]] || !(u > 0) || u > 0.1 * v)
                continue; /* no value, or no signal worth the name */
            double z = (v - truth[c]) / u;
            t->z_sum += z, t->z2_sum += z * z, t->n++;
            t->covered += fabs(z) <= 2.0;
            rel_sum += v / truth[c] - 1, used++;
        }
    }
    fclose(in);
    assert_true(used > 0);
    return rel_sum / (double)used;
}

/* results.json's ABC parameters and their reported sds, which must come
 * from the values' uncertainties. */
static void read_fit(const char *cap, double est[N_PARAMS], double sd[N_PARAMS])
{
    char path[256];
    snprintf(path, sizeof path, "%s/results.json", cap);
    json_error_t jerr;
    json_t *root = json_load_file(path, 0, &jerr);
    assert_non_null(root);
    json_t *p = json_object_get(root, "params"), *u = json_object_get(root, "uncertainty");
    assert_non_null(p);
    assert_non_null(u);
    assert_string_equal(json_string_value(json_object_get(u, "from")), "uncertainties");
    for (int c = 0; c < 3; c++) {
        est[c] = log(json_number_value(json_array_get(json_object_get(p, "kd"), (size_t)c)));
        est[3 + c] = log(json_number_value(json_array_get(json_object_get(p, "A"), (size_t)c)));
        sd[c] = json_number_value(json_array_get(json_object_get(u, "sd_log_kd"), (size_t)c));
        sd[3 + c] = json_number_value(json_array_get(json_object_get(u, "sd_log_A"), (size_t)c));
    }
    est[6] = log(json_number_value(json_object_get(p, "B")));
    est[7] = log(json_number_value(json_object_get(p, "C")));
    est[8] = json_number_value(json_object_get(p, "eta"));
    sd[6] = json_number_value(json_object_get(u, "sd_log_B"));
    sd[7] = json_number_value(json_object_get(u, "sd_log_C"));
    sd[8] = json_number_value(json_object_get(u, "sd_eta"));
    json_decref(root);
}

/* One repeat: its own seeds for each step (an operator's runs do not
 * share their noise), the plaque drawn with the reference's. */
static void one_repeat(int k, const brdf_material *mat, struct tally *t)
{
    char root[128], scene[4][160], id[128], args[256], cap[160];
    snprintf(root, sizeof root, "%s/cal%d", dir, k);
    for (int s = 0; s < 4; s++) {
        snprintf(scene[s], sizeof scene[s], "%s/lab-%d-%d.yaml", dir, k, s);
        write_scene(scene[s], 4ul * (unsigned long)k + (unsigned long)s + 100);
    }
    calibrate(root, scene[0], "dark --ladder", id, sizeof id);
    calibrate(root, scene[1], "stray --plan " PLAN, id, sizeof id);
    snprintf(args, sizeof args, "reference --plan %s --standard %s --stray newest", PLAN,
             STANDARD);
    calibrate(root, scene[2], args, id, sizeof id);
    snprintf(cap, sizeof cap, "%s/cap%d", dir, k);
    struct capture_config cfg = {.plan = PLAN, .model = "abc", .material = MATERIAL,
                                 .out_dir = cap, .quiet = 1, .calibrations = root,
                                 .assess_nodes = 2000};
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture(scene[3], &cfg, NULL, &sum, &err) < 0) {
        print_error("%s\n", err.msg);
        fail();
    }
    assert_true(sum.sd_measured);
    /* The plaque the reference read, from the simulator's side. */
    struct sim_scene sc;
    struct brdf_standard cert, plaque;
    assert_int_equal(sim_scene_load(scene[2], &sc, &err), 0);
    assert_int_equal(brdf_standard_load(STANDARD, &cert, &err), 0);
    assert_int_equal(sim_standard_truth(&sc, STANDARD, &plaque, &err), 0);
    int r = t->repeats++;
    t->drawn[r] = cert.rho[1] / plaque.rho[1] - 1; /* what trusting the certificate costs */
    t->shared[r] = tally_samples(cap, mat, t);
    read_fit(cap, t->est[r], t->sd[r]);
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' '%s'", root, cap);
    assert_int_equal(system(cmd), 0);
}

static double sd_of(const double *x, int n, int stride)
{
    double s = 0, s2 = 0;
    for (int k = 0; k < n; k++)
        s += x[k * stride];
    double m = s / n;
    for (int k = 0; k < n; k++)
        s2 += (x[k * stride] - m) * (x[k * stride] - m);
    return sqrt(s2 / (n - 1));
}

static void test_lab_chain_honest(void **state)
{
    (void)state;
    const int repeats = gonio_test_small() ? 4 : MAX_REPEATS;
    struct gonio_err err = {0};
    brdf_material *mat = brdf_material_open(MATERIAL, &err);
    assert_non_null(mat);
    static struct tally t;
    memset(&t, 0, sizeof t);
    for (int k = 0; k < repeats; k++)
        one_repeat(k, mat, &t);
    brdf_material_free(mat);
    double mean = t.z_sum / (double)t.n, sd = sqrt(t.z2_sum / (double)t.n - mean * mean);
    double cover = (double)t.covered / (double)t.n;
    /* A repeat's mean error against its plaque's departure: the shared
     * error is the plaque's, and the drawn plaque reaches the values. */
    double sxy = 0, sxx = 0, syy = 0, mx = 0, my = 0;
    for (int k = 0; k < t.repeats; k++)
        mx += t.drawn[k] / t.repeats, my += t.shared[k] / t.repeats;
    for (int k = 0; k < t.repeats; k++) {
        sxy += (t.drawn[k] - mx) * (t.shared[k] - my);
        sxx += (t.drawn[k] - mx) * (t.drawn[k] - mx);
        syy += (t.shared[k] - my) * (t.shared[k] - my);
    }
    double corr = sxx > 0 && syy > 0 ? sxy / sqrt(sxx * syy) : 0;
    printf("%d repeats of %s on %s: z-scores over %ld values: mean %.3f, sd %.3f; k = 2 "
           "coverage %.1f %%; a repeat's mean error against its plaque's departure from the "
           "certificate: correlation %.3f (the plaques' sd %.3f %%)\n\n",
           t.repeats, MATERIAL, PLAN, t.n, mean, sd, 100 * cover, corr,
           100 * sqrt(sxx / (t.repeats - 1)));
    /* Every figure first, then the verdicts, so that a failure shows all
     * that is off. */
    int off = !(sd >= 0.85 && sd <= 1.15) + !(cover >= 0.92 && cover <= 0.98) + !(corr >= 0.9);
    if (gonio_test_small()) {
        fprintf(stderr, "small size: %d repeats, too few for the parameters' spread\n",
                repeats);
    } else {
        printf("| parameter | reported sd (mean) | spread over the repeats | ratio |\n"
               "|---|---|---|---|\n");
        for (int j = 0; j < N_PARAMS; j++) {
            double rep = 0;
            for (int k = 0; k < t.repeats; k++)
                rep += t.sd[k][j] / t.repeats;
            double spread = sd_of(&t.est[0][j], t.repeats, N_PARAMS);
            printf("| %s | %.4f | %.4f | %.2f |\n", param_names[j], rep, spread, rep / spread);
            off += !(rep >= 0.75 * spread && rep <= 1.25 * spread);
        }
    }
    assert_int_equal(off, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lab_chain_honest),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
