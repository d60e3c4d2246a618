"""Fit the capstan friction model of a Bowden cable to input/output tension data.

The model is the rate-independent relation of paper Eq. 1-3 and Fig. 2 between the input tension
T_in and the output tension T_out of a sheath with total bending angle phi:

    T_in * exp(-mu*phi) <= T_out <= T_in * exp(+mu*phi)

T_out keeps its value (the dead zone at a reversal) until one of the bounds pushes it: it slides
on the loading line exp(-mu*phi) while T_in rises and on the unloading line exp(+mu*phi) while
T_in falls. `capstan_output` runs it on a sequence of T_in; `fit_capstan` finds the mu (and,
optionally, a constant sensor offset, paper Sec. VI-A saw about 0.5 N) that make it best match
measured T_out in the least-squares sense. Used by the FMU's characterisation test (Fig. 11), the
co-simulation's `characterize` scenario and the model audit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

# The fit runs the model on at most this many samples (evenly decimated), which keeps a 15 s
# record at 10 kHz to well under a second; the model is rate independent, so decimation only
# rounds the turning points.
MAX_FIT_SAMPLES = 6000


@dataclass(frozen=True)
class CapstanFit:
    """Result of fit_capstan."""

    mu: float  # fitted friction coefficient
    offset_n: float  # fitted constant offset of T_out (0 unless fit_offset)
    phi_rad: float  # bending angle the fit assumed
    rms_residual_n: float  # RMS of T_out - model over the samples used
    samples: int  # samples used


def capstan_output(
    T_in: np.ndarray, mu: float, phi_rad: float, T_out0: float | None = None
) -> np.ndarray:
    """Output tension of the capstan model (Eq. 1-3, Fig. 2) for the input sequence T_in.

    T_out0 is the output before the first sample (default: on the loading line).
    """
    t_in = np.asarray(T_in, dtype=float)
    if mu < 0 or not math.isfinite(mu):
        raise ValueError(f"mu = {mu} must be finite and >= 0")
    if phi_rad < 0 or not math.isfinite(phi_rad):
        raise ValueError(f"phi_rad = {phi_rad} must be finite and >= 0")
    lo = np.maximum(t_in, 0.0) * math.exp(-mu * phi_rad)
    hi = np.maximum(t_in, 0.0) * math.exp(mu * phi_rad)
    out = np.empty_like(t_in)
    y = lo[0] if T_out0 is None else float(T_out0)
    lo_l, hi_l = lo.tolist(), hi.tolist()
    for k in range(len(lo_l)):
        if y < lo_l[k]:
            y = lo_l[k]
        elif y > hi_l[k]:
            y = hi_l[k]
        out[k] = y
    return out


def fit_capstan(
    T_in: np.ndarray,
    T_out: np.ndarray,
    phi_rad: float,
    fit_offset: bool = False,
    mu_bounds: tuple[float, float] = (0.0, 1.0),
) -> CapstanFit:
    """Least-squares fit of mu (and a constant offset of T_out if fit_offset) to the data.

    T_in and T_out are equally long sequences of the input and output tension [N] (as sensors
    read them); phi_rad is the sheath's bending angle during the record. Raises ValueError
    for mismatched, too short or non-finite data.
    """
    t_in = np.asarray(T_in, dtype=float)
    t_out = np.asarray(T_out, dtype=float)
    if t_in.shape != t_out.shape or t_in.ndim != 1:
        raise ValueError(
            f"T_in and T_out must be 1-D of equal length, got {t_in.shape}, {t_out.shape}"
        )
    if len(t_in) < 10:
        raise ValueError(f"need at least 10 samples, got {len(t_in)}")
    if not (np.all(np.isfinite(t_in)) and np.all(np.isfinite(t_out))):
        raise ValueError("T_in and T_out must be finite")
    if not (phi_rad > 0 and math.isfinite(phi_rad)):
        raise ValueError(f"phi_rad = {phi_rad} must be > 0 (no bending: mu is unobservable)")
    stride = max(1, math.ceil(len(t_in) / MAX_FIT_SAMPLES))
    t_in, t_out = t_in[::stride], t_out[::stride]

    def residual(mu: float) -> tuple[float, float]:
        model = capstan_output(t_in, mu, phi_rad)
        offset = float(np.mean(t_out - model)) if fit_offset else 0.0
        return float(np.mean((t_out - model - offset) ** 2)), offset

    res = minimize_scalar(
        lambda mu: residual(mu)[0],
        bounds=mu_bounds,
        method="bounded",
        options={"xatol": 1e-7},
    )
    mse, offset = residual(float(res.x))
    return CapstanFit(
        mu=float(res.x),
        offset_n=offset,
        phi_rad=float(phi_rad),
        rms_residual_n=math.sqrt(mse),
        samples=len(t_in),
    )
