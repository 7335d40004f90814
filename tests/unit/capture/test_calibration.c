/* Calibration directories (capture/calibration.h): written and read back
 * as they were; the reduction's inputs derived from raw frames (the
 * photon-transfer gain, the dark's spread, the monitor's noise recovered
 * from a synthetic rig's readings); and the lookup that picks the newest
 * valid reference and refuses, naming the difference, one that is missing,
 * expired, of another rig or detector, or without the integration; a
 * reading out of the plane of incidence reduced with the instrument factor
 * at theta_r = +theta_o and the spot's factor at its own angles. */
#include <jansson.h>

#include "capture/calibration.h"
#include "journal/journal.h"
#include "tests/gonio_test.h"
#include "tests/unit/radiometry/synth.h"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "calibration");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* Raw frames of the synthetic rig: darks at 0.1 s, the standard at a grid
 * of geometries read `repeats` times each. */
static size_t make_frames(struct syn_rig *r, int repeats, struct cal_frame *f, size_t cap,
                          size_t *n_dark)
{
    size_t n = 0;
    for (int k = 0; k < 32 && n < cap; k++, n++) {
        f[n] = (struct cal_frame){.kind = CAL_DARK, .theta_i = NAN, .theta_r = NAN,
                                  .integration_s = 0.1, .monitor = NAN};
        for (int c = 0; c < 3; c++)
            f[n].counts[c] = syn_counts(r, 0.0, 0.1);
    }
    *n_dark = n;
    for (int ti = 0; ti <= 40; ti += 20)
        for (int tr = -60; tr <= 60; tr += 10)
            for (int k = 0; k < repeats && n < cap; k++, n++) {
                double fr[3];
                brdf_standard_brdf(&r->truth, ti, tr, fr);
                f[n] = (struct cal_frame){.kind = CAL_REFERENCE, .theta_i = ti, .theta_r = tr,
                                          .integration_s = 0.1, .full_scale = r->full_scale,
                                          .nonlinearity = r->k_stated, .rig_time_s = r->t_now};
                for (int c = 0; c < 3; c++)
                    f[n].counts[c] = syn_counts(r, syn_signal(r, fr[c], tr), 0.1);
                f[n].monitor = syn_monitor(r, 0.1);
                r->t_now += 0.5;
            }
    return n;
}

static void test_write_read_derive(void **state)
{
    (void)state;
    struct syn_rig r;
    syn_rig_init(&r, 7, 1);
    r.responsivity = 6e5, r.k_true = 0; /* photon transfer on a linear response */
    static struct cal_frame f[2048];
    size_t nd, n = make_frames(&r, 16, f, 2048, &nd);
    struct cal_meta m = {.id = "reference-x", .kind = CAL_REFERENCE, .created = 1000,
                         .valid_s = 3600, .rig = "lab", .detector = "rgb",
                         .standard = "spectralon-99", .dark = "dark-x",
                         .integrations = {0.1}, .n_integrations = 1, .in_position_deg = 0.05};
    struct gonio_err err = {0};
    assert_int_equal(cal_write(dir, &m, f + nd, n - nd, &err), 0);
    struct cal_meta dm = m;
    snprintf(dm.id, sizeof dm.id, "dark-x");
    dm.kind = CAL_DARK;
    assert_int_equal(cal_write(dir, &dm, f, nd, &err), 0);
    struct cal_meta back;
    struct cal_frame *bf = NULL;
    size_t bn = 0;
    assert_int_equal(cal_read(dir, "reference-x", &back, &bf, &bn, &err), 0);
    assert_string_equal(back.rig, "lab");
    assert_string_equal(back.dark, "dark-x");
    assert_int_equal(back.kind, CAL_REFERENCE);
    assert_int_equal((int)back.created, 1000);
    assert_int_equal(bn, n - nd);
    for (size_t k = 0; k < bn; k++) {
        assert_true(bf[k].counts[1] == f[nd + k].counts[1]);
        assert_true(bf[k].monitor == f[nd + k].monitor);
    }
    free(bf);
    struct cal_loaded cl;
    assert_int_equal(cal_load(dir, "reference-x", &cl, &err), 0);
    assert_int_equal(cl.cal.n_darks, 1);
    assert_int_equal(cl.cal.n_refs, 39);
    assert_int_equal(cl.refs[0].n, 16);
    double dark_sd = sqrt(r.gain * r.gain * r.dark_e_per_s * 0.1 + r.read_sd * r.read_sd);
    for (int c = 0; c < 3; c++) {
        assert_close(cl.darks[0].mean[c], r.offset + r.gain * r.dark_e_per_s * 0.1, 4.0);
        assert_rel_close(cl.darks[0].sd[c], dark_sd, 0.35);
        /* 39 geometries of 16 repeats: the gain to about 6 % (k = 1). */
        assert_rel_close(cl.cal.setup.adu_per_electron[c], r.gain, 0.15);
    }
    assert_rel_close(cl.cal.setup.monitor_rel_sd, r.monitor_rel_sd, 0.2);
    assert_close(cl.cal.setup.in_position_deg, 0.05, 0);
    assert_string_equal(cl.cal.standard.name, "spectralon-99");
    cal_loaded_free(&cl);
}

static void write_pair(const char *ref_id, const char *dark_id, time_t created, const char *rig,
                       const char *det, double integration)
{
    struct cal_frame fr = {.kind = CAL_DARK, .integration_s = integration, .monitor = NAN};
    struct cal_meta m = {.kind = CAL_DARK, .created = created, .valid_s = 3600,
                         .integrations = {integration}, .n_integrations = 1};
    snprintf(m.id, sizeof m.id, "%s", dark_id);
    snprintf(m.rig, sizeof m.rig, "%s", rig);
    snprintf(m.detector, sizeof m.detector, "%s", det);
    assert_int_equal(cal_write(dir, &m, &fr, 1, NULL), 0);
    fr.kind = CAL_REFERENCE;
    m.kind = CAL_REFERENCE;
    m.valid_s = 8 * 3600;
    snprintf(m.id, sizeof m.id, "%s", ref_id);
    snprintf(m.dark, sizeof m.dark, "%s", dark_id);
    snprintf(m.standard, sizeof m.standard, "spectralon-99");
    assert_int_equal(cal_write(dir, &m, &fr, 1, NULL), 0);
}

static void expect(const char *id, const struct cal_need *need, const char *needle)
{
    struct gonio_err err = {0};
    int rc = cal_select(dir, id, need, NULL, &err);
    if (rc != -GONIO_EBADCONFIG || !strstr(err.msg, needle)) {
        print_error("cal_select(%s) = %d '%s', expected '%s'\n", id ? id : "newest", rc,
                    err.msg, needle);
        fail();
    }
}

static void test_select_and_refusals(void **state)
{
    (void)state;
    char root[128];
    snprintf(root, sizeof root, "%s", dir);
    write_pair("ref-old", "dark-old", 10000, "lab", "rgb", 0.1);
    write_pair("ref-new", "dark-new", 11000, "lab", "rgb", 0.1);
    write_pair("ref-other", "dark-other", 12000, "bench", "rgb", 0.1);
    struct cal_need need = {.rig = "lab", .detector = "rgb", .integration_s = 0.1,
                            .now = 11500};
    struct cal_meta m;
    struct gonio_err err = {0};
    assert_int_equal(cal_select(dir, NULL, &need, &m, &err), 0);
    assert_string_equal(m.id, "ref-new");
    assert_int_equal(cal_select(dir, "ref-old", &need, &m, &err), 0);
    expect("ref-none", &need, "calibration ref-none: not found");
    expect("dark-new", &need, "is a dark calibration");
    expect("ref-other", &need, "is of rig 'bench', the capture's rig is 'lab'");
    need.detector = "spectral";
    expect("ref-new", &need, "is of detector 'rgb', the capture's detector is 'spectral'");
    expect(NULL, &need, "no valid reference calibration");
    need.detector = "rgb";
    need.integration_s = 0.3;
    expect("ref-new", &need, "does not cover integration 0.3 s (it has 0.1 s)");
    need.integration_s = 0.1;
    need.gain_state = 2;
    expect("ref-new", &need, "covers gain state 0, not the capture's 2");
    need.gain_state = 0;
    /* The darks last an hour, the references eight. */
    need.now = 11000 + 3601;
    expect("ref-new", &need, "its dark: calibration dark-new expired at");
    need.now = 11000 + 8 * 3600 + 1;
    expect("ref-new", &need, "calibration ref-new expired at");
    expect(NULL, &need, "expired");
}

static void test_budget_table(void **state)
{
    (void)state;
    struct cal_loaded cl;
    memset(&cl, 0, sizeof cl);
    snprintf(cl.meta.id, sizeof cl.meta.id, "reference-b");
    snprintf(cl.meta.dark, sizeof cl.meta.dark, "dark-b");
    syn_standard(&cl.cal.standard);
    snprintf(cl.cal.standard.warning, sizeof cl.cal.standard.warning, "as rho/pi");
    struct rad_value v[3];
    memset(v, 0, sizeof v);
    const double counting[3] = {0.03, 0.01, 0.02};
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++) {
            v[k].brdf[c] = 0.5;
            v[k].rel[RAD_U_COUNTING][c] = counting[k];
            v[k].rel[RAD_U_REFERENCE][c] = 0.006;
            v[k].u[c] = 0.5 * (k + 1) * 0.01;
        }
    v[0].rel[RAD_U_COUNTING][2] = NAN; /* a clipped value has no term */
    json_t *j = cal_budget_json(&cl, v, 3);
    assert_non_null(j);
    json_t *terms = json_object_get(j, "budget");
    assert_int_equal(json_array_size(terms), RAD_N_TERMS);
    json_t *row = json_array_get(terms, RAD_U_COUNTING);
    assert_string_equal(json_string_value(json_object_get(row, "term")), "counting");
    assert_string_equal(json_string_value(json_object_get(row, "kind")), "per sample");
    json_t *med = json_object_get(row, "median_relative_u");
    assert_close(json_real_value(json_array_get(med, 0)), 0.02, 1e-15);
    assert_close(json_real_value(json_array_get(med, 2)), 0.015, 1e-15);
    row = json_array_get(terms, RAD_U_REFERENCE);
    assert_string_equal(json_string_value(json_object_get(row, "kind")), "systematic");
    med = json_object_get(j, "combined_median_relative_u");
    assert_close(json_real_value(json_array_get(med, 1)), 0.02, 1e-15);
    assert_string_equal(json_string_value(json_object_get(j, "warning")), "as rho/pi");
    assert_string_equal(json_string_value(json_object_get(j, "dark")), "dark-b");
    json_decref(j);
}

/* A rig whose instrument factor leans with theta_r (brighter toward the
 * mirror side), an underfilled spot (cos theta_r): a reading out of the
 * plane at (20, 35 / phi 100) is reduced with the factor at theta_r = +35,
 * cos 35, and nothing of the standard's in-plane shape. */
static double lean(double tr)
{
    return 1e5 * (1.0 + 0.004 * tr);
}

static void test_out_of_plane_reading(void **state)
{
    (void)state;
    static struct rad_ref refs[3 * 13];
    struct rad_dark dark = {.integration_s = 0.1, .mean = {100, 100, 100}, .sd = {1, 1, 1},
                            .n = 32};
    struct cal_loaded cl;
    memset(&cl, 0, sizeof cl);
    syn_standard(&cl.cal.standard);
    size_t n = 0;
    for (int ti = 0; ti <= 40; ti += 20)
        for (int tr = -60; tr <= 60; tr += 10, n++) {
            double f[3];
            brdf_standard_brdf(&cl.cal.standard, ti, tr, f);
            refs[n] = (struct rad_ref){.theta_i = ti, .theta_r = tr, .integration_s = 0.1,
                                       .n = 4, .monitor = NAN};
            for (int c = 0; c < 3; c++)
                refs[n].counts[c] = 100 + lean(tr) * f[c] * cos(tr * BRDF_DEG) * 0.1;
        }
    cl.cal.darks = &dark, cl.cal.n_darks = 1;
    cl.cal.refs = refs, cl.cal.n_refs = n;
    cl.cal.setup = (struct rad_setup){.adu_per_electron = {1, 1, 1}, .in_position_deg = 0.05,
                                      .spot = RAD_SPOT_UNDERFILLED};
    const double brdf = 0.3;
    struct plan_point pt = {.theta_i = 20, .theta_o = 35, .phi_o = 100, .out_of_plane = 1};
    struct journal_sample s;
    journal_sample_clear(&s);
    s.point = -1;
    s.counts = 1;
    s.integration_s = 0.1;
    s.gain_state = 0;
    s.monitor = NAN;
    for (int c = 0; c < 3; c++)
        s.raw[c] = 100 + lean(35) * brdf * cos(35 * BRDF_DEG) * 0.1;
    struct gonio_err err = {0};
    assert_int_equal(cal_reduce_reading(&cl, &pt, &s, &err), 0);
    assert_int_equal(s.point, -1);
    for (int c = 0; c < 3; c++) {
        assert_close(s.rgb[c], brdf, 1e-9);
        assert_true(s.u[c] > 0 && s.u[c] < 0.05 * brdf);
    }
    /* beyond the reference's incidences: refused, naming the geometry */
    pt.theta_i = 50;
    assert_int_equal(cal_reduce_reading(&cl, &pt, &s, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "50"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_write_read_derive),
        cmocka_unit_test(test_select_and_refusals),
        cmocka_unit_test(test_budget_table),
        cmocka_unit_test(test_out_of_plane_reading),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
