/* fric_est_f64.c - double twin of fric_est.c (host only); see fric_est_f64.h. */
#include "fric_est_f64.h"

#include <math.h>

void fric_est_f64_reset(fric_est_f64_t *e, double x0)
{
    for (int32_t b = 0; b < 2; ++b) {
        e->p[b] = 0.0;
        e->q[b] = 0.0;
        e->n[b] = 0U;
        e->x_b[b] = x0;
    }
    e->x = x0;
    e->x_meas = x0;
    fric_est_window_reset(&e->win);
    e->implausible = 0;
    e->faults = 0U;
    e->accepted = 0;
    e->out_of_bounds = 0U;
    e->band_hi = exp(1.25 * x0);
}

void fric_est_f64_configure(fric_est_f64_t *e, const fric_est_config_t *cfg, double x0)
{
    e->cfg = *cfg;
    e->lambda_inv = 1.0 / (double)cfg->tau_ticks;
    fric_est_f64_reset(e, x0);
}

double fric_est_f64_step(fric_est_f64_t *e, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                         int32_t code_min, int32_t code_max, uint32_t adc_flags)
{
    const double q28 = 268435456.0;
    e->accepted = 0;
    /* ADC flags and range are checked even when frozen, so that every fault is reported. */
    if (adc_flags != 0U) {
        e->faults |= FE_FAULT_ADC;
    }
    if (code < code_min || code > code_max || t_out_q8 < INT16_MIN || t_out_q8 > INT16_MAX ||
        t_in_q8 < INT16_MIN || t_in_q8 > INT16_MAX) {
        e->faults |= FE_FAULT_RANGE;
    }
    if (e->faults != 0U) {
        return e->x; /* frozen until the next reset */
    }

    if (fric_est_window_code(&e->win, code) != 0) {
        e->implausible = 0;
    }
    if (e->win.same_ticks > 0U && t_in_q8 >= e->cfg.t_min_n_q8) {
        if ((double)t_in_q8 > (double)t_out_q8 * e->band_hi ||
            (double)t_in_q8 * e->band_hi < (double)t_out_q8) {
            e->implausible = 1;
        }
    }
    if (e->win.same_ticks >= (uint32_t)FE_STUCK_TICKS && e->implausible != 0) {
        e->faults |= FE_FAULT_STUCK;
        return e->x;
    }
    if (fric_est_window_push(&e->win, t_in_q8, t_out_q8) == 0) {
        return e->x;
    }
    int32_t d_in_q8 = 0;
    int32_t d_out_q8 = 0;
    const int32_t b = fric_est_window_branch(&e->win, e->cfg.t_min_n_q8, &d_in_q8, &d_out_q8);
    if (b < 0) {
        return e->x;
    }
    const double d_in = (double)d_in_q8;
    const double d_out = (double)d_out_q8;
    e->p[b] += (d_in * d_out - e->p[b]) * e->lambda_inv;
    e->q[b] += (d_out * d_out - e->q[b]) * e->lambda_inv;
    if (e->n[b] < 0xFFFFFFFFU) {
        ++e->n[b];
    }
    e->accepted = 1;
    if (e->n[b] < (uint32_t)FE_MIN_SAMPLES) {
        return e->x;
    }
    e->x_b[b] = (b == 0) ? log(e->p[0] / e->q[0]) : log(e->q[1] / e->p[1]);
    double xm;
    if (e->n[0] >= (uint32_t)FE_MIN_SAMPLES && e->n[1] >= (uint32_t)FE_MIN_SAMPLES) {
        xm = 0.5 * (e->x_b[0] + e->x_b[1]);
    } else {
        xm = e->x_b[b];
    }
    e->x_meas = xm;
    if (xm < (double)e->cfg.mu_phi_min_q28 / q28 || xm > (double)e->cfg.mu_phi_max_q28 / q28) {
        if (++e->out_of_bounds >= (uint32_t)FE_BOUND_SAMPLES) {
            e->faults |= FE_FAULT_BOUND;
        }
        return e->x;
    }
    e->out_of_bounds = 0U;
    const double rate = (double)e->cfg.rate_q28 / q28;
    e->x += fmin(rate, fmax(-rate, xm - e->x));
    e->band_hi = exp(1.25 * e->x);
    return e->x;
}
