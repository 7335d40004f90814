/* The premise checks' table (capture/checks.h): names, alone or in a comma
 * list, add to a mask and come back in the table's order; anything else,
 * an empty name included, is refused naming the value; a rig profile
 * without the axis a check needs is refused naming the check and the axis,
 * and one with it is not. */
#include <string.h>

#include "capture/checks.h"
#include "tests/gonio_test.h"

static void test_names(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    unsigned m = 0;
    char buf[64];
    assert_int_equal(capture_checks_parse("--check", "out-of-plane", &m, &err), 0);
    assert_int_equal(m, CAPTURE_CHECK_OUT_OF_PLANE);
    assert_string_equal(capture_checks_text(m, buf, sizeof buf), "out-of-plane");
    assert_int_equal(capture_checks_parse("--check", "isotropy", &m, &err), 0);
    assert_int_equal(m, CAPTURE_CHECK_ISOTROPY | CAPTURE_CHECK_OUT_OF_PLANE);
    assert_string_equal(capture_checks_text(m, buf, sizeof buf), "isotropy,out-of-plane");
    m = 0;
    assert_int_equal(capture_checks_parse("check", "out-of-plane,isotropy", &m, &err), 0);
    assert_int_equal(m, CAPTURE_CHECK_ISOTROPY | CAPTURE_CHECK_OUT_OF_PLANE);
    assert_string_equal(capture_checks_text(0, buf, sizeof buf), "");
    static const char *const bad[] = {"planarity", "isotropy,", "", "iso", "isotropy,,out-of-plane",
                                      "out-of-planes"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        m = 0;
        assert_int_equal(capture_checks_parse("check", bad[i], &m, &err), -GONIO_EUSAGE);
        char want[80];
        snprintf(want, sizeof want, "check '%s'", bad[i]);
        assert_non_null(strstr(err.msg, want));
    }
}

static void test_rig_axes(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct rig_profile rig;
    rig_profile_default(&rig);
    rig.out_of_plane = 1;
    rig.has_rotation = 0;
    unsigned both = CAPTURE_CHECK_ISOTROPY | CAPTURE_CHECK_OUT_OF_PLANE;
    assert_int_equal(capture_checks_rig("--check", CAPTURE_CHECK_OUT_OF_PLANE, &rig, "d", &err),
                     0);
    assert_int_equal(capture_checks_rig("--check", both, &rig, "d", &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "--check isotropy: rig 'd' has no rotation axis"));
    rig.has_rotation = 1;
    rig.out_of_plane = 0;
    assert_int_equal(capture_checks_rig("check", both, &rig, "flat", &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "check out-of-plane: rig 'flat' has no azimuth axis"));
    assert_int_equal(capture_checks_rig("check", CAPTURE_CHECK_ISOTROPY, &rig, "flat", &err), 0);
    assert_int_equal(capture_checks_rig("check", 0, &rig, "flat", &err), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_rig_axes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
