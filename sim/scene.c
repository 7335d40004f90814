#include "sim/scene.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "common/cfg.h"
#include "planner/rig.h"

static int copy_string(const struct cfg_doc *doc, const struct cfg_node *root, const char *key,
                       enum cfg_need need, char *out, size_t size, struct gonio_err *err)
{
    const char *v;
    int rc = cfg_string(doc, root, key, need, &v, err);
    if (rc <= 0)
        return rc;
    if (strlen(v) >= size)
        return cfg_error(doc, cfg_get(doc, root, key), key, err, "value longer than %zu characters",
                         size - 1);
    memcpy(out, v, strlen(v) + 1);
    return 1;
}

static int parse_effects(const struct cfg_doc *doc, const struct cfg_node *root,
                         struct sim_scene *scene, struct gonio_err *err)
{
    const struct cfg_node *effects;
    int rc = cfg_seq(doc, root, "effects", CFG_OPTIONAL, &effects, err);
    if (rc < 0 || !effects)
        return rc < 0 ? rc : 0;
    size_t n = cfg_seq_len(doc, effects);
    for (size_t i = 0; i < n; i++) {
        const struct cfg_node *item = cfg_seq_item(doc, effects, i);
        const struct cfg_node *name_node = cfg_is_map(doc, item) ? cfg_get(doc, item, "name") : item;
        const char *name = "?";
        if (name_node && cfg_is_scalar(doc, name_node))
            cfg_node_string(doc, name_node, "effects", &name, NULL);
        return cfg_error(doc, item, "effects", err,
                         "unknown effect '%s' (this build simulates no effects yet: use an "
                         "empty list)",
                         name);
    }
    scene->n_effects = (int)n;
    return 0;
}

int sim_scene_load(const char *path_or_name, struct sim_scene *scene, struct gonio_err *err)
{
    static const char *const keys[] = {"name", "description", "material", "rig", "detector",
                                       "seed", "effects", NULL};
    static const char *const detectors[] = {"rgb", "spectral", NULL};

    memset(scene, 0, sizeof *scene);
    if (plan_resolve_path(path_or_name, "scenes", scene->path, sizeof scene->path) < 0)
        return gonio_err_set(err, ENAMETOOLONG, "%s: scene path too long", path_or_name);
    struct cfg_doc *doc;
    int rc = cfg_load(scene->path, &doc, err);
    if (rc < 0)
        return rc;
    const struct cfg_node *root = cfg_root(doc);
    long seed = 1;
    int detector = SIM_DETECTOR_RGB;
    snprintf(scene->rig, sizeof scene->rig, "default");
    if ((rc = cfg_check_keys(doc, root, "scene", keys, err)) < 0 ||
        (rc = copy_string(doc, root, "name", CFG_OPTIONAL, scene->name, sizeof scene->name, err)) < 0 ||
        (rc = copy_string(doc, root, "material", CFG_REQUIRED, scene->material,
                          sizeof scene->material, err)) < 0 ||
        (rc = copy_string(doc, root, "rig", CFG_OPTIONAL, scene->rig, sizeof scene->rig, err)) < 0 ||
        (rc = cfg_enum(doc, root, "detector", CFG_OPTIONAL, detectors, &detector, err)) < 0 ||
        (rc = cfg_int(doc, root, "seed", CFG_OPTIONAL, 0, 4294967295L, &seed, err)) < 0 ||
        (rc = parse_effects(doc, root, scene, err)) < 0) {
        cfg_free(doc);
        return rc;
    }
    if (detector == SIM_DETECTOR_SPECTRAL) {
        rc = cfg_error(doc, cfg_get(doc, root, "detector"), "detector", err,
                       "spectral detection is not simulated yet (use 'rgb')");
        cfg_free(doc);
        return rc;
    }
    if (!scene->name[0]) {
        const char *base = strrchr(scene->path, '/');
        base = base ? base + 1 : scene->path;
        size_t len = strcspn(base, ".");
        if (len >= sizeof scene->name)
            len = sizeof scene->name - 1;
        memcpy(scene->name, base, len);
        scene->name[len] = '\0';
    }
    scene->detector = (enum sim_detector_kind)detector;
    scene->seed = (unsigned long)seed;
    cfg_free(doc);
    return 0;
}
