/* A calibration run's journal (capture/calibration.h, cal_run_measure) on
 * the simulated raw lab rig: a run stopped part way and started again keeps
 * the frames it read and reads only the rest, a torn last line is dropped,
 * a journal of another run is refused; and the operator's part: a rig
 * without a shutter with nobody to ask is refused, a reference asks for
 * its standard before it reads. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <unistd.h>
#include <sys/stat.h>

#include "capture/calibration.h"
#include "sim_source/sim_source.h"
#include "tests/gonio_test.h"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "calrun");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* The simulated lab rig, its profile and devices open. */
struct rig {
    sim_source *src;
    struct capture_rig crig;
    struct rig_profile prof;
    struct capture_devices dev;
};

static void rig_open(struct rig *r, const char *material)
{
    struct gonio_err err = {0};
    r->src = sim_source_new("lab", material, NULL, &err);
    assert_non_null(r->src);
    sim_source_rig(r->src, &r->crig);
    assert_int_equal(rig_profile_load(r->crig.profile, &r->prof, &err), 0);
    assert_int_equal(r->crig.open(r->crig.user, &r->prof, dir, &r->dev, &err), 0);
}

static void rig_close(struct rig *r)
{
    r->crig.close(r->crig.user, &r->dev);
    sim_source_free(r->src);
}

/* control: abort before the frame after `stop_after` frames. */
struct stopper {
    int calls, stop_after;
    char asked[512];
    enum capture_control answer;
};

static enum capture_control stop_control(void *user)
{
    struct stopper *s = user;
    return s->calls++ == s->stop_after ? CAPTURE_ABORT : CAPTURE_GO;
}

static enum capture_control record_ask(void *user, const char *instruction)
{
    struct stopper *s = user;
    snprintf(s->asked, sizeof s->asked, "%s", instruction);
    return s->answer;
}

static struct cal_meta dark_meta(const char *id, double integration_s)
{
    struct cal_meta m = {.kind = CAL_DARK, .n_integrations = 1,
                         .integrations = {integration_s}};
    snprintf(m.id, sizeof m.id, "%s", id);
    return m;
}

static size_t lines(const char *path)
{
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    size_t n = 0;
    int c;
    while ((c = fgetc(f)) != EOF)
        n += c == '\n';
    fclose(f);
    return n;
}

static void test_stopped_run_continues_its_journal(void **state)
{
    (void)state;
    struct rig r;
    rig_open(&r, NULL);
    struct cal_meta m = dark_meta("dark-run", r.prof.integration_s);
    struct cal_run run = {.root = dir, .meta = &m, .rig = &r.prof, .per_point = 6};
    struct stopper s = {.stop_after = 3};
    struct cal_hooks h = {.control = stop_control, .user = &s};
    struct cal_frame *first = NULL, *all = NULL;
    size_t n1 = 0, n2 = 0;
    int aborted = 0;
    struct gonio_err err = {0};
    assert_int_equal(cal_run_measure(&r.dev, &run, &h, &first, &n1, &aborted, &err), 0);
    assert_true(aborted);
    assert_int_equal(n1, 3);
    char jpath[256];
    snprintf(jpath, sizeof jpath, "%s/dark-run/journal.csv", dir);
    assert_int_equal(lines(jpath), 4); /* the header and three frames, synced */
    FILE *f = fopen(jpath, "a"); /* a kill mid-write: half a frame */
    fputs("dark,nan,nan,0.05,0,1003,99", f);
    fclose(f);
    s = (struct stopper){.stop_after = -1};
    assert_int_equal(cal_run_measure(&r.dev, &run, &h, &all, &n2, &aborted, &err), 0);
    assert_false(aborted);
    assert_int_equal(n2, 6);
    assert_int_equal(s.calls, 3); /* only the frames it lacked were read */
    for (size_t k = 0; k < n1; k++)
        assert_memory_equal(all[k].counts, first[k].counts, sizeof first[k].counts);
    assert_int_equal(lines(jpath), 7);
    struct cal_frame *back = NULL;
    size_t nb = 0;
    struct cal_meta written;
    assert_true(cal_read(dir, "dark-run", &written, NULL, NULL, &err) < 0); /* the caller's */
    free(first);
    free(all);
    free(back);

    /* Another run under the same id is not this journal's. */
    struct cal_meta other = dark_meta("dark-run", 2 * r.prof.integration_s);
    run.meta = &other;
    assert_true(cal_run_measure(&r.dev, &run, &h, &back, &nb, &aborted, &err) < 0);
    assert_non_null(strstr(err.msg, "not this calibration's journal"));
    rig_close(&r);
}

static void test_the_operator_is_asked(void **state)
{
    (void)state;
    struct rig r;
    rig_open(&r, "standard:spectralon-99");
    struct gonio_err err = {0};
    struct cal_frame *fr = NULL;
    size_t n = 0;
    int aborted = 0;
    /* No shutter and nobody to ask: refused before any frame. */
    r.prof.shutter = 0;
    struct cal_meta m = dark_meta("dark-noshutter", r.prof.integration_s);
    struct cal_run run = {.root = dir, .meta = &m, .rig = &r.prof, .per_point = 2};
    struct cal_hooks none = {0};
    assert_int_equal(cal_run_measure(&r.dev, &run, &none, &fr, &n, &aborted, &err),
                     -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "has no shutter"));
    /* A reference asks for its standard first; declined, nothing is read. */
    r.prof.shutter = 1;
    struct plan *plan = NULL;
    assert_true(plan_load("ds4", &r.prof, &plan, &err) > 0);
    struct cal_meta ref = {.kind = CAL_REFERENCE};
    snprintf(ref.id, sizeof ref.id, "reference-asked");
    snprintf(ref.standard, sizeof ref.standard, "spectralon-99");
    struct cal_run rrun = {.root = dir, .meta = &ref, .rig = &r.prof, .plan = plan,
                           .per_point = 2};
    struct stopper s = {.stop_after = -1, .answer = CAPTURE_ABORT};
    struct cal_hooks h = {.control = stop_control, .ask = record_ask, .user = &s};
    assert_int_equal(cal_run_measure(&r.dev, &rrun, &h, &fr, &n, &aborted, &err), 0);
    assert_true(aborted);
    assert_int_equal(n, 0);
    assert_non_null(strstr(s.asked, "mount the standard 'spectralon-99'"));
    free(fr);
    /* Mounted: every point read. */
    s = (struct stopper){.stop_after = -1, .answer = CAPTURE_GO};
    assert_int_equal(cal_run_measure(&r.dev, &rrun, &h, &fr, &n, &aborted, &err), 0);
    assert_false(aborted);
    assert_int_equal(n, 2 * plan_count(plan));
    free(fr);
    plan_free(plan);
    rig_close(&r);
}

/* A rig's sample changer (cal_hooks.mount), the in-process rig's: every
 * slot asked for, and what its journal says at each frame. */
struct changer {
    struct rig *r;
    int slots[8], n;
    char journal[64]; /* the changer journal's text at the last frame */
    char path[256];
    int asked; /* how often the operator was asked */
};

static enum capture_control changer_ask(void *user, const char *instruction)
{
    (void)instruction;
    struct changer *c = user;
    c->asked++;
    return CAPTURE_ABORT;
}

static int changer_mount(void *user, struct capture_devices *d, enum capture_slot slot,
                         const char *standard, struct gonio_err *err)
{
    struct changer *c = user;
    c->slots[c->n++ % 8] = (int)slot;
    return c->r->crig.mount(c->r->crig.user, d, slot, standard, err);
}

static void changer_frame(void *user, size_t done, size_t total, double rig_time_s)
{
    (void)done, (void)total, (void)rig_time_s;
    struct changer *c = user;
    FILE *f = fopen(c->path, "r");
    c->journal[0] = '\0';
    if (f) {
        if (!fgets(c->journal, sizeof c->journal, f))
            c->journal[0] = '\0';
        fclose(f);
    }
}

static double mean_r(const struct cal_frame *f, size_t n)
{
    double s = 0;
    for (size_t k = 0; k < n; k++)
        s += f[k].counts[0];
    return s / (double)n;
}

/* With a changer nobody is asked: the standard (or the light trap) is
 * swapped in, journalled while it is in, and the sample put back after;
 * the standard's frames are those of the standard mounted by hand. A run
 * killed after its last frame, the standard still in, puts the sample
 * back when it is started again. */
static void test_the_changer_swaps_them(void **state)
{
    (void)state;
    struct rig r, byhand;
    rig_open(&r, "analytic:rough-diffuse");
    struct gonio_err err = {0};
    struct plan *plan = NULL;
    assert_true(plan_load("ds4", &r.prof, &plan, &err) > 0);
    struct cal_meta ref = {.kind = CAL_REFERENCE};
    snprintf(ref.id, sizeof ref.id, "reference-changer");
    snprintf(ref.standard, sizeof ref.standard, "spectralon-99");
    struct cal_run run = {.root = dir, .meta = &ref, .rig = &r.prof, .plan = plan,
                          .per_point = 2};
    struct stopper s = {.stop_after = -1, .answer = CAPTURE_ABORT};
    struct changer c = {.r = &r};
    snprintf(c.path, sizeof c.path, "%s/reference-changer/changer", dir);
    struct cal_hooks h = {.control = stop_control, .ask = record_ask, .user = &s,
                          .mount = changer_mount, .mount_user = &c};
    struct cal_hooks follow = h;
    /* on_frame and ask share user: both take the changer */
    follow.on_frame = changer_frame, follow.ask = changer_ask, follow.user = &c;
    follow.control = NULL;
    struct cal_frame *fr = NULL, *hand = NULL;
    size_t n = 0, nh = 0;
    int aborted = 0;
    assert_int_equal(cal_run_measure(&r.dev, &run, &follow, &fr, &n, &aborted, &err), 0);
    assert_int_equal(c.asked, 0);
    assert_false(aborted);
    assert_int_equal(n, 2 * plan_count(plan));
    assert_int_equal(c.n, 2);
    assert_int_equal(c.slots[0], CAPTURE_SLOT_STANDARD);
    assert_int_equal(c.slots[1], CAPTURE_SLOT_SAMPLE);
    assert_string_equal(c.journal, "slot 1 in\n"); /* at the last frame */
    assert_int_equal(access(c.path, F_OK), -1);  /* the sample back: nothing to undo */
    rig_open(&byhand, "standard:spectralon-99");
    struct cal_meta ref2 = ref;
    snprintf(ref2.id, sizeof ref2.id, "reference-byhand");
    struct cal_run run2 = run;
    run2.meta = &ref2, run2.rig = &byhand.prof;
    s.answer = CAPTURE_GO;
    assert_int_equal(cal_run_measure(&byhand.dev, &run2, &(struct cal_hooks){.ask = record_ask,
                                     .user = &s}, &hand, &nh, &aborted, &err), 0);
    assert_int_equal(nh, n);
    double std_r = mean_r(fr, n);
    assert_true(fabs(std_r / mean_r(hand, nh) - 1) < 0.02);
    free(fr);
    free(hand);
    rig_close(&byhand);

    /* Killed with every frame read, the standard still in: started again,
     * it reads nothing and puts the sample back. */
    FILE *f = fopen(c.path, "w");
    fputs("slot 1 in\n", f);
    fclose(f);
    c.n = 0;
    assert_int_equal(cal_run_measure(&r.dev, &run, &h, &fr, &n, &aborted, &err), 0);
    assert_int_equal(n, 2 * plan_count(plan));
    assert_int_equal(c.n, 1);
    assert_int_equal(c.slots[0], CAPTURE_SLOT_SAMPLE);
    assert_int_equal(access(c.path, F_OK), -1);
    free(fr);

    /* Started again with the standard in and a journal that is not this
     * run's: refused, with the journal's error, and the sample put back. */
    f = fopen(c.path, "w");
    fputs("slot 1 in\n", f);
    fclose(f);
    char jpath[256];
    snprintf(jpath, sizeof jpath, "%s/reference-changer/journal.csv", dir);
    f = fopen(jpath, "a");
    fputs("dark,nan,nan,0.05,0,1003,99\n", f);
    fclose(f);
    c.n = 0, fr = NULL, err = (struct gonio_err){0};
    assert_true(cal_run_measure(&r.dev, &run, &h, &fr, &n, &aborted, &err) < 0);
    assert_non_null(strstr(err.msg, "journal.csv"));
    assert_int_equal(c.n, 1);
    assert_int_equal(c.slots[0], CAPTURE_SLOT_SAMPLE);
    assert_int_equal(access(c.path, F_OK), -1);

    /* Stray light: the light trap in, stopped part way, the sample back. */
    struct cal_meta stray = {.kind = CAL_STRAY};
    snprintf(stray.id, sizeof stray.id, "stray-changer");
    run.meta = &stray;
    s = (struct stopper){.stop_after = 3};
    c.n = 0;
    assert_int_equal(cal_run_measure(&r.dev, &run, &h, &fr, &n, &aborted, &err), 0);
    assert_true(aborted);
    assert_int_equal(n, 3);
    /* the trap: the dark and the stray light, far below the standard */
    assert_true(mean_r(fr, n) < 0.2 * std_r);
    assert_int_equal(c.n, 2);
    assert_int_equal(c.slots[0], CAPTURE_SLOT_TRAP);
    assert_int_equal(c.slots[1], CAPTURE_SLOT_SAMPLE);
    free(fr);
    plan_free(plan);
    rig_close(&r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stopped_run_continues_its_journal),
        cmocka_unit_test(test_the_operator_is_asked),
        cmocka_unit_test(test_the_changer_swaps_them),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
