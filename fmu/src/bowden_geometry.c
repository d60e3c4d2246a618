/* Bending angle of the sheath from the end-effector position; see bowden_geometry.h and the
 * derivation in fmu/README.md. */
#include "bowden_geometry.h"

#include <math.h>

#define TWO_PI 6.283185307179586476925286766559

typedef struct {
    double x, y, z;
} Vec3;

static Vec3 vec_sub(Vec3 a, Vec3 b)
{
    Vec3 r = {a.x - b.x, a.y - b.y, a.z - b.z};
    return r;
}

/* Angle between two vectors (Eq. 12). atan2(|P x Q|, P.Q) rather than acos of the normalised
   dot product keeps full precision near 0 and pi; a zero-length segment bends nothing. */
static double vec_angle(Vec3 p, Vec3 q)
{
    double cx = p.y * q.z - p.z * q.y;
    double cy = p.z * q.x - p.x * q.z;
    double cz = p.x * q.y - p.y * q.x;
    double cross = sqrt(cx * cx + cy * cy + cz * cz);
    double dot = p.x * q.x + p.y * q.y + p.z * q.z;
    if (cross == 0.0 && dot == 0.0) {
        return 0.0;
    }
    return atan2(cross, dot);
}

BowdenGeomStatus bowden_geometry_phi(double x_m, double y_m, double z_m, double length_m,
                                     int loop_routing, double *phi_rad)
{
    const Vec3 axis_y = {0.0, 1.0, 0.0}; /* OA and CE (Eq. 4) */
    const Vec3 c = {x_m, y_m, z_m};
    double dist_sq, half_len;
    Vec3 b, ab, bc;

    if (!isfinite(x_m) || !isfinite(y_m) || !isfinite(z_m) || !isfinite(length_m)) {
        return BOWDEN_GEOM_NOT_FINITE;
    }
    if (length_m <= 0.0) {
        return BOWDEN_GEOM_BAD_LENGTH;
    }
    dist_sq = x_m * x_m + y_m * y_m + z_m * z_m;
    if (sqrt(dist_sq) > length_m + BOWDEN_GEOM_TOL_M || y_m < -BOWDEN_GEOM_TOL_M) {
        return BOWDEN_GEOM_OUTSIDE;
    }
    half_len = 0.5 * length_m;

    if (!loop_routing) {
        /* Eq. 5-6: B above the midpoint M of AC in x, y, |AB| + |BC| = L, sagging below M.
           B lies on the prolate spheroid with foci A, C and semi-axes a = L/2,
           b = sqrt(a^2 - |AC|^2/4); on the vertical through M it is t below M with
           1/t^2 = u_z^2/a^2 + (1 - u_z^2)/b^2, u = AC/|AC| (README, "Free sag"). */
        double dist = sqrt(dist_sq);
        double a2 = half_len * half_len;
        double b2 = a2 - 0.25 * dist_sq;
        double uz2 = dist > 0.0 ? (z_m / dist) * (z_m / dist) : 0.0;
        double denom, t;
        if (b2 < 0.0) {
            b2 = 0.0; /* |AC| = L within BOWDEN_GEOM_TOL_M: the sheath is straight */
        }
        denom = uz2 * b2 + (1.0 - uz2) * a2;
        t = denom > 0.0 ? sqrt(a2 * b2 / denom) : 0.0;
        b.x = 0.5 * x_m;
        b.y = 0.5 * y_m;
        b.z = 0.5 * z_m - t;
        ab = b;
        bc = vec_sub(c, b);
        /* Eq. 7 */
        *phi_rad = vec_angle(axis_y, ab) + vec_angle(ab, bc) + vec_angle(bc, axis_y);
    } else {
        /* Eq. 8-9 (linear approximation of the crossing point B' of the loop):
           z_m = sqrt(L^2 - x^2 - y^2) is the highest reachable z above (x, y);
           s = (1 - z/z_m)/2 runs from 0 (C at the top) to 1 (C at the bottom);
           B' = (s x, s y, (z - z_m)/2), which lies below both A and C. */
        double ztop_sq = length_m * length_m - x_m * x_m - y_m * y_m;
        double ztop = ztop_sq > 0.0 ? sqrt(ztop_sq) : 0.0;
        double s = ztop > 0.0 ? 0.5 * (1.0 - z_m / ztop) : 0.5;
        b.x = s * x_m;
        b.y = s * y_m;
        b.z = 0.5 * (z_m - ztop);
        ab = b;
        bc = vec_sub(c, b);
        /* Eq. 10-11: the loop turns the long way round between AB' and B'C, so the
           curvature keeps one sign and the in-plane total is exactly 2 pi. */
        *phi_rad = vec_angle(axis_y, ab) + (TWO_PI - vec_angle(ab, bc)) + vec_angle(bc, axis_y);
    }
    return BOWDEN_GEOM_OK;
}
