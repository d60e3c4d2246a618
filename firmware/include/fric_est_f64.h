/*
 * fric_est_f64.h - the double twin of the friction estimate (host only: libm's log and exp), the
 * oracle fric_est.h is held against. The same method (fric_est.h), the same window and gate
 * (fric_est_gate_*, fric_est.c) on the same Q7.8 words, and in double: the accumulators P_b,
 * Q_b (no rounding), the ratios, ln, the band e^x_max, the branch average and the rate bound.
 * Configured from the same fixed-point configuration (fric_est_config_t), so both hold the same
 * values.
 */
#ifndef BOWDEN_FRIC_EST_F64_H
#define BOWDEN_FRIC_EST_F64_H

#include <stdint.h>

#include "fric_est.h"

typedef struct {
    fric_est_config_t cfg;
    double lambda_inv;                /* 1 / tau */
    double p[2], q[2];                /* means of dT_in dT_out and dT_out^2, (Q7.8 LSB)^2 */
    double x_b[2];
    double x;                         /* mu*phi */
    double x_meas;
    double band_hi;                   /* e^(5x/4) */
    fric_est_gate_t g;                /* the integer estimate's gate and window (fric_est.h) */
} fric_est_f64_t;

/* Apply a configuration (checked by fric_est_config_check) and reset to x0 (in mu*phi). */
void fric_est_f64_configure(fric_est_f64_t *e, const fric_est_config_t *cfg, double x0);
void fric_est_f64_reset(fric_est_f64_t *e, double x0);
/* One tick, the arguments of fric_est_step; returns the estimate mu*phi. */
double fric_est_f64_step(fric_est_f64_t *e, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                         int32_t code_min, int32_t code_max, uint32_t adc_flags);

/*
 * The double twin of the far-end output correction (fric_est.h): the same input checks and tare
 * on the same words (the integer part's watch, base), the integrators g_up, g_dn, the blend, the
 * bleed, the reversal tables and the correction in double. Every value is a multiple of 2^-28
 * below 2^53 of them (g), of 2^-24 N (o, r) or of 2^-36 N (T_ref g), so it is exact and equals
 * the integer correction's bit for bit (unit test). The reversal's bookkeeping (the branch and
 * the ticks since) is the integer part's, on the same words.
 */
typedef struct {
    fric_corr_t base;  /* configuration, tare, STUCK run and faults (its integrators unused) */
    double g[2];       /* g_up, g_dn */
    double o[2];       /* o_up, o_dn (offset_term), N */
    double rev[2][FC_REV_BINS]; /* reversal tables r_up, r_dn, N */
    double rev_out;    /* r(n) of the last tick, N */
    double p;          /* the proportional term of the last tick, N (a multiple of 1/256 N) */
    double out;        /* the correction, N, rounded to 1/256 N */
} fric_corr_f64_t;

void fric_corr_f64_configure(fric_corr_f64_t *c, const fric_corr_config_t *cfg, q3_28_t x0_q28);
void fric_corr_f64_reset(fric_corr_f64_t *c);
/* One tick, the arguments of fric_corr_step; returns c in N. */
double fric_corr_f64_step(fric_corr_f64_t *c, int32_t t_ref_q8, int32_t t_in_q8, int32_t t_out_q8,
                          int32_t code, int32_t code_min, int32_t code_max, uint32_t adc_flags,
                          int32_t w_q30, uint32_t lim);

#endif /* BOWDEN_FRIC_EST_F64_H */
