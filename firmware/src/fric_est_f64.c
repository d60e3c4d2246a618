/* fric_est_f64.c - double twin of fric_est.c (host only); see fric_est_f64.h. */
#include "fric_est_f64.h"

#include <math.h>

void fric_est_f64_reset(fric_est_f64_t *e, double x0)
{
    e->p[0] = e->p[1] = e->q[0] = e->q[1] = 0.0;
    e->x_b[0] = e->x_b[1] = e->x = e->x_meas = x0;
    e->band_hi = exp(1.25 * x0);
    fric_est_gate_reset(&e->g);
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
    const double t_in = (double)t_in_q8;
    const double t_out = (double)t_out_q8;
    const fric_est_input_t in = {t_in_q8, t_out_q8, code, code_min, code_max, adc_flags};
    const int32_t outside = t_in > t_out * e->band_hi || t_in * e->band_hi < t_out;
    const fric_est_sample_t s = fric_est_gate_tick(&e->g, &e->cfg, &in, outside);
    const int32_t b = s.branch;
    if (b < 0) {
        return e->x;
    }
    const double d_in = (double)s.d_in_q8;
    const double d_out = (double)s.d_out_q8;
    e->p[b] += (d_in * d_out - e->p[b]) * e->lambda_inv;
    e->q[b] += (d_out * d_out - e->q[b]) * e->lambda_inv;
    if (fric_est_gate_ready(&e->g, b) == 0) {
        return e->x;
    }
    e->x_b[b] = (b == 0) ? log(e->p[0] / e->q[0]) : log(e->q[1] / e->p[1]);
    const double xm = (fric_est_gate_ready(&e->g, -1) != 0) ? 0.5 * (e->x_b[0] + e->x_b[1])
                                                            : e->x_b[b];
    e->x_meas = xm;
    const double lo = (double)e->cfg.mu_phi_min_q28 / q28;
    const double hi = (double)e->cfg.mu_phi_max_q28 / q28;
    if (fric_est_gate_bounds(&e->g, !(xm < lo || xm > hi)) == 0) {
        return e->x;
    }
    const double rate = (double)e->cfg.rate_q28 / q28;
    e->x += fmin(rate, fmax(-rate, xm - e->x));
    e->band_hi = exp(1.25 * e->x);
    return e->x;
}

/* ---- The far-end output correction's twin (fric_est_f64.h) -------------------------------- */

void fric_corr_f64_reset(fric_corr_f64_t *c)
{
    fric_corr_reset(&c->base);
    c->g[0] = 0.0;
    c->g[1] = 0.0;
    c->o[0] = 0.0;
    c->o[1] = 0.0;
    for (int32_t b = 0; b < 2; ++b) {
        for (int32_t k = 0; k < FC_REV_BINS; ++k) {
            c->rev[b][k] = 0.0;
        }
    }
    c->rev_out = 0.0;
    c->p = 0.0;
    c->out = 0.0;
}

/* v - sign(v) ceil(|v| 2^-s) in units of 1/q: the integer part's bleed. */
static double bleed_f64(double v, double q, int32_t s)
{
    const double m = ceil(fabs(v) * q * ldexp(1.0, -s)) / q;
    return (v >= 0.0) ? v - m : v + m;
}

/* The reversal table of branch b at tick n, N: linear between the nodes, floor to 2^-24 N. */
static double rev_value_f64(const fric_corr_f64_t *c, int32_t b, int32_t n)
{
    const int32_t s = c->base.cfg.rev_bin_shift;
    if (b < 0 || n < 0 || n >= (FC_REV_BINS << s)) {
        return 0.0;
    }
    const int32_t k = n >> s;
    const double f = (double)(n & ((1 << s) - 1));
    const double r0 = c->rev[b][k];
    const double r1 = (k + 1 < FC_REV_BINS) ? c->rev[b][k + 1] : 0.0;
    return floor((r0 + (r1 - r0) * f * ldexp(1.0, -s)) * 16777216.0) / 16777216.0;
}

/* One learning step of branch b's table at tick m for the error e_n (N). */
static void rev_learn_f64(fric_corr_f64_t *c, int32_t b, int32_t m, double e_n)
{
    const fric_corr_config_t *cfg = &c->base.cfg;
    const int32_t s = cfg->rev_bin_shift;
    const double q24 = 16777216.0;
    if (m < 0 || m >= (FC_REV_BINS << s)) {
        return;
    }
    const int32_t k = m >> s;
    const double f = (double)(m & ((1 << s) - 1));
    const double d = ldexp(e_n, -cfg->rev_ki_shift);
    const double lim = (double)cfg->rev_limit_n_q8 / 256.0;
    const double w = ldexp(1.0, s);
    const double share[2] = {floor(d * (w - f) / w * q24) / q24, floor(d * f / w * q24) / q24};
    /* By travel: s_b (r[i+1] - r[i]) <= h, half a bin in N, on both sides of the node. */
    const double h = ldexp(1.0, s) / 512.0;
    const double sb = (b == 0) ? 1.0 : -1.0;
    for (int32_t j = 0; j < 2 && k + j < FC_REV_BINS; ++j) {
        const int32_t i = k + j;
        double v = bleed_f64(c->rev[b][i], q24, cfg->rev_leak_shift) + share[j];
        v = fmin(lim, fmax(-lim, v));
        if (cfg->rev_index != 0) {
            const double next = (i + 1 < FC_REV_BINS) ? c->rev[b][i + 1] : 0.0;
            double u = fmax(sb * v, sb * next - h);
            if (i > 0) {
                u = fmin(u, sb * c->rev[b][i - 1] + h);
            }
            v = sb * u;
        }
        c->rev[b][i] = v;
    }
}

void fric_corr_f64_configure(fric_corr_f64_t *c, const fric_corr_config_t *cfg, q3_28_t x0_q28)
{
    fric_corr_configure(&c->base, cfg, x0_q28); /* the watch's band, as the integer part's */
    fric_corr_f64_reset(c);
}

double fric_corr_f64_step(fric_corr_f64_t *c, int32_t t_ref_q8, int32_t t_in_q8, int32_t t_out_q8,
                          int32_t code, int32_t code_min, int32_t code_max, uint32_t adc_flags,
                          int32_t w_q30, uint32_t lim)
{
    fric_corr_t *b = &c->base;
    const fric_corr_config_t *cfg = &b->cfg;
    const double q28 = 268435456.0;
    const double q24 = 16777216.0;
    b->branch = -1;
    fric_corr_check_inputs(b, t_in_q8, t_out_q8, code, code_min, code_max, adc_flags);
    if (b->faults == 0U && b->tared == 0) {
        if (t_in_q8 > cfg->tare_max_n_q8) {
            b->faults |= FC_FAULT_TARE;
        } else {
            b->tare_sum_q8 += t_out_q8;
            if (++b->tare_n >= cfg->tare_ticks) {
                b->tare_q8 = (int32_t)floor((double)b->tare_sum_q8 / (double)cfg->tare_ticks + 0.5);
                b->tared = 1;
            }
        }
    }
    const double w = fmin(1.0, fmax(0.0, (double)w_q30 / 1073741824.0));
    const int32_t full = (w == 1.0) ? 0 : (w == 0.0) ? 1 : -1;
    for (int32_t k = 0; k < 2; ++k) {
        if (k != full) {
            b->held[k] = 0;
        } else if (b->held[k] < cfg->hold_ticks) {
            ++b->held[k];
        }
    }
    const int32_t slides = fric_corr_gate(b, t_ref_q8, t_out_q8, full);
    const int32_t rb = fric_corr_rev_track(b, (int32_t)(w * 1073741824.0), t_in_q8);
    const int32_t rn = fric_corr_rev_index(b);
    if (b->faults != 0U) {
        const double f = ldexp(1.0, -FC_BLEED_SHIFT);
        for (int32_t k = 0; k < 2; ++k) {
            /* g - sign(g) ceil(|g| 2^28 2^-s) 2^-28 */
            const double m = ceil(fabs(c->g[k]) * q28 * f) / q28;
            c->g[k] = (c->g[k] >= 0.0) ? c->g[k] - m : c->g[k] + m;
            const double mo = ceil(fabs(c->o[k]) * q24 * f) / q24;
            c->o[k] = (c->o[k] >= 0.0) ? c->o[k] - mo : c->o[k] + mo;
            for (int32_t j = 0; j < FC_REV_BINS; ++j) {
                c->rev[k][j] = bleed_f64(c->rev[k][j], q24, FC_BLEED_SHIFT);
            }
        }
    } else if (cfg->rev_enable != 0 && b->tared != 0 && rb >= 0 &&
               fric_corr_rev_may_learn(b) != 0) {
        const double e_n = ((double)t_ref_q8 - ((double)t_out_q8 - (double)b->tare_q8)) / 256.0;
        if ((e_n > 0.0 && (lim & FC_LIM_HI) == 0U) || (e_n < 0.0 && (lim & FC_LIM_LO) == 0U)) {
            rev_learn_f64(c, rb, rn - cfg->rev_lead_ticks, e_n);
        }
    }
    if (b->faults == 0U && b->tared != 0 && full >= 0 && b->held[full] >= cfg->hold_ticks &&
        slides != 0 && b->same_ticks < (uint32_t)FC_FRESH_TICKS) {
        /* e in N, T_ref in N: the step ki e T_ref / (16 N)^2, rounded half up to 2^-28. */
        const double e_n = ((double)t_ref_q8 - ((double)t_out_q8 - (double)b->tare_q8)) / 256.0;
        if ((e_n > 0.0 && (lim & FC_LIM_HI) == 0U) || (e_n < 0.0 && (lim & FC_LIM_LO) == 0U)) {
            const double t_n = (double)t_ref_q8 / 256.0;
            const double step = floor(ldexp(e_n * t_n / 256.0, -cfg->ki_shift) * q28 + 0.5) / q28;
            const double lim_g = (double)cfg->limit_q28 / q28;
            c->g[full] = fmin(lim_g, fmax(-lim_g, c->g[full] + step));
            if (cfg->offset_term != 0) {
                const double lim_o = 16.0 * lim_g;
                c->o[full] = fmin(lim_o, fmax(-lim_o, c->o[full] + ldexp(e_n, -cfg->ki_shift)));
            }
            b->branch = full;
        }
    }
    /* The blend in Q1.16 as the integer correction takes it (w >> 14), in double: exact. */
    const double w16 = floor(w * 65536.0) / 65536.0;
    const double g = floor((c->g[1] + (c->g[0] - c->g[1]) * w16) * q28) / q28;
    const double o = floor((c->o[1] + (c->o[0] - c->o[1]) * w16) * q24) / q24;
    c->rev_out = (cfg->rev_enable != 0) ? rev_value_f64(c, rb, rn) : 0.0;
    /* The proportional term: kp e rounded half up to 1/256 N (e kp_q16 < 2^35: exact). */
    if (b->faults != 0U || b->same_ticks >= (uint32_t)FC_FRESH_TICKS) {
        c->p = bleed_f64(c->p, 256.0, FC_BLEED_SHIFT);
    } else if (b->tared != 0) {
        const double e_q8 = (double)t_ref_q8 - ((double)t_out_q8 - (double)b->tare_q8);
        const double lim_p = (double)FC_P_LIMIT_Q8 / 256.0;
        c->p = fmin(lim_p, fmax(-lim_p, floor((e_q8 * (double)cfg->kp_q16 + 32768.0) / 65536.0) / 256.0));
    }
    c->out = floor(((double)t_ref_q8 / 256.0 * g + o + c->rev_out) * 256.0 + 0.5) / 256.0 + c->p;
    return c->out;
}
