/* A calibration for tests that capture on a realistic scene (lab,
 * bad-day), whose detector gives counts: the chain an operator runs,
 * `gonio calibrate dark` then `gonio calibrate reference`, offline, once,
 * into a folder of the test's own. A capture then names it through
 * capture_config.calibrations (and .calibration NULL: the newest valid
 * one for its rig and detector). The real command is run rather than its
 * library calls, so that the tests take the calibration exactly as the
 * CLI, the study and the scripts do. */
#ifndef GONIO_TEST_CAL_H
#define GONIO_TEST_CAL_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Calibrate scene's detector (on rig, NULL: the scene's) into root for
 * plan's points: a dark, then a reference read twice at each point. Its
 * id into id (may be NULL). 0, or -1 with the command's error printed. */
static inline int gonio_test_calibrate(const char *root, const char *scene, const char *rig,
                                       const char *plan, char *id, size_t size)
{
    const char *bin = getenv("GONIO_BIN");
    char rig_opt[1200] = "", cmd[4096], line[256] = "";
    if (rig)
        snprintf(rig_opt, sizeof rig_opt, " --rig '%s'", rig);
    const char *what[2] = {"dark", "reference"};
    for (int k = 0; k < 2; k++) {
        snprintf(cmd, sizeof cmd,
                 "'%s/gonio' calibrate %s --offline --scene '%s'%s --out '%s'%s%s%s",
                 bin ? bin : "build/bin", what[k], scene, rig_opt, root,
                 k ? " --repeats 2 --plan '" : "", k ? plan : "", k ? "'" : "");
        FILE *p = popen(cmd, "r");
        if (!p)
            return -1;
        /* stdout is the id; the command's errors go to the test's stderr */
        if (!fgets(line, sizeof line, p))
            line[0] = '\0';
        if (pclose(p) != 0) {
            fprintf(stderr, "failed: %s\n", cmd);
            return -1;
        }
        if (k == 1 && id) {
            snprintf(id, size, "%s", line);
            id[strcspn(id, "\n")] = '\0';
        }
    }
    return 0;
}

/* The other way to BRDF on a noisy scene, which no shipped realistic
 * scene takes: lab's light, noise and mechanics read by the simulator's
 * ideal meter (sim/exposure.h), no ADC, so the detector reports BRDF and
 * chooses each reading's integration before it reads. For tests of what
 * a detector choosing its own integration does to estimates, ETAs and
 * budgets. Written as dir/metered.yaml; its path into path. */
static inline void gonio_test_metered_scene(const char *dir, char *path, size_t size)
{
    snprintf(path, size, "%s/metered.yaml", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        return;
    fputs("name: metered\nmaterial: default\nrig: default\n"
          "detector: {kind: rgb, responsivity: 1.0e6, target_e: 30000}\n"
          "seed: 1\neffects:\n"
          "  - {name: lamp_drift, sigma: 0.005, tau_s: 1800}\n"
          "  - {name: stray_light, floor: 0.0005}\n"
          "  - {name: dark, rate_e_per_s: 500}\n"
          "  - {name: shot_noise}\n"
          "  - {name: read_noise, sigma_e: 12}\n"
          "  - {name: saturation, full_well_e: 100000}\n"
          "  - {name: jitter, sigma_deg: 0.02}\n"
          "  - {name: backlash, deg: 0.05, axes: [sample, arm]}\n",
          f);
    fclose(f);
}

#endif
