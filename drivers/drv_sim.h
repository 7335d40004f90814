/* Constructors of the in-process simulator backend: devices that drive a
 * sim_rig directly, with no protocol in between. */
#ifndef GONIO_DRIVERS_DRV_SIM_H
#define GONIO_DRIVERS_DRV_SIM_H

#include "drivers/drivers.h"
#include "sim/sim.h"

/* The rig must outlive the devices. An axis comes to rest with the
 * mechanics of the rig's profile (drivers.h, struct drv_axis_mechanics),
 * as a Modbus drive does: the simulated drive reports no IN-POS, so its
 * band decides; a scene's stall or alarm is reset and the move retried. */
drv_axis *drv_axis_new_sim(sim_rig *rig, enum sim_axis_id axis);
drv_detector *drv_detector_new_sim(sim_rig *rig);
drv_clock *drv_clock_new_sim(sim_rig *rig);

#endif
