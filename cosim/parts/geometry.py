"""Bending angle of the sheath from the end-effector position: the Python twin of
fmu/src/bowden_geometry.c (paper Sec. III, Eq. 4-14; derivation in fmu/README.md).

Frame: the actuator outlet A is the origin, the sheath leaves A along +y and enters the
end-effector C = (x, y, z) along +y; z is up. The workspace is the half-sphere |C| <= L, y >= 0
(Eq. 13). Both implementations are held to tests/fmu/geometry_vectors.json. The functions take
numpy arrays (broadcast) or floats.
"""

from __future__ import annotations

import numpy as np

# Tolerance on the workspace bound, as BOWDEN_GEOM_TOL_M in the C header. [m]
TOL_M = 1e-9


class WorkspaceError(ValueError):
    """A position lies outside the half-sphere |C| <= sheath_length, y >= 0."""


def _angle(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Angle between vectors along the last axis (Eq. 12), as atan2(|P x Q|, P.Q)."""
    cross = np.linalg.norm(np.cross(p, q), axis=-1)
    dot = np.sum(p * q, axis=-1)
    return np.arctan2(cross, dot)  # atan2(0, 0) = 0: a zero-length segment bends nothing


def in_workspace(x, y, z, length_m: float) -> np.ndarray:
    """True where (x, y, z) lies in the half-sphere of Eq. 13 (with TOL_M)."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    finite = np.isfinite(x) & np.isfinite(y) & np.isfinite(z)
    dist = np.sqrt(x * x + y * y + z * z)
    return finite & (dist <= length_m + TOL_M) & (y >= -TOL_M)


def bend_points(x, y, z, length_m: float, loop_routing: bool) -> np.ndarray:
    """The bend point B (free sag, Eq. 5-6) or loop crossing point B' (Eq. 8-9), shape (..., 3)."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    if loop_routing:
        ztop = np.sqrt(np.maximum(length_m**2 - x * x - y * y, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(ztop > 0.0, 0.5 * (1.0 - z / np.where(ztop > 0, ztop, 1.0)), 0.5)
        return np.stack([s * x, s * y, 0.5 * (z - ztop)], axis=-1)
    dist_sq = x * x + y * y + z * z
    dist = np.sqrt(dist_sq)
    a2 = 0.25 * length_m**2
    b2 = np.maximum(a2 - 0.25 * dist_sq, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        uz2 = np.where(dist > 0.0, (z / np.where(dist > 0, dist, 1.0)) ** 2, 0.0)
        denom = uz2 * b2 + (1.0 - uz2) * a2
        t = np.where(denom > 0.0, np.sqrt(a2 * b2 / np.where(denom > 0, denom, 1.0)), 0.0)
    return np.stack([0.5 * x, 0.5 * y, 0.5 * z - t], axis=-1)


def bending_angle(x, y, z, length_m: float = 1.0, loop_routing: bool = True):
    """Total bending angle phi [rad] of the sheath (Eq. 7 free sag, Eq. 11 with the loop).

    Raises WorkspaceError naming the allowed range if any position is outside the workspace,
    and ValueError for a non-positive length. Returns a float for scalar input.
    """
    if not np.isfinite(length_m) or length_m <= 0.0:
        raise ValueError(f"sheath_length = {length_m} m must be > 0")
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    ok = in_workspace(x, y, z, length_m)
    if not np.all(ok):
        bad = np.argwhere(~ok)[0]
        idx = tuple(bad) if x.ndim else ()
        raise WorkspaceError(
            f"position x, y, z = ({x[idx]}, {y[idx]}, {z[idx]}) m is outside the reachable "
            f"workspace: allowed is sqrt(x^2 + y^2 + z^2) <= sheath_length = {length_m} m and "
            "y >= 0"
        )
    c = np.stack([x, y, z], axis=-1)
    b = bend_points(x, y, z, length_m, loop_routing)
    axis_y = np.broadcast_to(np.array([0.0, 1.0, 0.0]), c.shape)
    ab, bc = b, c - b
    if loop_routing:
        # the loop turns the long way round between AB' and B'C (Eq. 10-11)
        phi = _angle(axis_y, ab) + (2.0 * np.pi - _angle(ab, bc)) + _angle(bc, axis_y)
    else:
        phi = _angle(axis_y, ab) + _angle(ab, bc) + _angle(bc, axis_y)
    return float(phi) if phi.ndim == 0 else phi


def hemisphere_grid(length_m: float = 1.0, n: int = 41) -> tuple[np.ndarray, ...]:
    """Points of an n x n x n grid over the cube [-L, L] x [0, L] x [-L, L] that lie in the
    half-sphere workspace (paper Fig. 8), as flat arrays x, y, z."""
    xs = np.linspace(-length_m, length_m, n)
    ys = np.linspace(0.0, length_m, (n + 1) // 2)
    gx, gy, gz = np.meshgrid(xs, ys, xs, indexing="ij")
    keep = gx**2 + gy**2 + gz**2 <= length_m**2
    return gx[keep], gy[keep], gz[keep]
