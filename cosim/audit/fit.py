"""The audit's models: the twin (cosim.audit.twin) with some effects of the vocabulary on, fitted
on the fit blocks only (cosim.audit.core, steps 2-3)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import fftconvolve

from . import twin
from .data import FIT, AuditData
from .effects import Effect

MU_BOUNDS = (1e-4, 1.0)
MU_SCALE = 0.01
# The nominal model's second property: the spread of the friction thresholds that makes the
# output turn gradually through the dead zone (fmu/README.md, "Gradual dead zone"). Measured
# cables turn gradually; a nominal model with the sharp corner leaves structure at every
# reversal that other causes then partly take (a rig with a gradual transition and no effect
# got sensor_gain, sensor_offset and tension_dependent_friction named). Fitted with mu in every
# model, within the FMU's range; it starts a little inside its bound at 0.
SPREAD = "dead_zone_spread"
SPREAD_BOUNDS = (0.0, 1.5)
SPREAD_SCALE = 0.1
SPREAD_START = 0.05
# Fits use at most this many residuals of the fit blocks (evenly strided): enough for the
# parameters, and it keeps the Jacobian small.
MAX_FIT_RESIDUALS = 20_000


@dataclass
class Model:
    """The twin with some effects on: parameters (FMU names) and its prediction of T_out_meas."""

    effects: tuple[Effect, ...]
    params: dict[str, float]
    prediction: np.ndarray
    nfev: int = 0

    def residual(self, data: AuditData) -> np.ndarray:
        return data.t_out_n - self.prediction

    def ms(self, data: AuditData, role: int) -> float:
        r = self.residual(data)[data.roles == role]
        return float(np.mean(r * r))

    def rms(self, data: AuditData, role: int) -> float:
        return math.sqrt(self.ms(data, role))


def fit_model(
    data: AuditData,
    effects: tuple[Effect, ...],
    start: dict[str, float] | None = None,
    free: tuple[Effect, ...] | None = None,
) -> Model:
    """Fit mu (unless the sidecar gives it) and the parameters of the `free` effects (default:
    all of `effects`) together on the fit blocks, the others held at `start`; the delay on its
    grid of whole samples (scanned, then its neighbours with the rest refitted)."""
    free = tuple(effects) if free is None else tuple(free)
    start = dict(start or {})
    params: dict[str, float] = {"mu": data.mu_given if data.mu_fixed else 0.075}
    params.update({k: v for k, v in start.items() if k != "mu" or not data.mu_fixed})
    for e in effects:
        if e.fmu_param not in params:
            params[e.fmu_param] = _start(e, data)
        for sh in e.shape:
            params.setdefault(sh.fmu_param, sh.start)
    params.setdefault(SPREAD, SPREAD_START)
    names: list[str] = ([] if data.mu_fixed else ["mu"]) + [SPREAD]
    names += [n for e in free if not e.discrete for n in e.fmu_params]
    delay = next((e for e in free if e.discrete), None)
    fit_idx = np.flatnonzero(data.roles == FIT)
    stride = max(1, math.ceil(len(fit_idx) / MAX_FIT_RESIDUALS))
    idx = fit_idx[::stride]
    nfev = 0
    if delay is None:
        if names:
            params, nfev = _least_squares(data, params, names, idx)
    else:
        # Coordinate descent: scan the delay with the rest held, refit the rest, until the scan
        # stays; then walk to neighbouring delays (the rest refitted) while that fits better, as
        # mu and the delay trade off near the optimum.
        dt = data.inputs.dt_s
        m = twin.delay_samples(_scan_delay(data, params, fit_idx), dt)
        for _ in range(6):
            params[delay.fmu_param] = m * dt
            if names:
                params, n_eval = _least_squares(data, params, names, idx)
                nfev += n_eval
            m_new = twin.delay_samples(_scan_delay(data, params, fit_idx), dt)
            if m_new == m:
                break
            m = m_new
        best = (_sse(data, params, idx), params)
        m_max = int(round(delay.bounds[1] / dt))
        for step in (-1, 1):
            m = twin.delay_samples(best[1][delay.fmu_param], dt) + step
            while 0 <= m <= m_max:
                trial = {**best[1], delay.fmu_param: m * dt}
                if names:
                    trial, n_eval = _least_squares(data, trial, names, idx)
                    nfev += n_eval
                sse = _sse(data, trial, idx)
                if sse >= best[0]:
                    break
                best = (sse, trial)
                m += step
        params = best[1]
    pred = twin.simulate(data.inputs, params)
    return Model(effects=tuple(effects), params=params, prediction=pred, nfev=nfev)


def _start(e: Effect, data: AuditData) -> float:
    """Where the fit of an effect starts: where its parameter has a slope on these data."""
    lo, hi = e.bounds
    if e.start_from == "t_out_high":  # a full scale: at the top of the output's readings
        return float(np.clip(np.percentile(data.t_out_n, 99.5), lo, hi))
    if e.start_from == "t_in_low":  # a slack threshold: where the input tension is low
        return float(np.clip(np.percentile(data.inputs.t_in_n, 15.0), lo, hi))
    # bounded at "off" (viscous, lag): start a little inside
    return e.off + (e.scale if e.off <= lo else 0.0)


def _sse(data: AuditData, params: dict[str, float], idx: np.ndarray) -> float:
    r = data.t_out_n[idx] - twin.simulate(data.inputs, params)[idx]
    return float(r @ r)


def _bounds_and_scale(name: str) -> tuple[float, float, float]:
    if name == "mu":
        return MU_BOUNDS[0], MU_BOUNDS[1], MU_SCALE
    if name == SPREAD:
        return SPREAD_BOUNDS[0], SPREAD_BOUNDS[1], SPREAD_SCALE
    from .effects import BY_PARAM, SHAPES  # noqa: PLC0415

    if name in SHAPES:
        sh = SHAPES[name]
        return sh.bounds[0], sh.bounds[1], sh.scale
    e = BY_PARAM[name]
    return e.bounds[0], e.bounds[1], e.scale


def _least_squares(data, params, names, idx):
    lo, hi, scale = (np.array(v) for v in zip(*(_bounds_and_scale(n) for n in names), strict=True))
    x0 = np.clip(np.array([params[n] for n in names]), lo, hi) / scale
    y = data.t_out_n[idx]

    cache: dict[tuple, np.ndarray] = {}

    def fun(x):
        p = dict(params)
        p.update(zip(names, x * scale, strict=True))
        # the sensor's parameters do not change the friction: reuse its output
        key = tuple(p.get(k, 0.0) for k in twin.FRICTION_PARAMS)
        if key not in cache:
            cache.clear()
            cache[key] = twin.friction_output(data.inputs, p)
        return twin.sensor_output(cache[key], p, data.inputs.dt_s)[idx] - y

    res = least_squares(
        fun,
        x0,
        bounds=(lo / scale, hi / scale),
        x_scale=1.0,
        diff_step=1e-4,
        max_nfev=20 * (len(names) + 1),
        xtol=1e-5,
        ftol=1e-6,
    )
    out = dict(params)
    out.update(zip(names, (res.x * scale).tolist(), strict=True))
    return out, int(res.nfev)


def _scan_delay(data: AuditData, params: dict[str, float], fit_idx: np.ndarray) -> float:
    """The whole-sample delay that fits best with the other parameters held (0 .. 0.2 s or a
    twentieth of the record): the sums of squares of every shift from two correlations."""
    dt = data.inputs.dt_s
    p = {**params, "sensor_delay": 0.0}
    offset = p.get("sensor_offset", 0.0)
    b = twin.sensor_output(twin.friction_output(data.inputs, p), p, dt) - offset
    n = len(b)
    m_max = int(min(0.2, 0.05 * n * dt) / dt)
    w = np.zeros(n)
    w[fit_idx] = 1.0
    yw = (data.t_out_n - offset) * w
    # the sensor reads b[0] before the start: b_ext[m_max + i - m] = b[i - m]
    b_ext = np.concatenate([np.full(m_max, b[0]), b])
    # S1(m) = sum_i yw_i b_ext[m_max + i - m], S2(m) = sum_i w_i b_ext[m_max + i - m]^2
    s1 = fftconvolve(b_ext, yw[::-1], mode="valid")[::-1]
    s2 = fftconvolve(b_ext**2, w[::-1], mode="valid")[::-1]
    sse = s2[: m_max + 1] - 2.0 * s1[: m_max + 1]
    return int(np.argmin(sse)) * dt
