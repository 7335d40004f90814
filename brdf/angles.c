#include "brdf/angles.h"

#include <math.h>

/* Below this sin(theta_h) the half vector is the normal and phi_h is taken
 * as 0: taking it from atan2 of rounding noise would turn phi_d by up to
 * 90 degrees at the exact mirror pairs every DS plan contains. */
#define PHI_H_EPS 1e-12

static void normalise(double v[3])
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0) {
        v[0] /= n;
        v[1] /= n;
        v[2] /= n;
    }
}

void brdf_pair_from_dirs(const double wi_in[3], const double wo_in[3], struct brdf_pair *p)
{
    for (int k = 0; k < 3; k++) {
        p->wi[k] = wi_in[k];
        p->wo[k] = wo_in[k];
    }
    normalise(p->wi);
    normalise(p->wo);

    double h[3] = {p->wi[0] + p->wo[0], p->wi[1] + p->wo[1], p->wi[2] + p->wo[2]};
    if (h[0] * h[0] + h[1] * h[1] + h[2] * h[2] < 1e-300) {
        h[0] = h[1] = 0; /* opposite directions: no half vector; use the normal */
        h[2] = 1;
    }
    normalise(h);
    /* atan2 of the transverse length is exact at theta_h = 0, where acos(h.z)
     * would return ~1e-8 from rounding in the normalisation. */
    double sin_th = hypot(h[0], h[1]);
    double th = atan2(sin_th, h[2]);
    double ph = sin_th < PHI_H_EPS ? 0.0 : atan2(h[1], h[0]);

    /* d = rotate_y(rotate_z(wi, -ph), -th) */
    double cp = cos(-ph), sp = sin(-ph);
    double t[3] = {p->wi[0] * cp - p->wi[1] * sp, p->wi[0] * sp + p->wi[1] * cp, p->wi[2]};
    double ct = cos(-th), st = sin(-th);
    double d[3] = {t[0] * ct + t[2] * st, t[1], -t[0] * st + t[2] * ct};

    p->theta_h = th;
    p->theta_d = atan2(hypot(d[0], d[1]), d[2]);
    p->phi_d = atan2(d[1], d[0]);
}

void brdf_pair_rotate(struct brdf_pair *p, double rotation_deg)
{
    if (rotation_deg == 0.0)
        return;
    double c = cos(rotation_deg * BRDF_DEG), s = sin(rotation_deg * BRDF_DEG);
    double *w[2] = {p->wi, p->wo};
    for (int k = 0; k < 2; k++) {
        double x = w[k][0], y = w[k][1];
        w[k][0] = c * x + s * y;
        w[k][1] = -s * x + c * y;
    }
}

void brdf_pair_inplane(double theta_i_deg, double theta_r_deg, struct brdf_pair *p)
{
    double ti = theta_i_deg * BRDF_DEG, tr = theta_r_deg * BRDF_DEG;
    const double wi[3] = {sin(ti), 0.0, cos(ti)};
    const double wo[3] = {-sin(tr), 0.0, cos(tr)};
    brdf_pair_from_dirs(wi, wo, p);
}

void brdf_pair_spherical(double theta_i_deg, double phi_i_deg, double theta_o_deg,
                         double phi_o_deg, struct brdf_pair *p)
{
    double ti = theta_i_deg * BRDF_DEG, pi_ = phi_i_deg * BRDF_DEG;
    double to = theta_o_deg * BRDF_DEG, po = phi_o_deg * BRDF_DEG;
    const double wi[3] = {sin(ti) * cos(pi_), sin(ti) * sin(pi_), cos(ti)};
    const double wo[3] = {sin(to) * cos(po), sin(to) * sin(po), cos(to)};
    brdf_pair_from_dirs(wi, wo, p);
}

void brdf_pair_from_hd(double theta_h, double theta_d, double phi_d, struct brdf_pair *p)
{
    const struct brdf_angle h = {theta_h, cos(theta_h), sin(theta_h)};
    const struct brdf_angle d = {theta_d, cos(theta_d), sin(theta_d)};
    const struct brdf_angle f = {phi_d, cos(phi_d), sin(phi_d)};
    brdf_pair_from_hd_cs(&h, &d, &f, p);
}

void brdf_pair_from_hd_cs(const struct brdf_angle *theta_h, const struct brdf_angle *theta_d,
                          const struct brdf_angle *phi_d, struct brdf_pair *p)
{
    /* In the half-vector frame wi is the difference vector d and wo its
     * mirror image about the half vector; rotate both by theta_h about y. */
    double d[3] = {theta_d->s * phi_d->c, theta_d->s * phi_d->s, theta_d->c};
    double ch = theta_h->c, sh = theta_h->s;
    p->wi[0] = d[0] * ch + d[2] * sh;
    p->wi[1] = d[1];
    p->wi[2] = -d[0] * sh + d[2] * ch;
    p->wo[0] = -d[0] * ch + d[2] * sh;
    p->wo[1] = -d[1];
    p->wo[2] = d[0] * sh + d[2] * ch;
    p->theta_h = theta_h->rad;
    p->theta_d = theta_d->rad;
    p->phi_d = phi_d->rad;
}

double brdf_pair_theta_i_deg(const struct brdf_pair *p)
{
    return atan2(hypot(p->wi[0], p->wi[1]), p->wi[2]) / BRDF_DEG;
}

double brdf_pair_theta_o_deg(const struct brdf_pair *p)
{
    return atan2(hypot(p->wo[0], p->wo[1]), p->wo[2]) / BRDF_DEG;
}

int brdf_pair_to_inplane(const struct brdf_pair *p, double *theta_i_deg, double *theta_r_deg)
{
    if (fabs(p->wi[1]) > 1e-9 || fabs(p->wo[1]) > 1e-9)
        return -1;
    double ti = atan2(p->wi[0], p->wi[2]);
    double tr = atan2(-p->wo[0], p->wo[2]);
    /* theta_i >= 0 by convention: mirror the plane when the source is on -x. */
    if (ti < 0) {
        ti = -ti;
        tr = -tr;
    }
    *theta_i_deg = ti / BRDF_DEG;
    *theta_r_deg = tr / BRDF_DEG;
    return 0;
}

void brdf_inplane_to_axes(double theta_i_deg, double theta_r_deg, double *s_deg, double *a_deg)
{
    *s_deg = theta_i_deg;
    *a_deg = theta_i_deg + theta_r_deg;
}

void brdf_axes_to_inplane(double s_deg, double a_deg, double *theta_i_deg, double *theta_r_deg)
{
    *theta_i_deg = s_deg;
    *theta_r_deg = a_deg - s_deg;
}

int brdf_axes_in_blind_zone(double a_deg, double blind_deg)
{
    return fabs(a_deg) < blind_deg;
}
