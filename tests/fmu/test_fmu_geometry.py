"""The bending-angle geometry (paper Sec. III, Fig. 8): C (in the FMU) and Python twin held to
the shared vectors, and the properties the paper states."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cosim.parts.geometry import WorkspaceError, bending_angle, hemisphere_grid
from cosim.parts.plant import Plant

VECTORS = json.loads(Path(__file__).with_name("geometry_vectors.json").read_text())


def test_vectors_cover_both_routings_and_closed_forms():
    assert len(VECTORS) >= 50
    assert {v["loop_routing"] for v in VECTORS} == {True, False}
    assert sum("closed_form" in v for v in VECTORS) >= 8


@pytest.mark.parametrize("v", VECTORS, ids=lambda v: f"{v['x']:.2f},{v['y']:.2f},{v['z']:.2f}")
def test_python_twin_matches_vectors(v):
    phi = bending_angle(v["x"], v["y"], v["z"], v["L"], v["loop_routing"])
    assert phi == pytest.approx(v["phi_rad"], rel=1e-12, abs=1e-12)


def test_fmu_geometry_matches_vectors(fmu_path):
    """The C geometry, read back as the FMU's phi output, for every vector."""
    groups: dict[tuple, list] = {}
    for v in VECTORS:
        groups.setdefault((v["L"], v["loop_routing"]), []).append(v)
    for (length, loop), vectors in groups.items():
        first = vectors[0]
        with Plant(
            {"sheath_length": length, "loop_routing": loop},
            {"x": first["x"], "y": first["y"], "z": first["z"]},
            fmu_path=fmu_path,
        ) as plant:
            for v in vectors:
                plant.u[Plant.X], plant.u[Plant.Y], plant.u[Plant.Z] = v["x"], v["y"], v["z"]
                plant.step(1e-6)
                assert plant.y[Plant.PHI] == pytest.approx(v["phi_rad"], rel=1e-12, abs=1e-12), v


def test_loop_routing_keeps_two_pi_in_the_loops_plane():
    """Fig. 8 (b): phi = 2*pi everywhere inside the half-sphere on the plane x = 0."""
    ys, zs = np.meshgrid(np.linspace(0, 0.99, 60), np.linspace(-0.99, 0.99, 60))
    inside = ys**2 + zs**2 < 0.99**2
    phi = bending_angle(0.0, ys[inside], zs[inside], 1.0, True)
    assert np.allclose(phi, 2 * math.pi, atol=1e-12)


def test_loop_routing_error_is_largest_near_plus_minus_l_on_x():
    """Fig. 8 (b): 'the highest error at around (+-1000, 0, 0)'."""
    x, y, z = hemisphere_grid(1.0, 41)
    err = np.abs(bending_angle(x, y, z, 1.0, True) - 2 * math.pi)
    worst = np.argmax(err)
    assert abs(abs(x[worst]) - 1.0) < 0.1 and abs(y[worst]) < 0.15 and abs(z[worst]) < 0.3
    assert bending_angle(0.999, 0.0, 0.0, 1.0, True) == pytest.approx(3 * math.pi, abs=0.2)


def test_free_sag_zero_at_full_reach_and_growing_towards_the_actuator():
    """Fig. 8 (a): zero at (0, L, 0), increasing as the end-effector approaches the actuator."""
    ys = np.linspace(1.0, 0.01, 50)
    phi = bending_angle(np.zeros_like(ys), ys, np.zeros_like(ys), 1.0, False)
    assert phi[0] == pytest.approx(0.0, abs=1e-9)
    assert np.all(np.diff(phi) > 0)
    assert phi[-1] > 0.95 * 2 * math.pi


def test_loop_routing_spread_is_much_smaller_than_free_sag():
    x, y, z = hemisphere_grid(1.0, 41)
    free = bending_angle(x, y, z, 1.0, False)
    loop = bending_angle(x, y, z, 1.0, True)
    assert np.std(loop) < 0.5 * np.std(free)
    p5_95 = lambda a: np.percentile(a, 95) - np.percentile(a, 5)  # noqa: E731
    assert p5_95(loop) < 0.5 * p5_95(free)
    # error against the reference of Eq. 14 (0 free, 2*pi with loop), mean over the workspace
    assert np.mean(np.abs(loop - 2 * math.pi)) < 0.2 * np.mean(np.abs(free))


@pytest.mark.parametrize("pos", [(1.01, 0, 0), (0, -0.01, 0), (0, 0.8, 0.8), (np.nan, 0.5, 0)])
def test_twin_refuses_positions_outside_the_workspace(pos):
    with pytest.raises(WorkspaceError, match="sheath_length = 1.0 m and y >= 0"):
        bending_angle(*pos, 1.0, True)


def test_twin_refuses_bad_length():
    with pytest.raises(ValueError, match="sheath_length"):
        bending_angle(0.0, 0.5, 0.0, -1.0, False)
