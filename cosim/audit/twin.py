"""A fast twin of the plant FMU in drive mode 1, for fitting; and the FMU run that reports.

The audit fits models by simulating the whole record many times, which the FMU through ctypes
(about 10 us a sample) cannot afford; `simulate` runs the same equations as
fmu/src/bowden_physics.c in drive mode 1 (the inlet tension prescribed, fmu/README.md "Drive mode
1") compiled with numba, about 0.05 us per sample and node. Every figure the audit reports comes
from `run_fmu`, the FMU itself, and a test holds the two together.

What the twin reproduces, step for step (fmu/README.md, "Sheath friction", "Effects"):

- the sheath as BOWDEN_N_SEG = 32 segments; each node keeps its tension unless the capstan bound
  to its neighbour, T_{k-1} exp(-mu dphi) <= T_k <= T_{k-1} exp(+mu dphi), pushes it (Eq. 1-3,
  the dead zone at reversals included), with dphi = max(0, phi(x, y, z) + phi_offset_per_x x
  + phi_offset_per_y y + phi_offset_per_z z + the quadratic surface phi_offset_per_xx x^2 + ...
  + phi_offset_per_yz y z)/32;
- mu_eff = mu + mu_viscous |v_c| + mu_viscous_tension_rate |r_in| + mu_drift t
  + mu_warmup (1 - exp(-(t - t0) / mu_warmup_tau)) + mu_step [t >= mu_step_time]
  + d(t) (the drift table mu_drift_table_0 .. on its knots: drift_table_value)
  (+ mu_tension_slope T_{k-1} per segment), with v_c the rate of the cable's inlet displacement
  (stretch in the sheath / EA + T_out / k_lc) and r_in the rate of the inlet tension, each
  low-pass filtered with 10 ms, as the FMU computes them after each step and uses in the next;
- the gradual dead zone (fmu/README.md, "Gradual dead zone"): with dead_zone_spread > 0 the
  output is T_n * mean_j(S_j) / S_ref over N_STRAND = 32 lumped capstans of log-normally
  spread widths (their factors follow a small change of the widths by a polynomial,
  STRAND_STEP_MAX: the FMU's numbers to round-off);
- static friction (fmu/README.md, "Static friction"): the strands remember the way they last
  slid, and one that must reverse is held by the breakaway width (mu + mu_static_excess) phi
  before it jumps to the kinetic bound; slack: T_out * min(1, T_in / slack_tension), times
  1 - L(T_in) (the slack table slack_table_0 .. on its knots: slack_table_value);
- the output sensor: the load cell's creep (sensor_creep, sensor_creep_tau), the second-order
  lag sensor_tau2 (two equal first-order stages, exact for a value held over the sample),
  first-order lag sensor_tau (exact for a step held over the sample), pure delay sensor_delay (a
  whole number of samples here, which the FMU then reproduces exactly), gain and offset, and the
  full scale (sensor_full_scale, a hard clip or a hyperbolic knee sensor_saturation_knee). With
  both creep and lag on, the FMU's lag sees the creep move within a sample, which the twin's
  per-sample cascade does not (a difference of the order of sensor_creep * dt / sensor_creep_tau
  of a step); so does the first-order lag after the second-order one (20 mN at the FMU's default
  step on a test input; the audit runs one internal step per sample, where they agree, and never
  fits both lags).

For the fits, `friction_derivatives` runs the same friction with its derivatives in mu, the
spread and static friction's excess beside it (forward mode, each clamp and breakaway on the side
it takes; the output the same numbers), where no friction term follows the cable's motion or the
tension: the Jacobian's columns for those parameters in one run instead of one run each.

Assumptions of the twin that the FMU does not make: the friction of a step uses the time at its
start for mu_drift, mu_warmup, mu_step and the drift table (the FMU moves it on by each internal
step of max_step within a sample: a change of at most mu_drift * 1 ms, and a step seen up to one
sample earlier; with one internal step per sample, as the audit runs it, the two agree), and the
cable's axial rigidity and the load cell's stiffness are the FMU's defaults (they enter only
through v_c, so only mu_viscous depends on them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.signal import lfilter, lfilter_zi
from scipy.stats import norm

# Constants of fmu/src/bowden_physics.[ch] and the FMU's defaults (fmu/gen_model.py); a test
# compares them with the built FMU.
N_SEG = 32  # BOWDEN_N_SEG
N_STRAND = 32  # BOWDEN_N_STRAND
# STRAND_Q of bowden_physics.c: standard normal quantiles at (j + 1/2) / N_STRAND (the C table
# holds these numbers; tests/fmu/test_fmu_dead_zone.py compares them)
STRAND_Q = norm.ppf((np.arange(N_STRAND) + 0.5) / N_STRAND)
# A change of the strands' width w from one sample to the next of at most this much (times the
# widest strand's scale) updates their factors exp(w s_j) by exp(dw s_j) to degree 6, whose
# truncation (x^7 / 5040 < 2e-18) is below round-off, instead of a libm exp and a division per
# strand; after STRAND_EXACT_EVERY such updates they are computed exactly again, so round-off
# cannot build up (the FMU's numbers to about 1e-13 relative in between).
STRAND_STEP_MAX = 0.01
STRAND_EXACT_EVERY = 1024
SPEED_TAU_S = 0.01  # BOWDEN_SPEED_TAU_S, filter of the cable speed v_c and the tension rate
CABLE_EA_N = 8000.0  # cable_EA default
LOADCELL_N_PER_M = 2e5  # loadcell_stiffness default


@dataclass(frozen=True)
class PlantInputs:
    """What drives the twin and the FMU, one value per sample at a fixed step dt_s."""

    t_in_n: np.ndarray  # inlet tension (T_in_cmd of drive mode 1)
    phi_rad: np.ndarray  # bending angle from the geometry (before the phi_offset_per_* effects)
    z_m: np.ndarray  # z of the end-effector (for phi_offset_per_z)
    position_m: np.ndarray | None  # (n, 3) positions for the FMU, None: constant phi
    t0_s: float  # time of the first sample
    dt_s: float  # sample period
    sheath_length_m: float
    loop_routing: bool
    x_m: np.ndarray | None = None  # x of the end-effector (for phi_offset_per_x), None: 0
    y_m: np.ndarray | None = None  # y of the end-effector (for phi_offset_per_y), None: 0


def _phi_xy(inputs: PlantInputs, p: Mapping[str, float]) -> np.ndarray:
    """The geometry's phi plus the bending error along x and y and its quadratic surface (z's
    linear part is added in the kernel)."""
    phi = np.asarray(inputs.phi_rad, dtype=np.float64)
    for coord, key in ((inputs.x_m, "phi_offset_per_x"), (inputs.y_m, "phi_offset_per_y")):
        k = float(p[key])
        if k != 0.0 and coord is not None:
            phi = phi + k * np.asarray(coord, dtype=np.float64)
    if any(float(p[k]) != 0.0 for k in BEND_SURFACE_PARAMS):
        phi = phi + bend_surface_value(p, *_coords(inputs))
    return phi


def _coords(inputs: PlantInputs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, y and z of every sample (a missing coordinate 0)."""
    z = np.asarray(inputs.z_m, dtype=np.float64)
    x = np.zeros_like(z) if inputs.x_m is None else np.asarray(inputs.x_m, dtype=np.float64)
    y = np.zeros_like(z) if inputs.y_m is None else np.asarray(inputs.y_m, dtype=np.float64)
    return x, y, z


# The bending error's free form (fmu/README.md "Bending angle error"): a quadratic surface of
# the position, phi_offset_per_ab * a * b for each pair of coordinates (rad/m^2).
BEND_SURFACE_TERMS = ("xx", "yy", "zz", "xy", "xz", "yz")
BEND_SURFACE_PARAMS = tuple(f"phi_offset_per_{ab}" for ab in BEND_SURFACE_TERMS)


def bend_surface_value(
    params: Mapping[str, float], x: np.ndarray, y: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """The quadratic surface's bending (rad) at positions x, y, z: effective_phi() of
    bowden_physics.c, its quadratic part."""
    c = {"x": x, "y": y, "z": z}
    out = np.zeros(np.shape(x))
    for ab, key in zip(BEND_SURFACE_TERMS, BEND_SURFACE_PARAMS, strict=True):
        k = float(params.get(key, 0.0))
        if k != 0.0:
            out = out + k * c[ab[0]] * c[ab[1]]
    return out


@njit(cache=True)
def _exp_small(x):
    """exp(x) for a per-segment friction angle +-mu*dphi (typically 0.02 rad): a degree-6 Taylor
    polynomial (Horner, multiplications only) for |x| <= 0.06 rad, relative error < 6e-13; libm
    beyond. Called for exp(+x) and exp(-x), two independent chains instead of exp and a division.
    """
    if x < -0.06 or x > 0.06:
        return math.exp(x)
    s = 1.0 + x * 0.16666666666666666
    s = 1.0 + x * 0.2 * s
    s = 1.0 + x * 0.25 * s
    s = 1.0 + x * 0.3333333333333333 * s
    s = 1.0 + x * 0.5 * s
    return 1.0 + x * s


@njit(cache=True)
def _strand_bounds_sloped(tin, e, mu_sc, sl, phi):
    """A strand's kinetic or breakaway bounds (lo, hi) with a tension slope: strand_bounds_sloped
    of bowden_physics.c (the capstan with the strand's coefficient (mu + slope T) sc over the
    whole bend; e = exp(mu sc phi)), the same operations in the same order."""
    qf = (e - 1.0) / mu_sc if mu_sc > 0.0 else phi
    den_lo = e + sl * qf * tin
    den_hi = 1.0 - sl * qf * tin
    lo = tin / (den_lo if den_lo > 1.0 else 1.0)
    if den_hi <= 0.0:
        hi = 1.7976931348623157e308
    else:
        g = e / den_hi
        hi = tin * (g if g > 1.0 else 1.0)
    return lo, hi


@njit(cache=True)
def _friction(
    t_in,
    dphi_geom,
    z,
    phi_off,
    mu,
    mu_visc,
    mu_rate,
    slope,
    drift,
    warm,
    warm_tau,
    step,
    step_t,
    table,
    spread,
    static,
    slack,
    t0,
    dt,
    ds,
    ea,
    klc,
    n_seg,
    smooth,
    strand_q,
):
    """T_out (true) at every sample: the drive-mode-1 physics of bowden_physics.c, with the
    strands at the standard normal quantiles `strand_q` (STRAND_Q: the FMU's). With
    `smooth` (the fits only: friction_output), a strand's breakaway jump is spread over the
    sample it falls in by where, between the two samples, its threshold was crossed
    (linearly): the output then moves continuously with the parameters instead of by whole
    samples."""
    n = t_in.shape[0]
    n_str = strand_q.shape[0]
    out = np.empty(n)
    tens = np.zeros(n_seg + 1)
    strands = np.zeros(n_str + 1)
    direction = np.zeros(n_str + 1)
    use_strands = spread > 0.0 or static > 0.0
    alpha_speed = 1.0 - math.exp(-dt / 0.01)
    speed = 0.0
    disp_prev = 0.0
    rate = 0.0  # the inlet tension's rate, filtered as the cable speed
    tin_prev = 0.0
    # The exponentials depend on the sample only through mu_c * dphi (the segments) and the
    # strands' widths w, ws: computed again only when those change (the same expressions, so
    # the same numbers; positions are held for seconds and mu_c is constant without viscous
    # friction or drift).
    strand_sc = np.empty(n_str + 1)
    for j in range(n_str + 1):
        strand_sc[j] = math.exp(spread * (strand_q[j] if j < n_str else 0.0))
    strand_e = np.empty(n_str + 1)
    strand_es = np.empty(n_str + 1)
    strand_ie = np.empty(n_str + 1)  # 1 / strand_e: a product per strand and sample, not a
    strand_ies = np.empty(n_str + 1)  # quotient (bowden_physics.c multiplies the same way)
    # each strand's breakaway thresholds of the sample before (smooth): tin / es_j, tin * es_j
    brk_lo = np.zeros(n_str + 1)
    brk_hi = np.zeros(n_str + 1)
    w_prev = -1.0
    ws_prev = -1.0
    since_exact = 0  # small updates of the strands' factors since they were computed exactly
    sc_max = strand_sc[n_str - 1] if n_str > 0 else 1.0  # the widest strand's scale
    seg_arg_prev = -1.0
    base_arg_prev = -1.0
    bp = 1.0
    bm = 1.0
    ep = 1.0
    em = 1.0
    # Without viscous friction and drift mu is the same at every sample; while phi also stays,
    # a segment the input's change did not move leaves every segment after it where it is
    # (each was inside its bounds from its unchanged neighbour after the last sample), so the
    # sweep stops there: the same numbers. (The stretch, summed only up to there, feeds only the
    # cable speed, which then enters nothing.)
    use_table = table.shape[0] == n  # else empty: no drift table
    may_stop = (
        mu_visc == 0.0
        and mu_rate == 0.0
        and drift == 0.0
        and warm == 0.0
        and step == 0.0
        and not use_table
    )
    dphi_prev = -1.0
    for k in range(n):
        # friction_now(): mu from the cable speed of the last step and the time at the step start
        t = t0 + (k - 1) * dt if k > 0 else t0
        mu_base = mu + mu_visc * abs(speed) + mu_rate * abs(rate) + drift * t
        if warm != 0.0:
            mu_base += warm * (1.0 - math.exp(-(t - t0) / warm_tau))
        if step != 0.0 and t >= step_t:
            mu_base += step
        if use_table and table[k] != 0.0:
            mu_base += table[k]
        mu_c = mu_base if mu_base > 0.0 else 0.0
        phi = dphi_geom[k] + phi_off * z[k]
        dphi = (phi if phi > 0.0 else 0.0) / n_seg
        if mu_c * dphi != seg_arg_prev:
            seg_arg_prev = mu_c * dphi
            ep = math.exp(mu_c * dphi)
            em = 1.0 / ep
        if slope != 0.0 and mu_base * dphi != base_arg_prev:
            base_arg_prev = mu_base * dphi
            bp = math.exp(mu_base * dphi)
            bm = math.exp(-mu_base * dphi)
        sd = slope * dphi
        tin = t_in[k] if t_in[k] > 0.0 else 0.0
        tens[0] = tin
        stretch = 0.0
        stop = may_stop and k > 0 and dphi == dphi_prev
        dphi_prev = dphi
        for j in range(1, n_seg + 1):
            if slope != 0.0:
                tp = tens[j - 1]
                m = mu_base + slope * tp
                if m > 0.0:
                    y = sd * tp
                    if -0.01 <= y <= 0.01:
                        # exp((mu_base + slope T) dphi) = exp(mu_base dphi) exp(y): y small, its
                        # exponential to degree 4 (Estrin), relative error < 1e-12
                        y2 = y * y
                        c = 0.5 + y2 * 0.041666666666666664
                        d = y * (1.0 + y2 * 0.16666666666666666)
                        lo = tp * bm * (1.0 - d + y2 * c)
                        hi = tp * bp * (1.0 + d + y2 * c)
                    else:
                        lo = tp * _exp_small(-m * dphi)
                        hi = tp * _exp_small(m * dphi)
                else:
                    lo = tp
                    hi = tp
            else:
                lo = tens[j - 1] * em
                hi = tens[j - 1] * ep
            if tens[j] < lo:
                tens[j] = lo
            elif tens[j] > hi:
                tens[j] = hi
            elif stop:
                break
            stretch += 0.5 * (tens[j - 1] + tens[j])
        out[k] = tens[n_seg]
        if use_strands:
            # strands_update and output_tension of bowden_physics.c (gradual dead zone, static
            # friction: a strand that must reverse is held by the breakaway width, then slides
            # to the kinetic bound)
            w = mu_c * (phi if phi > 0.0 else 0.0)
            ws = (mu_c + static) * (phi if phi > 0.0 else 0.0)
            dw = w - w_prev
            if (
                static == 0.0
                and w_prev >= 0.0
                and dw != 0.0
                and abs(dw) * sc_max <= STRAND_STEP_MAX
                and since_exact < STRAND_EXACT_EVERY
            ):
                # a small change of the width (mu drifting, or following a rate, from one
                # sample to the next): each factor times exp(dw s_j), by a polynomial exact to
                # round-off at these arguments, where a libm exp and a division per strand
                # cost most of the fits' time
                since_exact += 1
                w_prev = w
                ws_prev = ws
                for j in range(n_str + 1):
                    x = dw * strand_sc[j]
                    # exp(x) and exp(-x) to degree 6 (Horner), from the even and odd parts
                    x2 = x * x
                    even = 1.0 + x2 * (0.5 + x2 * (1.0 / 24.0 + x2 * (1.0 / 720.0)))
                    odd = x * (1.0 + x2 * (1.0 / 6.0 + x2 * (1.0 / 120.0)))
                    strand_e[j] *= even + odd
                    strand_ie[j] *= even - odd
            elif w != w_prev or ws != ws_prev:
                since_exact = 0
                w_prev = w
                ws_prev = ws
                if static == 0.0:  # the breakaway factors are the kinetic ones
                    for j in range(n_str + 1):
                        strand_e[j] = math.exp(w * strand_sc[j])
                        strand_ie[j] = 1.0 / strand_e[j]
                else:
                    for j in range(n_str + 1):
                        strand_e[j] = math.exp(w * strand_sc[j])
                        strand_ie[j] = 1.0 / strand_e[j]
                        if j < n_str:
                            strand_es[j] = math.exp(ws * strand_sc[j])
                        else:
                            strand_es[j] = strand_e[j]
                        strand_ies[j] = 1.0 / strand_es[j]
            total = 0.0
            phi_s = phi if phi > 0.0 else 0.0
            if static == 0.0 and slope == 0.0:
                # no breakaway part: every strand slides at its kinetic bounds (the loop below
                # with es = e, without its bookkeeping)
                # (the way each slid is read only by the breakaway part: not kept here)
                for j in range(n_str + 1):
                    # lo <= hi (the factors are >= 1): the clamp, without branches
                    strands[j] = min(max(strands[j], tin * strand_ie[j]), tin * strand_e[j])
                for j in range(n_str):
                    total += strands[j]
            else:
                for j in range(n_str + 1):
                    # each strand's kinetic bounds (klo, khi) and breakaway bounds (slo, shi);
                    # with a slope every width follows the tension as the segments' do
                    # (strands_update of bowden_physics.c): the whole bend's sloped capstan
                    if slope != 0.0:
                        klo, khi = _strand_bounds_sloped(
                            tin, strand_e[j], mu_c * strand_sc[j], slope * strand_sc[j], phi_s
                        )
                        if static != 0.0 and j < n_str:
                            slo, shi = _strand_bounds_sloped(
                                tin,
                                strand_es[j],
                                (mu_c + static) * strand_sc[j],
                                slope * strand_sc[j],
                                phi_s,
                            )
                        else:
                            slo = klo
                            shi = khi
                    else:
                        klo = tin * strand_ie[j]
                        khi = tin * strand_e[j]
                        slo = tin * strand_ies[j]
                        shi = tin * strand_es[j]
                    lo = klo if direction[j] > 0.0 else slo
                    hi = khi if direction[j] < 0.0 else shi
                    held = strands[j]
                    share = 1.0  # of the jump in this sample's output (smooth, breakaway only)
                    jumps = smooth and static != 0.0 and k > 0
                    if held < lo:
                        if jumps and direction[j] <= 0.0 and lo - brk_lo[j] > 0.0:
                            share = min(1.0, (lo - held) / (lo - brk_lo[j]))
                        strands[j] = klo
                        direction[j] = 1.0
                    elif held > hi:
                        if jumps and direction[j] >= 0.0 and brk_hi[j] - hi > 0.0:
                            share = min(1.0, (held - hi) / (brk_hi[j] - hi))
                        strands[j] = khi
                        direction[j] = -1.0
                    if smooth:
                        brk_lo[j] = slo
                        brk_hi[j] = shi
                    if j < n_str:
                        total += held + share * (strands[j] - held)
            if strands[n_str] > 0.0:
                out[k] = tens[n_seg] * (total / n_str) / strands[n_str]
        if slack > 0.0 and tin < slack:
            out[k] *= tin / slack
        disp = stretch * ds / ea + tens[n_seg] / klc
        if k > 0:
            speed += ((disp - disp_prev) / dt - speed) * alpha_speed
            rate += ((tin - tin_prev) / dt - rate) * alpha_speed
        disp_prev = disp
        tin_prev = tin
    return out


def friction_output(
    inputs: PlantInputs,
    params: Mapping[str, float],
    smooth: bool = False,
    strand_q: np.ndarray | None = None,
) -> np.ndarray:
    """True T_out of the twin (no sensor): the friction part of the model (smooth: the
    breakaway jumps spread over their sample, for the fits; _friction). `strand_q`: other
    quantiles for the strands than the FMU's STRAND_Q (cosim.studies.strands compares counts)."""
    p = _full(params)
    out = _friction(
        np.ascontiguousarray(inputs.t_in_n, dtype=np.float64),
        np.ascontiguousarray(_phi_xy(inputs, p), dtype=np.float64),
        np.ascontiguousarray(inputs.z_m, dtype=np.float64),
        float(p["phi_offset_per_z"]),
        float(p["mu"]),
        float(p["mu_viscous"]),
        float(p["mu_viscous_tension_rate"]),
        float(p["mu_tension_slope"]),
        float(p["mu_drift"]),
        float(p["mu_warmup"]),
        float(p["mu_warmup_tau"]),
        float(p["mu_step"]),
        float(p["mu_step_time"]),
        drift_table_at(inputs, p),
        float(p["dead_zone_spread"]),
        float(p["mu_static_excess"]),
        float(p["slack_tension"]),
        float(inputs.t0_s),
        float(inputs.dt_s),
        inputs.sheath_length_m / N_SEG,
        CABLE_EA_N,
        LOADCELL_N_PER_M,
        N_SEG,
        bool(smooth and float(p["mu_static_excess"]) > 0.0),
        np.ascontiguousarray(STRAND_Q if strand_q is None else strand_q, dtype=np.float64),
    )
    return _slack_table_applied(out, inputs, p)


def _slack_table_applied(out: np.ndarray, inputs: PlantInputs, p: Mapping[str, float]):
    """The output times (1 - the slack table's share lost), in place; untouched when the table
    is empty (every knot 0)."""
    knots = slack_table_knots(p)
    if np.any(knots):
        out *= 1.0 - slack_table_value(p, inputs.t_in_n)
    return out


@njit(cache=True)
def _friction_d(
    t_in,
    dphi_geom,
    z,
    phi_off,
    mu,
    drift,
    warm,
    warm_tau,
    step,
    step_t,
    table,
    spread,
    static,
    slack,
    t0,
    dt,
    n_seg,
    smooth,
    strand_q,
):
    """_friction's output and its derivatives in mu, dead_zone_spread and mu_static_excess, in
    one pass, where no friction term depends on the cable's motion or the tension (mu_viscous,
    mu_viscous_tension_rate and mu_tension_slope at 0) and spread > 0: the same operations as
    _friction for the output (the same numbers: a test compares them), and beside each state
    its derivative (forward mode), each clamp and each breakaway (its `smooth` share included)
    differentiated on the side it takes. The cable speed and the tension rate are left out:
    they enter nothing here."""
    n = t_in.shape[0]
    n_str = strand_q.shape[0]
    out = np.empty(n)
    d_mu = np.empty(n)
    d_sp = np.empty(n)
    d_st = np.empty(n)
    tens = np.zeros(n_seg + 1)
    dtens = np.zeros(n_seg + 1)  # d/d mu (the segments depend on neither of the others)
    strands = np.zeros(n_str + 1)
    direction = np.zeros(n_str + 1)
    s_mu = np.zeros(n_str + 1)  # the strands' derivatives
    s_sp = np.zeros(n_str + 1)
    s_st = np.zeros(n_str + 1)
    strand_sc = np.empty(n_str + 1)
    dsc = np.empty(n_str + 1)  # d strand_sc / d spread
    for j in range(n_str + 1):
        strand_sc[j] = math.exp(spread * (strand_q[j] if j < n_str else 0.0))
        dsc[j] = strand_sc[j] * (strand_q[j] if j < n_str else 0.0)
    strand_e = np.empty(n_str + 1)
    strand_es = np.empty(n_str + 1)
    strand_ie = np.empty(n_str + 1)
    strand_ies = np.empty(n_str + 1)
    # d(arg)/d(param) of exp(w sc_j) and exp(ws sc_j), whose derivatives are the factor times it
    ga_mu = np.zeros(n_str + 1)
    ga_sp = np.zeros(n_str + 1)
    gs_mu = np.zeros(n_str + 1)
    gs_sp = np.zeros(n_str + 1)
    gs_st = np.zeros(n_str + 1)
    brk_lo = np.zeros(n_str + 1)
    brk_hi = np.zeros(n_str + 1)
    bl_mu = np.zeros(n_str + 1)
    bl_sp = np.zeros(n_str + 1)
    bl_st = np.zeros(n_str + 1)
    bh_mu = np.zeros(n_str + 1)
    bh_sp = np.zeros(n_str + 1)
    bh_st = np.zeros(n_str + 1)
    w_prev = -1.0
    ws_prev = -1.0
    since_exact = 0
    sc_max = strand_sc[n_str - 1] if n_str > 0 else 1.0
    seg_arg_prev = -1.0
    ep = 1.0
    em = 1.0
    use_table = table.shape[0] == n  # else empty: no drift table
    may_stop = drift == 0.0 and warm == 0.0 and step == 0.0 and not use_table
    dphi_prev = -1.0
    for k in range(n):
        t = t0 + (k - 1) * dt if k > 0 else t0
        mu_base = mu + drift * t
        if warm != 0.0:
            mu_base += warm * (1.0 - math.exp(-(t - t0) / warm_tau))
        if step != 0.0 and t >= step_t:
            mu_base += step
        if use_table and table[k] != 0.0:
            mu_base += table[k]
        mu_c = mu_base if mu_base > 0.0 else 0.0
        dmc = 1.0 if mu_base > 0.0 else 0.0  # d mu_c / d mu
        phi = dphi_geom[k] + phi_off * z[k]
        phi_pos = phi if phi > 0.0 else 0.0
        dphi = phi_pos / n_seg
        if mu_c * dphi != seg_arg_prev:
            seg_arg_prev = mu_c * dphi
            ep = math.exp(mu_c * dphi)
            em = 1.0 / ep
        dep = ep * dphi * dmc
        dem = -em * dphi * dmc
        tin = t_in[k] if t_in[k] > 0.0 else 0.0
        tens[0] = tin
        stop = may_stop and k > 0 and dphi == dphi_prev
        dphi_prev = dphi
        for j in range(1, n_seg + 1):
            lo = tens[j - 1] * em
            hi = tens[j - 1] * ep
            if tens[j] < lo:
                tens[j] = lo
                dtens[j] = dtens[j - 1] * em + tens[j - 1] * dem
            elif tens[j] > hi:
                tens[j] = hi
                dtens[j] = dtens[j - 1] * ep + tens[j - 1] * dep
            elif stop:
                break
        out[k] = tens[n_seg]
        d_mu[k] = dtens[n_seg]
        d_sp[k] = 0.0
        d_st[k] = 0.0
        # The strands' factors as _friction brings them up to date, line for line: shared as a
        # numba function (even inlined) it cost 11 % of the kernel's time on this hot path.
        w = mu_c * phi_pos
        ws = (mu_c + static) * phi_pos
        dw = w - w_prev
        updated = False
        if (
            static == 0.0
            and w_prev >= 0.0
            and dw != 0.0
            and abs(dw) * sc_max <= STRAND_STEP_MAX
            and since_exact < STRAND_EXACT_EVERY
        ):
            since_exact += 1
            w_prev = w
            ws_prev = ws
            updated = True
            for j in range(n_str + 1):
                x = dw * strand_sc[j]
                x2 = x * x
                even = 1.0 + x2 * (0.5 + x2 * (1.0 / 24.0 + x2 * (1.0 / 720.0)))
                odd = x * (1.0 + x2 * (1.0 / 6.0 + x2 * (1.0 / 120.0)))
                strand_e[j] *= even + odd
                strand_ie[j] *= even - odd
        elif w != w_prev or ws != ws_prev:
            since_exact = 0
            w_prev = w
            ws_prev = ws
            updated = True
            if static == 0.0:
                for j in range(n_str + 1):
                    strand_e[j] = math.exp(w * strand_sc[j])
                    strand_ie[j] = 1.0 / strand_e[j]
            else:
                for j in range(n_str + 1):
                    strand_e[j] = math.exp(w * strand_sc[j])
                    strand_ie[j] = 1.0 / strand_e[j]
                    if j < n_str:
                        strand_es[j] = math.exp(ws * strand_sc[j])
                    else:
                        strand_es[j] = strand_e[j]
                    strand_ies[j] = 1.0 / strand_es[j]
        if updated:  # the factors are exp(+-w sc_j), exp(+-ws sc_j) (to round-off)
            for j in range(n_str + 1):
                ga_mu[j] = strand_sc[j] * phi_pos * dmc
                ga_sp[j] = w * dsc[j]
                if j < n_str:
                    gs_mu[j] = ga_mu[j]
                    gs_sp[j] = ws * dsc[j]
                    gs_st[j] = strand_sc[j] * phi_pos
                else:  # the reference strand's breakaway factor is its kinetic one
                    gs_mu[j] = ga_mu[j]
                    gs_sp[j] = ga_sp[j]
                    gs_st[j] = 0.0
        total = 0.0
        t_mu = 0.0
        t_sp = 0.0
        t_st = 0.0
        if static == 0.0:
            for j in range(n_str + 1):
                lo = tin * strand_ie[j]
                hi = tin * strand_e[j]
                if strands[j] < lo:  # min(max(s, lo), hi) with lo <= hi, on its side
                    strands[j] = lo
                    s_mu[j] = -lo * ga_mu[j]
                    s_sp[j] = -lo * ga_sp[j]
                elif strands[j] > hi:
                    strands[j] = hi
                    s_mu[j] = hi * ga_mu[j]
                    s_sp[j] = hi * ga_sp[j]
            for j in range(n_str):
                total += strands[j]
                t_mu += s_mu[j]
                t_sp += s_sp[j]
        else:
            for j in range(n_str + 1):
                e = strand_e[j]
                es = strand_es[j]
                if direction[j] > 0.0:
                    lo = tin * strand_ie[j]
                    lo_mu, lo_sp, lo_st = -lo * ga_mu[j], -lo * ga_sp[j], 0.0
                else:
                    lo = tin * strand_ies[j]
                    lo_mu, lo_sp, lo_st = -lo * gs_mu[j], -lo * gs_sp[j], -lo * gs_st[j]
                if direction[j] < 0.0:
                    hi = tin * e
                    hi_mu, hi_sp, hi_st = hi * ga_mu[j], hi * ga_sp[j], 0.0
                else:
                    hi = tin * es
                    hi_mu, hi_sp, hi_st = hi * gs_mu[j], hi * gs_sp[j], hi * gs_st[j]
                held = strands[j]
                h_mu, h_sp, h_st = s_mu[j], s_sp[j], s_st[j]
                share = 1.0
                c_mu, c_sp, c_st = 0.0, 0.0, 0.0  # the share's derivatives
                if held < lo:
                    if smooth and direction[j] <= 0.0 and k > 0 and lo - brk_lo[j] > 0.0:
                        num = lo - held
                        den = lo - brk_lo[j]
                        share = min(1.0, num / den)
                        if num / den < 1.0:
                            c_mu = ((lo_mu - h_mu) * den - num * (lo_mu - bl_mu[j])) / (den * den)
                            c_sp = ((lo_sp - h_sp) * den - num * (lo_sp - bl_sp[j])) / (den * den)
                            c_st = ((lo_st - h_st) * den - num * (lo_st - bl_st[j])) / (den * den)
                    strands[j] = tin * strand_ie[j]
                    s_mu[j] = -strands[j] * ga_mu[j]
                    s_sp[j] = -strands[j] * ga_sp[j]
                    s_st[j] = 0.0
                    direction[j] = 1.0
                elif held > hi:
                    if smooth and direction[j] >= 0.0 and k > 0 and brk_hi[j] - hi > 0.0:
                        num = held - hi
                        den = brk_hi[j] - hi
                        share = min(1.0, num / den)
                        if num / den < 1.0:
                            c_mu = ((h_mu - hi_mu) * den - num * (bh_mu[j] - hi_mu)) / (den * den)
                            c_sp = ((h_sp - hi_sp) * den - num * (bh_sp[j] - hi_sp)) / (den * den)
                            c_st = ((h_st - hi_st) * den - num * (bh_st[j] - hi_st)) / (den * den)
                    strands[j] = tin * e
                    s_mu[j] = strands[j] * ga_mu[j]
                    s_sp[j] = strands[j] * ga_sp[j]
                    s_st[j] = 0.0
                    direction[j] = -1.0
                if smooth:
                    brk_lo[j] = tin * strand_ies[j]
                    bl_mu[j] = -brk_lo[j] * gs_mu[j]
                    bl_sp[j] = -brk_lo[j] * gs_sp[j]
                    bl_st[j] = -brk_lo[j] * gs_st[j]
                    brk_hi[j] = tin * es
                    bh_mu[j] = brk_hi[j] * gs_mu[j]
                    bh_sp[j] = brk_hi[j] * gs_sp[j]
                    bh_st[j] = brk_hi[j] * gs_st[j]
                if j < n_str:
                    jump = strands[j] - held
                    total += held + share * jump
                    t_mu += h_mu + c_mu * jump + share * (s_mu[j] - h_mu)
                    t_sp += h_sp + c_sp * jump + share * (s_sp[j] - h_sp)
                    t_st += h_st + c_st * jump + share * (s_st[j] - h_st)
        ref = strands[n_str]
        if ref > 0.0:
            a = tens[n_seg]
            b = total / n_str
            out[k] = a * b / ref
            d_mu[k] = (dtens[n_seg] * b + a * t_mu / n_str) / ref - out[k] * s_mu[n_str] / ref
            d_sp[k] = a * t_sp / n_str / ref - out[k] * s_sp[n_str] / ref
            d_st[k] = a * t_st / n_str / ref - out[k] * s_st[n_str] / ref
        if slack > 0.0 and tin < slack:
            f = tin / slack
            out[k] *= f
            d_mu[k] *= f
            d_sp[k] *= f
            d_st[k] *= f
    return out, d_mu, d_sp, d_st


# the parameters friction_derivatives gives the output's slope in
DERIVATIVE_PARAMS = ("mu", "dead_zone_spread", "mu_static_excess")


def derivatives_supported(params: Mapping[str, float]) -> bool:
    """Whether friction_derivatives gives the slopes at these parameters (_friction_d)."""
    p = _full(params)
    return float(p["dead_zone_spread"]) > 0.0 and all(
        float(p[k]) == 0.0 for k in ("mu_viscous", "mu_viscous_tension_rate", "mu_tension_slope")
    )


def friction_derivatives(
    inputs: PlantInputs, params: Mapping[str, float], smooth: bool = False
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """friction_output(inputs, params, smooth) (the same numbers) and its derivatives in mu,
    dead_zone_spread and mu_static_excess, where derivatives_supported (_friction_d)."""
    p = _full(params)
    out, d_mu, d_sp, d_st = _friction_d(
        np.ascontiguousarray(inputs.t_in_n, dtype=np.float64),
        np.ascontiguousarray(_phi_xy(inputs, p), dtype=np.float64),
        np.ascontiguousarray(inputs.z_m, dtype=np.float64),
        float(p["phi_offset_per_z"]),
        float(p["mu"]),
        float(p["mu_drift"]),
        float(p["mu_warmup"]),
        float(p["mu_warmup_tau"]),
        float(p["mu_step"]),
        float(p["mu_step_time"]),
        drift_table_at(inputs, p),
        float(p["dead_zone_spread"]),
        float(p["mu_static_excess"]),
        float(p["slack_tension"]),
        float(inputs.t0_s),
        float(inputs.dt_s),
        N_SEG,
        bool(smooth and float(p["mu_static_excess"]) > 0.0),
        np.ascontiguousarray(STRAND_Q, dtype=np.float64),
    )
    if np.any(slack_table_knots(p)):  # the slack table's factor scales the slopes as the output
        kept = 1.0 - slack_table_value(p, inputs.t_in_n)
        out, d_mu, d_sp, d_st = out * kept, d_mu * kept, d_sp * kept, d_st * kept
    return out, {"mu": d_mu, "dead_zone_spread": d_sp, "mu_static_excess": d_st}


def _creep_and_lag(y: np.ndarray, p: Mapping[str, float], dt_s: float) -> np.ndarray:
    """The output sensor's creep and first-order lag applied to a true T_out (p: _full)."""
    creep = float(p["sensor_creep"])
    if creep != 0.0:
        # creep_lp follows T_out with sensor_creep_tau (exact for a value held over the sample)
        a = math.exp(-dt_s / float(p["sensor_creep_tau"]))
        lp = lfilter([1.0 - a], [1.0, -a], y, zi=[a * y[0]])[0]
        y = y - creep * (y - lp)
    tau2 = float(p["sensor_tau2"])
    if tau2 > 0.0:  # the second-order lag: 1 / (tau2 s + 1)^2 exact for a value held over the
        # sample, before the first-order lag (x2_k = u + a (x2 - u) + c a (x1 - u), c = dt/tau2)
        a = math.exp(-dt_s / tau2)
        c = dt_s / tau2
        b, den = [1.0 - a - c * a, a * a - a + c * a], [1.0, -2.0 * a, a * a]
        y = lfilter(b, den, y, zi=lfilter_zi(b, den) * y[0])[0]
    tau = float(p["sensor_tau"])
    if tau > 0.0:
        a = math.exp(-dt_s / tau)
        y = lfilter([1.0 - a], [1.0, -a], y, zi=[a * y[0]])[0]
    return y


def sensor_output(t_out_n: np.ndarray, params: Mapping[str, float], dt_s: float) -> np.ndarray:
    """The output sensor of the FMU applied to a true T_out: creep, lag, delay, gain, offset,
    full scale."""
    p = _full(params)
    y = _creep_and_lag(np.asarray(t_out_n, dtype=np.float64), p, dt_s)
    m = delay_samples(float(p["sensor_delay"]), dt_s)
    if m > 0:
        y = np.concatenate([np.full(min(m, len(y)), y[0]), y[: max(0, len(y) - m)]])
    return saturate(
        float(p["sensor_gain"]) * y + float(p["sensor_offset"]),
        float(p["sensor_full_scale"]),
        float(p["sensor_saturation_knee"]),
    )


SENSOR_DYNAMIC_PARAMS = ("sensor_creep", "sensor_tau", "sensor_tau2", "sensor_delay")


def sensor_dynamic(params: Mapping[str, float]) -> bool:
    """Whether the sensor has memory with these parameters (creep, lag or delay): then a reading
    needs the whole T_out before it, else it is a function of T_out at the same sample."""
    return any(float(params.get(k, 0.0)) != 0.0 for k in SENSOR_DYNAMIC_PARAMS)


def sensor_output_at(
    t_out_n: np.ndarray, params: Mapping[str, float], dt_s: float, idx: np.ndarray
) -> np.ndarray:
    """sensor_output(t_out_n, params, dt_s)[idx], the same numbers, with the sample-by-sample
    part (gain, offset, full scale) computed at idx only."""
    p = _full(params)
    y = _creep_and_lag(np.asarray(t_out_n, dtype=np.float64), p, dt_s)
    m = delay_samples(float(p["sensor_delay"]), dt_s)
    yi = y[np.maximum(idx - m, 0)] if m > 0 else y[idx]
    return saturate(
        float(p["sensor_gain"]) * yi + float(p["sensor_offset"]),
        float(p["sensor_full_scale"]),
        float(p["sensor_saturation_knee"]),
    )


def saturate(r: np.ndarray, full_scale_n: float, knee_n: float) -> np.ndarray:
    """The output sensor's full scale (saturate() of bowden_physics.c): none at 0, a hard clip
    with no knee, else the hyperbolic turn shifted so that zero reads zero."""
    if full_scale_n <= 0.0:
        return r
    if knee_n <= 0.0:
        return np.minimum(r, full_scale_n)
    f, k = full_scale_n, knee_n
    return 0.5 * (r + f - np.sqrt((r - f) ** 2 + k * k)) + 0.5 * (math.sqrt(f * f + k * k) - f)


def delay_samples(delay_s: float, dt_s: float) -> int:
    """The delay as a whole number of samples (the twin's resolution is one sample)."""
    return int(round(delay_s / dt_s))


def simulate(inputs: PlantInputs, params: Mapping[str, float]) -> np.ndarray:
    """T_out as the output sensor reads it (without noise), for FMU parameters `params`
    (names of fmu/gen_model.py; missing effects are off)."""
    return sensor_output(friction_output(inputs, params), params, inputs.dt_s)


# The friction drift's free form (fmu/README.md "Friction drift"): mu's change on
# DRIFT_TABLE_KNOTS evenly spaced knots (fmu/gen_model.py, BOWDEN_DRIFT_KNOTS of the FMU).
DRIFT_TABLE_KNOTS = 16
DRIFT_TABLE_KNOT_PARAMS = tuple(f"mu_drift_table_{i}" for i in range(DRIFT_TABLE_KNOTS))
DRIFT_TABLE_PARAMS = ("mu_drift_table_t0", "mu_drift_table_dt", *DRIFT_TABLE_KNOT_PARAMS)


def drift_table_knots(params: Mapping[str, float]) -> np.ndarray:
    """The drift table's knot values of these parameters (missing ones 0)."""
    return np.array([float(params.get(k, 0.0)) for k in DRIFT_TABLE_KNOT_PARAMS])


def drift_table_value(params: Mapping[str, float], t_s: np.ndarray) -> np.ndarray:
    """mu's change the drift table gives at FMU times t_s: drift_table() of bowden_physics.c, the
    same operations (linear between the knots, held flat outside)."""
    knots = drift_table_knots(params)
    t0 = float(params.get("mu_drift_table_t0", OFF["mu_drift_table_t0"]))
    step = float(params.get("mu_drift_table_dt", OFF["mu_drift_table_dt"]))
    s = (np.asarray(t_s, dtype=np.float64) - t0) / step
    last = DRIFT_TABLE_KNOTS - 1
    i = np.minimum(np.where(s > 0.0, s, 0.0), last - 1).astype(np.int64)
    inner = knots[i] + (s - i) * (knots[i + 1] - knots[i])
    return np.where(~(s > 0.0), knots[0], np.where(s >= last, knots[last], inner))


def drift_table_at(inputs: PlantInputs, params: Mapping[str, float]) -> np.ndarray:
    """The drift table's change of mu at each sample, at the time the friction of its step uses
    (_friction: the step's start); empty when every knot is 0 (the kernels then skip it)."""
    if not np.any(drift_table_knots(params)):
        return np.empty(0)
    n = len(inputs.t_in_n)
    k = np.arange(n, dtype=np.float64)
    t = np.where(k > 0, inputs.t0_s + (k - 1.0) * inputs.dt_s, inputs.t0_s)
    return np.ascontiguousarray(drift_table_value(params, t), dtype=np.float64)


# The slack's free form (fmu/README.md "Slack"): the share of the output lost at low input
# tension on SLACK_TABLE_KNOTS knots at T_in = i * slack_table_dt (fmu/gen_model.py,
# BOWDEN_SLACK_KNOTS of the FMU).
SLACK_TABLE_KNOTS = 8
SLACK_TABLE_KNOT_PARAMS = tuple(f"slack_table_{i}" for i in range(SLACK_TABLE_KNOTS))
SLACK_TABLE_PARAMS = ("slack_table_dt", *SLACK_TABLE_KNOT_PARAMS)


def slack_table_knots(params: Mapping[str, float]) -> np.ndarray:
    """The slack table's knot values of these parameters (missing ones 0)."""
    return np.array([float(params.get(k, 0.0)) for k in SLACK_TABLE_KNOT_PARAMS])


def slack_table_value(params: Mapping[str, float], t_in_n: np.ndarray) -> np.ndarray:
    """The share of the output the slack table loses at input tensions t_in_n: slack_table() of
    bowden_physics.c (linear between the knots, to 0 at SLACK_TABLE_KNOTS * slack_table_dt, 0
    above, the first knot's below 0)."""
    knots = np.append(slack_table_knots(params), 0.0)
    step = float(params.get("slack_table_dt", OFF["slack_table_dt"]))
    s = np.asarray(t_in_n, dtype=np.float64) / step
    last = SLACK_TABLE_KNOTS
    i = np.minimum(np.where(s > 0.0, s, 0.0), last - 1).astype(np.int64)
    inner = knots[i] + (s - i) * (knots[i + 1] - knots[i])
    return np.where(~(s > 0.0), knots[0], np.where(s >= last, 0.0, inner))


# The parameters of the friction part (the rest only change the sensor's reading).
FRICTION_PARAMS = (
    "mu",
    "mu_viscous",
    "mu_viscous_tension_rate",
    "mu_tension_slope",
    "phi_offset_per_z",
    "phi_offset_per_x",
    "phi_offset_per_y",
    "mu_drift",
    "mu_warmup",
    "mu_warmup_tau",
    "mu_step",
    "mu_step_time",
    "dead_zone_spread",
    "mu_static_excess",
    "slack_tension",
    *DRIFT_TABLE_PARAMS,
    *BEND_SURFACE_PARAMS,
    *SLACK_TABLE_PARAMS,
)

# Every parameter the twin knows, with its value when the effect is off.
OFF = {
    "mu": 0.075,
    "sensor_offset": 0.0,
    "sensor_gain": 1.0,
    "mu_viscous": 0.0,
    "mu_viscous_tension_rate": 0.0,
    "mu_tension_slope": 0.0,
    "phi_offset_per_z": 0.0,
    "sensor_tau": 0.0,
    "sensor_delay": 0.0,
    "mu_drift": 0.0,
    "mu_warmup": 0.0,
    "mu_warmup_tau": 60.0,
    "mu_step": 0.0,
    "mu_step_time": 0.0,
    "dead_zone_spread": 0.0,
    "mu_static_excess": 0.0,
    "slack_tension": 0.0,
    "sensor_full_scale": 0.0,
    "sensor_saturation_knee": 0.0,
    "sensor_creep": 0.0,
    "sensor_creep_tau": 1.0,
    "sensor_tau2": 0.0,
    "phi_offset_per_x": 0.0,
    "phi_offset_per_y": 0.0,
    **{k: 0.0 for k in DRIFT_TABLE_KNOT_PARAMS},
    "mu_drift_table_t0": 0.0,
    "mu_drift_table_dt": 1.0,
    **{k: 0.0 for k in BEND_SURFACE_PARAMS},
    **{k: 0.0 for k in SLACK_TABLE_KNOT_PARAMS},
    "slack_table_dt": 1.0,
}


def _full(params: Mapping[str, float]) -> dict[str, float]:
    unknown = set(params) - set(OFF)
    if unknown:
        raise KeyError(f"the twin has no parameter {sorted(unknown)[0]!r}")
    return {**OFF, **params}


# The FMU's largest internal step allowed (fmu/gen_model.py, max_step's maximum).
FMU_MAX_STEP_LIMIT_S = 1e-3


def fmu_step_for(dt_s: float) -> float:
    """The internal step the audit runs the FMU with: one per sample (at most the FMU's limit).
    In drive mode 1 the inlet tension is prescribed and held over the sample, so the internal
    steps only repeat the same tension profile (they integrate the motor, which this mode does
    not use); what moves within a sample is the time of mu_drift and the 10 ms filter of the
    cable speed, which the twin also steps once per sample. The FMU's default (100 us, chosen for
    the motor in drive mode 0) made its two runs most of a long audit's time."""
    return min(float(dt_s), FMU_MAX_STEP_LIMIT_S)


def run_fmu(
    inputs: PlantInputs,
    params: Mapping[str, float],
    fmu_path=None,
    max_step_s: float | None = None,
) -> np.ndarray:
    """T_out_meas from the plant FMU itself (cosim.parts.plant.Plant, drive mode 1, no noise),
    driven by the same inputs as the twin; the FMU starts at t0_s loaded from rest, as the twin.
    max_step_s: the FMU's internal step (None: its default; the audit: fmu_step_for)."""
    from cosim.parts.plant import Plant  # noqa: PLC0415 (needs the built FMU)

    p = _full(params)
    fmu_params: dict[str, float | int | bool] = {
        "drive_mode": 1,
        "loop_routing": bool(inputs.loop_routing),
        "sheath_length": float(inputs.sheath_length_m),
        **{k: float(v) for k, v in p.items()},
    }
    # The FMU's delay reads its own time grid; a whole number of samples keeps it on a sample.
    fmu_params["sensor_delay"] = delay_samples(p["sensor_delay"], inputs.dt_s) * inputs.dt_s
    if max_step_s is not None:
        fmu_params["max_step"] = float(max_step_s)
    n = len(inputs.t_in_n)
    pos = inputs.position_m
    if pos is None:
        pos = np.tile(fixed_position(inputs.sheath_length_m), (n, 1))
    out = np.empty(n)
    tin = inputs.t_in_n.tolist()
    xs, ys, zs = pos[:, 0].tolist(), pos[:, 1].tolist(), pos[:, 2].tolist()
    with Plant(
        fmu_params,
        inputs={"T_in_cmd": tin[0], "x": xs[0], "y": ys[0], "z": zs[0]},
        fmu_path=fmu_path,
        start_time_s=float(inputs.t0_s),
        instance_name="audit",
    ) as plant:
        out[0] = plant.y[plant.T_OUT_MEAS]
        u, step, dt, idx = plant.u, plant.step, float(inputs.dt_s), plant.T_OUT_MEAS
        for k in range(1, n):
            u[1] = tin[k]
            u[2] = xs[k]
            u[3] = ys[k]
            u[4] = zs[k]
            out[k] = step(dt)[idx]
    return out


def fixed_position(sheath_length_m: float) -> np.ndarray:
    """The position the FMU holds when the data have none: in the loop's plane (x = 0), half the
    sheath's length in front of the actuator (phi = 2 pi with loop routing)."""
    return np.array([0.0, 0.5 * sheath_length_m, 0.0])
