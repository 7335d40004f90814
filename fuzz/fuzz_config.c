/* goniod's configuration file (daemon/config.h): YAML from the operator. */
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "daemon/config.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("goniod.yaml", data, size);
    struct goniod_config cfg;
    struct gonio_err err = {0};
    if (goniod_config_load(path, &cfg, &err) < 0) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    /* What `goniod --check` prints is a configuration goniod accepts, and
     * it means the same. */
    char again[PATH_MAX + 16];
    snprintf(again, sizeof again, "%s/check.yaml", fuzz_dir());
    fuzz_file("check.yaml", NULL, 0);
    FILE *f = fopen(again, "w");
    FUZZ_CHECK(f);
    goniod_config_print(f, &cfg);
    FUZZ_CHECK(fclose(f) == 0);
    struct goniod_config cfg2;
    int rc = goniod_config_load(again, &cfg2, &err);
    if (rc < 0)
        fprintf(stderr, "reloading the printed config: %s\n", err.msg);
    FUZZ_CHECK(rc == 0);
    FUZZ_CHECK(cfg.driver == cfg2.driver && !strcmp(cfg.rig, cfg2.rig) &&
               !strcmp(cfg.capture_root, cfg2.capture_root) &&
               !strcmp(cfg.socket_path, cfg2.socket_path));
    return 0;
}
