/* gonio-sim's sample changer (slave MB_SLAVE_CHANGER, docs/protocol-modbus.md
 * "Sample changer"): a write of the target slot swaps what the simulated
 * rig measures, through the same mount the in-process rig's changer uses
 * (sim_rig_mount): slot 1 the standard, slot 2 a light trap. The swap is instantaneous in rig time, so the status
 * reads IN-POS at once; a master must still poll it, as a real changer is
 * BUSY while it swaps. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#include "sim/modbus_server_private.h"
#include "sim/standard_draw.h"

int msim_changer_new(msim *m, const brdf_material *sample, const struct sim_scene *scene,
                     struct gonio_err *err)
{
    struct msim_changer *c = &m->changer;
    c->sample = sample;
    if (scene)
        c->scene = *scene;
    c->has_scene = scene != NULL;
    if (!m->profile->sample_changer)
        return 0;
    c->map = modbus_mapping_new_start_address(0, 0, 0, 0, 0, MB_CH_NREGS, 0, 0);
    if (!c->map)
        return gonio_err_set(err, ENOMEM, "gonio-sim: out of memory");
    struct sim_scene none = {0};
    if (!(c->standard = sim_material_open(scene ? scene : &none, MSIM_CHANGER_STANDARD, err)) ||
        !(c->trap = sim_material_open(scene ? scene : &none, MSIM_CHANGER_TRAP, err)))
        return -abs(err && err->code ? err->code : GONIO_EBADCONFIG);
    put32(c->map->tab_registers, MB_CH_STATUS, MB_CH_IN_POS);
    return 0;
}

void msim_changer_free(msim *m)
{
    modbus_mapping_free(m->changer.map);
    brdf_material_free(m->changer.standard);
    brdf_material_free(m->changer.trap);
}

void msim_changer_target(msim *m)
{
    struct msim_changer *c = &m->changer;
    uint16_t *r = c->map->tab_registers;
    uint32_t slot = get32(r, MB_CH_TARGET);
    if (slot >= MB_CH_SLOTS) {
        put32(r, MB_CH_TARGET, get32(r, MB_CH_AT)); /* refused: stays where it is */
        return;
    }
    struct gonio_err err = {0};
    const brdf_material *mat = slot == MB_CH_SLOT_STANDARD ? c->standard
                               : slot == MB_CH_SLOT_TRAP   ? c->trap
                                                           : c->sample;
    if (sim_rig_mount(m->rig, mat, c->has_scene ? &c->scene : NULL, &err) < 0) {
        fprintf(stderr, "gonio-sim: sample changer: %s\n", err.msg);
        return;
    }
    c->moves[slot]++;
    put32(r, MB_CH_AT, slot);
}
