/* The detector's raw mode over Modbus (docs/protocol-modbus.md, "Raw
 * mode"): gonio-sim serving a scene with an adc publishes the counts the
 * in-process simulator reads for the same scene and seed, count for count,
 * with its full scale, nonlinearity and monitor, shutter open and closed;
 * and the driver refuses a raw block out of range, naming the register and
 * its value. The refusals need a device that publishes such values, which
 * gonio-sim never does: a small Modbus TCP slave on loopback serves them. */
#include <errno.h>
#include <math.h>
#include <modbus.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <netinet/in.h>

#include "drivers/drv_modbus.h"
#include "drivers/drv_sim.h"
#include "modbus_map/modbus_map.h"
#include "rig/rig.h"
#include "sim/scene.h"
#include "sim/sim.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

static char scene_path[256];

/* Dark, shot and read noise through a 16-bit ADC with a lamp monitor: no
 * drift and no mechanics, so the rig clock and the moves draw nothing that
 * could set the two paths apart. */
static const char scene_text[] =
    "name: raw-test\n"
    "material: default\n"
    "seed: 23\n"
    "effects:\n"
    "  - {name: dark, rate_e_per_s: 2000}\n"
    "  - {name: shot_noise}\n"
    "  - {name: read_noise, sigma_e: 15}\n"
    "  - {name: adc, gain_adu_per_e: 0.8, bits: 16, offset_adu: 1000, nonlinearity: 0.02}\n"
    "  - {name: lamp_monitor, rate_counts_per_s: 1.0e6}\n";

enum { N_OPEN = 12, N_CLOSED = 12 };

struct readings {
    struct drv_reading r[N_OPEN + N_CLOSED];
};

/* N_OPEN readings with the shutter open, then N_CLOSED closed. */
static void take(drv_detector *d, double t, struct readings *out)
{
    struct gonio_err err = {0};
    for (int i = 0; i < N_OPEN + N_CLOSED; i++) {
        if (i == N_OPEN && drv_detector_shutter(d, 1, &err) < 0)
            fail_msg("%s", err.msg);
        if (drv_detector_acquire(d, t, &out->r[i], &err) < 0)
            fail_msg("%s", err.msg);
    }
}

static void test_modbus_equals_in_process(void **state)
{
    (void)state;
    snprintf(scene_path, sizeof scene_path, "/tmp/gonio-raw-test-%d.yaml", (int)getpid());
    FILE *f = fopen(scene_path, "w");
    assert_non_null(f);
    fputs(scene_text, f);
    fclose(f);
    /* 62500 us: the integration as gonio-sim takes it from its register */
    const double t = 62500 * 1e-6;

    static struct readings mb, in;
    struct sim_proc sim;
    const char *args[] = {"--scene", scene_path, "--time-scale", "50", NULL};
    assert_int_equal(sim_proc_start(&sim, args), 0);
    drv_modbus_bus *bus = sim_proc_rtu(&sim, 50);
    assert_non_null(bus);
    struct gonio_err err = {0};
    drv_detector *d = drv_detector_new_modbus(bus, MB_SLAVE_DETECTOR, &err);
    assert_non_null(d);
    take(d, t, &mb);
    /* A retried trigger (its answer lost under load) may have started an
     * integration more, which draws from the streams: then the two paths
     * agree in distribution only. */
    struct drv_modbus_stats st;
    drv_modbus_bus_stats(bus, &st);
    int exact = st.retries == 0;
    if (!exact)
        fprintf(stderr, "# %ld retries on the bus: counts compared in distribution\n",
                st.retries);
    drv_detector_free(d);
    drv_modbus_bus_free(bus);
    assert_int_equal(sim_proc_stop(&sim), 0);

    struct sim_scene sc;
    struct rig_profile prof;
    assert_int_equal(sim_scene_load(scene_path, &sc, &err), 0);
    assert_int_equal(rig_profile_load(sc.rig, &prof, &err), 0);
    brdf_material *m = brdf_material_open(sc.material, &err);
    assert_non_null(m);
    sim_rig *rig = sim_rig_new_scene(&prof, m, &sc, NULL, &err);
    assert_non_null(rig);
    d = drv_detector_new_sim(rig);
    take(d, t, &in);
    drv_detector_free(d);
    sim_rig_free(rig);
    brdf_material_free(m);
    unlink(scene_path);

    double dark_sum = 0, in_dark_sum = 0;
    for (int i = 0; i < N_OPEN + N_CLOSED; i++) {
        const struct drv_reading *a = &mb.r[i], *b = &in.r[i];
        assert_int_equal(a->unit, DRV_UNIT_COUNTS);
        assert_int_equal(b->unit, DRV_UNIT_COUNTS);
        for (int c = 0; c < 3 && exact; c++)
            assert_close(a->rgb[c], b->rgb[c], 0);
        if (exact)
            assert_close(a->monitor, b->monitor, 0);
        else /* 62500 counts, Poisson */
            assert_close(a->monitor, b->monitor, 6 * sqrt(2 * 62500.0));
        assert_close(a->full_scale, 65535, 0);
        assert_close(b->full_scale, 65535, 0);
        assert_close(a->nonlinearity, b->nonlinearity, 0);
        assert_close(a->integration_s, t, 1e-12);
        assert_int_equal(a->gain_state, 0);
        assert_int_equal(a->flags, b->flags);
        if (i >= N_OPEN) {
            dark_sum += a->rgb[0] + a->rgb[1] + a->rgb[2];
            in_dark_sum += b->rgb[0] + b->rgb[1] + b->rgb[2];
        }
        else /* the material's light, well above the dark and below the clip */
            assert_true(a->rgb[1] > 2000 && a->flags == 0);
    }
    /* closed: offset + gain x dark (125 e-), sd 0.8 sqrt(125 + 225) = 15 ADU */
    double want = 1000 + 0.8 * 2000 * t;
    assert_close(dark_sum / (3 * N_CLOSED), want, 4 * 15 / sqrt(3 * N_CLOSED));
    assert_close(in_dark_sum / (3 * N_CLOSED), want, 4 * 15 / sqrt(3 * N_CLOSED));
}

/* ---- a spectral detector's bands ----------------------------------------- */

/* The scene above with a spectral detector (31 bands, 400-700 nm) whose
 * bands' offsets differ. */
static const char spectral_text[] =
    "name: raw-bands-test\n"
    "material: default\n"
    "detector: {kind: spectral}\n"
    "seed: 29\n"
    "effects:\n"
    "  - {name: dark, rate_e_per_s: 2000}\n"
    "  - {name: shot_noise}\n"
    "  - {name: read_noise, sigma_e: 15}\n"
    "  - {name: adc, gain_adu_per_e: 0.8, bits: 16, offset_adu: 1000, nonlinearity: 0.02,\n"
    "     offset_spread_adu: 300}\n";

enum { N_SPECTRA = 6, N_BANDS = 31 };

struct spectra {
    int n_bands[N_SPECTRA];
    double nm[N_SPECTRA][N_BANDS], bands[N_SPECTRA][N_BANDS], rgb[N_SPECTRA][3];
};

static void take_spectra(drv_detector *d, double t, struct spectra *out)
{
    struct gonio_err err = {0};
    for (int i = 0; i < N_SPECTRA; i++) {
        struct drv_reading r;
        if (drv_detector_acquire(d, t, &r, &err) < 0)
            fail_msg("%s", err.msg);
        assert_int_equal(r.unit, DRV_UNIT_COUNTS);
        out->n_bands[i] = r.n_bands;
        for (int k = 0; k < r.n_bands && k < N_BANDS; k++) {
            out->nm[i][k] = r.bands_nm[k];
            out->bands[i][k] = r.bands[k];
        }
        memcpy(out->rgb[i], r.rgb, sizeof out->rgb[i]);
    }
}

/* gonio-sim serving a spectral scene with an adc gives the band counts the
 * in-process simulator reads, count for count, at the same centres: the
 * per-band values a calibration reduces band by band. */
static void test_spectral_bands_equal_in_process(void **state)
{
    (void)state;
    char path[256];
    snprintf(path, sizeof path, "/tmp/gonio-raw-bands-%d.yaml", (int)getpid());
    gonio_test_write_text(path, spectral_text);
    const double t = 62500 * 1e-6;
    static struct spectra mb, in;
    struct sim_proc sim;
    const char *args[] = {"--scene", path, "--time-scale", "50", NULL};
    assert_int_equal(sim_proc_start(&sim, args), 0);
    drv_modbus_bus *bus = sim_proc_rtu(&sim, 50);
    assert_non_null(bus);
    struct gonio_err err = {0};
    drv_detector *d = drv_detector_new_modbus(bus, MB_SLAVE_DETECTOR, &err);
    assert_non_null(d);
    take_spectra(d, t, &mb);
    struct drv_modbus_stats st;
    drv_modbus_bus_stats(bus, &st);
    int exact = st.retries == 0; /* as test_modbus_equals_in_process */
    drv_detector_free(d);
    drv_modbus_bus_free(bus);
    assert_int_equal(sim_proc_stop(&sim), 0);

    struct sim_scene sc;
    struct rig_profile prof;
    assert_int_equal(sim_scene_load(path, &sc, &err), 0);
    assert_int_equal(rig_profile_load(sc.rig, &prof, &err), 0);
    brdf_material *m = brdf_material_open(sc.material, &err);
    assert_non_null(m);
    sim_rig *rig = sim_rig_new_scene(&prof, m, &sc, NULL, &err);
    assert_non_null(rig);
    d = drv_detector_new_sim(rig);
    take_spectra(d, t, &in);
    drv_detector_free(d);
    sim_rig_free(rig);
    brdf_material_free(m);
    unlink(path);
    for (int i = 0; i < N_SPECTRA; i++) {
        assert_int_equal(mb.n_bands[i], N_BANDS);
        assert_int_equal(in.n_bands[i], N_BANDS);
        for (int k = 0; k < N_BANDS; k++) {
            assert_close(mb.nm[i][k], in.nm[i][k], 0);
            if (exact)
                assert_close(mb.bands[i][k], in.bands[i][k], 0);
            else /* the same band's light and offset, another draw */
                assert_close(mb.bands[i][k], in.bands[i][k], 0.05 * in.bands[i][k]);
        }
        for (int c = 0; c < 3 && exact; c++)
            assert_close(mb.rgb[i][c], in.rgb[i][c], 0);
    }
    assert_close(mb.nm[0][0], 400, 0);
    assert_close(mb.nm[0][N_BANDS - 1], 700, 0);
}

/* ---- a device that publishes what it is told ------------------------------ */

/* The raw block and channels a case publishes on each trigger. */
struct published {
    uint32_t counts[3], raw_seq_delta, gain, full, monitor, shutter;
    float k;
    int no_raw_block; /* map only 0x0000-0x0011: no shutter, no raw block */
};

static const struct published good = {
    .counts = {1200, 65535, 3000}, .gain = 2, .full = 65535, .monitor = MB_DET_MONITOR_NONE,
    .k = 0.02f};

/* Serve one connection of the driver: every trigger completes at once
 * with the case's values (status READY | RAW, the next sequence). */
static void serve(int listen_fd, modbus_t *ctx, const struct published *p)
{
    int nregs = p->no_raw_block ? MB_DET_CHANNELS + 6 : MB_DET_RAW_END;
    modbus_mapping_t *map = modbus_mapping_new(0, 0, nregs, 0);
    uint16_t *r = map->tab_registers;
    uint32_t seq = 0;
    mb_put32(r + MB_DET_COUNT, 3);
    if (!map || modbus_tcp_accept(ctx, &listen_fd) < 0)
        _exit(1);
    uint8_t q[MODBUS_TCP_MAX_ADU_LENGTH];
    for (;;) {
        int n = modbus_receive(ctx, q);
        if (n < 0)
            break;
        if (n == 0)
            continue;
        modbus_reply(ctx, q, n, map);
        if (mb_get32(r + MB_DET_TRIGGER) != 1)
            continue;
        mb_put32(r + MB_DET_TRIGGER, 0);
        seq++;
        mb_put32(r + MB_DET_SEQUENCE, seq);
        mb_put32(r + MB_DET_STATUS, MB_DET_READY | MB_DET_RAW);
        for (int c = 0; c < 3; c++)
            mb_put32(r + MB_DET_CHANNELS + 2 * c, p->counts[c]);
        if (p->no_raw_block)
            continue;
        mb_put32(r + MB_DET_RAW_SEQUENCE, seq + p->raw_seq_delta);
        mb_put32(r + MB_DET_GAIN_STATE, p->gain);
        mb_put32(r + MB_DET_FULL_SCALE, p->full);
        mb_put_float(r + MB_DET_NONLINEARITY, p->k);
        mb_put32(r + MB_DET_MONITOR, p->monitor);
        mb_put32(r + MB_DET_SHUTTER, p->shutter);
    }
    /* freed so that memcheck sees no leak in this child (check-valgrind) */
    modbus_mapping_free(map);
    modbus_close(ctx);
    modbus_free(ctx);
    _exit(0);
}

struct device {
    pid_t pid;
    drv_modbus_bus *bus;
    drv_detector *det;
};

static void device_start(struct device *dev, const struct published *p)
{
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", 0);
    assert_non_null(ctx);
    int fd = modbus_tcp_listen(ctx, 1);
    assert_true(fd >= 0);
    struct sockaddr_in addr;
    socklen_t len = sizeof addr;
    assert_int_equal(getsockname(fd, (struct sockaddr *)&addr, &len), 0);
    dev->pid = gonio_test_fork();
    assert_true(dev->pid >= 0);
    if (dev->pid == 0)
        serve(fd, ctx, p);
    close(fd);
    modbus_free(ctx);
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.host = "127.0.0.1";
    cfg.port = ntohs(addr.sin_port);
    cfg.retries = 0;
    cfg.timeout_s *= gonio_test_time_factor();
    struct gonio_err err = {0};
    dev->bus = drv_modbus_bus_new_tcp(&cfg, &err);
    if (!dev->bus)
        fail_msg("%s", err.msg);
    dev->det = drv_detector_new_modbus(dev->bus, MB_SLAVE_DETECTOR, &err);
    assert_non_null(dev->det);
}

static void device_stop(struct device *dev)
{
    drv_detector_free(dev->det);
    drv_modbus_bus_free(dev->bus);
    int status;
    waitpid(dev->pid, &status, 0);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

/* One acquisition of the case's values: the error it fails with ("" when
 * it succeeds, *r then holds the reading). */
static void acquire_case(const struct published *p, struct drv_reading *r, char *msg,
                         size_t size)
{
    struct device dev;
    device_start(&dev, p);
    struct gonio_err err = {0};
    int rc = drv_detector_acquire(dev.det, 0.001, r, &err);
    snprintf(msg, size, "%s", rc < 0 ? err.msg : "");
    if (rc < 0)
        assert_int_equal(rc, -GONIO_EDEVICE);
    device_stop(&dev);
}

static void test_good_block_read(void **state)
{
    (void)state;
    struct drv_reading r;
    char msg[600];
    acquire_case(&good, &r, msg, sizeof msg);
    assert_string_equal(msg, "");
    assert_int_equal(r.unit, DRV_UNIT_COUNTS);
    assert_close(r.rgb[0], 1200, 0);
    assert_close(r.rgb[2], 3000, 0);
    assert_close(r.full_scale, 65535, 0);
    assert_close(r.nonlinearity, 0.02, 0); /* as written, not float32's 0.0199999996 */
    assert_int_equal(r.gain_state, 2);
    assert_true(isnan(r.monitor));
    assert_int_equal(r.flags, DRV_READING_SATURATED); /* green at the full scale */
}

static void test_bad_block_refused(void **state)
{
    (void)state;
    struct {
        struct published p;
        const char *want;
    } cases[] = {
        {good, "register 0x000e (channel G) reads 70000 counts, above the full scale 65535"},
        {good, "register 0x0104 (full scale) reads 0 counts"},
        {good, "register 0x0106 (nonlinearity) reads 0.7, outside 0 to 0.5"},
        {good, "register 0x0106 (nonlinearity) reads nan"},
        {good, "register 0x0100 (raw sequence) reads 4: the block is of another reading"},
        {good, "register 0x0102 (gain state) reads 300, above 255"},
        {good, "register 0x010a (shutter) reads 1, where the driver left it open (0)"},
    };
    cases[0].p.counts[1] = 70000;
    cases[1].p.full = 0;
    cases[1].p.counts[1] = 0;
    cases[2].p.k = 0.7f;
    cases[3].p.k = NAN;
    cases[4].p.raw_seq_delta = 3;
    cases[5].p.gain = 300;
    cases[6].p.shutter = 1;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        struct drv_reading r;
        char msg[600];
        acquire_case(&cases[i].p, &r, msg, sizeof msg);
        if (!strstr(msg, cases[i].want) || !strstr(msg, "detector (slave 3)"))
            fail_msg("case %zu: '%s'\nwanted '%s'", i, msg, cases[i].want);
    }
}

/* A detector without the register answers exception 02: no shutter. */
static void test_no_shutter(void **state)
{
    (void)state;
    struct published p = good;
    p.no_raw_block = 1;
    struct device dev;
    device_start(&dev, &p);
    struct gonio_err err = {0};
    assert_int_equal(drv_detector_shutter(dev.det, 1, &err), -ENOTSUP);
    assert_non_null(strstr(err.msg, "detector (slave 3) has no shutter (register 0x010a"));
    device_stop(&dev);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_modbus_equals_in_process),
        cmocka_unit_test(test_spectral_bands_equal_in_process),
        cmocka_unit_test(test_good_block_read),
        cmocka_unit_test(test_bad_block_refused),
        cmocka_unit_test(test_no_shutter),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
