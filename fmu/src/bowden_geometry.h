/* Bending angle of the sheath from the end-effector position (paper Sec. III, Eq. 4-14).
 *
 * Frame: the actuator outlet A is the origin, the sheath leaves A along +y (O = (0,-1,0)) and
 * enters the end-effector C = (x, y, z) along +y (E = C + (0,1,0)); z is up. The derivation,
 * including the parts of Eq. 4-14 lost in the paper's text, is in fmu/README.md. The Python
 * twin is cosim/parts/geometry.py; both are held to tests/fmu/geometry_vectors.json.
 */
#ifndef BOWDEN_GEOMETRY_H
#define BOWDEN_GEOMETRY_H

typedef enum {
    BOWDEN_GEOM_OK = 0,
    BOWDEN_GEOM_NOT_FINITE = 1,   /* x, y, z or L is NaN or infinite */
    BOWDEN_GEOM_BAD_LENGTH = 2,   /* L <= 0 */
    BOWDEN_GEOM_OUTSIDE = 3       /* C outside the half-sphere |C| <= L, y >= 0 (Eq. 13) */
} BowdenGeomStatus;

/* Tolerance on the workspace bound, so that a position computed as exactly L away (or y = 0)
   with rounding error is still accepted. [m] */
#define BOWDEN_GEOM_TOL_M 1e-9

/* Total bending angle phi [rad] of a sheath of length length_m from the outlet to (x, y, z) [m],
 * free sagging (loop_routing = 0, Eq. 4-7) or with one loop (loop_routing != 0, Eq. 8-11).
 * Writes *phi_rad only when it returns BOWDEN_GEOM_OK. */
BowdenGeomStatus bowden_geometry_phi(double x_m, double y_m, double z_m, double length_m,
                                     int loop_routing, double *phi_rad);

#endif /* BOWDEN_GEOMETRY_H */
