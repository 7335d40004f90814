/* The reference standard the simulator mounts as its sample (the material
 * `standard:NAME`, brdf/standard.h). By default the plaque is exactly its
 * certificate. A real plaque is not: its reflectance and shape lie within
 * the certificate's stated uncertainty, and a calibration that trusts the
 * certificate carries that one error into every value it reduces. A scene
 * naming the effect `standard_draw` mounts such a plaque, drawn once per
 * scene seed:
 *
 *   rho_true = (rho + u_rho z1) (1 + u_shape z2)      z1, z2 ~ N(0, 1)
 *
 * per channel and per wavelength of the certificate alike (one z1: the
 * certificate's u taken as fully correlated over the spectrum, as the
 * loader converts it to RGB), the shape's relative u as a scale of the
 * whole shape. The engine reduces against the certificate and never sees
 * the draw; tests compare against it through sim_standard_truth. */
#ifndef GONIO_SIM_STANDARD_DRAW_H
#define GONIO_SIM_STANDARD_DRAW_H

#include "brdf/material.h"
#include "brdf/standard.h"
#include "common/err.h"
#include "sim/scene.h"

/* The plaque scene mounts for standard NAME (a file or a name,
 * brdf_standard_load): its certificate, drawn as above when the scene
 * names standard_draw. 0, or the load's error. */
int sim_standard_truth(const struct sim_scene *scene, const char *name,
                       struct brdf_standard *out, struct gonio_err *err);

/* The material the simulator of scene measures for spec: spec as
 * brdf_material_open opens it, except that `standard:NAME` is the plaque
 * sim_standard_truth gives (its name stays spec). NULL with err. */
brdf_material *sim_material_open(const struct sim_scene *scene, const char *spec,
                                 struct gonio_err *err);

#endif
