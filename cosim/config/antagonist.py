"""The antagonistic joint's scenario: two cables on one joint, a joint-torque reference, and the
controller's split of it into two tension references with a pretension floor (co-contraction).

The split (the controller's side; on a board the processor computes it before each channel's
compensator):

    T_1 = T_pre + min(max(tau_ref, 0) / r, T_max - T_pre)
    T_2 = T_pre + min(max(-tau_ref, 0) / r, T_max - T_pre)

so T_1 - T_2 = tau_ref / r while neither saturates, and the cable that does not pull holds
exactly T_pre (the floor), also when tau_ref saturates. This is the plain max split, not a
smooth one (e.g. T_pre + (x + sqrt(x^2 + eps^2)) / 2 with x = tau_ref / r): the max split keeps
the idle cable's reference constant at T_pre, so that its compensator sees no reversal there
(a smooth split turns each zero crossing of tau_ref into a minimum of both references, a
reversal for both compensators), and it never asks for more tension than the torque needs.
Its corner at tau_ref = 0 is a corner of T_ref, which the loop follows as it follows fig14's.

The scenario `antagonist` (named assumptions, fmu/README.md "An antagonistic joint"):
- tau_ref: fig14's reference turned into a torque: a 0.5 Hz sine whose cable references span
  fig14's 2 .. 15 N (T_pre = 2 N, amplitude (15 - 2) N * r), eased in over 0.5 s; 6 s, errors
  from t = 1 s.
- cable 1 (pulls theta forward): loop routing, mu 0.075 (the paper's), fig14's end-effector path;
- cable 2: loop routing, its liner 20 % rougher (mu 0.09, the estimation study's `mu_high`), the
  held-out fig14path2's path; both compensators calibrated once at mu 0.075 and the phi at their
  start, so cable 2's is off by 20 % unless the online estimate corrects it.
- the joint (cosim.parts.joint.JointParams defaults), no load torque.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from cosim.config.run import SimConfig
from cosim.config.scenarios import (
    FIG14_FREQ_HZ,
    FIG14_MAX_N,
    FIG14_MIN_N,
    MU_PAPER,
    Scenario,
    _ease,
    _fig14_path,
    get_scenario,
)
from cosim.parts.joint import JointParams

ANTAGONIST = "antagonist"
DURATION_S = 6.0
SETTLE_S = 1.0
PRETENSION_N = FIG14_MIN_N  # T_pre: fig14's minimum reference
TENSION_MAX_N = 24.0  # T_max: the characterisation's peak (Sec. VI-A), the most a cable is asked


@dataclass(frozen=True)
class Cable:
    """One cable of the pair: its FMU parameters (over the run's), routing and path."""

    name: str
    plant: dict = field(default_factory=dict)
    loop_routing: bool = True
    trajectory: Callable = _fig14_path()


@dataclass(frozen=True)
class Antagonist:
    """What the pair's world does: the torque reference, the load, the joint, the two cables and
    the split's floor and ceiling."""

    name: str
    duration_s: float
    tau_ref: Callable[[np.ndarray], np.ndarray]  # N m, at times t (s)
    cables: tuple[Cable, Cable]
    joint: JointParams = field(default_factory=JointParams)
    tau_load: Callable[[np.ndarray], np.ndarray] = lambda t: np.zeros_like(t)
    pretension_n: float = PRETENSION_N
    tension_max_n: float = TENSION_MAX_N
    settle_s: float = SETTLE_S

    def split(self, tau_n_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(T_1, T_2): the tension references for the torque `tau_n_m` (module docstring)."""
        return split_tensions(
            tau_n_m, self.joint.pulley_radius_m, self.pretension_n, self.tension_max_n
        )

    def cable_scenario(self, i: int) -> Scenario:
        """Cable i's single-cable scenario: its T_ref the split's T_i of tau_ref, its path; the
        machinery of one cable (sample_inputs, firmware_t_ref's preview) then applies as is."""
        cable = self.cables[i]

        def t_ref(t: np.ndarray) -> np.ndarray:
            return self.split(np.asarray(self.tau_ref(np.asarray(t, dtype=np.float64))))[i]

        return Scenario(
            name=f"{self.name}.{cable.name}",
            duration_s=self.duration_s,
            description=f"cable {cable.name} of the {self.name} pair",
            t_ref=t_ref,
            trajectory=cable.trajectory,
            settle_s=self.settle_s,
        )

    def cable_config(self, cfg: SimConfig, i: int) -> SimConfig:
        """The run's configuration with cable i's own FMU parameters over the run's."""
        return replace(cfg, plant={**cfg.plant, **self.cables[i].plant})


def split_tensions(
    tau_n_m: np.ndarray, radius_m: float, pretension_n: float, tension_max_n: float
) -> tuple[np.ndarray, np.ndarray]:
    """The co-contraction split (module docstring): each cable T_pre plus its side of tau/r,
    capped at T_max. Arrays of the shape of tau_n_m."""
    if not (math.isfinite(radius_m) and radius_m > 0.0):
        raise ValueError(f"pulley radius {radius_m!r} m must be a finite number > 0")
    if not 0.0 <= pretension_n <= tension_max_n:
        raise ValueError(
            f"pretension {pretension_n!r} N must lie in [0, T_max = {tension_max_n!r} N]"
        )
    pull = np.asarray(tau_n_m, dtype=np.float64) / radius_m
    room = tension_max_n - pretension_n
    t_1 = pretension_n + np.minimum(np.maximum(pull, 0.0), room)
    t_2 = pretension_n + np.minimum(np.maximum(-pull, 0.0), room)
    return t_1, t_2


def _antagonist() -> Antagonist:
    joint = JointParams()
    amp = (FIG14_MAX_N - FIG14_MIN_N) * joint.pulley_radius_m

    def tau_ref(t: np.ndarray) -> np.ndarray:
        return amp * np.sin(2.0 * np.pi * FIG14_FREQ_HZ * t) * _ease(t)

    return Antagonist(
        name=ANTAGONIST,
        duration_s=DURATION_S,
        tau_ref=tau_ref,
        joint=joint,
        cables=(
            Cable("1", {}, True, _fig14_path()),
            Cable("2", {"mu": 1.2 * MU_PAPER}, True, get_scenario("fig14path2").trajectory),
        ),
    )


def saturating(scen: Antagonist, factor: float = 3.0) -> Antagonist:
    """The scenario with tau_ref `factor` times larger, so that the split's ceiling T_max cuts
    each half period flat (the floor must hold on the idle side meanwhile)."""
    base = scen.tau_ref
    return replace(scen, name=f"{scen.name}_saturating", tau_ref=lambda t: factor * base(t))


def get_antagonist(name: str = ANTAGONIST) -> Antagonist:
    """The pair's scenario `name` (`antagonist`)."""
    if name != ANTAGONIST:
        raise ValueError(f"pair scenario must be {ANTAGONIST!r}; got {name!r}")
    return _antagonist()
