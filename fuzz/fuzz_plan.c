/* Capture plans (planner/planner.h): YAML from the user, on the design's
 * default rig. */
#include <stdlib.h>

#include "fuzz/fuzz.h"
#include "planner/planner.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("plan.yaml", data, size);
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *plan = NULL;
    struct gonio_err err = {0};
    int n = plan_load(path, &rig, &plan, &err);
    if (n < 0) {
        FUZZ_CHECK(err.msg[0] && !plan);
        return 0;
    }
    FUZZ_CHECK(plan && (size_t)n == plan_count(plan));
    for (size_t i = 0; i < plan_count(plan); i++) {
        const struct plan_point *pt = plan_point(plan, i);
        /* Every point placed on the rig is within the axes' limits. */
        FUZZ_CHECK(pt->ax.s >= rig.sample.min && pt->ax.s <= rig.sample.max);
        FUZZ_CHECK(pt->ax.a >= rig.arm.min && pt->ax.a <= rig.arm.max);
    }
    struct plan_estimate est;
    plan_estimate(plan, &rig, &est);
    /* The plan document is built as a JSON tree: some 800 bytes a point,
     * 1.35 GB for a 1.6-million-point grid in a release build and past
     * the fuzzer's 2 GB limit under ASan. Memory in proportion to the plan
     * is by design; the document is checked up to the largest shipped plan
     * (oop200k). */
    if (plan_count(plan) <= 200000)
        free(plan_json_text(plan, &est));
    plan_free(plan);
    return 0;
}
