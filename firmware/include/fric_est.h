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

typedef struct {
    fric_est_config_t cfg;
    int32_t tau_shift;                /* s with tau = 2^s */
    int64_t p[2], q[2];               /* P_b, Q_b (b = 0 loading, 1 unloading), Q.(16+28) */
    uint32_t n[2];                    /* accepted samples per branch (saturating) */
    q3_28_t x_b[2];                   /* ln G_up, -ln G_dn of the last update of each branch */
    q3_28_t x;                        /* the estimate mu*phi, Q3.28 */
    q3_28_t x_meas;                   /* the last measurement, Q3.28 */
    uq8_24_t band_hi;                 /* e^(5x/4), UQ8.24 (the STUCK band) */
    fric_est_window_t win;            /* the last W + 1 ticks, the far-end code's run */
    int32_t implausible;              /* T_in left the band while the code was unchanged */
    uint32_t faults;                  /* FE_FAULT_* (latched) */
    int32_t accepted;                 /* 1 if the last tick's sample was used */
    uint32_t out_of_bounds;           /* consecutive measurements outside the bounds */
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

/*
 * One tick: T_in (Q7.8, as the T_IN register), the far-end raw code and its conversion to Q7.8
 * (t_out_q8, 32-bit: outside Q7.8 is a RANGE fault), the code's limits, and the ADC front-end
 * flags (non-zero: a fault). Returns the estimate x (Q3.28), frozen once a fault is latched.
 */
q3_28_t fric_est_step(fric_est_t *e, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                      int32_t code_min, int32_t code_max, uint32_t adc_flags);

/* The window's parts of fric_est_step, shared with the double twin (fric_est_f64.c). */

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

/*
 * ln(v) for v in UQ8.24 (v > 0), in Q3.28, clamped to [-8, 8 - 2^-28] (0 gives -8).
 * v = m 2^k with m in [2^-1/2, 2^1/2); ln m = 2 atanh(z), z = (m - 1)/(m + 1), |z| <= 0.1716, by
 * its odd series to z^9 (truncation < 7e-10); z in Q1.30 by the long division; k ln 2 from ln 2
 * in Q.40. |error| <= 4 LSB of Q3.28 (unit test against libm over the whole range).
 */
q3_28_t fric_est_ln_q28(uq8_24_t v);

#endif /* BOWDEN_FRIC_EST_H */
