"""The antagonistic joint's scenario: two cables on one joint, a joint-torque reference, and the
controller's split of it into two tension references with a pretension floor (co-contraction).

The split (the controller's side; on a board the processor computes it before each channel's
compensator), with x = tau_ref / r:

    T_1 = T_pre + min((x + sqrt(x^2 + eps^2)) / 2, T_max - T_pre)
    T_2 = T_pre + min((-x + sqrt(x^2 + eps^2)) / 2, T_max - T_pre)

so T_1 - T_2 = tau_ref / r exactly while neither saturates, both stay above the floor T_pre,
and the idle cable's reference falls smoothly towards T_pre (T_pre + eps/2 at tau_ref = 0).
eps = 0 is the max split, T_i = T_pre + min(max(+-x, 0), T_max - T_pre), which holds the idle
cable at exactly T_pre but gives each reference a corner at every zero crossing of tau_ref (its
slope jumps from 0 to the full dx/dt), where no compensator helps the loop. The scenario uses
the smooth split with eps = T_pre = 2 N (set before any run). Which split: both were run on
`antagonist` and then on a second torque reference chosen to decide (`multisine_torque`), and
the smooth split cut the torque error on both for the paper law, the preview mode and the
preview mode with the estimate (e.g. preview + estimate 4.4 -> 2.8 % RMS on `antagonist`,
6.5 -> 4.6 % on the multi-sine) and raised the least tensions (cosim/README.md, "The
antagonistic joint"); its cost is co-contraction: eps/2 = 1 N more on both cables near zero torque.

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
    smooth_n: float = PRETENSION_N  # the split's width eps (N); 0: the max split

    def split(self, tau_n_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(T_1, T_2): the tension references for the torque `tau_n_m` (module docstring)."""
        return split_tensions(
            tau_n_m,
            self.joint.pulley_radius_m,
            self.pretension_n,
            self.tension_max_n,
            self.smooth_n,
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
    tau_n_m: np.ndarray,
    radius_m: float,
    pretension_n: float,
    tension_max_n: float,
    smooth_n: float = PRETENSION_N,
) -> tuple[np.ndarray, np.ndarray]:
    """The co-contraction split (module docstring): each cable T_pre plus its side of tau/r,
    capped at T_max, each side (x + sqrt(x^2 + eps^2)) / 2 with eps = smooth_n (0: max(x, 0),
    the max split). Arrays of the shape of tau_n_m."""
    if not (math.isfinite(smooth_n) and smooth_n >= 0.0):
        raise ValueError(f"smooth split width {smooth_n!r} N must be a finite number >= 0")
    if not (math.isfinite(radius_m) and radius_m > 0.0):
        raise ValueError(f"pulley radius {radius_m!r} m must be a finite number > 0")
    if not 0.0 <= pretension_n <= tension_max_n:
        raise ValueError(
            f"pretension {pretension_n!r} N must lie in [0, T_max = {tension_max_n!r} N]"
        )
    pull = np.asarray(tau_n_m, dtype=np.float64) / radius_m
    room = tension_max_n - pretension_n
    if smooth_n > 0.0:
        root = np.hypot(pull, smooth_n)
        side_1, side_2 = 0.5 * (root + pull), 0.5 * (root - pull)
    else:
        side_1, side_2 = np.maximum(pull, 0.0), np.maximum(-pull, 0.0)
    t_1 = pretension_n + np.minimum(side_1, room)
    t_2 = pretension_n + np.minimum(side_2, room)
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


def max_split(scen: Antagonist) -> Antagonist:
    """The scenario with the max split (eps = 0): the idle cable held at exactly T_pre."""
    return replace(scen, name=f"{scen.name}_max_split", smooth_n=0.0)


def multisine_torque(scen: Antagonist) -> Antagonist:
    """The scenario with another torque reference (the second case of the choice of split): 0.3, 0.7
    and 1.3 Hz sines (the held-out `multisine`'s frequencies) with weights 0.5, 0.3 and 0.2 of
    the same amplitude, eased in; their sum crosses zero at other slopes and holds near it
    for other times than the single sine."""
    amp = float(np.max(np.abs(scen.tau_ref(np.linspace(1.0, 3.0, 2001)))))

    def tau_ref(t: np.ndarray) -> np.ndarray:
        w = 2.0 * np.pi * t
        wave = 0.5 * np.sin(0.3 * w) + 0.3 * np.sin(0.7 * w + 1.0) + 0.2 * np.sin(1.3 * w + 2.0)
        return amp * wave * _ease(t)

    return replace(scen, name=f"{scen.name}_multisine", tau_ref=tau_ref)


def get_antagonist(name: str = ANTAGONIST) -> Antagonist:
    """The pair's scenario `name` (`antagonist`)."""
    if name != ANTAGONIST:
        raise ValueError(f"pair scenario must be {ANTAGONIST!r}; got {name!r}")
    return _antagonist()
