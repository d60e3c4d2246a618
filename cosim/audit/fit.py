"""The audit's models: the twin (cosim.audit.twin) with some effects of the vocabulary on, fitted
on the fit blocks only (cosim.audit.core, steps 2-3)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.optimize._numdiff import approx_derivative
from scipy.signal import fftconvolve, lfilter

from . import twin
from .data import FIT, AuditData
from .effects import Effect
from .twin import PlantInputs

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
# ... and, when a fit is given no spread to start from (the nominal model's), from each of
# SPREAD_RESTARTS as well: the spread's effect is of second order near 0 (the strands' quantiles
# are symmetric, so mean_j e^(spread q_j) grows as spread^2 / 2: a fit started at 0 stays
# there), and mu can take part of a wide turn, so a fit started near 0 can settle there with a
# wide spread in the record (a tuning plant of random_plants_tuning.yaml with spread 0.49 and a
# tension slope: spread 0 and mu 0.067, 0.67 N RMS on the fit blocks; started from 0.5, spread
# 0.53 and 0.45 N; docs/results.md, "Where the sensorless mode's worst plants lose"; measured on
# the FMU before its strands followed the slope, which found that plant's spread from 0.05
# afterwards). A restart replaces the fit from
# SPREAD_START only when it lowers the fit blocks' residual mean square by at least
# SPREAD_RESTART_GAIN (the audit's rule's least share for a finding, 2 %: below it the two are the
# same fit, and the one from SPREAD_START stays, to the digit).
SPREAD_RESTARTS = (0.5,)
SPREAD_RESTART_GAIN = 0.02
# Fits use at most this many residuals of the fit blocks (evenly strided): enough for the
# parameters, and it keeps the Jacobian small.
MAX_FIT_RESIDUALS = 20_000
# On long records the fits run the friction part of the twin on every q-th sample, q the
# smallest that keeps it within this many samples, and read it between them by linear
# interpolation (the sensor's creep, lag and delay still run at the full rate on it); the
# residuals fitted sit on that grid. The friction is a hysteresis driven by the smoothed input:
# what a coarser step changes is where a reversal's extreme falls (at a reversal the input is
# flat, so it moves by about T'' (q dt)^2 / 8: 1e-3 N at 60 N/s^2 and q dt = 12 ms) and the
# 10 ms filter of the cable speed (viscous friction only). Records up to this length are fitted
# on every sample; every model is then simulated at the full rate, and the decision and the
# report use those predictions only. The friction loop is most of an audit's time: without
# this, 20 minutes of 1 kHz data cost about 1500 runs of 1.2 million samples.
MAX_FIT_FRICTION_SAMPLES = 100_000
# ... and on every record the fits' friction grid is at least this coarse (q = 2 at 1 kHz): the
# input that drives the friction is smoothed (data.SMOOTH_S, a 41 ms Savitzky-Golay window of
# order 5, flat to about 70 Hz), the sensor's lags and creep are filtered on the grid exactly
# for an input linear between its samples (_grid_lag), and the delay is read at the full rate
# from the interpolated friction; a 2 ms grid moves a reversal's extreme by T'' (2 ms)^2 / 8
# (3e-5 N at 60 N/s^2), a thousandth of the noise floor. It halves the friction runs and the
# Jacobian of every fit; the models are still simulated at the full rate for the decision and
# the report. Not for a model with viscous friction (RATE_PARAMS): it follows the cable speed
# and the tension rate, derivatives filtered with 10 ms, whose noise a coarser step changes (a
# case of the rig's tension-rate friction kept its last round's creep at its bound only at the
# full rate); those fits run at the full rate below MAX_FIT_FRICTION_SAMPLES.
FIT_FRICTION_STEP_S = 2e-3
RATE_PARAMS = ("mu_viscous", "mu_viscous_tension_rate")
# Friction outputs kept per fit (least recently used dropped): the Jacobian's columns for the
# sensor's parameters (offset, gain, lag, delay, full scale, creep) reuse the friction of the
# point they are taken at; those for mu, the spread and static friction's excess come from the
# slopes the point's friction run computed beside it (twin.friction_derivatives), where it can.
FRICTION_CACHE = 4
# least_squares' relative step (diff_step) for the columns taken by differences (_least_squares)
DIFF_STEP = 1e-4


@dataclass
class Model:
    """The twin with some effects on: parameters (FMU names) and its prediction of T_out_meas."""

    effects: tuple[Effect, ...]
    params: dict[str, float]
    prediction: np.ndarray | None  # None once the audit no longer needs it (core.run)
    nfev: int = 0
    friction_runs: int = 0  # runs of the twin's friction loop the fit took (its main cost)

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
    """Fit mu (unless the sidecar gives it), the dead zone's spread and the parameters of the
    `free` effects (default: all of `effects`) together on the fit blocks, the others held at
    `start`; the delay on its grid of whole samples (scanned, then its neighbours with the rest
    refitted). Without a spread in `start`, from SPREAD_START and from each of SPREAD_RESTARTS,
    the best kept (SPREAD_RESTART_GAIN)."""
    if SPREAD not in (start or {}):
        # the nominal model's spread from SPREAD_START, then from each restart (SPREAD_RESTARTS)
        best = _fit_model(data, effects, {**(start or {}), SPREAD: SPREAD_START}, free)
        nfev, runs = best.nfev, best.friction_runs
        for s in SPREAD_RESTARTS:
            m = _fit_model(data, effects, {**(start or {}), SPREAD: s}, free)
            nfev, runs = nfev + m.nfev, runs + m.friction_runs
            if m.ms(data, FIT) < (1.0 - SPREAD_RESTART_GAIN) * best.ms(data, FIT):
                best = m
        best.nfev, best.friction_runs = nfev, runs
        return best
    return _fit_model(data, effects, start, free)


def _fit_model(
    data: AuditData,
    effects: tuple[Effect, ...],
    start: dict[str, float] | None,
    free: tuple[Effect, ...] | None,
) -> Model:
    free = tuple(effects) if free is None else tuple(free)
    start = dict(start or {})
    # forms whose start a scan finds (effects.Effect.scan), unless the start gives them
    to_scan = [e for e in free if e.scan in ("warmup", "step") and e.fmu_param not in start]
    params: dict[str, float] = {"mu": data.mu_given if data.mu_fixed else 0.075}
    params.update({k: v for k, v in start.items() if k != "mu" or not data.mu_fixed})
    for e in effects:
        if e.fmu_param not in params:
            params[e.fmu_param] = _start(e, data)
        for sh in e.shape:
            params.setdefault(sh.fmu_param, sh.start)
    params.setdefault(SPREAD, SPREAD_START)
    names: list[str] = ([] if data.mu_fixed else ["mu"]) + [SPREAD]
    names += [n for e in free if not e.discrete for n in e.fmu_params if n not in _SCANNED]
    delay = next((e for e in free if e.discrete), None)
    rates = any(p in RATE_PARAMS for e in effects for p in e.fmu_params)
    ev = _Evaluator(data, coarse=not rates)
    fit_idx = np.flatnonzero(data.roles == FIT)
    stride = max(1, math.ceil(len(fit_idx) / MAX_FIT_RESIDUALS))
    idx = ev.on_grid(fit_idx, stride)
    for e in to_scan:
        params.update(_scan_start(ev, params, e, idx))
    nfev = 0
    started = False  # fitted from a breakaway's starts already
    for e in free:
        if e.scan == "breakaway" and e.fmu_param not in start:
            # each start fitted (the delay held), the best kept; with a delay the fit below
            # goes on from it
            started = True
            best = None
            for st in _breakaway_starts(ev, params, e, idx):
                trial, n_eval = _least_squares(ev, {**params, **st}, names, idx)
                nfev += n_eval
                sse = _sse(ev, trial, idx)
                if best is None or sse < best[0]:
                    best = (sse, trial)
            params = best[1]
    if delay is None:
        if names and not started:
            params, nfev = _least_squares(ev, params, names, idx)
    else:
        # Coordinate descent: scan the delay with the rest held, refit the rest, until the scan
        # stays; then walk to neighbouring delays (the rest refitted) while that fits better, as
        # mu and the delay trade off near the optimum.
        dt = data.inputs.dt_s
        m = twin.delay_samples(_scan_delay(ev, params, fit_idx), dt)
        for _ in range(6):
            params[delay.fmu_param] = m * dt
            if names:
                params, n_eval = _least_squares(ev, params, names, idx)
                nfev += n_eval
            m_new = twin.delay_samples(_scan_delay(ev, params, fit_idx), dt)
            if m_new == m:
                break
            m = m_new
        best = (_sse(ev, params, idx), params)
        m_max = int(round(delay.bounds[1] / dt))
        for step in (-1, 1):
            m = twin.delay_samples(best[1][delay.fmu_param], dt) + step
            while 0 <= m <= m_max:
                trial = {**best[1], delay.fmu_param: m * dt}
                if names:
                    trial, n_eval = _least_squares(ev, trial, names, idx)
                    nfev += n_eval
                sse = _sse(ev, trial, idx)
                if sse >= best[0]:
                    break
                best = (sse, trial)
                m += step
        params = best[1]
    pred = twin.simulate(data.inputs, params)
    return Model(
        effects=tuple(effects),
        params=params,
        prediction=pred,
        nfev=nfev,
        friction_runs=ev.friction_runs + 1,
    )


def _scanned() -> frozenset[str]:
    from .effects import SHAPES  # noqa: PLC0415

    return frozenset(n for n, sh in SHAPES.items() if sh.scanned)


_SCANNED = _scanned()
# the time constants a warm-up's scan tries: from this many seconds to SCAN_TAU_SPAN records
SCAN_TAU_MIN_S = 0.2
SCAN_TAU_SPAN = 10.0
SCAN_TAU_COUNT = 48
# a step's scan keeps this share of the fit residuals on each side of the instant
SCAN_STEP_EDGE = 0.05
SCAN_D_MU = 1e-3  # mu's change for the model's slope in mu that the scans use


def _scan_start(ev: _Evaluator, params: dict[str, float], e: Effect, idx: np.ndarray) -> dict:
    """The start of a drift form whose shape the least squares cannot find from its default
    (a warm-up's time constant, a step's instant, where the slope is zero): the model's slope in
    mu, J = d(reading)/d(mu) at the fit residuals, times the form's time course g(t) is the
    change a small amplitude a makes, a J g; for each time constant (geometric grid) or instant
    (every gap between fit residuals, SCAN_STEP_EDGE kept on each side) the amplitude that fits
    the residual r best is a = (r . Jg) / (Jg . Jg), and it removes (r . Jg)^2 / (Jg . Jg). The
    shape that removes most is taken, with its amplitude (clipped to the bounds). A step's
    instant falls in the middle of a sample, so that no sample sits on it."""
    data = ev.data
    dt = data.inputs.dt_s
    t0 = data.inputs.t0_s
    p0 = {**params, e.fmu_param: e.off}
    pred0 = ev.reading(p0, idx)
    j = (ev.reading({**p0, "mu": p0["mu"] + SCAN_D_MU}, idx) - pred0) / SCAN_D_MU
    r = data.t_out_n[idx] - pred0
    tk = t0 + idx * dt
    lo, hi = e.bounds
    shape = e.shape[0].fmu_param
    if e.scan == "step":
        rj = np.cumsum((r * j)[::-1])[::-1]
        jj = np.cumsum((j * j)[::-1])[::-1]
        n = len(idx)
        a, b = max(1, int(n * SCAN_STEP_EDGE)), max(2, n - int(n * SCAN_STEP_EDGE))
        score = rj[a:b] ** 2 / np.maximum(jj[a:b], 1e-300)
        i = a + int(np.argmax(score))
        instant = 0.5 * (tk[i - 1] + tk[i])
        instant = t0 + (math.floor((instant - t0) / dt) + 0.5) * dt
        amp = rj[i] / jj[i] if jj[i] > 0 else 0.0
        return {e.fmu_param: float(np.clip(amp, lo, hi)), shape: float(instant)}
    span = max(float(tk[-1] - t0), SCAN_TAU_MIN_S)
    best = (-1.0, e.shape[0].start, 0.0)
    for tau in np.geomspace(SCAN_TAU_MIN_S, SCAN_TAU_SPAN * span, SCAN_TAU_COUNT):
        jg = j * (1.0 - np.exp(-(tk - t0) / tau))
        ss = float(jg @ jg)
        if ss > 0:
            rg = float(r @ jg)
            if rg * rg / ss > best[0]:
                best = (rg * rg / ss, float(tau), rg / ss)
    tau_lo, tau_hi = e.shape[0].bounds
    return {
        e.fmu_param: float(np.clip(best[2], lo, hi)),
        shape: float(np.clip(best[1], tau_lo, tau_hi)),
    }


# a breakaway's starts: its scan tries this many values of the excess from SCAN_BREAKAWAY_MIN
# to its bound (geometric) at the current spread and each of SCAN_BREAKAWAY_SPREADS, and the
# least squares starts from the SCAN_BREAKAWAY_STARTS best (the sum of squares has several
# valleys in the excess and the spread: the strands' jumps fall after other reversals)
SCAN_BREAKAWAY_COUNT = 16
SCAN_BREAKAWAY_MIN = 2e-3
SCAN_BREAKAWAY_SPREADS = (0.0, 0.1, 0.2, 0.35, 0.6)
SCAN_BREAKAWAY_STARTS = 2


def _breakaway_starts(ev: _Evaluator, params, e: Effect, idx) -> list[dict]:
    """Starts of static friction's excess and the spread: at "off" the model has no slope in
    the excess (a strand held a little longer jumps a little less, a change of second order),
    and the spread that the nominal model fitted without it took part of its hold; the points
    of a grid in both with the smallest sums of squares on the fit residuals, the rest held."""
    lo, hi = e.bounds
    xs = np.geomspace(max(lo, SCAN_BREAKAWAY_MIN), hi, SCAN_BREAKAWAY_COUNT)
    scored = sorted(
        (_sse(ev, {**params, SPREAD: sp, e.fmu_param: float(x)}, idx), sp, float(x))
        for sp in (float(params[SPREAD]), *SCAN_BREAKAWAY_SPREADS)
        for x in xs
    )
    return [{SPREAD: sp, e.fmu_param: x} for _, sp, x in scored[:SCAN_BREAKAWAY_STARTS]]


def _start(e: Effect, data: AuditData) -> float:
    """Where the fit of an effect starts: where its parameter has a slope on these data."""
    lo, hi = e.bounds
    if e.start_from == "t_out_high":  # a full scale: at the top of the output's readings
        return float(np.clip(np.percentile(data.t_out_n, 99.5), lo, hi))
    if e.start_from == "t_in_low":  # a slack threshold: where the input tension is low
        return float(np.clip(np.percentile(data.inputs.t_in_n, 15.0), lo, hi))
    # bounded at "off" (viscous, lag): start a little inside
    return e.off + (e.scale if e.off <= lo else 0.0)


class _Evaluator:
    """The twin's reading of T_out_meas at chosen samples, for the fits (MAX_FIT_FRICTION_SAMPLES:
    the friction on every q-th sample on long records; FRICTION_CACHE: friction outputs reused
    while only the sensor's parameters change)."""

    def __init__(self, data: AuditData, coarse: bool = True):
        """coarse: the grid at least FIT_FRICTION_STEP_S; else only as MAX_FIT_FRICTION_SAMPLES
        needs."""
        self.data = data
        inp = data.inputs
        self.n = len(inp.t_in_n)
        self.q = max(
            1,
            math.ceil(self.n / MAX_FIT_FRICTION_SAMPLES),
            int(FIT_FRICTION_STEP_S / inp.dt_s + 1e-9) if coarse else 1,
        )
        if self.q == 1:
            self.inputs = inp
        else:
            sl = slice(None, None, self.q)
            self.inputs = PlantInputs(  # contiguous once, not copied at every friction run
                t_in_n=np.ascontiguousarray(inp.t_in_n[sl], dtype=np.float64),
                phi_rad=np.ascontiguousarray(inp.phi_rad[sl], dtype=np.float64),
                z_m=np.ascontiguousarray(inp.z_m[sl], dtype=np.float64),
                x_m=None if inp.x_m is None else np.ascontiguousarray(inp.x_m[sl]),
                y_m=None if inp.y_m is None else np.ascontiguousarray(inp.y_m[sl]),
                position_m=None,
                t0_s=inp.t0_s,
                dt_s=inp.dt_s * self.q,
                sheath_length_m=inp.sheath_length_m,
                loop_routing=inp.loop_routing,
            )
        self._cache: dict[tuple, list] = {}
        self.friction_runs = 0

    def on_grid(self, indices: np.ndarray, stride: int) -> np.ndarray:
        """Every stride-th of the indices, taken among those on the friction's grid."""
        if self.q > 1:
            indices = indices[indices % self.q == 0]
            stride = max(1, math.ceil(len(indices) / MAX_FIT_RESIDUALS))
        return indices[::stride]

    def _entry(self, params: dict[str, float], slopes: bool = False) -> list:
        """[friction on the grid, at every sample (friction_full), its slopes on the grid in
        the parameters twin.friction_derivatives gives (with `slopes`, where supported)]."""
        key = tuple(params.get(k, 0.0) for k in twin.FRICTION_PARAMS)
        entry = self._cache.pop(key, None)
        if slopes and (entry is None or entry[2] is None) and twin.derivatives_supported(params):
            # the same friction (twin.friction_derivatives), with its slopes beside it
            y, slope = twin.friction_derivatives(self.inputs, params, smooth=True)
            entry = [y, None if entry is None else entry[1], slope]
            self.friction_runs += 1
        elif entry is None:
            entry = [twin.friction_output(self.inputs, params, smooth=True), None, None]
            self.friction_runs += 1
            while len(self._cache) >= FRICTION_CACHE:
                del self._cache[next(iter(self._cache))]
        self._cache[key] = entry  # most recently used last
        return entry

    def friction_full(self, params: dict[str, float]) -> np.ndarray:
        """The friction part at every sample (interpolated between the grid's samples)."""
        entry = self._entry(params)
        if self.q == 1:
            return entry[0]
        if entry[1] is None:
            grid = np.arange(0, self.n, self.q, dtype=np.float64)
            entry[1] = np.interp(np.arange(self.n, dtype=np.float64), grid, entry[0])
        return entry[1]

    def reading(
        self, params: dict[str, float], idx: np.ndarray, slopes: bool = False
    ) -> np.ndarray:
        """The twin's T_out_meas at idx (on the grid when q > 1). With q > 1, a creep or a lag
        (no delay) is filtered on the grid itself: each first-order stage as the full rate's
        filter of an input linear between the grid's samples (_grid_lag). `slopes`: keep the
        friction's slopes with it where they can be had (slope)."""
        if slopes:
            self._entry(params, slopes=True)
        dt = self.data.inputs.dt_s
        if self.q > 1 and float(params.get("sensor_delay", 0.0)) == 0.0:
            y = self._entry(params)[0]
            creep = float(params.get("sensor_creep", 0.0))
            if creep != 0.0:
                y = y - creep * (y - _grid_lag(y, float(params["sensor_creep_tau"]), dt, self.q))
            tau2 = float(params.get("sensor_tau2", 0.0))
            if tau2 > 0.0:
                y = _grid_lag(_grid_lag(y, tau2, dt, self.q), tau2, dt, self.q)
            tau = float(params.get("sensor_tau", 0.0))
            if tau > 0.0:
                y = _grid_lag(y, tau, dt, self.q)
            static = {k: v for k, v in params.items() if k not in twin.SENSOR_DYNAMIC_PARAMS}
            return twin.sensor_output_at(y, static, dt, idx // self.q)
        return twin.sensor_output_at(self.friction_full(params), params, dt, idx)

    def _linear(self, y: np.ndarray, params: dict[str, float], idx: np.ndarray) -> np.ndarray:
        """The sensor's linear part (creep, lags, delay, gain) of friction `y` (on the grid
        when q > 1, as reading takes it) at idx: reading is saturate(this + offset)."""
        dt = self.data.inputs.dt_s
        p = twin._full(params)
        gain = float(p["sensor_gain"])
        if self.q > 1 and float(p["sensor_delay"]) == 0.0:
            creep = float(p["sensor_creep"])
            if creep != 0.0:
                y = y - creep * (y - _grid_lag(y, float(p["sensor_creep_tau"]), dt, self.q))
            tau2 = float(p["sensor_tau2"])
            if tau2 > 0.0:
                y = _grid_lag(_grid_lag(y, tau2, dt, self.q), tau2, dt, self.q)
            tau = float(p["sensor_tau"])
            if tau > 0.0:
                y = _grid_lag(y, tau, dt, self.q)
            return gain * y[idx // self.q]
        if self.q > 1:
            grid = np.arange(0, self.n, self.q, dtype=np.float64)
            y = np.interp(np.arange(self.n, dtype=np.float64), grid, y)
        y = twin._creep_and_lag(y, p, dt)
        m = twin.delay_samples(float(p["sensor_delay"]), dt)
        return gain * (y[np.maximum(idx - m, 0)] if m > 0 else y[idx])

    def slope(
        self, params: dict[str, float], idx: np.ndarray, names: list[str]
    ) -> dict[str, np.ndarray] | None:
        """The reading's derivatives at idx in those of `names` the friction's slopes kept by
        reading(params, idx, slopes=True) cover (twin.DERIVATIVE_PARAMS; the sensor's part is
        linear up to its full scale, differentiated as saturate's slope); None where they were
        not kept."""
        entry = self._entry(params)
        if entry[2] is None:
            return None
        p = twin._full(params)
        scale = 1.0
        full_scale = float(p["sensor_full_scale"])
        if full_scale > 0.0:
            r = self._linear(entry[0], params, idx) + float(p["sensor_offset"])
            knee = float(p["sensor_saturation_knee"])
            if knee <= 0.0:
                scale = (r < full_scale).astype(np.float64)
            else:
                scale = 0.5 * (1.0 - (r - full_scale) / np.sqrt((r - full_scale) ** 2 + knee**2))
        # at no excess the breakaway has no first-order slope (_breakaway_starts): its column
        # by differences, as before
        names = [n for n in names if n in entry[2] and (n != "mu_static_excess" or p[n] > 0.0)]
        return {n: scale * self._linear(entry[2][n], params, idx) for n in names}


def _grid_lag(u: np.ndarray, tau_s: float, dt_s: float, q: int) -> np.ndarray:
    """The twin's first-order lag (y_k = a y_(k-1) + (1 - a) u_k at dt_s, a = exp(-dt_s/tau_s),
    starting settled) read every q-th sample, for an input linear between those samples:
    y_n = a^q y_(n-1) + b0 u_(n-1) + b1 u_n with b1 = (1 - a) sum_(i=1..q) a^(q-i) i / q and
    b0 = 1 - a^q - b1 (the q steps summed)."""
    a = math.exp(-dt_s / tau_s)
    i = np.arange(1, q + 1, dtype=np.float64)
    b1 = float((1.0 - a) * np.sum(a ** (q - i) * i / q))
    aq = a**q
    b0 = 1.0 - aq - b1
    return lfilter([b1, b0], [1.0, -aq], u, zi=[(1.0 - b1) * u[0]])[0]


def _sse(ev: _Evaluator, params: dict[str, float], idx: np.ndarray) -> float:
    r = ev.data.t_out_n[idx] - ev.reading(params, idx)
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


def _least_squares(ev: _Evaluator, params, names, idx):
    lo, hi, scale = (np.array(v) for v in zip(*(_bounds_and_scale(n) for n in names), strict=True))
    x0 = np.clip(np.array([params[n] for n in names]), lo, hi) / scale
    y = ev.data.t_out_n[idx]

    slopes = any(n in twin.DERIVATIVE_PARAMS for n in names)

    def point(x):
        p = dict(params)
        p.update(zip(names, x * scale, strict=True))
        return p

    def fun(x):
        return ev.reading(point(x), idx, slopes) - y

    def jac(x):
        """mu's, the spread's and the excess's columns from the friction's slopes
        (_Evaluator.slope), the others (and those, where the slopes are not had) by forward
        differences as least_squares takes them (its own approx_derivative, diff_step)."""
        p = point(x)
        exact = ev.slope(p, idx, names) if slopes else None
        exact = exact or {}
        out = np.empty((len(y), len(names)))
        rest = [i for i, name in enumerate(names) if name not in exact]
        for i, name in enumerate(names):
            if name in exact:
                out[:, i] = exact[name] * scale[i]
        if rest:

            def fun_rest(xr):
                xf = x.copy()
                xf[rest] = xr
                return ev.reading(point(xf), idx) - y  # (no slopes at the steps)

            out[:, rest] = approx_derivative(
                fun_rest,
                x[rest],
                method="2-point",
                rel_step=DIFF_STEP,
                f0=ev.reading(p, idx) - y,
                bounds=(lo[rest] / scale[rest], hi[rest] / scale[rest]),
            )
        return out

    res = least_squares(
        fun,
        x0,
        jac=jac if slopes else "2-point",
        bounds=(lo / scale, hi / scale),
        x_scale=1.0,
        diff_step=DIFF_STEP,
        max_nfev=20 * (len(names) + 1),
        xtol=1e-5,
        ftol=1e-6,
    )
    out = dict(params)
    out.update(zip(names, (res.x * scale).tolist(), strict=True))
    return out, int(res.nfev)


def _scan_delay(ev: _Evaluator, params: dict[str, float], fit_idx: np.ndarray) -> float:
    """The whole-sample delay that fits best with the other parameters held (0 .. 0.2 s or a
    twentieth of the record): the sums of squares of every shift from two correlations."""
    data = ev.data
    dt = data.inputs.dt_s
    p = {**params, "sensor_delay": 0.0}
    offset = p.get("sensor_offset", 0.0)
    b = twin.sensor_output(ev.friction_full(p), p, dt) - offset
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
