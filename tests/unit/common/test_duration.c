/* Durations as gonio plan and gonio results print them: rounded once, then
 * split into fields, so no field ever reads 60 and hours appear past 60 min. */
#include "tests/gonio_test.h"

#include <string.h>

#include "common/duration.h"

static void test_words(void **state)
{
    (void)state;
    char b[64];
    gonio_duration_words(7378.4, b, sizeof b); /* oop200k's estimate printed 2092 min before */
    assert_string_equal(b, "2 h 2 min 58 s");
    gonio_duration_words(125578, b, sizeof b);
    assert_string_equal(b, "34 h 52 min 58 s");
    gonio_duration_words(819.8, b, sizeof b);
    assert_string_equal(b, "13 min 40 s");
    gonio_duration_words(59.6, b, sizeof b);
    assert_string_equal(b, "1 min 0 s");
    gonio_duration_words(0.2, b, sizeof b);
    assert_string_equal(b, "0 s");
}

static void test_hms(void **state)
{
    (void)state;
    char b[64];
    gonio_duration_hms(1199.9999, b, sizeof b); /* printed 19:60 min before */
    assert_string_equal(b, "0:20:00");
    gonio_duration_hms(125578, b, sizeof b);
    assert_string_equal(b, "34:52:58");
    gonio_duration_hms(59.4, b, sizeof b);
    assert_string_equal(b, "0:00:59");
    gonio_duration_hms(-1, b, sizeof b);
    assert_string_equal(b, "0:00:00");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_words),
        cmocka_unit_test(test_hms),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
