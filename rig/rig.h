/* Rig profile: what the planner needs to know about a rig's motion (axis
 * speeds, accelerations and limits, settle and integration times, blind
 * zone). Loaded from configs/rigs/NAME.yaml (docs/plans.md lists the keys).
 * The capture engine and the simulator read the same profile, so the plan's
 * time estimate and the simulated clock agree. */
#ifndef GONIO_RIG_RIG_H
#define GONIO_RIG_RIG_H

#include "common/err.h"

/* One motor axis: degrees, degrees/s, degrees/s^2. */
struct rig_axis {
    double speed, accel;
    double min, max;
};

/* How the rig's drives come to rest (mechanics), for the drivers: a move is
 * done when the drive rests within in_position_deg of the target; one
 * resting outside is re-commanded up to move_retries times, approaching
 * from the reference side (approach: +1 from below, -1 from above) through
 * a point backlash_deg beyond the target when the rig has backlash. The
 * plan's estimate counts the approach legs (rig_move_time_backlash), not
 * re-commands. */
struct rig_mechanics {
    double in_position_deg;
    double backlash_deg; /* 0: direct approach from either side */
    int approach;        /* +1 positive (from below), -1 negative */
    int move_retries;
};

/* The absolute method's geometry (beam, optional; docs/plans.md): the
 * detector's aperture of area aperture_mm2 at distance_mm from the sample's
 * centre subtends omega = A / R^2, each with its standard uncertainty
 * (the tolerances); the arm faces the source at arm_deg; the beam is read
 * through an attenuator (a neutral density filter) of certified
 * transmittance attenuation (1: none) with its standard uncertainty. */
struct rig_beam {
    int on;
    double aperture_mm2, aperture_u_mm2;
    double distance_mm, distance_u_mm;
    double arm_deg;
    double attenuation, attenuation_u;
};

/* The solid angle A / R^2 (sr) and its relative standard uncertainty. */
double rig_beam_omega(const struct rig_beam *b, double *rel_u);

struct rig_profile {
    char name[64];
    struct rig_axis sample;  /* s = theta_i */
    struct rig_axis arm;     /* a = theta_i + theta_r, from the source */
    struct rig_axis azimuth; /* out-of-plane axis; used when out_of_plane */
    /* The sample's rotation about its own normal (axes.rotation, optional):
     * it turns an anisotropic sample's tangent against the plane of
     * incidence and leaves an isotropic one's readings alone. */
    struct rig_axis rotation;
    int has_rotation;
    int out_of_plane;
    double blind_deg;        /* detector within this of the source: unreachable */
    double settle_s;         /* wait after each move */
    double integration_s;    /* fixed integration (no noise in the scene) */
    double auto_min_s, auto_max_s; /* auto-exposure bounds */
    struct rig_mechanics mech;
    /* The detector has a shutter the dark frames close (shutter, default
     * true); without one the operator covers it when asked. */
    int shutter;
    /* The rig has a sample changer (sample_changer, default false): a
     * hardware rig's driver must wire its drive (goniod's
     * driver.slaves.sample_changer) or goniod refuses the profile. */
    int sample_changer;
    struct rig_beam beam;
};

/* The design's default profile (DESIGN.md section 9), without a file. */
void rig_profile_default(struct rig_profile *rig);

/* Load a profile: a path (contains '/' or ends in .yaml) or a bare name
 * resolved to <gonio_config_dir()>/rigs/NAME.yaml. Every value is
 * range-checked; unknown keys are errors. Returns 0, or -GONIO_EBADCONFIG /
 * -GONIO_ENOTFOUND with err = "path:line:col: key 'x': problem". */
int rig_profile_load(const char *path_or_name, struct rig_profile *rig, struct gonio_err *err);

#endif
