/* fric_est.c - the online friction estimate; the method, formats and bounds are in fric_est.h. */
#include "fric_est.h"

#include "fxp.h"

#define FE_HIST (FE_WINDOW_TICKS + 1) /* T(k - W) .. T(k) */

/* e^(5x/4): the band around a held T_out that T_in may cross in a dead zone with friction up to
 * a quarter above the estimate (x <= 4: 5x/4 <= 5 < 5.5, the domain of fxp_exp_uq8_24). */
static uq8_24_t band_of(q3_28_t x)
{
    return fxp_exp_uq8_24((q3_28_t)(x + (x >> 2)));
}

void fric_est_config_default(fric_est_config_t *cfg)
{
    if (cfg == 0) {
        return;
    }
    cfg->enable = 0;
    cfg->tau_ticks = 128;
    cfg->rate_q28 = (q3_28_t)536871L; /* 0.002 per tick = round(0.002 * 2^28): 2.0/s at 1 kHz */
    cfg->mu_phi_min_q28 = (q3_28_t)13421773L;     /* 0.05 = round(0.05 * 2^28) */
    cfg->mu_phi_max_q28 = (q3_28_t)(2L * Q3_28_ONE); /* 2.0 */
    cfg->t_min_n_q8 = Q7_8_ONE / 2;                /* 0.5 N */
}

/* s with 2^s = v, or -1 when v is not a power of two. */
static int32_t log2_exact(int32_t v)
{
    if (v <= 0 || (v & (v - 1)) != 0) {
        return -1;
    }
    int32_t s = 0;
    while ((v >> s) != 1) {
        ++s;
    }
    return s;
}

int32_t fric_est_config_check(const fric_est_config_t *cfg, q3_28_t x0_q28, q3_28_t slope_q28)
{
    if (cfg == 0) {
        return FE_ERR_NULL;
    }
    if (cfg->enable != 0 && cfg->enable != 1) {
        return FE_ERR_ENABLE;
    }
    if (cfg->tau_ticks < FE_TAU_MIN_TICKS || cfg->tau_ticks > FE_TAU_MAX_TICKS ||
        log2_exact(cfg->tau_ticks) < 0) {
        return FE_ERR_TAU;
    }
    if (cfg->rate_q28 < 0 || cfg->rate_q28 > (q3_28_t)(Q3_28_ONE / 16)) {
        return FE_ERR_RATE;
    }
    if (cfg->mu_phi_min_q28 < 0 || cfg->mu_phi_max_q28 > FE_X_MAX_Q28 ||
        cfg->mu_phi_min_q28 >= cfg->mu_phi_max_q28) {
        return FE_ERR_BOUNDS;
    }
    if (cfg->t_min_n_q8 < 0 || cfg->t_min_n_q8 > FE_TMIN_MAX_Q8) {
        return FE_ERR_T_MIN;
    }
    if (cfg->enable != 0) {
        if (x0_q28 < cfg->mu_phi_min_q28 || x0_q28 > cfg->mu_phi_max_q28) {
            return FE_ERR_BOUNDS;
        }
        if (slope_q28 != 0) {
            return FE_ERR_SLOPE;
        }
    }
    return FE_OK;
}

/* fric_est_reset with the band of x0 given. */
static void est_reset_band(fric_est_t *e, q3_28_t x0_q28, uq8_24_t band)
{
    /* The configuration kept; the accumulators zero; every measurement at the start value. */
    e->p[0] = e->p[1] = e->q[0] = e->q[1] = 0;
    e->x_b[0] = e->x_b[1] = e->x = e->x_meas = x0_q28;
    e->band_hi = band;
    fric_est_gate_reset(&e->g);
}

void fric_est_reset(fric_est_t *e, q3_28_t x0_q28)
{
    est_reset_band(e, x0_q28, band_of(x0_q28));
}

void fric_est_restart(fric_est_t *e, q3_28_t x0_q28)
{
    est_reset_band(e, x0_q28, (x0_q28 == e->x0_cfg_q28) ? e->band_x0 : band_of(x0_q28));
}

void fric_est_configure(fric_est_t *e, const fric_est_config_t *cfg, q3_28_t x0_q28)
{
    e->cfg = *cfg;
    e->tau_shift = log2_exact(cfg->tau_ticks);
    if (e->tau_shift < 0) {
        e->tau_shift = 8; /* unreachable after fric_est_config_check */
    }
    e->x0_cfg_q28 = x0_q28;
    e->band_x0 = band_of(x0_q28);
    est_reset_band(e, x0_q28, e->band_x0);
}

uint32_t fric_est_input_faults(int32_t t_in_q8, int32_t t_out_q8, int32_t code, int32_t code_min,
                               int32_t code_max, uint32_t adc_flags)
{
    uint32_t faults = 0U;
    if (adc_flags != 0U) {
        faults |= FE_FAULT_ADC;
    }
    if (code < code_min || code > code_max || t_out_q8 < Q7_8_MIN || t_out_q8 > Q7_8_MAX ||
        t_in_q8 < Q7_8_MIN || t_in_q8 > Q7_8_MAX) {
        faults |= FE_FAULT_RANGE;
    }
    return faults;
}

void fric_est_window_reset(fric_est_window_t *w)
{
    for (int32_t i = 0; i < FE_WINDOW_TICKS; ++i) {
        w->hist_in[i] = 0;
        w->hist_out[i] = 0;
    }
    w->hist_in_last = 0;
    w->hist_out_last = 0;
    w->filled = 0U;
    w->pos = 0U;
    w->last_code = 0;
    w->same_ticks = 0U;
}

int32_t fric_est_window_code(fric_est_window_t *w, int32_t code)
{
    int32_t changed = 0;
    if (w->filled > 0U && code == w->last_code) {
        if (w->same_ticks < 0xFFFFFFFFU) {
            ++w->same_ticks;
        }
    } else {
        w->same_ticks = 0U;
        changed = 1;
    }
    w->last_code = code;
    return changed;
}

int32_t fric_est_window_push(fric_est_window_t *w, int32_t t_in_q8, int32_t t_out_q8)
{
    /* The newest sample in *_last, the W before it in the ring. */
    if (w->filled > 0U) {
        w->hist_in[w->pos] = w->hist_in_last;
        w->hist_out[w->pos] = w->hist_out_last;
        w->pos = (w->pos + 1U < (uint32_t)FE_WINDOW_TICKS) ? w->pos + 1U : 0U;
    }
    w->hist_in_last = (int16_t)t_in_q8;
    w->hist_out_last = (int16_t)t_out_q8;
    if (w->filled < (uint32_t)FE_HIST) {
        ++w->filled;
    }
    return (w->filled < (uint32_t)FE_HIST) ? 0 : 1;
}

/* The history entry j ticks before the newest (j in [0, W]). */
static inline int32_t hist_at(const int16_t *h, int16_t newest_val, uint32_t pos, uint32_t j)
{
    if (j == 0U) {
        return newest_val;
    }
    /* pos is the slot of T(k - W + ... ): entries k-1 .. k-W live in the W slots, pos is where
     * k-W is (the oldest), so k-j is at pos + W - j. */
    uint32_t i = pos + (uint32_t)FE_WINDOW_TICKS - j;
    if (i >= (uint32_t)FE_WINDOW_TICKS) {
        i -= (uint32_t)FE_WINDOW_TICKS;
    }
    return h[i];
}

int32_t fric_est_window_branch(const fric_est_window_t *w, int32_t t_min_q8, int32_t *d_in_q8,
                               int32_t *d_out_q8)
{
    const uint32_t n = (uint32_t)FE_WINDOW_TICKS;
    const int32_t in_a = hist_at(w->hist_in, w->hist_in_last, w->pos, n);
    const int32_t in_m = hist_at(w->hist_in, w->hist_in_last, w->pos, n / 2U);
    const int32_t in_e = hist_at(w->hist_in, w->hist_in_last, w->pos, n / 8U);
    const int32_t in_s = hist_at(w->hist_in, w->hist_in_last, w->pos, n - n / 8U);
    const int32_t out_a = hist_at(w->hist_out, w->hist_out_last, w->pos, n);
    const int32_t out_m = hist_at(w->hist_out, w->hist_out_last, w->pos, n / 2U);
    const int32_t out_e = hist_at(w->hist_out, w->hist_out_last, w->pos, n / 8U);
    const int32_t out_s = hist_at(w->hist_out, w->hist_out_last, w->pos, n - n / 8U);
    const int32_t in_c = w->hist_in_last;
    const int32_t out_c = w->hist_out_last;
    if (in_a < t_min_q8 || in_c < t_min_q8 || out_a < t_min_q8 || out_c < t_min_q8) {
        return -1;
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
    if (b >= 0) {
        *d_in_q8 = in_c - in_a;
        *d_out_q8 = out_c - out_a;
    }
    return b;
}

void fric_est_gate_reset(fric_est_gate_t *g)
{
    fric_est_window_reset(&g->win);
    g->n[0] = 0U;
    g->n[1] = 0U;
    g->implausible = 0;
    g->faults = 0U;
    g->accepted = 0;
    g->out_of_bounds = 0U;
}

fric_est_sample_t fric_est_gate_tick(fric_est_gate_t *g, const fric_est_config_t *cfg,
                                     const fric_est_input_t *in, int32_t outside_band)
{
    fric_est_sample_t s = {-1, 0, 0};
    fric_est_window_t *w = &g->win;
    g->accepted = 0;
    g->faults |= fric_est_input_faults(in->t_in_q8, in->t_out_q8, in->code, in->code_min,
                                       in->code_max, in->adc_flags);
    if (g->faults != 0U) {
        return s;
    }
    /* STUCK: an unchanged code while T_in leaves the band friction allows around it. */
    if (fric_est_window_code(w, in->code) != 0) {
        g->implausible = 0;
    }
    if (w->same_ticks > 0U && in->t_in_q8 >= cfg->t_min_n_q8 && outside_band != 0) {
        g->implausible = 1;
    }
    if (w->same_ticks >= (uint32_t)FE_STUCK_TICKS && g->implausible != 0) {
        g->faults |= FE_FAULT_STUCK;
        return s;
    }
    if (fric_est_window_push(w, in->t_in_q8, in->t_out_q8) == 0) {
        return s;
    }
    s.branch = fric_est_window_branch(w, cfg->t_min_n_q8, &s.d_in_q8, &s.d_out_q8);
    if (s.branch >= 0) {
        if (g->n[s.branch] < 0xFFFFFFFFU) {
            ++g->n[s.branch];
        }
        g->accepted = 1;
    }
    return s;
}

int32_t fric_est_gate_ready(const fric_est_gate_t *g, int32_t b)
{
    const uint32_t need = (uint32_t)FE_MIN_SAMPLES;
    return (b < 0) ? (g->n[0] >= need && g->n[1] >= need) : (g->n[b] >= need);
}

int32_t fric_est_gate_bounds(fric_est_gate_t *g, int32_t in_bounds)
{
    if (in_bounds != 0) {
        g->out_of_bounds = 0U;
    } else if (++g->out_of_bounds >= (uint32_t)FE_BOUND_SAMPLES) {
        g->faults |= FE_FAULT_BOUND;
    }
    return in_bounds;
}

/* acc <- acc + (v 2^FE_ACC_FRAC - acc) / 2^s, rounded (v in [0, 2^30), acc in [0, 2^58)). */
static inline int64_t forget(int64_t acc, int64_t v, int32_t s)
{
    int64_t d = v * (INT64_C(1) << FE_ACC_FRAC) - acc; /* |d| < 2^58 */
    return acc + ((d + (INT64_C(1) << (s - 1))) >> s);
}

q3_28_t fric_est_step(fric_est_t *e, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                      int32_t code_min, int32_t code_max, uint32_t adc_flags)
{
    /* The STUCK band, T_out <= T_in <= T_out e^(5x/4): Q7.8 * UQ8.24 in int64 (|T| < 2^31 even
     * for a word the gate refuses, band < 2^30 (e^4 < 55): products below 2^61). */
    const int64_t in24 = (int64_t)t_in_q8 * (INT64_C(1) << 24);
    const int64_t out24 = (int64_t)t_out_q8 * (INT64_C(1) << 24);
    const int64_t out_hi = (int64_t)t_out_q8 * (int64_t)e->band_hi;
    const int64_t in_hi = (int64_t)t_in_q8 * (int64_t)e->band_hi; /* T_in e^x_max */
    const fric_est_input_t in = {t_in_q8, t_out_q8, code, code_min, code_max, adc_flags};
    const int32_t outside = in24 > out_hi || in_hi < out24;
    const fric_est_sample_t s = fric_est_gate_tick(&e->g, &e->cfg, &in, outside);
    const int32_t b = s.branch;
    if (b < 0) {
        return e->x; /* no sample this tick (frozen by a latched fault until the next reset) */
    }

    /* Increments |d| < 2^15 with the same sign: products in (0, 2^30). */
    const int64_t d_in = s.d_in_q8;
    const int64_t d_out = s.d_out_q8;
    e->p[b] = forget(e->p[b], d_in * d_out, e->tau_shift);
    e->q[b] = forget(e->q[b], d_out * d_out, e->tau_shift);
    if (fric_est_gate_ready(&e->g, b) == 0) {
        return e->x;
    }
    /* G_up = P/Q >= 1 and 1/G_dn = Q/P >= 1 for mu*phi >= 0: the larger over the smaller keeps
     * the UQ8.24 ratio's relative rounding below 2^-25. */
    uq8_24_t ratio = (b == 0) ? fxp_div_uq8_24((uint64_t)e->p[0], (uint64_t)e->q[0])
                              : fxp_div_uq8_24((uint64_t)e->q[1], (uint64_t)e->p[1]);
    e->x_b[b] = (ratio == 0U) ? (q3_28_t)(-8L * Q3_28_ONE) : fric_est_ln_q28(ratio);
    int64_t xm;
    if (fric_est_gate_ready(&e->g, -1) != 0) {
        xm = ((int64_t)e->x_b[0] + (int64_t)e->x_b[1]) >> 1;
    } else {
        xm = e->x_b[b];
    }
    e->x_meas = (q3_28_t)xm;
    const int32_t in_bounds = xm >= e->cfg.mu_phi_min_q28 && xm <= e->cfg.mu_phi_max_q28;
    if (fric_est_gate_bounds(&e->g, in_bounds) == 0) {
        return e->x;
    }
    int64_t dx = xm - (int64_t)e->x;
    if (dx > e->cfg.rate_q28) {
        dx = e->cfg.rate_q28;
    } else if (dx < -(int64_t)e->cfg.rate_q28) {
        dx = -(int64_t)e->cfg.rate_q28;
    }
    e->x = (q3_28_t)((int64_t)e->x + dx);
    if (dx != 0) {
        e->band_hi = band_of(e->x);
    }
    return e->x;
}

q3_28_t fric_est_ln_q28(uq8_24_t v)
{
    return fxp_ln_q28(v); /* shared with the compensator's dead-zone inverse (fxp.h) */
}

/* ---- The far-end output correction (fric_est.h, "The far-end output correction") ---------- */

void fric_corr_config_default(fric_corr_config_t *cfg)
{
    if (cfg == 0) {
        return;
    }
    cfg->enable = 0;
    cfg->ki_shift = 6;                          /* 2^-6 per tick: 16 per second at 16 N */
    cfg->hold_ticks = 30;
    cfg->limit_q28 = (q3_28_t)(Q3_28_ONE / 2); /* 0.5 */
    cfg->tare_ticks = 64;
    cfg->tare_max_n_q8 = Q7_8_ONE / 2;
    cfg->slide_gate = 0;
    cfg->offset_term = 0;
    cfg->rev_enable = 0;
    cfg->rev_ki_shift = 4;     /* 2^-4 per tick: the margins of fric_est.h */
    cfg->rev_bin_shift = 6;    /* 16 bins of 64 ticks: 1.02 s after the reversal */
    cfg->rev_lead_ticks = 0;
    cfg->rev_leak_shift = 12;  /* 64 updates per reversal: 1/64 of a node per reversal */
    cfg->rev_limit_n_q8 = 2 * Q7_8_ONE;
    cfg->rev_index = 0;        /* by ticks: the travel index is an option (fric_est.h) */
    cfg->kp_q16 = 0;           /* the proportional term off */
}

int32_t fric_corr_config_check(const fric_corr_config_t *cfg)
{
    if (cfg == 0) {
        return FE_ERR_NULL;
    }
    if (cfg->enable != 0 && cfg->enable != 1) {
        return FC_ERR_ENABLE;
    }
    if (cfg->ki_shift < FC_KI_SHIFT_MIN || cfg->ki_shift > FC_KI_SHIFT_MAX) {
        return FC_ERR_KI;
    }
    if (cfg->hold_ticks < 0 || cfg->hold_ticks > FC_HOLD_MAX_TICKS) {
        return FC_ERR_HOLD;
    }
    if (cfg->limit_q28 < 0 || cfg->limit_q28 > FC_LIMIT_MAX_Q28) {
        return FC_ERR_LIMIT;
    }
    if (cfg->tare_ticks > FC_TARE_MAX_TICKS || log2_exact(cfg->tare_ticks) < 0) {
        return FC_ERR_TARE;
    }
    if (cfg->tare_max_n_q8 < 0 || cfg->tare_max_n_q8 > FC_TARE_T_MAX_Q8) {
        return FC_ERR_TARE_MAX;
    }
    if (cfg->slide_gate != 0 && cfg->slide_gate != 1) {
        return FC_ERR_GATE;
    }
    if (cfg->offset_term != 0 && cfg->offset_term != 1) {
        return FC_ERR_OFFSET;
    }
    /* By travel the bins may be wider (up to FC_REV_BIN_TRAVEL_MAX) and take no lead. */
    const int32_t bin_max = (cfg->rev_index == 1) ? FC_REV_BIN_TRAVEL_MAX : FC_REV_BIN_MAX;
    const int32_t lead_max = (cfg->rev_index == 1) ? 0 : FC_REV_LEAD_MAX;
    if ((cfg->rev_enable != 0 && cfg->rev_enable != 1) ||
        (cfg->rev_index != 0 && cfg->rev_index != 1) || cfg->rev_ki_shift < FC_REV_KI_MIN ||
        cfg->rev_ki_shift > FC_REV_KI_MAX || cfg->rev_bin_shift < 0 ||
        cfg->rev_bin_shift > bin_max || cfg->rev_lead_ticks < 0 || cfg->rev_lead_ticks > lead_max ||
        cfg->rev_leak_shift < FC_REV_LEAK_MIN || cfg->rev_leak_shift > FC_REV_LEAK_MAX) {
        return FC_ERR_REV;
    }
    if (cfg->rev_limit_n_q8 < 0 || cfg->rev_limit_n_q8 > FC_REV_LIMIT_MAX_Q8) {
        return FC_ERR_REV_LIMIT;
    }
    if (cfg->kp_q16 < 0 || cfg->kp_q16 > FC_KP_MAX_Q16) {
        return FC_ERR_KP;
    }
    return FE_OK;
}

void fric_corr_reset(fric_corr_t *c)
{
    for (int32_t b = 0; b < 2; ++b) {
        c->g_q28[b] = 0;
        c->o_q24[b] = 0;
        c->held[b] = 0;
    }
    c->tare_sum_q8 = 0;
    c->tare_n = 0;
    c->tare_q8 = 0;
    c->tared = 0;
    c->last_code = 0;
    c->implausible = 0;
    c->same_ticks = 0U;
    c->started = 0;
    c->faults = 0U;
    c->out_q8 = 0;
    c->p_q8 = 0;
    c->branch = -1;
    for (int32_t i = 0; i < FC_GATE_TICKS; ++i) {
        c->gate_ref[i] = 0;
        c->gate_out[i] = 0;
    }
    c->gate_pos = 0U;
    c->gate_filled = 0U;
    for (int32_t b = 0; b < 2; ++b) {
        for (int32_t k = 0; k < FC_REV_BINS; ++k) {
            c->rev_q24[b][k] = 0;
        }
    }
    c->rev_branch = -1;
    c->rev_ticks = 0;
    c->w_prev = -1;
    c->rev_out_q24 = 0;
    c->rev_ext_q8 = 0;
    c->rev_ln_ext_q28 = 0;
    c->rev_travel = 0;
}

/* x0 clamped to the STUCK band's domain. */
static q3_28_t corr_band_x(q3_28_t x0_q28)
{
    const q3_28_t x_max = (q3_28_t)(11L * (Q3_28_ONE / 4)); /* 2x <= 5.5: fxp_exp's domain */
    return (x0_q28 < 0) ? 0 : (x0_q28 > x_max) ? x_max : x0_q28;
}

void fric_corr_configure(fric_corr_t *c, const fric_corr_config_t *cfg, q3_28_t x0_q28)
{
    const q3_28_t x = corr_band_x(x0_q28);
    c->cfg = *cfg;
    c->band_q24 = fxp_exp_uq8_24((q3_28_t)(2 * x));
    c->band_x_q28 = x;
    fric_corr_reset(c);
}

void fric_corr_restart(fric_corr_t *c, q3_28_t x0_q28)
{
    const q3_28_t x = corr_band_x(x0_q28);
    if (x != c->band_x_q28) {
        c->band_q24 = fxp_exp_uq8_24((q3_28_t)(2 * x));
        c->band_x_q28 = x;
    }
    fric_corr_reset(c);
}

void fric_corr_check_inputs(fric_corr_t *c, int32_t t_in_q8, int32_t t_out_q8, int32_t code,
                            int32_t code_min, int32_t code_max, uint32_t adc_flags)
{
    if (adc_flags != 0U) {
        c->faults |= FC_FAULT_ADC;
    }
    if (code < code_min || code > code_max || t_out_q8 < Q7_8_MIN || t_out_q8 > Q7_8_MAX ||
        t_in_q8 < Q7_8_MIN || t_in_q8 > Q7_8_MAX) {
        c->faults |= FC_FAULT_RANGE;
    }
    if (c->started == 0 || code != c->last_code) {
        c->started = 1;
        c->last_code = code;
        c->implausible = 0;
        c->same_ticks = 0U;
        return;
    }
    if (c->same_ticks < 0xFFFFFFFFU) {
        ++c->same_ticks;
    }
    if (t_in_q8 >= FC_STUCK_T_MIN_Q8) {
        /* Q7.8 * UQ8.24 in int64: |T| < 2^17, band < 2^30 (e^5.5 < 245). */
        const int64_t in24 = (int64_t)t_in_q8 * (INT64_C(1) << 24);
        const int64_t out24 = (int64_t)t_out_q8 * (INT64_C(1) << 24);
        if (in24 > (int64_t)t_out_q8 * (int64_t)c->band_q24 ||
            (int64_t)t_in_q8 * (int64_t)c->band_q24 < out24) {
            c->implausible = 1;
        }
    }
    if (c->same_ticks >= (uint32_t)FC_STUCK_TICKS && c->implausible != 0) {
        c->faults |= FC_FAULT_STUCK;
    }
}

static inline int16_t clamp16(int32_t v)
{
    return (int16_t)((v > Q7_8_MAX) ? Q7_8_MAX : (v < Q7_8_MIN) ? Q7_8_MIN : v);
}

int32_t fric_corr_gate(fric_corr_t *c, int32_t t_ref_q8, int32_t t_out_q8, int32_t b)
{
    const int32_t ref = clamp16(t_ref_q8);
    const int32_t out = clamp16(t_out_q8);
    const int32_t full = (c->gate_filled >= (uint32_t)FC_GATE_TICKS);
    const int32_t ref_a = c->gate_ref[c->gate_pos]; /* FC_GATE_TICKS ticks ago once full */
    const int32_t out_a = c->gate_out[c->gate_pos];
    c->gate_ref[c->gate_pos] = (int16_t)ref;
    c->gate_out[c->gate_pos] = (int16_t)out;
    c->gate_pos = (c->gate_pos + 1U < (uint32_t)FC_GATE_TICKS) ? c->gate_pos + 1U : 0U;
    if (!full) {
        ++c->gate_filled;
    }
    if (c->cfg.slide_gate == 0) {
        return 1;
    }
    if (!full || b < 0) {
        return 0;
    }
    const int32_t s = (b == 0) ? 1 : -1;
    const int32_t dref = s * (ref - ref_a); /* |.| < 2^16 */
    const int32_t dout = s * (out - out_a);
    return (dref >= FC_GATE_MIN_Q8 && 2 * dout >= dref) ? 1 : 0;
}

/* v - sign(v) ceil(|v| 2^-s): the bleed, reaching 0 (|v| < 2^31 - 2^s, s <= 24). */
static inline int32_t bleed(int32_t v, int32_t s)
{
    const int32_t r = (INT32_C(1) << s) - 1;
    return (v >= 0) ? v - ((v + r) >> s) : v + ((-v + r) >> s);
}

int32_t fric_corr_rev_track(fric_corr_t *c, int32_t w_q30, int32_t t_in_q8)
{
    const int32_t b = (w_q30 > c->w_prev) ? 0 : 1; /* the way w moves: 0 loading */
    const int32_t started = (c->w_prev >= 0 && w_q30 != c->w_prev && b != c->rev_branch);
    if (started) {
        c->rev_branch = b;
        c->rev_ticks = 0;
    } else if (c->rev_branch >= 0 && c->rev_ticks < (INT32_C(1) << 24)) {
        ++c->rev_ticks;
    }
    c->w_prev = w_q30;
    if (c->cfg.rev_index == 0 || c->rev_branch < 0) {
        return c->rev_branch;
    }
    /* By travel: T_in at least FC_REV_T_FLOOR_Q8, its ln (UQ8.24 = Q7.8 << 16 < 2^31), the
     * extreme the branch's way back since the reversal began (the highest unloading, the lowest
     * loading) and the log travel from it in 2^-8 of ln, >= 0 and < 2^11 (T in [1, 128) N). */
    int32_t t = clamp16(t_in_q8);
    t = (t < FC_REV_T_FLOOR_Q8) ? FC_REV_T_FLOOR_Q8 : t;
    const q3_28_t lt = fxp_ln_q28((uq8_24_t)t << 16);
    if (started || (c->rev_branch == 1 && t > c->rev_ext_q8) ||
        (c->rev_branch == 0 && t < c->rev_ext_q8)) {
        c->rev_ext_q8 = t;
        c->rev_ln_ext_q28 = lt;
    }
    const int32_t u = (c->rev_branch == 1) ? c->rev_ln_ext_q28 - lt : lt - c->rev_ln_ext_q28;
    c->rev_travel = (u > 0) ? (u >> 20) : 0;
    return c->rev_branch;
}

int32_t fric_corr_rev_index(const fric_corr_t *c)
{
    return (c->cfg.rev_index != 0) ? c->rev_travel : c->rev_ticks;
}

int32_t fric_corr_rev_may_learn(const fric_corr_t *c)
{
    return (c->same_ticks < (uint32_t)FC_FRESH_TICKS) ? 1 : 0;
}

/* The reversal table of branch b at tick n (linear between the nodes, 0 from node FC_REV_BINS
 * on), Q7.24 N: r_k 2^s + (r_k1 - r_k) f < 2^35 in int64, floor. */
static int32_t rev_value(const fric_corr_t *c, int32_t b, int32_t n)
{
    const int32_t s = c->cfg.rev_bin_shift;
    if (b < 0 || n < 0 || n >= (FC_REV_BINS << s)) {
        return 0;
    }
    const int32_t k = n >> s;
    const int32_t f = n & ((INT32_C(1) << s) - 1);
    const int64_t r0 = c->rev_q24[b][k];
    const int64_t r1 = (k + 1 < FC_REV_BINS) ? c->rev_q24[b][k + 1] : 0;
    return (int32_t)((r0 * (INT64_C(1) << s) + (r1 - r0) * f) >> s);
}

/* One learning step of branch b's table at tick m since the reversal for the error e (Q7.8):
 * d = e << (16 - ki) (|d| < 2^31), its two shares floor(d (2^s - f) 2^-s), floor(d f 2^-s),
 * then the leak and the clamp to +-rev_limit (Q7.24 = limit_q8 << 16 <= 2^27). */
static void rev_learn(fric_corr_t *c, int32_t b, int32_t m, int32_t e_q8)
{
    const int32_t s = c->cfg.rev_bin_shift;
    if (m < 0 || m >= (FC_REV_BINS << s)) {
        return;
    }
    const int32_t k = m >> s;
    const int64_t f = m & ((INT32_C(1) << s) - 1);
    const int64_t d = (int64_t)e_q8 * (INT64_C(1) << (16 - c->cfg.rev_ki_shift));
    const int64_t lim = (int64_t)c->cfg.rev_limit_n_q8 * (INT64_C(1) << 16);
    const int64_t share[2] = {(d * ((INT64_C(1) << s) - f)) >> s, (d * f) >> s};
    /* By travel: s_b (r[i+1] - r[i]) <= h on both sides of the node (fric_est.h), in the
     * branch's sign (sb v, the node seen the branch's way: |sb v| <= 2^27); h = 1/2 N per unit
     * of ln, 2^s / 512 N a bin, Q7.24. */
    const int64_t h = INT64_C(1) << (s + 15);
    const int64_t sb = (b == 0) ? 1 : -1;
    for (int32_t j = 0; j < 2 && k + j < FC_REV_BINS; ++j) {
        const int32_t i = k + j;
        int64_t v = (int64_t)bleed(c->rev_q24[b][i], c->cfg.rev_leak_shift) + share[j];
        v = (v > lim) ? lim : (v < -lim) ? -lim : v;
        if (c->cfg.rev_index != 0) {
            const int64_t next = (i + 1 < FC_REV_BINS) ? c->rev_q24[b][i + 1] : 0;
            const int64_t lo = sb * next - h; /* sb r[i] >= sb r[i+1] - h */
            int64_t u = sb * v;
            u = (u < lo) ? lo : u;
            if (i > 0) {
                const int64_t hi = sb * (int64_t)c->rev_q24[b][i - 1] + h; /* sb r[i] <= .. */
                u = (u > hi) ? hi : u;
            }
            v = sb * u;
        }
        c->rev_q24[b][i] = (int32_t)v;
    }
}

int32_t fric_corr_step(fric_corr_t *c, int32_t t_ref_q8, int32_t t_in_q8, int32_t t_out_q8,
                       int32_t code, int32_t code_min, int32_t code_max, uint32_t adc_flags,
                       int32_t w_q30, uint32_t lim)
{
    c->branch = -1;
    fric_corr_check_inputs(c, t_in_q8, t_out_q8, code, code_min, code_max, adc_flags);
    if (c->faults == 0U && c->tared == 0) {
        if (t_in_q8 > c->cfg.tare_max_n_q8) {
            c->faults |= FC_FAULT_TARE;
        } else {
            c->tare_sum_q8 += t_out_q8;
            if (++c->tare_n >= c->cfg.tare_ticks) {
                const int32_t s = log2_exact(c->cfg.tare_ticks); /* >= 0: checked */
                /* The mean, rounded half up (|sum| < 2^27). */
                c->tare_q8 = (int32_t)((c->tare_sum_q8 + ((INT64_C(1) << s) >> 1)) >> s);
                c->tared = 1;
            }
        }
    }
    if (w_q30 < 0) {
        w_q30 = 0;
    } else if (w_q30 > (int32_t)Q1_30_ONE) {
        w_q30 = (int32_t)Q1_30_ONE;
    }
    /* Which branch is fully in force, and for how long. */
    const int32_t full = (w_q30 == (int32_t)Q1_30_ONE) ? 0 : (w_q30 == 0) ? 1 : -1;
    for (int32_t b = 0; b < 2; ++b) {
        if (b != full) {
            c->held[b] = 0;
        } else if (c->held[b] < c->cfg.hold_ticks) {
            ++c->held[b];
        }
    }
    const int32_t slides = fric_corr_gate(c, t_ref_q8, t_out_q8, full);
    const int32_t rb = fric_corr_rev_track(c, w_q30, t_in_q8);
    const int32_t rn = fric_corr_rev_index(c);
    if (c->faults != 0U) {
        for (int32_t b = 0; b < 2; ++b) {
            c->g_q28[b] = bleed(c->g_q28[b], FC_BLEED_SHIFT);
            c->o_q24[b] = bleed(c->o_q24[b], FC_BLEED_SHIFT);
            for (int32_t k = 0; k < FC_REV_BINS; ++k) {
                c->rev_q24[b][k] = bleed(c->rev_q24[b][k], FC_BLEED_SHIFT);
            }
        }
    } else if (c->cfg.rev_enable != 0 && c->tared != 0 && rb >= 0 &&
               fric_corr_rev_may_learn(c) != 0) {
        const int32_t e = t_ref_q8 - (t_out_q8 - c->tare_q8); /* |e| < 2^17 */
        if ((e > 0 && (lim & FC_LIM_HI) == 0U) || (e < 0 && (lim & FC_LIM_LO) == 0U)) {
            rev_learn(c, rb, rn - c->cfg.rev_lead_ticks, e);
        }
    }
    if (c->faults == 0U && c->tared != 0 && full >= 0 && c->held[full] >= c->cfg.hold_ticks &&
        slides != 0 && c->same_ticks < (uint32_t)FC_FRESH_TICKS) {
        const int32_t e = t_ref_q8 - (t_out_q8 - c->tare_q8); /* |e| < 2^17 */
        if ((e > 0 && (lim & FC_LIM_HI) == 0U) || (e < 0 && (lim & FC_LIM_LO) == 0U)) {
            const int64_t g_max = c->cfg.limit_q28; /* <= 2^28 */
            const int64_t p = (int64_t)e * (int64_t)t_ref_q8; /* Q15.16 N^2, |p| < 2^33 */
            const int32_t k = c->cfg.ki_shift - 4;             /* in [0, 12] */
            const int64_t step = (k == 0) ? p : ((p + (INT64_C(1) << (k - 1))) >> k);
            int64_t v = (int64_t)c->g_q28[full] + step;
            if (v > g_max) {
                v = g_max;
            } else if (v < -g_max) {
                v = -g_max;
            }
            c->g_q28[full] = (q3_28_t)v;
            if (c->cfg.offset_term != 0) {
                /* o_b in Q7.24 N, bound 16 N * limit = limit_q28 in Q7.24 (16 * 2^24 = 2^28). */
                int64_t o = (int64_t)c->o_q24[full] + (int64_t)e * (INT64_C(1) << (16 - c->cfg.ki_shift));
                o = (o > g_max) ? g_max : (o < -g_max) ? -g_max : o;
                c->o_q24[full] = (int32_t)o;
            }
            c->branch = full;
        }
    }
    /* g = g_dn + w16 (g_up - g_dn) in Q3.28 (floor); c = T_ref g rounded half up to Q7.8. */
    const int64_t w16 = (int64_t)(w_q30 >> 14); /* Q1.16, [0, 2^16] */
    const int64_t d = (int64_t)c->g_q28[0] - (int64_t)c->g_q28[1]; /* |d| <= 2^29 */
    const int64_t g = (((int64_t)c->g_q28[1] * (INT64_C(1) << 16)) + d * w16) >> 16;
    /* o = o_dn + w16 (o_up - o_dn) in Q7.24 (floor), as g. */
    const int64_t od = (int64_t)c->o_q24[0] - (int64_t)c->o_q24[1]; /* |od| <= 2^29 */
    const int64_t o = (((int64_t)c->o_q24[1] * (INT64_C(1) << 16)) + od * w16) >> 16;
    /* Q7.8 * Q3.28 = Q.36 N (|.| < 2^45), + o in Q.36 (|.| < 2^41). */
    c->rev_out_q24 = (c->cfg.rev_enable != 0) ? rev_value(c, rb, rn) : 0;
    const int64_t cq = (int64_t)t_ref_q8 * g + (o + c->rev_out_q24) * (INT64_C(1) << 12);
    /* The proportional term: kp e rounded half up to Q7.8 N (|e kp| < 2^35), clamped. */
    if (c->faults != 0U || c->same_ticks >= (uint32_t)FC_FRESH_TICKS) {
        c->p_q8 = bleed(c->p_q8, FC_BLEED_SHIFT);
    } else if (c->tared != 0) {
        const int64_t e = (int64_t)t_ref_q8 - ((int64_t)t_out_q8 - c->tare_q8);
        const int64_t p = (e * c->cfg.kp_q16 + (INT64_C(1) << 15)) >> 16;
        c->p_q8 = (int32_t)((p > FC_P_LIMIT_Q8) ? FC_P_LIMIT_Q8 : (p < -FC_P_LIMIT_Q8) ? -FC_P_LIMIT_Q8 : p);
    }
    c->out_q8 = (int32_t)((cq + (INT64_C(1) << 27)) >> 28) + c->p_q8;
    return c->out_q8;
}
