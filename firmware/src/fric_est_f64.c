/* fric_est_f64.c - double twin of fric_est.c (host only); see fric_est_f64.h. */
#include "fric_est_f64.h"

#include <math.h>

#define FE_HIST (FE_WINDOW_TICKS + 1)

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
    for (int32_t i = 0; i < FE_WINDOW_TICKS; ++i) {
        e->hist_in[i] = 0;
        e->hist_out[i] = 0;
    }
    e->hist_in_last = 0;
    e->hist_out_last = 0;
    e->filled = 0U;
    e->pos = 0U;
    e->last_code = 0;
    e->same_ticks = 0U;
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

static int32_t hist_at(const int16_t *h, int16_t newest_val, uint32_t pos, uint32_t j)
{
    if (j == 0U) {
        return newest_val;
    }
    uint32_t i = pos + (uint32_t)FE_WINDOW_TICKS - j;
    if (i >= (uint32_t)FE_WINDOW_TICKS) {
        i -= (uint32_t)FE_WINDOW_TICKS;
    }
    return h[i];
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

    if (e->filled > 0U && code == e->last_code) {
        if (e->same_ticks < 0xFFFFFFFFU) {
            ++e->same_ticks;
        }
    } else {
        e->same_ticks = 0U;
        e->implausible = 0;
    }
    e->last_code = code;
    if (e->same_ticks > 0U && t_in_q8 >= e->cfg.t_min_n_q8) {
        if ((double)t_in_q8 > (double)t_out_q8 * e->band_hi ||
            (double)t_in_q8 * e->band_hi < (double)t_out_q8) {
            e->implausible = 1;
        }
    }
    if (e->same_ticks >= (uint32_t)FE_STUCK_TICKS && e->implausible != 0) {
        e->faults |= FE_FAULT_STUCK;
        return e->x;
    }
    if (e->filled > 0U) {
        e->hist_in[e->pos] = e->hist_in_last;
        e->hist_out[e->pos] = e->hist_out_last;
        e->pos = (e->pos + 1U < (uint32_t)FE_WINDOW_TICKS) ? e->pos + 1U : 0U;
    }
    e->hist_in_last = (int16_t)t_in_q8;
    e->hist_out_last = (int16_t)t_out_q8;
    if (e->filled < (uint32_t)FE_HIST) {
        ++e->filled;
    }
    if (e->filled < (uint32_t)FE_HIST) {
        return e->x;
    }
    const uint32_t w = (uint32_t)FE_WINDOW_TICKS;
    const int32_t in_a = hist_at(e->hist_in, e->hist_in_last, e->pos, w);
    const int32_t in_m = hist_at(e->hist_in, e->hist_in_last, e->pos, w / 2U);
    const int32_t in_e = hist_at(e->hist_in, e->hist_in_last, e->pos, w / 8U);
    const int32_t in_s = hist_at(e->hist_in, e->hist_in_last, e->pos, w - w / 8U);
    const int32_t out_a = hist_at(e->hist_out, e->hist_out_last, e->pos, w);
    const int32_t out_m = hist_at(e->hist_out, e->hist_out_last, e->pos, w / 2U);
    const int32_t out_e = hist_at(e->hist_out, e->hist_out_last, e->pos, w / 8U);
    const int32_t out_s = hist_at(e->hist_out, e->hist_out_last, e->pos, w - w / 8U);
    const int32_t in_c = t_in_q8;
    const int32_t out_c = t_out_q8;
    const int32_t tmin = e->cfg.t_min_n_q8;
    if (in_a < tmin || in_c < tmin || out_a < tmin || out_c < tmin) {
        return e->x;
    }
    const int32_t half = FE_SLIDE_MIN_Q8 / 2;
    int32_t b = -1;
    for (int32_t s = 1; s >= -1; s -= 2) {
        if (s * (in_m - in_a) >= half && s * (in_c - in_m) >= half && s * (in_c - in_e) > 0 &&
            s * (in_s - in_a) > 0 && s * (out_m - out_a) >= half &&
            s * (out_c - out_m) >= half && s * (out_c - out_e) > 0 && s * (out_s - out_a) > 0) {
            b = (s > 0) ? 0 : 1;
        }
    }
    if (b < 0) {
        return e->x;
    }
    const double d_in = (double)(in_c - in_a);
    const double d_out = (double)(out_c - out_a);
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
