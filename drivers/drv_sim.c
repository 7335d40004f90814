#include "drivers/drv_sim.h"

#include <stdlib.h>

#include "drivers/drivers_private.h"

struct sim_axis_priv {
    sim_rig *rig;
    enum sim_axis_id id;
};

static int sim_start_move(void *priv, double target_deg, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    return sim_rig_start_move(p->rig, p->id, target_deg, err);
}

static int sim_wait(void *priv, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    sim_rig_advance(p->rig, sim_rig_move_end(p->rig, p->id) - sim_rig_now(p->rig));
    return 0;
}

static int sim_position(void *priv, double *deg, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    *deg = sim_rig_position(p->rig, p->id);
    return 0;
}

static int sim_home(void *priv, struct gonio_err *err)
{
    struct sim_axis_priv *p = priv;
    int rc = sim_rig_start_move(p->rig, p->id, 0.0, err);
    return rc < 0 ? rc : sim_wait(priv, err);
}

static int sim_stop(void *priv, struct gonio_err *err)
{
    (void)err;
    struct sim_axis_priv *p = priv;
    sim_rig_stop(p->rig, p->id);
    return 0;
}

static const struct drv_axis_ops sim_axis_ops = {
    .name = "sim",
    .start_move = sim_start_move,
    .wait = sim_wait,
    .position = sim_position,
    .home = sim_home,
    .stop = sim_stop,
    .free_priv = free,
};

drv_axis *drv_axis_new_sim(sim_rig *rig, enum sim_axis_id axis)
{
    static const char *names[SIM_N_AXES] = {"sample", "arm", "azimuth"};
    struct sim_axis_priv *p = malloc(sizeof *p);
    if (!p)
        return NULL;
    p->rig = rig;
    p->id = axis;
    return drv_axis_alloc(&sim_axis_ops, p, names[axis]);
}

static int sim_acquire(void *priv, double integration_s, struct drv_reading *out,
                       struct gonio_err *err)
{
    out->integration_s = integration_s;
    out->flags = 0;
    return sim_rig_measure(priv, integration_s, out->rgb, err);
}

static const struct drv_detector_ops sim_detector_ops = {
    .name = "sim",
    .acquire = sim_acquire,
};

drv_detector *drv_detector_new_sim(sim_rig *rig)
{
    return drv_detector_alloc(&sim_detector_ops, rig);
}

static double sim_now(void *priv)
{
    return sim_rig_now(priv);
}

static int sim_sleep(void *priv, double seconds)
{
    sim_rig_advance(priv, seconds);
    return 0;
}

static const struct drv_clock_ops sim_clock_ops = {
    .name = "sim",
    .now = sim_now,
    .sleep = sim_sleep,
};

drv_clock *drv_clock_new_sim(sim_rig *rig)
{
    return drv_clock_alloc(&sim_clock_ops, rig);
}
