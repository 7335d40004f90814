/* The premise checks a capture can make after its last point
 * (docs/checks.md): their names as operators give them (gonio capture
 * --check, goniod's request field check, request.json), and the axis each
 * needs of the rig profile. One table for every host, so that the names,
 * the refusals and their wording are the same offline and through goniod. */
#ifndef GONIO_CAPTURE_CHECKS_H
#define GONIO_CAPTURE_CHECKS_H

#include <stddef.h>

#include "common/err.h"
#include "rig/rig.h"

#define CAPTURE_CHECK_ISOTROPY 0x1u     /* "isotropy": capture/isotropy_check.h */
#define CAPTURE_CHECK_OUT_OF_PLANE 0x2u /* "out-of-plane": capture/oop_check.h */

/* A check's name, or several separated by commas, OR'd into *mask (so
 * that a repeated option adds). -GONIO_EUSAGE naming WHAT (the option or
 * field: "--check", "check"), the value and the checks there are. */
int capture_checks_parse(const char *what, const char *text, unsigned *mask,
                         struct gonio_err *err);

/* mask's names, comma-separated in the table's order ("" for none), into
 * buf; returns buf. */
const char *capture_checks_text(unsigned mask, char *buf, size_t size);

/* Refuse a check of mask that the rig profile (named rig_name, as the
 * operator named it) cannot make: -GONIO_EUSAGE naming WHAT, the check and
 * the axis the profile lacks. */
int capture_checks_rig(const char *what, unsigned mask, const struct rig_profile *rig,
                       const char *rig_name, struct gonio_err *err);

#endif
