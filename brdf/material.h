/* Materials behind one interface: a ground truth (NBRDF network, MERL table,
 * published ABC or shifted-gamma fit, the embedded default) or a fitted
 * model all answer "what is the RGB BRDF for these direction pairs".
 *
 * Values are linear RGB in 1/sr, cosine not included. A pair for which the
 * material has no data (a MERL cell marked unmeasured) comes back as NAN in
 * all three channels, never as a negative reflectance. */
#ifndef GONIO_BRDF_MATERIAL_H
#define GONIO_BRDF_MATERIAL_H

#include <stddef.h>

#include "brdf/angles.h"
#include "common/err.h"

typedef struct brdf_material brdf_material;

/* Open a material by specification:
 *   nbrdf:NAME   NBRDF network <shared>/data/merl/nbrdf_f32/NAME.nbrdf
 *   merl:PATH    MERL .binary table
 *   abc:NAME     published ABC fit of a MERL material (Low et al. 2012)
 *   sgd:NAME     published shifted-gamma fit (Bagher et al. 2012)
 *   builtin:NAME a material embedded in the library (brdf/embedded.h)
 *   analytic:NAME an analytic material outside MERL (brdf/analytic.h), or
 *                one built from parameters, analytic:KIND?key=value&...
 *                (brdf/analytic_spec.h)
 *   standard:NAME a reflectance standard (brdf/standard.h), NAME a file or
 *                <config>/standards/NAME.yaml
 *   trap         a light trap: reflects nothing (the stray-light calibration)
 *   default      the embedded default (no shared data needed)
 * NAME may also be a path to a file of that kind. Errors name the spec, the
 * file and the problem. */
brdf_material *brdf_material_open(const char *spec, struct gonio_err *err);

/* Evaluate n pairs into rgb[3n]. Returns the number of pairs without data. */
size_t brdf_material_eval(const brdf_material *m, const struct brdf_pair *pairs, size_t n,
                          double *rgb);

/* 1 when the material is isotropic: its values do not change as the
 * sample turns about its normal (brdf_pair_rotate), as MERL tables and
 * the isotropic models assume; 0 for an anisotropic material. */
int brdf_material_isotropic(const brdf_material *m);

/* The specification the material was opened with (or the model's name). */
const char *brdf_material_name(const brdf_material *m);

void brdf_material_free(brdf_material *m);

/* The names `default` resolves to, and the list of embedded materials. */
const char *brdf_material_default_spec(void);

#endif
