"""The compensator's breakaway term (comp.h, breakaway): the fixed point against its double twin,
off by default bit for bit, the law's three pieces after a reversal, its limits and saturation at
full scale, and the plant FMU's static friction driven open loop with the preview law's T_in."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from open_loop import (
    LSB,
    PHI,
    preview_open_loop_pct,
    reference,
    refusal_codes,
    twin_cases,
)

from cosim.parts import firmware as fw

CONFIGS = {
    "paper": fw.CompensatorParams(mode="paper", breakaway=0.034),
    "smooth": fw.CompensatorParams(mode="smooth", mu=0.09, phi_rad=7.0, breakaway=0.05),
    "preview": fw.CompensatorParams(mode="preview", breakaway=0.021),
    "preview-spread": fw.CompensatorParams(mode="preview", breakaway=0.034, dead_zone_spread=0.4),
    "preview-slope": fw.CompensatorParams(
        mode="preview", mu=0.0525, mu_slope_per_n=-0.001, offset_n=0.4, breakaway=0.25
    ),
    "preview-slope-up-spread": fw.CompensatorParams(
        mode="preview", mu=0.053, mu_slope_per_n=0.001, dead_zone_spread=0.3, breakaway=0.037
    ),
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_breakaway_fixed_matches_double_twin(name):
    """A random walk over the whole Q7.8 range and the reversals: |T_c fixed - T_c twin| within
    the compensator's documented bound (CompensatorParams.error_bound_n)."""
    params = CONFIGS[name]
    bound = params.error_bound_n()
    for label, words in twin_cases():
        fixed = fw.Compensator(params).run_words(words) * LSB
        twin = fw.CompensatorF64(params.quantized()).run(words * LSB)
        worst = float(np.max(np.abs(fixed - twin)))
        assert worst <= bound, f"{name}, {label}: {worst:.5f} N > bound {bound:.5f} N"


@pytest.mark.parametrize("mode", ["paper", "smooth", "preview"])
def test_without_a_breakaway_the_law_is_todays_bit_for_bit(mode):
    """breakaway 0 (the default) gives the same words as a compensator never given the field,
    and a breakaway changes them (the extension is not a no-op)."""
    words = np.round(reference() * 256).astype(np.int16)
    base = fw.Compensator(fw.CompensatorParams(mode=mode)).run_words(words)
    zero = fw.Compensator(fw.CompensatorParams(mode=mode, breakaway=0.0)).run_words(words)
    brk = fw.Compensator(fw.CompensatorParams(mode=mode, breakaway=0.03)).run_words(words)
    assert np.array_equal(base, zero)
    assert np.max(np.abs(brk.astype(int) - base.astype(int))) > 64


def test_the_three_pieces_after_a_reversal():
    """PAPER mode, H = 1 LSB, a ramp up to 12 N and down: the first loading carries no excess;
    after the top reversal T_c is T_ref e^(-W) e^(-b/2) (the jump's first half), then holds at
    Y e^(-(2W + 9b/8)) (Y the top's T_c: b/8 past the modelled breakaway), then follows T_ref
    e^(-W) again; the same in both twins."""
    params = fw.CompensatorParams(mode="paper", breakaway=0.03, hysteresis_n=LSB)
    q = params.quantized()
    w_n, b = q.mu * q.phi_rad, q.breakaway * q.phi_rad
    up = np.arange(2.0, 12.005, 0.01)
    down = np.arange(12.0 - 0.01, 4.0, -0.01)
    ref = np.round(np.concatenate([up, down]) * 256) * LSB
    twin = fw.CompensatorF64(q).run(ref)
    fixed = fw.Compensator(params).run_words(np.round(ref * 256).astype(np.int16)) * LSB
    assert np.max(np.abs(fixed - twin)) <= params.error_bound_n()
    n = len(up)
    assert twin[:n] == pytest.approx(ref[:n] * math.exp(w_n), rel=1e-9)
    after = ref[n:]
    hold = twin[n - 1] * math.exp(-(2 * w_n + 9 * b / 8))
    free = after * math.exp(-w_n)
    expected = np.clip(hold, free * math.exp(-b / 2), free)
    assert twin[n:] == pytest.approx(expected, rel=1e-9)
    # each piece is visited: the half jump, the hold, the free branch
    assert np.sum(expected == free * math.exp(-b / 2)) > 20
    assert np.sum(expected == hold) > 20
    assert np.sum(expected == free) > 20


def _turns(peak_n: float, valley_n: float, end_n: float) -> np.ndarray:
    """Q7.8 steps of 0.01 N from 2 N up to `peak_n`, down to `valley_n` and up to `end_n`."""
    legs = [
        np.arange(2.0, peak_n + 0.005, 0.01),
        np.arange(peak_n - 0.01, valley_n - 0.005, -0.01),
        np.arange(valley_n + 0.01, end_n + 0.005, 0.01),
    ]
    return np.round(np.concatenate(legs) * 256) * LSB


@pytest.mark.parametrize("slope", [0.001, -0.00076])
def test_the_hold_takes_the_dead_zones_width_at_the_turns_tension(slope):
    """With a tension slope the dead zone is G_up(X) / G_dn(X) wide at the turn's output tension
    X (comp.h): after the top reversal the hold is Y G_dn(X) / G_up(X) e^(-9b/8) where the slope
    widens the zone (a hold at the slope-free e^-(2W) would keep the cable stuck for the whole
    jump), Y e^-(2W + 9b/8) where it narrows it. PAPER mode, H = 1 LSB, in both twins."""
    params = fw.CompensatorParams(
        mode="paper", mu=0.053, mu_slope_per_n=slope, breakaway=0.037, hysteresis_n=LSB
    )
    q = params.quantized()
    w_n, b = q.mu * q.phi_rad, q.breakaway * q.phi_rad
    e = math.exp(w_n)
    qs = q.phi_rad * math.expm1(w_n) / w_n

    def gains(t):
        c = q.mu_slope_per_n * qs * t
        return e / (1.0 - c), 1.0 / (e + c)

    ref = _turns(15.0, 6.0, 6.0)
    twin = fw.CompensatorF64(q).run(ref)
    fixed = fw.Compensator(params).run_words(np.round(ref * 256).astype(np.int16)) * LSB
    assert np.max(np.abs(fixed - twin)) <= params.error_bound_n()
    top = int(np.argmax(ref))
    gu_x, gd_x = gains(ref[top + 1])  # the turn's tension: the step on which the detector turns
    width = max(math.log(gu_x / gd_x), 2 * w_n)
    assert (width > 2 * w_n + 0.1) == (slope > 0)  # the slope widens the zone at 15 N, or not
    hold = twin[top] * math.exp(-(width + 9 * b / 8))
    after = ref[top + 1 :]
    free = after * np.array([gains(t)[1] for t in after])
    expected = np.clip(hold, free * math.exp(-b / 2), free)
    assert twin[top + 1 :] == pytest.approx(expected, rel=1e-9)
    assert np.sum(expected == hold) > 20


def test_the_holds_factor_saturates_at_e4_on_a_wide_loading_turn():
    """mu 0.2, a slope of 0.0015 /N and the largest breakaway the check lets through with it: at
    a loading turn at 6 N the zone is e^2.66 wide and the hold's factor e^(2.66 + 9b/8) = e^4.08
    goes past e^4, where both twins hold it; as T_ref rises to 15 N the output is the plain law's
    T_c0 clamped to [T_c0, T_c0 e^(b/2)] around Y e^4 (Y the turn's T_c), the hold in force
    between."""
    params = fw.CompensatorParams(
        mode="paper", mu=0.2, mu_slope_per_n=0.0015, breakaway=0.2, hysteresis_n=LSB
    )
    q = params.quantized()
    b = q.breakaway * q.phi_rad
    ref = _turns(15.0, 6.0, 15.0)
    twin = fw.CompensatorF64(q).run(ref)
    fixed = fw.Compensator(params).run_words(np.round(ref * 256).astype(np.int16)) * LSB
    # error_bound_n is loose here (the tables' curvature at mu 0.2 with a slope near its limit):
    # measured 13.4 LSB, the gain tables' interpolation; a hold at e^4.08 would be 7 N off
    assert np.max(np.abs(fixed - twin)) <= 16 * LSB
    assert np.max(twin) < 127.0  # below Q7.8's full scale: the hold, not the saturation, shows
    valley = int(np.argmax(ref)) + int(np.argmin(ref[int(np.argmax(ref)) :]))
    plain = fw.CompensatorF64(dataclasses.replace(q, breakaway=0.0)).run(ref)[valley + 1 :]
    expected = np.clip(twin[valley] * math.exp(4.0), plain, plain * math.exp(b / 2))
    assert twin[valley + 1 :] == pytest.approx(expected, rel=1e-9)
    held = (expected > plain) & (expected < plain * math.exp(b / 2))
    assert np.sum(held) > 20


def test_breakaway_saturates_at_full_scale():
    """The largest breakaway with mu: the most positive word saturates to 127.996 N on either
    branch (the loading branch's excess after a reversal at full scale too), the most negative
    one gives the floor, in both twins."""
    params = fw.CompensatorParams(mode="paper", mu=0.1, phi_rad=PHI, breakaway=0.25)
    comp = fw.Compensator(params)
    twin = fw.CompensatorF64(params.quantized())
    for word in (32767, -32768, 32767, -32768, 32767, 32767, -32768):
        want = 32767 if word > 0 else 0
        assert comp.step_word(word) == want
        assert twin.step(word * LSB) == want * LSB
    floored = fw.Compensator(fw.CompensatorParams(mode="paper", breakaway=0.25, tc_min_n=64.0))
    assert floored.step_word(-32768) == 64 * 256
    assert floored.step_word(32767) == 32767


@pytest.mark.parametrize(
    "fields",
    [
        {"breakaway": 0.2501},
        {"breakaway": -0.001},
        # (2 mu + 9/8 m_s) phi = (0.6 + 0.28) * 4.6 > 4: the hold's factor beyond e^4
        {"mu": 0.3, "phi_rad": 4.6, "breakaway": 0.25},
    ],
)
def test_a_breakaway_outside_the_limits_is_refused_by_both(fields):
    """COMP_ERR_BREAKAWAY from the fixed point and the twin alike."""
    assert refusal_codes(fw.CompensatorParams(mode="paper", **fields)) == (15, 15)


# (RMS, peak) of the output error in % of 15 N after the first second, fig14's shape (2 to 15 N
# at 0.5 Hz), the FMU's static friction alone (mu_static_excess 0.034, the report set's largest
# draws): measured today 3.79 / 19.12, with the term 2.31 / 10.08; budgets about 15 % above.
BUDGET = (2.7, 11.6)


# The same with the FMU's tension slope of +0.001 /N beside the static friction (tuning plants of
# cosim/studies/sweep/examples/random_plants_tuning.yaml reach 0.0012): measured 2.47 / 10.03,
# where the hold at the slope-free width left the term without effect (3.92 / 19.64, as without
# the term); budgets about 15 % above.
BUDGET_SLOPE = (2.85, 11.6)


def test_the_term_halves_the_stick_slip_with_a_tension_slope_open_loop():
    """A slope that widens the dead zone at the top: the hold at the turn's width breaks the cable
    loose, about half the peak and less RMS than the law without the term."""
    plant = {"mu_static_excess": 0.034, "mu_tension_slope": 0.001}
    rms, peak = preview_open_loop_pct(plant, breakaway=0.034, mu_slope_per_n=0.001)
    rms_off, peak_off = preview_open_loop_pct(plant, breakaway=0.0, mu_slope_per_n=0.001)
    assert rms <= BUDGET_SLOPE[0] and peak <= BUDGET_SLOPE[1], (rms, peak)
    assert rms < 0.7 * rms_off and peak < 0.6 * peak_off, (rms, rms_off, peak, peak_off)


def test_the_term_halves_the_fmus_stick_slip_open_loop():
    """The FMU's static friction alone (mu nominal, every other effect off, the inlet tension
    prescribed: drive mode 1), driven with the preview law's T_in with and without the plant's
    breakaway: the term splits the jump, about half the peak and less RMS."""
    plant = {"mu_static_excess": 0.034}
    rms, peak = preview_open_loop_pct(plant, breakaway=0.034)
    rms_today, peak_today = preview_open_loop_pct(plant, breakaway=0.0)
    assert rms <= BUDGET[0] and peak <= BUDGET[1], (rms, peak)
    assert rms < 0.7 * rms_today and peak < 0.6 * peak_today, (rms, rms_today, peak, peak_today)
