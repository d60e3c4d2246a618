/*
 * comp.h - the feedforward friction compensator of Jeong & Cho (IROS 2015), Sec. IV, in fixed point.
 *
 * Paper law (Eq. 15-16):  T_c = T_ref * exp(sign(delta) * mu * phi),  delta = dT_ref/dt,
 * keeping the last sign of delta when delta = 0. It inverts the capstan friction of the sheath
 * (Eq. 1-3): loading, T_out = T_in * exp(-mu*phi); unloading, T_out = T_in * exp(+mu*phi).
 *
 * Four modes:
 *  - COMP_MODE_NONE:   T_c = T_ref (no compensation; the baseline of the co-simulation).
 *  - COMP_MODE_PAPER:  Eq. 15 with the direction from the detector below; T_c jumps at a reversal.
 *  - COMP_MODE_SMOOTH: a smooth inverse in the spirit of Agrawal et al. (ICRA 2010, "smooth
 *    backlash inverse"): after a reversal the gain moves from one branch to the other linearly in
 *    the distance T_ref travels, over a tension band B, instead of jumping.
 *  - COMP_MODE_PREVIEW: a smooth inverse driven by the reference P ticks ahead (P =
 *    preview_ticks). The firmware generates T_ref, so it knows it ahead: in this mode the input
 *    of comp_step is T_ref(t + P) (the waveform generator runs P ticks ahead, or the host passes
 *    the reference P ticks ahead). The detector runs on it, so the gain starts to change branch
 *    P ticks before the reversal reaches the loop: with P about D/2 plus the loop's lag, the
 *    change is centred on the reversal, which covers the tension loop's closed-loop lag and the
 *    interface delay (ADC, PWM). The blend moves in time, not in tension: s moves one step per
 *    tick over D = ramp_ticks steps, so a change of branch takes D ticks whatever the slope of
 *    T_ref near the reversal (a travel-based band is slowest exactly there, where T_ref is flat),
 *    and the weight is the smoothstep w = x^2 (3 - 2x) of x = s/D: no corner at either end of the
 *    ramp (a linear ramp's end made the input tension undershoot, which the dead zone passes to
 *    the output). The gain is applied to T_ref(t + L) (L = lead_ticks <= P), taken from a delay
 *    line of the last P + 1 inputs: the inverse of the actuator's first-order lag in the form a
 *    known future allows (for a lag of time constant tau, T_c + tau dT_c/dt = T_c(t + tau) to
 *    first order, without differentiating a quantized signal).
 *    Start-up: the first input fills the delay line (a reference at rest); the waveform source
 *    pre-rolls P ticks at fw_start, so that the line holds T_ref(0 .. P) at the first tick.
 *
 * Floor (a cable cannot push): in every mode T_c = max(T_c, tc_min), tc_min in [0, 64] N; the
 * FPGA's TC_MIN register (written by fw_start from the same field) floors T_c' again after its
 * slew limit.
 *
 * Direction detector (hysteresis band H): the detector tracks the extreme of T_ref since the last
 * reversal and declares a reversal when T_ref has moved back from it by at least H. A noisy or
 * dithering T_ref whose peak-to-peak amplitude is below H never flips it. With H = 1 LSB
 * (1/256 N) it is exactly Eq. 16: the sign of the first difference, held when the difference is 0.
 * Before the first reversal the direction is "loading" (+1): a cable starts slack and is pulled.
 *
 * Extensions the model audit can emit (off by default):
 *  - offset_n: the output tension sensor reads offset_n above the cable (the paper's Fig. 11 shows
 *    ~0.5 N); the compensator aims the measured output at T_ref: T_eff = T_ref - offset_n.
 *  - mu_slope_per_n = s: friction coefficient varying with the local tension along the sheath,
 *    mu(T) = mu + s*T (the plant FMU's `mu_tension_slope`). Integrating the capstan relation
 *    dT/dphi = -+(mu + s*T)*T (Eq. 1 with this mu) along the sheath gives, for an output tension T,
 *      loading:   T_in = T * G_up(T),  G_up(T) = E / (1 - s*q*T)
 *      unloading: T_in = T * G_dn(T),  G_dn(T) = 1 / (E + s*q*T)
 *    with E = exp(mu*phi) and q = (E - 1)/mu = phi*(exp(mu*phi) - 1)/(mu*phi) (q = phi at mu = 0);
 *    with s = 0 these are exp(+-mu*phi). They are tabulated at configuration at 65 nodes every 2 N
 *    of |T_eff| (clamped to 127.996 N) and linearly interpolated per step. The law holds up to
 *    COMP_MU_SLOPE_RANGE_N (48 N, a node); above it the gains stay those at 48 N.
 *  - dead_zone_spread = sigma: the gradual dead zone of the plant FMU (fmu/README.md "Gradual dead
 *    zone"): the cable's friction thresholds spread log-normally around mu*phi, so after a
 *    reversal the output turns gradually. In the log domain the lumped capstan is a play
 *    (backlash) operator, ln T_out = play_w(ln T_in) (Eq. 1-3 with T_out held inside
 *    [T_in e^-w, T_in e^+w]), and strands of widths w_j make ln T_out close to a
 *    Prandtl-Ishlinskii sum of plays (1/M) sum_j play_{w_j}(ln T_in): exact for the strands'
 *    geometric mean, where the FMU takes their arithmetic mean (see below). The compensator uses
 *    M = COMP_DZ_PLAYS strands at the log-normal's quantiles, w_j = W e^(sigma q_j) with
 *    q_j = Phi^-1((j + 1/2) / M) (COMP_DZ_QUANTILES_Q28) and W = mu*phi, then scales them by
 *    h / mean_j(w_j) and multiplies the output by e^c, with
 *      a_up = -ln mean_j e^(-w_j),  a_dn = ln mean_j e^(+w_j),  h = (a_up + a_dn)/2,
 *      c = (a_dn - a_up)/2,
 *    so that both saturated branches are those of the M strands' arithmetic mean exactly
 *    (loading T_out = T_in e^-a_up, unloading T_in e^+a_dn). Plays compose, play_a o play_b = play_(a+b),
 *    so the model is play_(w_1) followed by a PI model with thresholds r_j = w_j - w_1 (r_1 = 0,
 *    the linear part) and weights 1/M, whose inverse is again a PI model (P. Krejci, K. Kuhnen,
 *    "Inverse control of systems with hysteresis and creep", IEE Proc. Control Theory Appl.
 *    148(3), 2001):
 *      thresholds r'_i = (1/M) sum_(j<=i) (r_i - r_j),
 *      weights p'_1 = M, p'_i = -M / (i (i - 1)) for i >= 2 (they sum to 1),
 *    and the first play inverts as the branch's jump, with exponent w_1 instead of mu*phi: the
 *    gain tables become G_up e^(w_1 - W) and G_dn e^(W - w_1), so that a friction slope keeps
 *    its whole factor (the strands' widths all follow mu(T); with the slope's factor on the
 *    first play alone, a slope and a spread together tracked worse than the slope alone). In the
 *    multiplicative form a step with y = ln(max(T_eff, 1 LSB)) updates the plays
 *    u_i = clamp(u_i, y - r'_i, y + r'_i) (i = 2..M; at the first step u_i = y -+ r'_i on the
 *    detector's branch) and multiplies the gain by
 *      F = exp(clamp(sum_(i>=2) p'_i (u_i - y) - c, -4, 4)).
 *    With sigma = 0 all widths are W, r'_i = 0, c = 0: F = 1 and the law is the one above,
 *    bit for bit (the step skips the plays). PREVIEW keeps its time blend for the first play's
 *    jump and its lead: the plays follow the reference the gain is applied to.
 *    The FMU's arithmetic mean against the geometric one of the plays: at spread 0.6 and
 *    mu*phi = 0.47 (mu 0.075, loop routing) the FMU's 32 strands put the saturated branches at
 *    e^-0.509 (loading) and e^+0.630 (unloading), where the geometric sum of the same strands
 *    gives e^-+0.559 (5 % and 7 % of the tension off); the 8 plays' arithmetic mean, which the
 *    scaling and c above match, gives e^-0.506 and e^+0.597 (the unloading branch 3 % below the
 *    FMU's: 8 quantiles thin the tails). Taking the branches from the FMU's 32 strands instead
 *    made the open-loop test below worse (1.67 % RMS against 1.23 % at spread 0.6), as did 16
 *    plays (1.35 %; better at 0.3): inside the turn after a reversal the difference of the means
 *    matters more than on the branches. The open-loop test: tests/firmware/test_fw_dead_zone.py.
 *  - breakaway = m_s: static friction above the sliding one after a reversal (the plant FMU's
 *    `mu_static_excess`, fmu/README.md "Static friction"; Armstrong-Helouvry et al. 1994,
 *    "stick-slip"). After a reversal the cable holds until T_in has moved past the breakaway
 *    width (mu + m_s)*phi and then slides to the kinetic branch at once: the output cannot follow
 *    T_ref through that jump, it holds and then falls (unloading) or rises (loading) by the factor
 *    e^(-+b), b = m_s*phi. The compensator cannot remove the jump, only place it. On the branch
 *    entered at the last reversal, with T_c0 the step's T_c without the term and Y the extreme of
 *    the T_c put out since the detector turned (the largest on an unloading branch),
 *      unloading: T_c = clamp(Y e^-(2 w_1 + 9b/8), T_c0 e^(-b/2), T_c0)
 *      loading:   T_c = clamp(Y e^+(2 w_1 + 9b/8), T_c0, T_c0 e^(+b/2))
 *    (w_1 = mu*phi, or the dead-zone inverse's first play). With a slope the zone's width at the
 *    turn is the first play's ln(G_up(X) / G_dn(X)) at the turn's output tension X (|T_eff| on
 *    the step the detector turns), and 2 w_1 above is the wider of the two: a positive slope
 *    widens the zone at the top, and a hold above the cable's breakaway level keeps the cable
 *    stuck until T_ref has moved by the whole jump, where a hold below it costs at most its
 *    margin, so a slope that narrows the zone keeps the slope-free hold (room for a bending
 *    angle the position adds; chosen on the tuning plants, docs/results.md "The breakaway's hold
 *    with a tension slope"). The factor is set at the turn, capped at e^4 on a loading branch.
 *    Assumed: the static width follows the slope as the kinetic one does (the FMU integrates
 *    mu + m_s + s*T; the level differs by under 1 % at mu 0.053, m_s 0.037, s 0.001 /N, 15 N).
 *    T_in first runs ahead by half the
 *    jump, so that the cable breaks loose when T_ref has moved by b/2 (an error of at most
 *    T (1 - e^(-b/2)) before and after, where the plain inverse leaves T (1 - e^-b) before it),
 *    then holds b/8 past the breakaway level Y e^-+(2 w_1 + b) that the stuck output Y e^-+w_1
 *    implies (held at that level exactly, the FMU's cable stayed stuck) while T_ref comes to the
 *    output, then follows the plain law. Indexed by the travel since the reversal, not by ticks.
 *    The excess enters with the change of branch: T_c0 + (T_b - T_c0) * (1 - w) unloading, * w
 *    loading (w the blend weight below); the first loading from rest carries none. Assumed, as
 *    the FMU does: one breakaway for every strand, no growth with the time at rest. With m_s = 0
 *    the step does not run this part: the law is the one above bit for bit.
 *  - slack_tension_n = S: pretension lost at low input tension (the plant FMU's `slack_tension`,
 *    fmu/README.md "Slack": T_out = T_out * min(1, T_in / S)). Below S the output is the friction
 *    law's times T_in / S; on a branch the friction law is a gain, T_out = T_in / G with G the
 *    gain the step applies, so the T_in that gives T_ref is the root of T_in^2 / (G S) = T_ref:
 *      T_c = sqrt(T_c1 * S)  where 0 < T_c1 < S,  T_c = T_c1 elsewhere,
 *    with T_c1 the step's T_c without the term (the friction inverse: slope, dead-zone inverse,
 *    breakaway, floor and saturation), continuous at T_c1 = S and never below T_c1. It is the
 *    last part of the step: the sqrt applies to the inlet tension the friction inverse asks for,
 *    since the FMU's loss is a factor of the inlet tension on the output the friction gives (and
 *    the breakaway's extreme Y follows T_c1, the friction inverse's own T_c). In fixed point
 *    T_c1 and S are Q7.8 words (S <= 64 N: 16384 LSB), their product < 2^28 in 32 bits is Q14.16,
 *    and its integer square root rounded to the nearest is T_c in Q7.8 exactly: the word nearest
 *    sqrt(T_c1 * S) for the Q7.8 word T_c1 (no ties: (r + 1/2)^2 is not an integer). Its result
 *    lies in [T_c1, S] (the root of (S - 1 LSB) S rounds to S - 1 LSB): no saturation. Against
 *    the twin (comp_f64.h) the bound on T_c1 grows by the root's slope, sqrt(S / T_c1) / 2, plus
 *    1/2 LSB of its own rounding
 *    (cosim.parts.firmware.CompensatorParams.error_bound_n). Assumed: the FMU's linear loss, one
 *    S for the whole cable. With S = 0 the step does not run this part: the law is the one above
 *    bit for bit.
 *    The turn at a slack bottom: after an unloading branch whose T_c went below S, the friction
 *    holds its output X at the reversal (the dead zone), and below S the cable passes
 *    X T_in / S of it, so the output follows T_in itself, without a dead zone, until T_in
 *    reaches S; the law's change of branch would lift T_in past S at once and the output to X
 *    while T_ref is still at the bottom. So the step keeps the least T_c below S on the
 *    unloading branch and its T_eff; from the detector's turn to loading, T_c is at most
 *    T_eff k, k = T_c,min / T_eff,min (= S / X when the output tracked at the bottom), while
 *    T_eff k < S; the first step where it is not ends the turn and the law takes over (T_c
 *    steps up to the loading branch). A new unloading branch, a reset and comp_hold_slack
 *    start it afresh. In fixed point k is UQ16.16, one 32-bit division at the turn (T_c,min <
 *    2^14 LSB; a ratio of 255 or more, a T_eff near 0, starts no turn), and the cap T_eff k is
 *    rounded to Q7.8. Against the twin the cap carries the relative difference of T_c,min
 *    (that step's bound) times T_c, plus 2^-16 of T_eff and 1/2 LSB, and the two may end a
 *    turn a step apart (tests/firmware/test_fw_slack.py).
 *  - mu_per_inlet_rate = m_r (s/N): friction that rises with the inlet tension's rate (the plant
 *    FMU's `mu_viscous_tension_rate`, and its `mu_viscous` through the cable's stretch rate,
 *    fmu/README.md "Viscous friction"; the viscous term of Armstrong-Helouvry et al. 1994). On a
 *    branch the friction exponent grows from mu*phi to (mu + m_r*|r_in|)*phi, so the gain the step
 *    applies, after the blend, is multiplied by
 *      e^x,  x = (2w - 1) * min(m_r * r_hat * phi, COMP_VISC_X_MAX),
 *    with w the blend weight (1 loading, 0 unloading, the same weight as the gain's blend) and
 *    r_hat the predicted inlet tension's rate: the blended gain G (without this factor) times the
 *    rate of the reference the gain is applied to, |T_eff(k) - T_eff(k-1)| * f_tick, saturated at
 *    the full scale 4096 N/s (COMP_VISC_RATE_FS_Q16) and low-pass filtered with the FMU's 10 ms
 *    time constant (COMP_VISC_TAU_MS: r_hat += (min(G |dT_eff| f_tick, 4096 N/s) - r_hat) *
 *    (1 - e^(-1 / (tau f_tick))), the FMU's filter of its rates at a communication step of one
 *    tick; 1/(tau f_tick) held at 4 below 25 Hz). The first step after a reset or a
 *    configuration has no rate (r_hat starts from 0). The reference's rate, not
 *    T_c's: near a reversal T_ref is flat and the cable sticks (v_c ~ 0 in the FMU), while T_c
 *    moves fast there through the blend; the term must not add friction there. The factor sits
 *    after the blend and before the dead-zone inverse's F, the breakaway term, the floor, the
 *    saturation and the slack's root (the root stays last). f_tick is the compensator's tick
 *    rate (comp_set_tick_rate_hz; 1 kHz after comp_init, the firmware's tick_rate_hz from
 *    fw_configure). Formats: m_r Q3.28 s/N in [0, COMP_VISC_MAX_Q28] (1/16 s/N: the audit's
 *    range of both forms, mu_viscous up to 50 s/m being about 0.007 s/N on the nominal cable);
 *    |dT_eff| * f_tick in Q.8 N/s, capped at 2^26 (262144 N/s, above the full scale at any gain
 *    >= e^-4); G times it in Q.32, rounded to r_hat's UQ12.16 N/s and saturated at the full scale
 *    4096 N/s (2^28); the filter's weight in UQ0.24; m_r*phi in Q3.28 (<= 0.79); m_r*phi*r_hat
 *    < 2^56 in int64, rounded to Q3.28 and clamped at COMP_VISC_X_MAX = 1 (the exponent grows by
 *    at most 1: the gain stays below UQ8.24's ceiling, e^(4 + 1) = 148 < 256, and a step of T_ref,
 *    whose one-tick rate saturates r_hat, raises the friction by a bounded factor); (2w - 1) * x
 *    in Q3.28 and e^x by fxp_exp_uq8_24 (its error: fxp.h); G e^x in UQ8.24 (< 2^31.3), then
 *    T_eff * G e^x < 2^49 in int64. The fixed point and its twin differ by the rounding of r_hat
 *    (about 5 LSB of UQ12.16 in the filter's steady state) and of e^x; against the twin the bound
 *    becomes bound * e^(COMP_VISC_X_MAX) + 1 LSB (cosim.parts.firmware.CompensatorParams.
 *    error_bound_n). Assumed: one m_r for both branches (the FMU's tension-rate form has one; in
 *    its cable-speed form the inlet's travel per inlet tension differs by branch, m_r ~
 *    mu_viscous * L_s / EA times (1 - e^(-mu phi))/(mu phi) loading and (e^(mu phi) - 1)/(mu phi)
 *    unloading, plus the load cell's give: cosim.parts.firmware.mu_per_inlet_rate_of_cable_speed,
 *    whose mean the open-loop test takes); r_hat from the gain without the factor itself (second
 *    order in x); no rate where T_ref is flat (the FMU's tension-rate form takes T_in's rate,
 *    fast through the blend at a reversal, which the term does not see: what that form's
 *    open-loop error keeps lies at the reversals; tests/firmware/test_fw_viscous.py). With
 *    m_r = 0 the step does not run this part: the law is the one above bit for bit.
 * Full law of a step, with T_eff = T_ref - offset_n (mode NONE: T_c = T_ref):
 *   G_up, G_dn as above (exp(+-mu*phi) without a slope),
 *   w = s / B in [0, 1] (PAPER: w = 1 loading, 0 unloading; SMOOTH: s moves by |dT_ref| per step
 *   towards B when loading and towards 0 when unloading; PREVIEW: s moves by one per
 *   step, and w = x^2 (3 - 2x) with x = s / D),
 *   T_c = max(tc_min, sat_Q7.8( T_eff * (G_dn + w*(G_up - G_dn)) * F )), F = 1 without a spread
 *   (the viscous factor e^x, when m_r > 0, on the blended gain; the breakaway term, when
 *   m_s > 0, on the product before the saturation; the slack's root, when S > 0, on the result),
 * with T_eff = T_ref(t + L) - offset_n in PREVIEW mode (w from the input T_ref(t + P)).
 *
 * Smoothness bound (SMOOTH mode): between two consecutive steps whose references differ by d,
 *   |dT_c| <= d * (G_up,max + T_max*((G_up - G_dn)_max/B + G'_max)) + 2 LSB,
 * with T_max the larger |T_eff| of the two steps and G'_max the largest |dG/dT| of either branch
 * over [0, 128] N (0 without a slope): the first term is the reference moving on a branch, the
 * second the blend, the third the tension-dependent friction; 2 LSB of rounding.
 *
 * Accuracy against the double twin (comp_f64.h) fed the same Q7.8 references: with
 * mu_slope = 0, |T_c - T_c,f64| <= COMP_ERR_BOUND_LSB; with a slope, add the interpolation error
 * T_max * h^2/8 * G''_max with h = 2 N and G''_max the largest |d2G/dT2| of either branch
 * (cosim.parts.firmware.CompensatorParams.error_bound_n).
 */
#ifndef BOWDEN_COMP_H
#define BOWDEN_COMP_H

#include "bowden_q.h"

/* Mode of the compensator (int32 in the config so the layout is fixed for ctypes). */
#define COMP_MODE_NONE 0
#define COMP_MODE_PAPER 1
#define COMP_MODE_SMOOTH 2
#define COMP_MODE_PREVIEW 3

/* Configuration limits (checked in one place, comp_config_check). */
#define COMP_MU_MAX_Q28 ((q3_28_t)Q3_28_ONE)               /* mu in [0, 1] */
#define COMP_PHI_MAX_Q24 ((q7_24_t)210828714L)             /* phi in [0, 4*pi] rad */
#define COMP_MU_SLOPE_MAX_Q28 ((q3_28_t)(Q3_28_ONE / 128)) /* |mu_slope| <= 1/128 per N */
/* Tension (N) up to which mu + mu_slope*T must stay >= 0: the highest tension the sheath can carry
 * on the bench, the drive's 4 A limit at the RE25's k_t through 5.4:1 and a 10 mm spool (45.5 N at
 * the inlet, fmu/README.md "Drive and motor"), rounded up. The whole Q7.8 range (128 N) refused
 * measured slopes such as -0.0008 /N at mu 0.075 whose mu stays positive wherever a cable is
 * pulled. Above it the tables hold the gains at COMP_MU_SLOPE_RANGE_N (comp.h's law above), so
 * that a negative slope never makes the unloading gain exceed the loading one. */
#define COMP_MU_SLOPE_RANGE_N 48
#define COMP_EXPONENT_MAX_Q28 ((q3_28_t)(4L * Q3_28_ONE))  /* mu*phi <= 4 (gain <= 54.6) */
#define COMP_GAIN_MAX ((uq8_24_t)916004956UL) /* every gain <= e^4 (UQ8.24, floor) */
#define COMP_GAIN_MIN ((uq8_24_t)307286UL)    /* every gain >= e^-4 (UQ8.24, ceiling) */
#define COMP_OFFSET_MAX_Q8 ((q7_8w_t)(64 * Q7_8_ONE))      /* |offset| <= 64 N */
#define COMP_HYST_MIN_Q8 ((q7_8w_t)1)                      /* H in [1/256 N, 32 N] */
#define COMP_HYST_MAX_Q8 ((q7_8w_t)(32 * Q7_8_ONE))
#define COMP_BAND_MIN_Q8 ((q7_8w_t)1) /* B in [1/256 N, 128 N] */
#define COMP_BAND_MAX_Q8 ((q7_8w_t)(128 * Q7_8_ONE))
#define COMP_TC_MIN_MAX_Q8 ((q7_8w_t)(64 * Q7_8_ONE)) /* floor in [0, 64] N */
#define COMP_PREVIEW_MAX_TICKS 128                     /* P in [0, 128] ticks */
#define COMP_RAMP_MAX_TICKS 256                        /* D in [1, 256] ticks */
#define COMP_DZ_SPREAD_MAX_Q28 ((q3_28_t)Q3_28_ONE) /* dead_zone_spread in [0, 1] */
#define COMP_BRK_MAX_Q28 ((q3_28_t)(Q3_28_ONE / 4)) /* breakaway in [0, 0.25], (2 mu + m_s)*phi <= 4 */
#define COMP_SLACK_MAX_Q8 ((q7_8w_t)(64 * Q7_8_ONE)) /* slack_tension in [0, 64] N */
#define COMP_VISC_MAX_Q28 ((q3_28_t)(Q3_28_ONE / 16)) /* mu_per_inlet_rate in [0, 1/16] s/N */
/* The viscous term's rate filter: the FMU's time constant of its rate estimates
 * (BOWDEN_SPEED_TAU_S, fmu/README.md "Viscous friction"), so that the predicted rate lags the
 * reference as the plant's rate lags its inlet tension. */
#define COMP_VISC_TAU_MS 10
#define COMP_VISC_RATE_FS_Q16 ((int64_t)1 << 28)      /* r_hat's full scale, 4096 N/s in UQ12.16 */
#define COMP_VISC_X_MAX_Q28 ((q3_28_t)Q3_28_ONE)       /* the exponent's growth, at most 1 */
#define COMP_TICK_RATE_MAX_HZ 65535U                   /* comp_set_tick_rate_hz: [1, 65535] Hz */

/* The dead-zone inverse's strands: M plays at the standard normal's quantiles
 * q_j = Phi^-1((j + 1/2) / M), Q3.28, rounded. 8: the FMU's 32 strands turn the output in 32
 * kinks; 8 plays follow that turn to a few per cent of the dead zone (the offline test) at one
 * clamp and multiply each per step. */
#define COMP_DZ_PLAYS 8
#define COMP_DZ_QUANTILES_MAX_Q28 411812348L /* the largest, q_M */
#define COMP_DZ_QUANTILES_Q28                                                                  \
    {-411812348L, -238141591L, -131204919L, -42227765L, 42227765L, 131204919L, 238141591L,   \
     411812348L}

/* Preview defaults (ticks of the processor, 1 ms at 1 kHz), from `bowden tune`. */
#define COMP_DEFAULT_PREVIEW_TICKS 60
#define COMP_DEFAULT_LEAD_TICKS 0
#define COMP_DEFAULT_RAMP_TICKS 120

/* Gain table: nodes every 2 N (512 LSB of Q7.8) over |T_eff| in [0, 128] N. */
#define COMP_TAB_SHIFT 9
#define COMP_TAB_NODES 65

/* Bound of |T_c(fixed) - T_c(double twin)| in Q7.8 LSB with mu_slope = 0: 0.5 LSB of final
 * rounding, plus gain and blend quantization below 0.01 LSB; held by the unit tests. */
#define COMP_ERR_BOUND_LSB 1

/* Status codes of comp_configure (0 is success; each error names the offending field). */
#define COMP_OK 0
#define COMP_ERR_NULL 1       /* a null pointer */
#define COMP_ERR_MODE 2       /* mode not NONE, PAPER or SMOOTH */
#define COMP_ERR_MU 3         /* mu outside [0, 1] */
#define COMP_ERR_PHI 4        /* phi outside [0, 4*pi] rad */
#define COMP_ERR_MU_SLOPE 5   /* |mu_slope| > 1/128 per N, mu + mu_slope*48 N < 0, or a gain
                               * outside [e^-4, e^4] somewhere in [0, 128] N */
#define COMP_ERR_EXPONENT 6   /* mu*phi > 4 */
#define COMP_ERR_OFFSET 7     /* |offset| > 64 N */
#define COMP_ERR_HYSTERESIS 8 /* H outside [1/256, 32] N */
#define COMP_ERR_BAND 9       /* B outside [1/256, 128] N (a band of zero is rejected) */
#define COMP_ERR_TC_MIN 10    /* floor outside [0, 64] N */
#define COMP_ERR_PREVIEW 11   /* P outside [0, COMP_PREVIEW_MAX_TICKS] ticks */
#define COMP_ERR_LEAD 12      /* L outside [0, P] ticks */
#define COMP_ERR_RAMP 13      /* D outside [1, COMP_RAMP_MAX_TICKS] ticks */
#define COMP_ERR_DEAD_ZONE 14 /* dead_zone_spread outside [0, 1], or the widest strand
                               * mu*phi*e^(spread*q_M) above 4 */
#define COMP_ERR_BREAKAWAY 15 /* breakaway outside [0, 0.25], or (2 mu + breakaway)*phi above 4 */
#define COMP_ERR_SLACK 16     /* slack_tension outside [0, 64] N */
#define COMP_ERR_VISCOUS 17   /* mu_per_inlet_rate outside [0, 1/16] s/N */
#define COMP_ERR_TICK_RATE 18 /* comp_set_tick_rate_hz: a rate outside [1, 65535] Hz */

/* Configuration, built from comp_config_default() then changed field by field. */
typedef struct {
    int32_t mode;                  /* COMP_MODE_* */
    q3_28_t mu_q28;                /* friction coefficient mu, Q3.28, [0, 1] */
    q7_24_t phi_rad_q24;           /* total bending angle phi, Q7.24 rad, [0, 4*pi] */
    q3_28_t mu_slope_per_n_q28;    /* d(mu)/d|T|, Q3.28 per N, [-1/128, 1/128] */
    q7_8w_t offset_n_q8;           /* output sensor offset, Q7.8 N, [-64, 64] */
    q7_8w_t hysteresis_n_q8;       /* detector band H, Q7.8 N, [1/256, 32] */
    q7_8w_t band_n_q8;             /* smooth inverse band B, Q7.8 N, [1/256, 128] */
    q7_8w_t tc_min_n_q8;           /* floor of T_c (minimum pretension), Q7.8 N, [0, 64] */
    int32_t preview_ticks;         /* PREVIEW: P, how far ahead the input is, [0, 128] ticks */
    int32_t lead_ticks;            /* PREVIEW: L, the gain's reference, [0, 128] and at most P */
    int32_t ramp_ticks;            /* PREVIEW: D, ticks of a change of branch, [1, 256] */
    q3_28_t dead_zone_spread_q28;  /* log std of the friction thresholds, Q3.28, [0, 1] */
    q3_28_t breakaway_q28;         /* static friction's excess over mu after a reversal, Q3.28,
                                      [0, 0.25] */
    q7_8w_t slack_tension_n_q8;    /* input tension below which the cable has lost part of its
                                      pretension, Q7.8 N, [0, 64] */
    q3_28_t mu_per_inlet_rate_q28; /* friction's rise per inlet tension rate, Q3.28 s/N,
                                      [0, 1/16] */
} comp_config_t;

/* The compensator: configuration in force, gain tables and the state of the last step. */
typedef struct {
    comp_config_t cfg;
    uq8_24_t g_up[COMP_TAB_NODES]; /* G_up at |T| = 2 N * index, UQ8.24 */
    uq8_24_t g_dn[COMP_TAB_NODES]; /* G_dn at |T| = 2 N * index, UQ8.24 */
    int32_t blend_top;             /* s at the loading branch: B in LSB, or D in PREVIEW */
    uint32_t inv_band;             /* floor(2^(31+m) / top) with m = floor(log2 top) */
    int32_t band_shift;            /* m + 1: w = (s * inv_band) >> (m + 1) is s/B in Q1.30 */
    int32_t prev_ref;              /* T_ref of the last step, Q7.8 in 32 bits */
    int32_t extreme;               /* extreme of T_ref since the last reversal, Q7.8 */
    int32_t blend;                 /* s in [0, top]: top = loading branch, 0 = unloading */
    int32_t dir;                   /* +1 loading, -1 unloading (sign of delta, held at 0) */
    int32_t started;               /* 0 until the first step */
    int32_t line[COMP_PREVIEW_MAX_TICKS + 1]; /* PREVIEW: the last P + 1 inputs, Q7.8 */
    int32_t line_pos;              /* PREVIEW: index of the newest input in line */
    int32_t line_writes;           /* PREVIEW: inputs written to line since the first step, at
                                      most P + 1 */
    int32_t line_first;            /* the first step's input: what an unwritten slot reads */
    int32_t tables_of_cfg;         /* 1 while g_up, g_dn are the tables of cfg's mu, phi and
                                      mu_slope (comp_configure); 0 after comp_set_exponent_q28 */
    int32_t corr_q8;               /* the far-end output correction added to T_eff, Q7.8 N, [-16,
                                      16] (comp_set_correction_q8; 0 after comp_reset) */
    int32_t applied_q8;            /* the reference the last step applied, T_ref(t + L), Q7.8 */
    int32_t dz_on;                 /* 1 when the dead-zone inverse is in force (spread > 0) */
    int32_t kind;                  /* what a step runs after the detector (comp.c COMP_KIND_*) */
    int32_t dz_fresh;              /* 1 until the plays are set at the next step */
    q3_28_t dz_r_q28[COMP_DZ_PLAYS];  /* thresholds r'_i of the inverse PI model, Q3.28 (i >= 1) */
    q3_28_t dz_p_q28[COMP_DZ_PLAYS];  /* weights p'_i of the inverse PI model, Q3.28 (i >= 1) */
    q3_28_t dz_d_q28[COMP_DZ_PLAYS];  /* plays u_i - y of the last step, Q3.28 (i >= 1) */
    q3_28_t dz_y_q28;              /* y = ln T_eff of the last step, Q3.28 (ln N) */
    q3_28_t dz_c_q28;              /* c: the arithmetic mean's shift, Q3.28 */
    q3_28_t dz_x1_q28;             /* w_1: the first play's exponent, Q3.28 */
    int32_t brk_on;                /* 1 when the breakaway term is in force (breakaway > 0) */
    int32_t brk_dir;               /* the detector's direction the extreme below belongs to */
    int32_t brk_y_q8;              /* Y: the extreme of T_c on that branch, Q7.8 */
    int32_t brk_last_q8;           /* the last T_c put out, Q7.8 */
    uq8_24_t brk_full;             /* the hold's e^-(2 w_1 + 9b/8), UQ8.24 (b = m_s*phi) */
    uq8_24_t brk_full_up;          /* e^+(2 w_1 + 9b/8), UQ8.24 (the exponent <= 4, checked) */
    uq8_24_t brk_half;             /* e^(-b/2), UQ8.24 */
    uq8_24_t brk_half_up;          /* e^(+b/2), UQ8.24 */
    uq8_24_t brk_f_dn;             /* the hold's factor on Y of the branch entered last: brk_full,
                                      or with a slope its value at that turn's tension (UQ8.24) */
    uq8_24_t brk_f_up;             /* the same on a loading branch, <= e^4 (UQ8.24) */
    int32_t brk_k_q24;             /* with a slope: s*q (comp.h), Q7.24 per N */
    uq8_24_t brk_e;                /* e^(mu*phi), UQ8.24 */
    uq8_24_t brk_dn_k;             /* e^-(w_1 + 9b/8), UQ8.24 */
    uq8_24_t brk_up_k;             /* e^(w_1 - mu*phi), UQ8.24 */
    uq8_24_t brk_b98_up;           /* e^(9b/8), UQ8.24 */
    int32_t slk_on;                /* 1 when the slack's root is in force (slack_tension > 0) */
    int32_t slk_held;              /* 1 while the slack's root is held off (comp_hold_slack; 0
                                      after comp_reset) */
    int32_t slk_dir;               /* the detector's direction the slack's turn last saw */
    int32_t slk_min_q8;            /* the least T_c below S on the unloading branch, Q7.8 (0:
                                      none) */
    int32_t slk_eff_q8;            /* T_eff at that T_c, Q7.8 */
    uint32_t slk_k_q16;            /* T_c / T_eff there, UQ16.16: the turn's ratio (0: none) */
    int32_t vis_on;                /* 1 when the viscous term is in force (mu_per_inlet_rate > 0) */
    int32_t vis_fresh;             /* 1 until the next step sets vis_prev_q8 (no rate yet) */
    int32_t vis_prev_q8;           /* T_eff of the last step, Q7.8 in 32 bits */
    int32_t vis_r_q16;             /* r_hat, the filtered predicted inlet rate, UQ12.16 N/s */
    uint32_t tick_rate_hz;         /* f_tick, [1, 65535] Hz (comp_set_tick_rate_hz) */
    uint32_t vis_alpha_q24;        /* the filter's weight 1 - e^(-1/(tau f_tick)), UQ0.24 */
    q3_28_t vis_k_q28;             /* m_r * phi, Q3.28 s/N (<= 0.79) */
} comp_t;

/* Defaults: PAPER mode, mu = 0.075 (paper Fig. 11), phi = 2*pi (loop routing), no slope, no offset,
 * H = 4 LSB (1/64 N: above the +-1 LSB dither of a quantized constant), B = 0.5 N, floor 0 N,
 * P and L: COMP_DEFAULT_PREVIEW_TICKS / COMP_DEFAULT_LEAD_TICKS (chosen by `bowden tune` on the
 * tune scenario; hdl/README.md). */
void comp_config_default(comp_config_t *cfg);

/* Check a configuration without applying it; returns COMP_OK or the COMP_ERR_* of the first bad
 * field in the order of the struct. With a friction slope it builds the gain tables on the stack
 * (520 bytes) to check every gain. */
int32_t comp_config_check(const comp_config_t *cfg);

/* mu * phi of a configuration in Q3.28, rounded (the exponent of the gains), in 64 bits. */
int64_t comp_config_exponent_q28(const comp_config_t *cfg);

/* The preview fields' check, shared by comp_config_check and the double twin's (comp_f64.c):
 * COMP_OK, or COMP_ERR_PREVIEW / _LEAD / _RAMP for P, L, D outside their ranges. */
int32_t comp_check_preview(int32_t preview_ticks, int32_t lead_ticks, int32_t ramp_ticks);

/* Put the compensator in the default configuration and reset its state. */
void comp_init(comp_t *c);

/*
 * Apply a configuration: on success recompute the gain tables (up to ~100k instructions),
 * keep the detector's direction and put the blend fully on the current branch; on error return the
 * COMP_ERR_* code and leave the compensator (configuration and state) untouched.
 */
int32_t comp_configure(comp_t *c, const comp_config_t *cfg);

/*
 * The compensator's tick rate f_tick in Hz, [1, 65535] (the viscous term's rate and its filter,
 * comp.h): COMP_ERR_TICK_RATE outside, the rate in force kept. comp_init sets 1000 Hz (the
 * firmware's default tick_rate_hz); fw_configure sets the firmware's. Keeps the state.
 */
int32_t comp_set_tick_rate_hz(comp_t *c, uint32_t hz);

/* Forget the history: the next step starts in the loading direction on its branch. */
void comp_reset(comp_t *c);

/*
 * One step of the compensator at the processor's rate: T_ref (Q7.8 N) in (T_ref(t + P) in PREVIEW
 * mode), T_c (Q7.8 N) out.
 * Scaling and overflow: T_eff = T_ref - offset in 32 bits (|T_eff| < 2^17); gains are UQ8.24
 * (<= 54.6 * 2^24 < 2^30); the interpolation and blend products are < 2^62 in 64 bits; the product
 * T_eff * G (Q15.32, < 2^47) is rounded to Q7.8 and saturated to [-128, 127.996] N, so no input
 * overflows. About 60-90 host instructions (see the callgrind benchmark).
 */
q7_8_t comp_step_q7_8(comp_t *c, q7_8_t t_ref);

/*
 * Replace the friction exponent mu*phi in force by x (Q3.28, [0, 4]) without touching the
 * configuration: the gain tables become exp(+x) and exp(-x) (the online estimate, fric_est.h).
 * Only without a friction slope (COMP_ERR_MU_SLOPE otherwise) and for x in [0, 4]
 * (COMP_ERR_EXPONENT); the state (direction, blend) is kept. About 450 instructions (two exp,
 * two table fills); comp_configure restores exp(+-mu*phi).
 */
int32_t comp_set_exponent_q28(comp_t *c, q3_28_t x_q28);

/*
 * The far-end output correction (fric_est.h, fric_corr_step): from the next step on T_eff =
 * T_ref - offset + corr, corr clamped to [-16, 16] N (Q7.8). Not in mode NONE (T_c = T_ref).
 */
void comp_set_correction_q8(comp_t *c, int32_t corr_q8);
/*
 * The slack's root held off (held != 0) or in force again (0) from the next step: while the
 * far-end cell's zero is taken (fw.c) the cable must be slack, and the root lifts a small T_c
 * to sqrt(T_c S), e.g. 0.54 N for 0.08 N with S = 3.6 N, above the tare's T_in ceiling
 * (fric_est.h, tare_max). 0 (in force) after comp_reset.
 */
void comp_hold_slack(comp_t *c, int32_t held);
/* The reference the last step applied its gain to (T_ref(t + L) in PREVIEW, else T_ref), Q7.8:
 * what the output should read now. */
int32_t comp_applied_ref_q8(const comp_t *c);

/* Current direction (+1 loading, -1 unloading) and blend weight s/B in Q1.30 (for telemetry). */
int32_t comp_direction(const comp_t *c);
int32_t comp_blend_q1_30(const comp_t *c);

#endif /* BOWDEN_COMP_H */
