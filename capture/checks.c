/* The premise checks' names and the axes they need (capture/checks.h). */
#include "capture/checks.h"

#include <stdio.h>
#include <string.h>

static const struct {
    unsigned bit;
    const char *name;
    /* what the rig must have, and what it is for */
    const char *axis, *purpose;
} checks[] = {
    {CAPTURE_CHECK_ISOTROPY, "isotropy", "rotation axis (axes.rotation)",
     "to turn the sample about its normal; use a rig profile with one, such as 'rotating'"},
    {CAPTURE_CHECK_OUT_OF_PLANE, "out-of-plane", "azimuth axis (out_of_plane, axes.azimuth)",
     "to take the detector out of the plane of incidence; use a rig profile with one, such "
     "as 'default' or 'rotating'"},
};

#define N_CHECKS (sizeof checks / sizeof *checks)

int capture_checks_parse(const char *what, const char *text, unsigned *mask,
                         struct gonio_err *err)
{
    for (const char *s = text;;) {
        size_t n = strcspn(s, ",");
        size_t k = 0;
        while (k < N_CHECKS && !(strlen(checks[k].name) == n && !strncmp(s, checks[k].name, n)))
            k++;
        if (k == N_CHECKS)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s '%.60s': no such check (the checks are 'isotropy' and "
                                 "'out-of-plane', or both separated by a comma)",
                                 what, text);
        *mask |= checks[k].bit;
        if (!s[n])
            return 0;
        s += n + 1;
    }
}

const char *capture_checks_text(unsigned mask, char *buf, size_t size)
{
    size_t len = 0;
    if (size)
        buf[0] = '\0';
    for (size_t k = 0; k < N_CHECKS && len < size; k++)
        if (mask & checks[k].bit)
            len += (size_t)snprintf(buf + len, size - len, "%s%s", len ? "," : "",
                                    checks[k].name);
    return buf;
}

int capture_checks_rig(const char *what, unsigned mask, const struct rig_profile *rig,
                       const char *rig_name, struct gonio_err *err)
{
    for (size_t k = 0; k < N_CHECKS; k++) {
        if (!(mask & checks[k].bit))
            continue;
        int has = checks[k].bit == CAPTURE_CHECK_ISOTROPY ? rig->has_rotation : rig->out_of_plane;
        if (!has)
            return gonio_err_set(err, GONIO_EUSAGE, "%s %s: rig '%s' has no %s %s", what,
                                 checks[k].name, rig_name, checks[k].axis, checks[k].purpose);
    }
    return 0;
}
