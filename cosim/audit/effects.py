"""The audit's vocabulary: one object per cause, one-to-one with the plant FMU's effect
parameters (fmu/README.md, "Effects").

Each candidate has the same shape: its FMU parameter with unit
and fit bounds (and, for the saturation and the creep, a Shape: the second parameter fitted
with it, the knee or the time constant), the value that means "absent", a typical size (the
optimiser's scale), the equation it adds, and `applicable(data)`, which says why it cannot be
fitted on some data. Fitting and prediction go through one model (cosim.audit.twin: the FMU's
physics, vectorised, with these parameters), so adding a cause is adding one object to
VOCABULARY.

Forms: a cause may come in more than one form, each its own FMU parameter and law (viscous
friction that grows with the cable's speed, or with the inlet tension's rate). VOCABULARY holds
each cause's first form, which every round fits; FORMS lists all of a cause's forms, and the
others are fitted only for a cause whose first form survives (it removes at least the rule's
minimum share of the selection blocks' residual: cosim.audit.core.FORM_SCREEN), so a form costs
fits only where its cause shows. A form that stands on its own (`screened` False: the bending
error along x or y, which the form along z cannot stand in for, the coordinates being
independent) is fitted with the first whenever its cause is. The form is chosen on the
selection blocks, as the cause is, and printed with the finding (`label`).

Static friction moves the output in jumps (each strand's breakaway after a reversal), whose
instants move by whole samples with its excess, mu and the spread: the fits run the twin with
each jump spread over its sample by where the threshold was crossed (twin._friction, `smooth`),
so that the least squares sees a slope; predictions, the decision and the report use the exact
twin and the FMU.
"""

from __future__ import annotations

from dataclasses import dataclass

# A shape's fitted value within this share of a bound's own size is at that bound (Shape.at_bound).
# Chosen before any case was run with it: the least squares ends on an active bound to round-off,
# and 1 % keeps a creep of 50.5 ms, or a knee of 1.98 N, from passing as an estimate.
SHAPE_AT_BOUND_SHARE = 0.01


@dataclass(frozen=True)
class Shape:
    """A second FMU parameter fitted together with an effect's own: the form of its turn or its
    time constant (the load cell's creep time, the saturation's knee)."""

    fmu_param: str
    unit: str
    bounds: tuple[float, float]
    start: float
    scale: float
    scanned: bool = False  # not moved by the least squares (no slope): set by the form's scan
    # which bounds (lower, upper) are values of the form itself (the knee's 0: a hard clip).
    # A fit that ends at any other bound wants a value the form does not have (a creep faster
    # than its range is a gain or a lead, a knee of its widest bends every reading as a gain
    # would): the candidate is not a finding (at_bound).
    bound_is_form: tuple[bool, bool] = (False, False)

    def at_bound(self, value: float) -> str | None:
        """Why `value` is not an estimate of this shape, or None: it sits at a bound that is not
        a value of the form, within SHAPE_AT_BOUND_SHARE of that bound (or of the range, for a
        bound at 0)."""
        lo, hi = self.bounds
        for side, bound, is_form in (
            ("lower", lo, self.bound_is_form[0]),
            ("upper", hi, self.bound_is_form[1]),
        ):
            tol = SHAPE_AT_BOUND_SHARE * (abs(bound) if bound != 0.0 else hi - lo)
            if not is_form and abs(value - bound) <= tol:
                return (
                    f"{self.fmu_param} = {value:.4g} {self.unit} is at the {side} bound of its "
                    f"range [{lo:g}, {hi:g}]"
                )
        return None


@dataclass(frozen=True)
class Effect:
    """A candidate cause of the residual and the FMU parameter it maps to."""

    cause: str  # name in the audit's vocabulary
    fmu_param: str  # the plant FMU's parameter (fmu/gen_model.py)
    unit: str
    bounds: tuple[float, float]  # fit bounds, inside the FMU's allowed range
    off: float  # value when the effect is absent
    scale: float  # typical size: the optimiser's scale and first step
    equation: str  # what it adds to the model, in the FMU README's notation
    needs_positions: bool = False  # only observable when the end-effector moves
    discrete: bool = False  # fitted on a grid of whole samples (the delay)
    compensator_key: str | None = None  # the `--params` compensator field it sets, if any
    shape: tuple[Shape, ...] = ()  # further parameters fitted with it (a form, a time constant)
    # where its fit starts when "off" gives it no slope: "t_out_high" (near the largest output
    # reading: a full scale), "t_in_low" (at a low input tension: a slack threshold)
    start_from: str | None = None
    form: str = ""  # the form's name when the cause has more than one (FORMS)
    # a start found by a scan before the least squares (cosim.audit.fit._scan_start): "warmup"
    # (the time constant), "step" (the instant, which the least squares then holds);
    # "breakaway" (fit._breakaway_start): static friction's excess, which has no slope at "off"
    scan: str | None = None
    axis: int = 2  # the position coordinate (0 x, 1 y, 2 z) a needs_positions effect follows
    screened: bool = True  # fitted only when the cause's first form survives the screen

    @property
    def label(self) -> str:
        """The cause as a finding prints it: with its form when it has several."""
        if len(FORMS.get(self.cause, ())) > 1:
            return f"{self.cause} (form: {self.form})"
        return self.cause

    @property
    def fmu_params(self) -> tuple[str, ...]:
        """Every FMU parameter the effect sets: its own, then its shape's."""
        return (self.fmu_param, *(s.fmu_param for s in self.shape))

    def applicable(self, has_positions: bool, spans_m: tuple[float, ...]) -> str | None:
        """None when the effect can be fitted on these data, else why not (spans_m: how far
        x, y and z move)."""
        if self.needs_positions and not has_positions:
            return "the data have no positions (x_m, y_m, z_m)"
        span = spans_m[self.axis]
        if self.needs_positions and span < MIN_SPAN_M:
            name = "xyz"[self.axis]
            return f"{name} spans only {span * 1000:.0f} mm (at least {MIN_SPAN_M * 1000:.0f} mm)"
        return None

    def describe(self, value: float) -> str:
        """`fmu_param = value unit`, with the unit scaled for reading."""
        if self.unit == "s":
            return f"{self.fmu_param} = {value * 1000:.3g} ms"
        unit = f" {self.unit}" if self.unit and self.unit != "1" else ""
        return f"{self.fmu_param} = {value:.4g}{unit}"

    def describe_all(self, params: dict[str, float]) -> str:
        """describe() of its own parameter, then its shape's parameters in brackets."""
        text = self.describe(params[self.fmu_param])
        if self.shape:
            text += " (" + ", ".join(_describe(s, params[s.fmu_param]) for s in self.shape) + ")"
        return text


def _describe(s: Shape, value: float) -> str:
    unit = f" {s.unit}" if s.unit and s.unit != "1" else ""
    return f"{s.fmu_param} = {value:.4g}{unit}"


# The audit fits a saturation's knee up to this width: a turn into saturation over a few N at
# most. With a knee of tens of N the hyperbola bends every reading and stands in for a gain or a
# tension-dependent friction (it took their place on the FMU cases of the other causes).
KNEE_MAX_N = 2.0

# phi_offset_per_x, _y, _z are only observable when their coordinate moves by at least this much
# (5 cm: a phi change of 0.05 rad per rad/m, under 1 % of the 2 pi of a loop).
MIN_SPAN_M = 0.05

VOCABULARY: tuple[Effect, ...] = (
    Effect(
        "sensor_offset",
        "sensor_offset",
        "N",
        (-50.0, 50.0),
        0.0,
        0.5,
        "T_out_meas = ... + sensor_offset",
        compensator_key="offset_n",
    ),
    Effect(
        "sensor_gain",
        "sensor_gain",
        "1",
        (0.5, 2.0),
        1.0,
        0.05,
        "T_out_meas = sensor_gain * T_out + ...",
    ),
    Effect(
        "viscous_friction",
        "mu_viscous",
        "s/m",
        (0.0, 50.0),
        0.0,
        1.0,
        "mu_eff = mu + mu_viscous * |v_c| (v_c: cable speed at the inlet)",
        form="cable speed",
    ),
    Effect(
        "tension_dependent_friction",
        "mu_tension_slope",
        "1/N",
        (-0.02, 0.02),
        0.0,
        0.001,
        "mu_eff = mu + mu_tension_slope * T (per segment)",
        compensator_key="mu_slope_per_n",
    ),
    Effect(
        "bending_angle_error",
        "phi_offset_per_z",
        "rad/m",
        (-10.0, 10.0),
        0.0,
        0.5,
        "phi_eff = phi(x, y, z) + phi_offset_per_z * z",
        needs_positions=True,
        form="z",
    ),
    Effect(
        "lag",
        "sensor_tau",
        "s",
        (0.0, 0.2),
        0.0,
        0.005,
        "T_out_meas = Lag_{sensor_tau}[T_out] (first order)",
        form="first order",
    ),
    Effect(
        "time_delay",
        "sensor_delay",
        "s",
        (0.0, 0.2),
        0.0,
        0.005,
        "T_out_meas = Delay_{sensor_delay}[T_out]",
        discrete=True,
    ),
    Effect(
        "friction_drift",
        "mu_drift",
        "1/s",
        (-0.01, 0.01),
        0.0,
        1e-4,
        "mu_eff = mu + mu_drift * t",
        form="linear",
    ),
    Effect(
        "slack",
        "slack_tension",
        "N",
        (0.0, 50.0),
        0.0,
        0.5,
        "T_out = T_out * min(1, T_in / slack_tension) (pretension lost at low input tension)",
        start_from="t_in_low",
    ),
    Effect(
        "sensor_saturation",
        "sensor_full_scale",
        "N",
        (0.5, 1000.0),
        0.0,
        0.5,
        "T_out_meas = sat_{sensor_full_scale, sensor_saturation_knee}[...] (hard clip at knee 0)",
        shape=(
            Shape(
                "sensor_saturation_knee",
                "N",
                (0.0, KNEE_MAX_N),
                0.2,
                0.5,
                bound_is_form=(True, False),
            ),
        ),
        start_from="t_out_high",
    ),
    Effect(
        "load_cell_creep",
        "sensor_creep",
        "1",
        (-0.3, 0.3),
        0.0,
        0.01,
        "T_read = T_out - sensor_creep * (T_out - Lag_{sensor_creep_tau}[T_out])",
        shape=(Shape("sensor_creep_tau", "s", (0.05, 30.0), 1.0, 0.5),),
    ),
    Effect(
        "static_friction",
        "mu_static_excess",
        "1",
        (0.0, 0.3),
        0.0,
        0.005,
        "ws_j = (mu_eff + mu_static_excess) * phi_eff * exp(dead_zone_spread * q_j): a strand "
        "that must reverse holds to its breakaway width, then jumps to the kinetic bound",
        scan="breakaway",
        compensator_key="breakaway",
    ),
)

# The further forms of causes of VOCABULARY (each its own FMU parameter), fitted only when the
# cause's first form survives (module docstring).
OTHER_FORMS: tuple[Effect, ...] = (
    Effect(
        "bending_angle_error",
        "phi_offset_per_x",
        "rad/m",
        (-10.0, 10.0),
        0.0,
        0.5,
        "phi_eff = phi(x, y, z) + phi_offset_per_x * x",
        needs_positions=True,
        form="x",
        axis=0,
        screened=False,
    ),
    Effect(
        "bending_angle_error",
        "phi_offset_per_y",
        "rad/m",
        (-10.0, 10.0),
        0.0,
        0.5,
        "phi_eff = phi(x, y, z) + phi_offset_per_y * y",
        needs_positions=True,
        form="y",
        axis=1,
        screened=False,
    ),
    Effect(
        "viscous_friction",
        "mu_viscous_tension_rate",
        "s/N",
        (0.0, 0.05),
        0.0,
        1e-3,
        "mu_eff = mu + mu_viscous_tension_rate * |r_in| (r_in: rate of the inlet tension)",
        form="tension rate",
    ),
    Effect(
        "lag",
        "sensor_tau2",
        "s",
        (0.0, 0.2),
        0.0,
        0.005,
        "T_out_meas = Lag_{sensor_tau2}[Lag_{sensor_tau2}[T_out]] (second order, critical)",
        form="second order",
    ),
    Effect(
        "friction_drift",
        "mu_warmup",
        "1",
        (-0.1, 0.1),
        0.0,
        0.005,
        "mu_eff = mu + mu_warmup * (1 - exp(-(t - t_start) / mu_warmup_tau))",
        shape=(Shape("mu_warmup_tau", "s", (0.2, 1e4), 10.0, 5.0),),
        form="warm-up",
        scan="warmup",
    ),
    Effect(
        "friction_drift",
        "mu_step",
        "1",
        (-0.1, 0.1),
        0.0,
        0.005,
        "mu_eff = mu + mu_step * [t >= mu_step_time]",
        shape=(Shape("mu_step_time", "s", (-1e9, 1e9), 0.0, 1.0, scanned=True),),
        form="step",
        scan="step",
    ),
)

BY_CAUSE = {e.cause: e for e in VOCABULARY}
FORMS: dict[str, tuple[Effect, ...]] = {
    c: (e, *(o for o in OTHER_FORMS if o.cause == c)) for c, e in BY_CAUSE.items()
}
ALL_FORMS: tuple[Effect, ...] = (*VOCABULARY, *OTHER_FORMS)
BY_PARAM = {e.fmu_param: e for e in ALL_FORMS}
SHAPES = {sh.fmu_param: sh for e in ALL_FORMS for sh in e.shape}
CAUSES = tuple(e.cause for e in VOCABULARY)
