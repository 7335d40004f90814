/* Orderings against each other and against the lower bound: for each plan,
 * the move and total rig time of every order, the ratio of the move time
 * to greedy nearest neighbour (the reference measured in the same run) and
 * to the lower bound of any order, and the CPU time of the ordering.
 *
 *   order_bench [PLAN...]   (default: ds1 ds2 ds3, default rig) */
#include <stdio.h>
#include <time.h>

#include "planner/planner.h"

static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    static const char *defaults[] = {"ds1", "ds2", "ds3"};
    const char **plans = argc > 1 ? (const char **)argv + 1 : defaults;
    int np = argc > 1 ? argc - 1 : 3;
    static const enum plan_order_mode modes[] = {PLAN_ORDER_GREEDY, PLAN_ORDER_TRAVEL,
                                                 PLAN_ORDER_AS_WRITTEN, PLAN_ORDER_PROGRESSIVE};
    struct rig_profile rig;
    rig_profile_default(&rig);
    printf("%-6s %-12s %6s %9s %9s %9s %9s %9s\n", "plan", "order", "points", "move_s",
           "total_s", "/greedy", "/bound", "cpu_s");
    for (int p = 0; p < np; p++) {
        struct plan *plan;
        struct gonio_err err = {0};
        if (plan_load(plans[p], &rig, &plan, &err) < 0) {
            fprintf(stderr, "order_bench: %s\n", err.msg);
            return 1;
        }
        double t0 = cpu_s();
        double lb = plan_move_lower_bound(plan, &rig);
        double lb_cpu = cpu_s() - t0, greedy_move = 0;
        for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
            t0 = cpu_s();
            if (plan_order(plan, modes[m], &rig) < 0)
                return 1;
            double cpu = cpu_s() - t0;
            struct plan_estimate est;
            plan_estimate(plan, &rig, &est);
            if (modes[m] == PLAN_ORDER_GREEDY)
                greedy_move = est.move_s;
            printf("%-6s %-12s %6zu %9.1f %9.1f %9.3f %9.3f %9.3f\n", plan_name(plan),
                   plan_order_name(modes[m]), plan_count(plan), est.move_s, est.total_s,
                   est.move_s / greedy_move, est.move_s / lb, cpu);
        }
        printf("%-6s %-12s %6s %9.1f %9s %9.3f %9s %9.3f\n", plan_name(plan), "lower-bound",
               "", lb, "", lb / greedy_move, "", lb_cpu);
        plan_free(plan);
    }
    return 0;
}
