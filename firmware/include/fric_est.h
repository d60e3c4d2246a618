/*
 * fric_est.h - online estimate of the sheath's friction exponent x = mu*phi from the two load
 * cells (T_in at the drive, T_out at the far end), integer only, off by default.
 *
 * Physics (Jeong & Cho 2015, Eq. 1-3, the capstan law): while the whole sheath slides,
 *   loading:   T_in = E * T_out,   unloading: T_in = T_out / E,   E = exp(mu*phi).
 * In the dead zone after a reversal T_out holds while T_in crosses from one branch to the other;
 * those samples carry no friction information and are left out (the gate below).
 *
 * Measurement: increments over a window of W = FE_WINDOW_TICKS ticks, dT_in = T_in(k) -
 * T_in(k-W), dT_out likewise. On a sliding branch dT_in = G_b dT_out with G_up = E, G_dn = 1/E,
 * whatever constant offset the far-end sensor has: the form is insensitive to a sensor offset
 * (it cancels in every increment), and the two branches combined,
 *   x_meas = (ln G_up - ln G_dn) / 2 = (ln(P_up/Q_up) + ln(Q_dn/P_dn)) / 2,
 * are also insensitive to a scale error g of the far-end sensor (G_up/g and 1/(g E) give the same
 * x). Per branch, least squares through the origin with a forgetting factor lambda = 1 - 1/tau
 * over the accepted samples:
 *   P_b <- P_b + (dT_in dT_out - P_b) / tau,   Q_b <- Q_b + (dT_out^2 - Q_b) / tau,
 * so G_b = P_b / Q_b. Until a branch has FE_MIN_SAMPLES accepted samples only the other one is
 * used (x_meas = ln G_up, or -ln G_dn). The estimate moves towards x_meas by at most `rate` per
 * tick (bounded rate of change): x <- x + clamp(x_meas - x, -rate, +rate).
 *
 * Gate (a sample is used on branch b, sign s = +1 loading, -1 unloading) when, with the window's
 * ticks a = k - W, m = k - W/2, c = k and e = k - W/8 on both cells:
 *   s (T(m) - T(a)) >= delta/2 and s (T(c) - T(m)) >= delta/2   (sliding over the whole window),
 *   s (T(c) - T(e)) > 0, s (T(a') - T(a)) > 0, a' = k - 7W/8     (moving that way at both ends),
 *   T_in and T_out >= t_min at a and c                            (no slack cable),
 * delta = FE_SLIDE_MIN_Q8. T_out held in a dead zone fails the first line; a window that
 * reaches back into a dead zone (T_in moving, T_out not yet) or on past a reversal fails the
 * second.
 *
 * Faults (latched until fric_est_reset; any of them freezes the estimate at its last value; ADC
 * and RANGE are still checked and added while frozen):
 *   FE_FAULT_ADC    the ADC front-end flags (DRDY lost, CRC error) are set;
 *   FE_FAULT_RANGE  the far-end code is outside [code_min, code_max] (the loop's ADC_MIN/ADC_MAX:
 *                   an absent or broken cell drives its channel to a rail) or its tension is
 *                   outside Q7.8;
 *   FE_FAULT_STUCK  the far-end code has not changed for FE_STUCK_TICKS ticks while T_in left the
 *                   band [T_out e^-5x/4, T_out e^5x/4] that friction up to a quarter above the
 *                   estimate allows around a held T_out (a dead zone stays inside it; a frozen
 *                   cell does not once the cable moves);
 *   FE_FAULT_BOUND  x_meas (with enough samples) outside [x_min, x_max] for FE_BOUND_SAMPLES
 *                   accepted samples in a row (the estimate does not follow it meanwhile).
 *
 * Formats: tensions Q7.8 N in int32 (|T| < 2^15); increments |dT| < 2^15, products < 2^30 (Q16.16
 * N^2 as integers of 2^-16 N^2); P_b, Q_b are those means in Q.FE_ACC_FRAC (2^-16-N^2 units with
 * FE_ACC_FRAC = 28 more fraction bits: < 2^58 in int64); tau = 2^s, so the forgetting is an
 * arithmetic shift with rounding and keeps no multiply error; G_b = P/Q (or Q/P) in UQ8.24 by the
 * 64-bit long division; x, x_meas, rate and the bounds Q3.28.
 *
 * Accuracy against the double twin (fric_est_f64.h) fed the same words: the gates and counts are
 * exact integers in both; the accumulators differ by the shift's rounding (relative < 2^-20);
 * the ratio's UQ8.24 rounding and fric_est_ln_q28 add up to FE_ERR_BOUND_LSB LSB of Q3.28 in x
 * (unit-tested over whole runs).
 */
#ifndef BOWDEN_FRIC_EST_H
#define BOWDEN_FRIC_EST_H

#include "bowden_q.h"

#define FE_WINDOW_TICKS 32        /* W: increments over 32 ticks (32 ms at 1 kHz) */
#define FE_SLIDE_MIN_Q8 16        /* delta: 1/16 N of travel over the window on both cells */
#define FE_MIN_SAMPLES 32         /* accepted samples before a branch's ratio is used */
#define FE_BOUND_SAMPLES 64       /* consecutive measurements out of bounds before BOUND */
#define FE_STUCK_TICKS 100        /* ticks of an unchanged far-end code before STUCK can latch */
#define FE_ACC_FRAC 28            /* extra fraction bits of P_b, Q_b */
#define FE_TAU_MIN_TICKS 16       /* tau: a power of two in [16, 32768] accepted samples */
#define FE_TAU_MAX_TICKS 32768
#define FE_X_MAX_Q28 ((q3_28_t)(4L * Q3_28_ONE)) /* bounds within [0, 4] (the compensator's) */
#define FE_TMIN_MAX_Q8 (64 * Q7_8_ONE)           /* t_min in [0, 64] N */
/* |x - x_f64| bound in LSB of Q3.28 (3.7e-9 each): the two ln (<= 4 LSB each, fxp test) and
 * the ratios' UQ8.24 rounding (<= 2^-25 relative for a ratio >= 1: 8 LSB each), halved by the
 * branch average, plus the accumulators' shift rounding; held by the unit tests. */
#define FE_ERR_BOUND_LSB 24

/* Fault bits (fric_est_t.faults and the telemetry). */
#define FE_FAULT_ADC 0x1u
#define FE_FAULT_RANGE 0x2u
#define FE_FAULT_STUCK 0x4u
#define FE_FAULT_BOUND 0x8u

/* Status codes of fric_est_config_check (70-79, after the FW_ERR_* and SETTINGS_ERR_* codes). */
#define FE_OK 0
#define FE_ERR_NULL 70
#define FE_ERR_ENABLE 71   /* enable not 0 or 1 */
#define FE_ERR_TAU 72      /* tau_ticks not a power of two in [16, 32768] */
#define FE_ERR_RATE 73     /* rate outside [0, 1/16] per tick */
#define FE_ERR_BOUNDS 74   /* bounds outside [0, 4], min >= max, or the start value outside */
#define FE_ERR_T_MIN 75    /* t_min outside [0, 64] N */
#define FE_ERR_SLOPE 76    /* enabled with a friction slope (the gains would not be exp(+-x)) */

/* Configuration (a part of fw_config_t; parameters est.*). */
typedef struct {
    int32_t enable;          /* [0, 1]: 0 off (default), 1 on */
    int32_t tau_ticks;       /* forgetting time constant, accepted samples, 2^s in [16, 32768] */
    q3_28_t rate_q28;        /* largest change of the estimate per tick, Q3.28, [0, 1/16] */
    q3_28_t mu_phi_min_q28;  /* lower bound of mu*phi, Q3.28, [0, 4), below max */
    q3_28_t mu_phi_max_q28;  /* upper bound of mu*phi, Q3.28, (0, 4], above min */
    q7_8w_t t_min_n_q8;      /* minimum tension on both cells, Q7.8 N, [0, 64] */
} fric_est_config_t;

/*
 * The window (Measurement and Gate above), one for the estimate and its double twin: the two
 * cells' Q7.8 words of the last W + 1 ticks and the far-end code's run of unchanged ticks (STUCK).
 * fric_est_step and fric_est_f64_step keep one each and ask it the same questions, so both take
 * the same ticks onto the same branch with the same increments.
 */
typedef struct {
    int16_t hist_in[FE_WINDOW_TICKS]; /* T(k-W) .. T(k-1), Q7.8, ring */
    int16_t hist_out[FE_WINDOW_TICKS];
    int16_t hist_in_last;             /* T(k), Q7.8 */
    int16_t hist_out_last;
    uint32_t filled;                  /* ticks in the history (saturates at W + 1) */
    uint32_t pos;                     /* ring slot of T(k-W), the next to overwrite */
    int32_t last_code;                /* the far-end code of the last tick */
    uint32_t same_ticks;              /* ticks the code has not changed */
} fric_est_window_t;

/*
 * The gate's bookkeeping around the window, one for the estimate and its double twin: both take
 * a tick through the same fric_est_gate_* calls in the same order (input checks, the code's run,
 * the window's sample, the samples per branch, the bounds), so only the arithmetic differs.
 */
typedef struct {
    fric_est_window_t win;            /* the last W + 1 ticks, the far-end code's run */
    uint32_t n[2];                    /* accepted samples per branch (saturating) */
    int32_t implausible;              /* T_in left the band while the code was unchanged */
    uint32_t faults;                  /* FE_FAULT_* (latched) */
    int32_t accepted;                 /* 1 if the last tick's sample was used */
    uint32_t out_of_bounds;           /* consecutive measurements outside the bounds */
} fric_est_gate_t;

typedef struct {
    fric_est_config_t cfg;
    int32_t tau_shift;                /* s with tau = 2^s */
    int64_t p[2], q[2];               /* P_b, Q_b (b = 0 loading, 1 unloading), Q.(16+28) */
    q3_28_t x_b[2];                   /* ln G_up, -ln G_dn of the last update of each branch */
    q3_28_t x;                        /* the estimate mu*phi, Q3.28 */
    q3_28_t x_meas;                   /* the last measurement, Q3.28 */
    uq8_24_t band_hi;                 /* e^(5x/4), UQ8.24 (the STUCK band) */
    fric_est_gate_t g;                /* window, samples per branch, faults, bounds run */
    q3_28_t x0_cfg_q28;               /* the x0 of the last fric_est_configure, */
    uq8_24_t band_x0;                 /* and its band (fric_est_restart keeps it) */
} fric_est_t;

/* Defaults: off; tau 128 samples; rate 0.002 per tick (2.0 per second at 1 kHz); bounds
 * [0.05, 2.0]; t_min 0.5 N. (tau and rate chosen on the tuning set: firmware/README.md.) */
void fric_est_config_default(fric_est_config_t *cfg);

/* FE_OK or the FE_ERR_* of the first bad field; x0 is the start value (the compensator's mu*phi),
 * slope_q28 the compensator's friction slope (must be 0 when enabled). */
int32_t fric_est_config_check(const fric_est_config_t *cfg, q3_28_t x0_q28, q3_28_t slope_q28);

/* Apply a checked configuration (no check here) and reset to x0. */
void fric_est_configure(fric_est_t *e, const fric_est_config_t *cfg, q3_28_t x0_q28);

/* Forget everything (history, sums, faults) and start again from x0. */
void fric_est_reset(fric_est_t *e, q3_28_t x0_q28);
/* fric_est_reset of a configured estimator: the band of the configuration's x0 reused when x0 is
 * that (the soft CPU has no FPU: an exponential is some 900 clocks), else computed. */
void fric_est_restart(fric_est_t *e, q3_28_t x0_q28);

/*
 * One tick: T_in (Q7.8, as the T_IN register), the far-end raw code and its conversion to Q7.8
 * (t_out_q8, 32-bit: outside Q7.8 is a RANGE fault), the code's limits, and the ADC front-end
 * flags (non-zero: a fault). Returns the estimate x (Q3.28), frozen once a fault is latched.
 */
q3_28_t fric_est_step(fric_est_t *e, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                      int32_t code_min, int32_t code_max, uint32_t adc_flags);

/* The window's parts of fric_est_step, shared with the double twin (fric_est_f64.c). */

/* The faults a tick's inputs raise, checked even when the estimate is frozen so that every fault
 * is reported: FE_FAULT_ADC for non-zero front-end flags, FE_FAULT_RANGE for a code outside
 * [code_min, code_max] or a tension outside Q7.8. */
uint32_t fric_est_input_faults(int32_t t_in_q8, int32_t t_out_q8, int32_t code, int32_t code_min,
                               int32_t code_max, uint32_t adc_flags);

/* Empty window: no ticks, no code seen. */
void fric_est_window_reset(fric_est_window_t *w);

/* Count the ticks the far-end code has not changed (saturating); 1 when it changed or at the
 * first tick (the run starts again), else 0. */
int32_t fric_est_window_code(fric_est_window_t *w, int32_t code);

/* Add a tick's words (Q7.8, in range); 1 once the window holds W + 1 ticks, else 0. */
int32_t fric_est_window_push(fric_est_window_t *w, int32_t t_in_q8, int32_t t_out_q8);

/* The gate over a full window: the branch of the newest tick, 0 loading, 1 unloading, -1 none
 * (a cell below t_min_q8 at either end, or not sliding one way over the whole window), and the
 * increments T(k) - T(k-W) of both cells (Q7.8, |d| < 2^15; set only for a branch). */
int32_t fric_est_window_branch(const fric_est_window_t *w, int32_t t_min_q8, int32_t *d_in_q8,
                               int32_t *d_out_q8);

/* No samples, no faults, an empty window. */
void fric_est_gate_reset(fric_est_gate_t *g);

/* A tick's inputs, as fric_est_step takes them. */
typedef struct {
    int32_t t_in_q8, t_out_q8;        /* the two cells, Q7.8 */
    int32_t code, code_min, code_max; /* the far-end ADC code and its valid range */
    uint32_t adc_flags;               /* the front-end's flags (non-zero: FE_FAULT_ADC) */
} fric_est_input_t;

/* A tick's sample: the branch (0 loading, 1 unloading, -1 none) and, on a branch, the
 * increments T(k) - T(k-W) of both cells (Q7.8). */
typedef struct {
    int32_t branch;
    int32_t d_in_q8, d_out_q8;
} fric_est_sample_t;

/* A tick through the gate. The input faults are latched (fric_est_input_faults); once any fault
 * is latched the estimate is frozen until the next reset (branch -1). Else the far-end code's
 * run is counted: a new code clears `implausible`, and with the code unchanged and T_in >= t_min
 * the caller's band test (`outside_band`: the tensions outside the band friction allows) sets
 * it. A code unchanged for FE_STUCK_TICKS while implausible latches FE_FAULT_STUCK (-1, nothing
 * pushed); else the tick is pushed and, over a full window, the branch and increments of
 * fric_est_window_branch are returned and the sample counted on its branch (`n`, `accepted`);
 * -1 while the window fills or on no branch. */
fric_est_sample_t fric_est_gate_tick(fric_est_gate_t *g, const fric_est_config_t *cfg,
                                     const fric_est_input_t *in, int32_t outside_band);

/* 1 when branch b (or, b = -1, each branch) holds the FE_MIN_SAMPLES a measurement needs. */
int32_t fric_est_gate_ready(const fric_est_gate_t *g, int32_t b);

/* A measurement inside the bounds (in_bounds != 0) ends a run outside them; one outside counts
 * the run and latches FE_FAULT_BOUND at FE_BOUND_SAMPLES. Returns in_bounds. */
int32_t fric_est_gate_bounds(fric_est_gate_t *g, int32_t in_bounds);

/*
 * ln(v) for v in UQ8.24 (v > 0), in Q3.28, clamped to [-8, 8 - 2^-28] (0 gives -8).
 * v = m 2^k with m in [2^-1/2, 2^1/2); ln m = 2 atanh(z), z = (m - 1)/(m + 1), |z| <= 0.1716, by
 * its odd series to z^9 (truncation < 7e-10); z in Q1.30 by the long division; k ln 2 from ln 2
 * in Q.40. |error| <= 4 LSB of Q3.28 (unit test against libm over the whole range).
 */
q3_28_t fric_est_ln_q28(uq8_24_t v);

/*
 * The far-end output correction (off by default): the second use of the far-end load cell. The
 * compensator is the feedforward; on top of it a slow integral of the far-end error corrects
 * the output tension it aims at (a two-degree-of-freedom structure):
 *   e = T_ref - (T_out,meas - T_tare),    T_eff = T_ref - offset + c,   c = g T_ref
 * (comp.h, comp_set_correction_q8), with T_ref the reference the compensator applied at the last
 * tick (comp_applied_ref_q8) and g a relative correction of the compensator's gain. A gain, not an
 * offset: what the feedforward leaves on a branch (mu*phi off, friction rising with tension or
 * speed, a bending-angle error) scales with the tension, and an offset integrated at high
 * tension pulls a low tension towards zero and slackens the cable there. One integrator per
 * branch, g_up (loading) and g_dn (unloading), because a friction error of the model changes sign
 * with the branch (T_out = T_in e^-+x); the applied correction follows the compensator's blend w
 * (Q1.30, 1 loading), so it changes branch with the gain and never jumps:
 *   g = g_dn + w (g_up - g_dn).
 * Integration (per tick, ki = 2^-ki_shift): g_b <- clamp(g_b + ki e T_ref / T_0^2, +-limit), T_0 =
 * 16 N (the least-squares gradient of e^2 in g, normalised so that the loop's rate at 16 N is ki),
 * only on the branch fully in force (w = 1 or 0) and only after hold_ticks ticks of it (held
 * through a change of branch and the dead zone after it, where T_out does not follow T_c), with
 * the slide gate on (slide_gate 1) only while the output slides with the reference: over the last
 * FC_GATE_TICKS ticks T_ref moved the branch's way by at least FC_GATE_MIN_Q8 and T_out,meas by at
 * least half as much (a gradual dead zone, a breakaway or slack holds T_out while T_ref moves: the
 * error there is the reversal's, which no gain of the branch removes), and not towards a command
 * limit (anti-windup: no integration up while T_c or the drive's current is at
 * its upper limit or the loop is faulted, none down at the floor or the lower current limit;
 * FC_LIM_* of the caller), and not on a reading that has not changed for FC_FRESH_TICKS ticks (a
 * live cell's code moves with its noise and with a sliding cable: a held code is a dead zone, a
 * reference at rest, or a cell that failed before STUCK can tell, and integrating a failed
 * reading for the ~1 s STUCK needs winds the correction up).
 * Loop margin: from g to T_out the plant's low-frequency gain is T_ref G_plant / G_model, about
 * T_ref (G_plant / G_model in 0.7 .. 1.4 for mu*phi 25 % off the compensator's); the integrator's
 * loop gain crosses over at w_c = (T_ref / T_0)^2 (G_plant / G_model) f_tick 2^-ki_shift rad/s,
 * at most 1.4 f_tick 2^-ki_shift below 16 N, and the tension loop's and the far-end sensor's lag
 * tau_d leaves the phase margin 90 deg - w_c tau_d and the gain margin (pi / (2 tau_d)) / w_c (an
 * integrator with a delay); firmware/README.md gives the figures.
 * Offset term (offset_term 1): each branch also integrates an offset, o_b <- clamp(o_b + ki e,
 * +-16 N limit), and c = g T_ref + o (o blended as g): with the gain's step ki e T_ref / T_0^2
 * this is the normalised least-squares gradient of an affine error model a + b T_ref (regressors
 * T_0 and T_ref), whose loop gain is at most twice the gain's alone below T_0 = 16 N. o_b is
 * Q7.24 N (a step e 2^(16 - ki_shift)); the sum g T_ref + o is formed in Q.36 N before rounding.
 * Tare: the far-end cell's zero is the mean of its readings over the first tare_ticks ticks after
 * the start, taken at zero load: fw_tick writes T_c at its floor until the tare's last reading
 * (fw.c); T_in above tare_max on any of them is the fault TARE (the offset would then carry
 * tension). No correction before the tare ends.
 * Faults (latched until fric_corr_reset, which fw_start calls): FC_FAULT_ADC (the ADC front-end
 * flags), FC_FAULT_RANGE (code outside [code_min, code_max] or its tension outside Q7.8),
 * FC_FAULT_STUCK (the code unchanged for FC_STUCK_TICKS ticks while T_in, above FC_STUCK_T_MIN_Q8,
 * left the band [T_out e^-2x, T_out e^2x] around the held reading, x the compensator's configured
 * mu*phi: a dead zone of friction up to twice the configured one stays inside it, as the
 * estimate's STUCK band does), FC_FAULT_TARE. With a fault the integrators stop and bleed to
 * zero, g_b <- g_b - ceil(|g_b| 2^-FC_BLEED_SHIFT) sign(g_b), a first-order decay of
 * 2^FC_BLEED_SHIFT ticks: the compensator falls back to the feedforward alone without a step.
 * Formats: tensions and e in Q7.8 N (32-bit, |e| < 2^17); e T_ref in Q15.16 N^2 (int64, < 2^33);
 * g_b in Q3.28 (|g_b| <= limit <= 1); the step ki e T_ref / T_0^2 = e T_ref 2^(4 - ki_shift) in
 * Q3.28 (ki_shift in [4, 16]: a right shift by 0 .. 12, rounded half up); the blend in Q1.16
 * (w >> 14), (g_up - g_dn) w16 < 2^47 in int64 (floor); c = T_ref g rounded half up to Q7.8
 * (< 2^45). The double twin (fric_est_f64.h) holds g_b as numbers: every value is an integer
 * multiple of 2^-28 below 2^53 of them, so both are exact and agree bit for bit (unit test).
 *
 * Proportional term (kp > 0, off by default): the far-end error acts at once as well,
 *   p = clamp(kp e, +-FC_P_LIMIT),   c = g T_ref + o + r(n) + p,
 * e as above with the tick's own reading (no anti-windup: p holds no state of its own). What
 * the integrators and the reversal table learn over many ticks or reversals, a breakaway
 * that lets go later than the last pass, friction that rises with the cable's speed, an error
 * of the first reversal, p meets in the tick it shows: a dead zone holds T_out while T_ref
 * moves, e grows, and p drives T_c across the dead zone faster. From the tare on, while no
 * fault is latched and the far-end code is fresh (changed within FC_FRESH_TICKS ticks, the
 * integrators' rule: a live cell's code moves with its noise, a failed one holds it, and p
 * acting on a stuck reading for the ticks STUCK needs drove the output further off than the
 * feedforward alone); otherwise p bleeds as the integrators do (2^FC_BLEED_SHIFT ticks), so
 * that the fall back to the feedforward alone has no step. FC_P_LIMIT bounds it besides.
 * Loop margin: from c to T_out,meas the gain is the one above, about G_plant / G_model (0.7 ..
 * 1.4) times the tension loop's and the far-end cell's response, and 0 inside a dead zone, so
 * the loop kp (G_plant / G_model) closes through the tension loop's and the cell's lag
 * tau_d: firmware/README.md gives the measured margins ("The far-end proportional term").
 * Formats: kp in Q15.16 (<= 2^18), e kp < 2^35 in int64, rounded half up to Q7.8 N; the twin
 * computes the same product in double (exact below 2^53) and agrees bit for bit.
 *
 * Reversal table (rev_enable 1): what a correction held through a reversal cannot reach (a dead
 * zone wider or more gradual than the model's, breakaway, slack, the drive's lag) is learnt as
 * the shape of the reversal and added as feedforward from the first tick after the next one.
 * Per branch b a table of FC_REV_BINS output corrections r_b[k] (Q7.24 N), indexed by the ticks
 * n since the reversal into b began (the tick the blend w left the other branch's end: the
 * compensator's branch change, preview_ticks ahead of T_ref's), a bin 2^rev_bin_shift ticks
 * wide, linear between the nodes and 0 from node FC_REV_BINS on (the table ends without a step):
 *   r(n) = r_b[k] + (r_b[k+1] - r_b[k]) f 2^-s,  k = n >> s, f = n & (2^s - 1), r_b[BINS] = 0,
 *   c = g T_ref + o + r(n).
 * Ticks, not the reference's travel: near a reversal a smooth T_ref barely moves (its travel
 * grows with the square of the time), so a travel index crowds the ticks where the error is
 * largest into its first bin, while the compensator's blend and the drive's lag run in ticks.
 * Learning, per tick under the integrators' conditions (tared, no fault, the anti-windup of
 * FC_LIM_*, a fresh far-end code: learning on a held one, as a dead zone holds it, let a cell
 * stuck inside the STUCK band teach the table a 1.8 N error before STUCK latched): the error e
 * of tick n is credited to the correction applied rev_lead_ticks earlier (the tension loop's and
 * the cell's lag), m = n - lead, spread over the two nodes of m as they weigh it:
 *   d = e 2^-rev_ki_shift (Q7.24),  r_b[k] += d (2^s - f) 2^-s,  r_b[k+1] += d f 2^-s (floor),
 * each node updated then leaks, r <- r - sign(r) ceil(|r| 2^-rev_leak_shift), and is clamped to
 * +-rev_limit. Two loops in one: within a pass the node being updated is the one applied (lead
 * 0), so the table is also a local integrator of rate 2^-rev_ki_shift (times the hat weights,
 * 1/2 .. 1) per tick, whose crossover w_c = (G_plant / G_model) f_tick 2^-rev_ki_shift (1/2 .. 1)
 * with the loop's lag tau_d (10 ms, firmware/README.md) leaves the phase margin 90 deg - w_c
 * tau_d and the gain margin (pi / (2 tau_d)) / w_c: rev_ki_shift 4 at a friction ratio up to 1.4,
 * w_c <= 88 rad/s, 40 deg and 1.8 (rev_ki_shift 3: 175 rad/s, no margin left); across passes
 * it carries what it learnt to the same ticks of the next reversal (iterative learning), the
 * leak forgetting 2^(s - rev_leak_shift) per reversal. A fault bleeds the tables as g_b: the
 * feedforward alone remains.
 * Indexed by the inlet's travel (rev_index 1; 0, ticks, stays the default: on the random-plant
 * tuning set ticks did better, firmware/README.md): n is the log travel of T_in since the
 * reversal began, from its extreme the branch's way back since then (unloading
 * ln(max T_in / T_in), loading ln(T_in / min T_in), T_in taken as FC_REV_T_FLOOR_Q8 at least), in
 * 2^-8 of ln, bins of 2^rev_bin_shift of them (rev_bin_shift <= 7: bins up to 1/2, 16 of them
 * cover T_in's whole branch): the stretch of the inlet's cable, the motor's position change
 * through the stuck cable on a stiff drive, in the units of the capstan law (the cable slips
 * where ln T_in has moved by 2 mu phi plus the breakaway, paper Eq. 1-3). A breakaway lets go at
 * a travel of the inlet, not at a tick: a correction the table learnt by ticks moves the tick of
 * the break and can land, on the next pass, on the other side of it (alternation over the
 * reversal); by travel it lands at the same point of the slip. The error is credited to the
 * travel of the tick itself (rev_lead_ticks must be 0); one fxp_ln_q28 per tick. The index now
 * depends on the correction (r moves T_c, T_in follows, the travel moves): a loop whose gain is
 * the table's slope the branch's way, s_b dr/dn (s_b = +1 loading, -1 unloading), over T_in, times
 * the tension loop's |T_in / T_c|. Every update keeps s_b (r_b[k+1] - r_b[k]) <= h = 1/2 N per unit
 * of ln (2^(rev_bin_shift + 15) in Q7.24 a bin) on both neighbours of the node updated (r_b[BINS]
 * = 0 included), so that loop's gain is at most (1/2 N) / (1 N) = 1/2 times |T_in / T_c|, below 1
 * for a tension loop peaking less than 6 dB: a correction never runs away along the travel (no
 * fold, no jump of T_c). The slope the other way (which slows the travel) is not bounded. A
 * fault's bleed rounds each node on its own (the bound may then be off by an LSB; nothing is
 * learnt until fric_corr_reset).
 * Formats: r_b in Q7.24 N (|r| <= rev_limit <= 8 N = 2^27); d = e << (16 - rev_ki_shift) in
 * int64; the spread products < 2^50; r(n) floor in Q7.24, added to the Q.36 sum << 12; ln T_in
 * Q3.28 of T_in in UQ8.24 (Q7.8 << 16), the log travel in [0, 2^11) (T_in in [1, 128) N). The twin
 * holds r_b as multiples of 2^-24 N below 2^53 of them: exact, bit for bit; the travel is the
 * integer part's (fric_corr_rev_track, the same words).
 */
#define FC_STUCK_TICKS 100            /* ticks of an unchanged far-end code before STUCK can latch */
#define FC_STUCK_T_MIN_Q8 (Q7_8_ONE / 2) /* ... while T_in, above 0.5 N, left the band */
#define FC_FRESH_TICKS 8              /* no integration once the code has held for 8 ticks */
#define FC_BLEED_SHIFT 7              /* a dropped correction decays with 128 ticks */
#define FC_KI_SHIFT_MIN 4             /* ki = 2^-ki_shift per tick, ki_shift in [4, 16] */
#define FC_KI_SHIFT_MAX 16
#define FC_HOLD_MAX_TICKS 4096        /* hold_ticks in [0, 4096] */
#define FC_LIMIT_MAX_Q28 ((q3_28_t)Q3_28_ONE) /* limit in [0, 1] */
#define FC_TARE_MAX_TICKS 1024        /* tare_ticks: a power of two in [1, 1024] */
#define FC_TARE_T_MAX_Q8 (8 * Q7_8_ONE) /* tare_max in [0, 8] N */
#define FC_GATE_TICKS 32              /* the slide gate's window, ticks */
#define FC_GATE_MIN_Q8 16             /* ... over which T_ref moves at least 1/16 N (2 N/s) */
#define FC_REV_BINS 16                /* reversal table: nodes per branch */
#define FC_REV_KI_MIN 2               /* rev_ki_shift in [2, 16] */
#define FC_REV_KI_MAX 16
#define FC_REV_BIN_MAX 6              /* rev_bin_shift in [0, 6]: bins of 1 .. 64 ticks */
#define FC_REV_BIN_TRAVEL_MAX 7       /* ... in [0, 7] by travel: bins of 2^-8 .. 1/2 in ln T_in */
#define FC_REV_T_FLOOR_Q8 Q7_8_ONE    /* by travel, T_in taken as 1 N at least (the slope bound) */
#define FC_REV_LEAD_MAX 64            /* rev_lead_ticks in [0, 64] */
#define FC_REV_LEAK_MIN 2             /* rev_leak_shift in [2, 24] */
#define FC_REV_LEAK_MAX 24
#define FC_REV_LIMIT_MAX_Q8 (8 * Q7_8_ONE) /* rev_limit in [0, 8] N */
#define FC_KP_MAX_Q16 (4 << 16)       /* kp in [0, 4] */
#define FC_P_LIMIT_Q8 (4 * Q7_8_ONE)  /* |kp e| <= 4 N */

/* Limits the caller reports (fric_corr_step's lim): the command cannot go higher / lower. */
#define FC_LIM_HI 0x1u
#define FC_LIM_LO 0x2u

/* Fault bits (fric_corr_t.faults and the telemetry). */
#define FC_FAULT_ADC 0x1u
#define FC_FAULT_RANGE 0x2u
#define FC_FAULT_STUCK 0x4u
#define FC_FAULT_TARE 0x8u

/* Status codes of fric_corr_config_check (80-90). */
#define FC_ERR_ENABLE 80   /* enable not 0 or 1 */
#define FC_ERR_KI 81       /* ki_shift outside [4, 16] */
#define FC_ERR_HOLD 82     /* hold_ticks outside [0, 4096] */
#define FC_ERR_LIMIT 83    /* limit outside [0, 1] */
#define FC_ERR_TARE 84     /* tare_ticks not a power of two in [1, 1024] */
#define FC_ERR_TARE_MAX 85 /* tare_max outside [0, 8] N */
#define FC_ERR_GATE 86     /* slide_gate not 0 or 1 */
#define FC_ERR_OFFSET 87   /* offset_term not 0 or 1 */
#define FC_ERR_REV 88      /* rev_enable or rev_index not 0 or 1, a rev_* shift or lead outside
                            * its range, or a lead with rev_index 1 */
#define FC_ERR_REV_LIMIT 89 /* rev_limit outside [0, 8] N */
#define FC_ERR_KP 90       /* kp outside [0, 4] */

/* Configuration (a part of fw_config_t; parameters corr.*). */
typedef struct {
    int32_t enable;          /* [0, 1]: 0 off (default), 1 on */
    int32_t ki_shift;        /* integral rate 2^-ki_shift per tick, [4, 16] */
    int32_t hold_ticks;      /* ticks a branch is in force before it integrates, [0, 4096] */
    q3_28_t limit_q28;       /* |g_up|, |g_dn| bound, Q3.28, [0, 1] */
    int32_t tare_ticks;      /* ticks of the far-end zero after the start, 2^s in [1, 1024] */
    q7_8w_t tare_max_n_q8;   /* largest T_in during the tare, Q7.8 N, [0, 8] */
    int32_t slide_gate;      /* [0, 1]: 1 integrates only while T_out slides with T_ref */
    int32_t offset_term;     /* [0, 1]: 1 adds an offset per branch, c = g T_ref + o_b */
    int32_t rev_enable;      /* [0, 1]: 1 learns and applies the reversal table */
    int32_t rev_ki_shift;    /* reversal table's rate 2^-rev_ki_shift per tick, [2, 16] */
    int32_t rev_bin_shift;   /* a bin of the reversal table is 2^s ticks, [0, 6] */
    int32_t rev_lead_ticks;  /* the error is credited this many ticks back, [0, 64] */
    int32_t rev_leak_shift;  /* leak 2^-rev_leak_shift per update of a node, [2, 24] */
    q7_8w_t rev_limit_n_q8;  /* |r_b[k]| bound, Q7.8 N, [0, 8] */
    int32_t rev_index;       /* [0, 1]: 0 the table by ticks (default), 1 by the inlet's travel */
    int32_t kp_q16;          /* proportional gain on the far-end error, Q15.16, [0, 4] (0 off) */
} fric_corr_config_t;

typedef struct {
    fric_corr_config_t cfg;
    q3_28_t g_q28[2];        /* g_up, g_dn, Q3.28 */
    int32_t o_q24[2];        /* o_up, o_dn (offset_term), Q7.24 N, |o_b| <= limit 16 N */
    int32_t held[2];         /* ticks each branch has been fully in force (saturating) */
    int64_t tare_sum_q8;     /* sum of the far-end words over the tare, Q7.8 N */
    int32_t tare_n;          /* ticks of the tare so far */
    int32_t tare_q8;         /* the far-end zero, Q7.8 N */
    int32_t tared;           /* 1 once the tare is complete */
    int32_t last_code;       /* STUCK: the far-end code of the last tick */
    int32_t implausible;     /* STUCK: T_in left the band since the code last changed */
    uq8_24_t band_q24;       /* STUCK: e^2x, UQ8.24 (x clamped to 2.75: the exp's domain) */
    uint32_t same_ticks;     /* STUCK: ticks the code has not changed (saturating) */
    int32_t started;         /* 0 until the first tick */
    uint32_t faults;         /* FC_FAULT_* (latched) */
    int32_t out_q8;          /* the correction c, Q7.8 N */
    int32_t branch;          /* the branch integrated at the last tick (0, 1), -1 none */
    int16_t gate_ref[FC_GATE_TICKS]; /* slide gate: T_ref, T_out,meas of the last ticks, Q7.8 */
    int16_t gate_out[FC_GATE_TICKS];
    uint32_t gate_pos;       /* ring slot of the oldest (the next to overwrite) */
    uint32_t gate_filled;    /* ticks in the ring (saturates at FC_GATE_TICKS) */
    int32_t rev_q24[2][FC_REV_BINS]; /* reversal tables r_up, r_dn, Q7.24 N */
    int32_t rev_branch;      /* the branch the last reversal went into (0, 1), -1 none yet */
    int32_t rev_ticks;       /* ticks since that reversal began (saturating) */
    int32_t w_prev;          /* the blend of the last tick, Q1.30 (-1 before the first) */
    int32_t rev_out_q24;     /* r(n) of the last tick, Q7.24 N */
    int32_t rev_ext_q8;      /* rev_index 1: T_in's extreme since the reversal began, Q7.8 N */
    q3_28_t rev_ln_ext_q28;  /* rev_index 1: its ln, Q3.28 */
    int32_t rev_travel;      /* rev_index 1: T_in's log travel from it, 2^-8 of ln, [0, 2^11) */
    q3_28_t band_x_q28;      /* STUCK: the clamped x0 band_q24 was computed for */
    int32_t p_q8;            /* the proportional term kp e of the last tick, Q7.8 N */
} fric_corr_t;

/* Defaults: off; ki_shift 6, hold_ticks 30, limit 0.5 and the slide gate off, chosen on the
 * random-plant tuning set (firmware/README.md); tare 64 ticks below 0.5 N; the reversal table
 * off, its rates (firmware/README.md) chosen on the same set. */
void fric_corr_config_default(fric_corr_config_t *cfg);
/* FE_OK or the FC_ERR_* of the first bad field (FE_ERR_NULL for a null pointer). */
int32_t fric_corr_config_check(const fric_corr_config_t *cfg);
/* Apply a checked configuration and reset; x0 is the compensator's mu*phi (Q3.28, the STUCK
 * band). */
void fric_corr_configure(fric_corr_t *c, const fric_corr_config_t *cfg, q3_28_t x0_q28);
/* Forget everything (integrators, tare, faults): the start of a run. */
void fric_corr_reset(fric_corr_t *c);
/* fric_corr_configure(c, &c->cfg, x0) of a configured correction: its STUCK band reused when the
 * clamped x0 is the one it was computed for, else computed. */
void fric_corr_restart(fric_corr_t *c, q3_28_t x0_q28);
/*
 * One tick: the reference the compensator applied (Q7.8), T_in (Q7.8), the far-end word (Q7.8,
 * 32-bit) and raw code with its limits and the ADC flags (as fric_est_step), the compensator's
 * blend w (Q1.30, [0, 2^30]) and the command limits reached (FC_LIM_*). Returns c (Q7.8 N).
 */
int32_t fric_corr_step(fric_corr_t *c, int32_t t_ref_q8, int32_t t_in_q8, int32_t t_out_q8,
                       int32_t code, int32_t code_min, int32_t code_max, uint32_t adc_flags,
                       int32_t w_q30, uint32_t lim);
/* The slide gate of a tick shared with the double twin: pushes the words (clamped to Q7.8) and
 * returns 1 when branch b (0 loading, 1 unloading) slides over the window (always 1 with
 * slide_gate 0; 0 until the window is full or for b < 0). */
int32_t fric_corr_gate(fric_corr_t *c, int32_t t_ref_q8, int32_t t_out_q8, int32_t b);
/* The reversal table's bookkeeping shared with the double twin: from the blend w (Q1.30,
 * clamped) finds a reversal's start (w moving the other way than the last reversal's branch)
 * and counts the ticks since, and from T_in (Q7.8, clamped to it) its travel since then
 * (rev_index 1); returns the branch of the reversal in progress, -1 before the first. */
int32_t fric_corr_rev_track(fric_corr_t *c, int32_t w_q30, int32_t t_in_q8);
/* The reversal table's index of the tick after fric_corr_rev_track: the ticks since the
 * reversal (rev_index 0) or T_in's log travel since it in 2^-8 of ln (rev_index 1). */
int32_t fric_corr_rev_index(const fric_corr_t *c);
/* The reversal table's learning condition of a tick besides the fault, tare and anti-windup:
 * the far-end code fresh (changed within FC_FRESH_TICKS ticks). */
int32_t fric_corr_rev_may_learn(const fric_corr_t *c);
/* The checks of a tick shared with the double twin: adds FC_FAULT_* of the inputs to *faults
 * (ADC flags, range, STUCK run of *c). */
void fric_corr_check_inputs(fric_corr_t *c, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                            int32_t code_min, int32_t code_max, uint32_t adc_flags);

#endif /* BOWDEN_FRIC_EST_H */
