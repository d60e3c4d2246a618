"""The joint an antagonistic pair of cables drives: a pulley of radius r on a joint with inertia,
damping, a stiffness (the load it moves against) and a load torque.

It stands where a joint FMU would stand in the composition (the BowdenPlant FMU twice and this
joint, outputs to inputs at each communication step, `cosim/engines/antagonist.py`), with the
interface such an FMU would have: parameters fixed at the start, inputs held over a step,
outputs after it. It is Python, not an FMU, because its two states need no solver (the step is
exact, below); a joint FMU would take the same variables.

    inputs    T_1, T_2 (N)   the tensions of the cables at the pulley (each FMU's true T_out)
              tau_load (N m) the load torque, against theta
    outputs   theta (rad), omega (rad/s), tau_cables (N m) = r * (T_1 - T_2)
              d_1, d_2 (m)   the cables' far-end displacements: d_1 = -r*theta, d_2 = +r*theta
                             (each FMU's input end_displacement)

Equation (rigid pulley, cables tangent to it, no slip on the pulley; fmu/README.md, "An
antagonistic joint"):

    J * theta'' = r * (T_1 - T_2) - b * theta' - k * theta - tau_load

Cable 1 pulls theta forward, so turning forward takes its end towards its sheath (d_1 = -r*theta)
and pulls cable 2's out (d_2 = +r*theta): the cables do work r*(T_1 - T_2)*theta' on the joint.
The step is the exact solution for the inputs held over it (zero-order hold; the matrix
exponential of the 2x2 system, computed once per step size), so the joint itself adds no
integration error at any step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class JointParams:
    """The joint's parameters (named assumptions: a small tendon-driven joint, e.g. a finger or
    wrist joint of a glove or an instrument; fmu/README.md, "An antagonistic joint", J1-J4)."""

    pulley_radius_m: float = 0.02  # r (J1)
    inertia_kg_m2: float = 1e-3  # J: pulley and the link it turns (J2)
    damping_n_m_s_per_rad: float = 0.02  # b: bearing and tissue losses (J3)
    stiffness_n_m_per_rad: float = 1.0  # k: the load as a spring about theta = 0 (J4)

    def __post_init__(self) -> None:
        for name in ("pulley_radius_m", "inertia_kg_m2"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"joint {name} = {v!r}: must be a finite number > 0")
        for name in ("damping_n_m_s_per_rad", "stiffness_n_m_per_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"joint {name} = {v!r}: must be a finite number >= 0")


class Joint:
    """One joint, at rest at theta = 0 after construction; `step(dt_s)` with the inputs held."""

    def __init__(self, params: JointParams | None = None) -> None:
        self.p = params if params is not None else JointParams()
        self.theta_rad = 0.0
        self.omega_rad_s = 0.0
        self.t_1_n = 0.0
        self.t_2_n = 0.0
        self.tau_load_n_m = 0.0
        self._h = None
        self._phi = self._gam = None

    def _constants(self, dt_s: float) -> None:
        from scipy.linalg import expm  # noqa: PLC0415 (the command line starts without scipy)

        p = self.p
        a = np.array(
            [
                [0.0, 1.0, 0.0],
                [
                    -p.stiffness_n_m_per_rad / p.inertia_kg_m2,
                    -p.damping_n_m_s_per_rad / p.inertia_kg_m2,
                    1.0 / p.inertia_kg_m2,
                ],
                [0.0, 0.0, 0.0],
            ]
        )
        e = expm(a * dt_s)  # [[Phi, Gamma], [0, 1]]: the held input's exact step
        self._phi = tuple(float(v) for v in e[:2, :2].ravel())
        self._gam = (float(e[0, 2]), float(e[1, 2]))
        self._h = dt_s

    @property
    def tau_cables_n_m(self) -> float:
        """r * (T_1 - T_2): the cables' torque on the joint from the inputs in force."""
        return self.p.pulley_radius_m * (self.t_1_n - self.t_2_n)

    @property
    def end_displacements_m(self) -> tuple[float, float]:
        """(d_1, d_2): each cable's far-end displacement away from its sheath outlet."""
        s = self.p.pulley_radius_m * self.theta_rad
        return -s, s

    def step(self, dt_s: float) -> None:
        """Advance by dt_s with T_1, T_2 and tau_load held (exact for held inputs)."""
        if dt_s != self._h:
            self._constants(dt_s)
        tau = self.tau_cables_n_m - self.tau_load_n_m
        p00, p01, p10, p11 = self._phi
        g0, g1 = self._gam
        th, om = self.theta_rad, self.omega_rad_s
        self.theta_rad = p00 * th + p01 * om + g0 * tau
        self.omega_rad_s = p10 * th + p11 * om + g1 * tau
