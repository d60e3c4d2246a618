"""Fixtures of the plant FMU tests: the built FMU and small helpers to run it."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from cosim.parts.plant import FMU_PATH, Plant
from cosim.project.paths import REPO_ROOT

HERE = Path(__file__).resolve().parent
IN_PLANE = {"x": 0.0, "y": 0.6, "z": -0.2}  # a position in the loop's plane: phi = 2*pi


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    """The packaged FMU, built with `make fmu` when missing (make test builds it first)."""
    if not FMU_PATH.exists():
        subprocess.run(["make", "fmu"], cwd=REPO_ROOT, check=True)
    return FMU_PATH


@pytest.fixture(scope="session")
def gen_model():
    """fmu/gen_model.py, the one source of the variables."""
    from fmu import gen_model

    return gen_model


@pytest.fixture
def make_plant(fmu_path):
    """Factory of initialised Plant handles, closed at the end of the test."""
    plants = []

    def factory(params=None, inputs=None):
        plant = Plant(params, inputs=IN_PLANE if inputs is None else inputs, fmu_path=fmu_path)
        plants.append(plant)
        return plant

    yield factory
    for plant in plants:
        plant.close()


def run_tension(plant: Plant, t_in_cmd: np.ndarray, dt_s: float = 1e-4) -> np.ndarray:
    """Drive mode 1: step through the prescribed input tensions; outputs as rows (n, 8)."""
    out = np.empty((len(t_in_cmd), 8))
    u, step = plant.u, plant.step
    for k, value in enumerate(t_in_cmd.tolist()):
        u[Plant.T_IN_CMD] = value
        out[k] = step(dt_s)
    return out


def run_current(plant: Plant, current_a: np.ndarray, dt_s: float = 1e-4) -> np.ndarray:
    """Drive mode 0: step through the current commands; outputs as rows (n, 8)."""
    out = np.empty((len(current_a), 8))
    step = plant.step_current
    for k, value in enumerate(current_a.tolist()):
        out[k] = step(value, dt_s)
    return out


@pytest.fixture
def tension_runner():
    return run_tension


@pytest.fixture
def current_runner():
    return run_current
