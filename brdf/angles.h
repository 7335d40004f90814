/* Geometry conventions (design brief section 2).
 *
 * Directions are unit vectors pointing away from the surface, normal on +z.
 * In-plane: wi = (sin ti, 0, cos ti), wo = (-sin tr, 0, cos tr), so that
 * theta_r = theta_i is the mirror direction and negative theta_r is
 * back-scatter. Isotropic materials are compared in Rusinkiewicz
 * half/difference coordinates with phi_h = 0. Angles are in degrees at every
 * interface except the half/difference triple, which is in radians as in
 * the MERL layout. */
#ifndef GONIO_BRDF_ANGLES_H
#define GONIO_BRDF_ANGLES_H

/* One direction pair with its half/difference coordinates, computed once so
 * that every material and metric sees the same (and the exact-mirror phi_h
 * rule is applied in one place). */
struct brdf_pair {
    double wi[3], wo[3];
    double theta_h, theta_d, phi_d; /* radians; phi_d in (-pi, pi] */
};

/* Build a pair from in-plane angles (degrees, theta_r signed). */
void brdf_pair_inplane(double theta_i_deg, double theta_r_deg, struct brdf_pair *p);

/* Build a pair from spherical angles (degrees): the general out-of-plane case. */
void brdf_pair_spherical(double theta_i_deg, double phi_i_deg, double theta_o_deg,
                         double phi_o_deg, struct brdf_pair *p);

/* Build a pair from direction vectors (need not be normalised). */
void brdf_pair_from_dirs(const double wi[3], const double wo[3], struct brdf_pair *p);

/* Build a pair from half/difference angles (radians), phi_h = 0. */
void brdf_pair_from_hd(double theta_h, double theta_d, double phi_d, struct brdf_pair *p);

/* An angle with its cosine and sine, as a grid's tables hold them. */
struct brdf_angle {
    double rad, c, s;
};

/* brdf_pair_from_hd with the cosines and sines given: the same arithmetic,
 * so the same pair to the last bit, without the trigonometry (the
 * reference domains build a million pairs from 90 + 90 + 180 angles). */
void brdf_pair_from_hd_cs(const struct brdf_angle *theta_h, const struct brdf_angle *theta_d,
                          const struct brdf_angle *phi_d, struct brdf_pair *p);

/* A lab-frame pair as a sample turned rotation_deg about its normal sees
 * it: wi and wo turned by -rotation_deg about z; theta_h, theta_d and
 * phi_d, which a turn about the normal leaves alone, are kept to the last
 * bit (an isotropic material reads the same value, the exact mirror's
 * phi_h = 0 rule included). */
void brdf_pair_rotate(struct brdf_pair *p, double rotation_deg);

/* Polar angles of the two directions, degrees. */
double brdf_pair_theta_i_deg(const struct brdf_pair *p);
double brdf_pair_theta_o_deg(const struct brdf_pair *p);

/* In-plane angles of a pair lying in the x-z plane (|y| below 1e-9). Returns
 * 0, or -1 when the pair is out of plane. */
int brdf_pair_to_inplane(const struct brdf_pair *p, double *theta_i_deg, double *theta_r_deg);

/* Rig axes of a two-axis rig with a fixed source: sample rotation
 * s = theta_i, detector arm angle from the source a = theta_i + theta_r. */
void brdf_inplane_to_axes(double theta_i_deg, double theta_r_deg, double *s_deg, double *a_deg);
void brdf_axes_to_inplane(double s_deg, double a_deg, double *theta_i_deg, double *theta_r_deg);

/* True when the detector arm would sit within blind_deg of the source. */
int brdf_axes_in_blind_zone(double a_deg, double blind_deg);

#define BRDF_DEG (3.14159265358979323846 / 180.0)

#endif
