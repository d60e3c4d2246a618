/* comp.c - the fixed-point friction compensator; the law, formats and bounds are in comp.h. */
#include "comp.h"

#include "fxp.h"

/* comp_t.kind: what a step runs after the detector. */
#define COMP_KIND_SHARP 0 /* PAPER, SMOOTH, PREVIEW without a dead-zone spread */
#define COMP_KIND_NONE 1  /* mode NONE */
#define COMP_KIND_DZ 2    /* PAPER, SMOOTH, PREVIEW with the dead-zone inverse */
#define COMP_KIND_BRK 3   /* PAPER, SMOOTH, PREVIEW with the breakaway term, the slack's root
                           * or the viscous term (and any spread) */

void comp_config_default(comp_config_t *cfg)
{
    if (cfg == 0) {
        return;
    }
    cfg->mode = COMP_MODE_PAPER;
    cfg->mu_q28 = (q3_28_t)20132659L;       /* 0.075 (paper Fig. 11) = round(0.075 * 2^28) */
    cfg->phi_rad_q24 = (q7_24_t)105414357L; /* 2*pi (loop routing) = round(2*pi * 2^24) */
    cfg->mu_slope_per_n_q28 = 0;
    cfg->offset_n_q8 = 0;
    cfg->hysteresis_n_q8 = 4;         /* 1/64 N */
    cfg->band_n_q8 = Q7_8_ONE / 2;    /* 0.5 N (bowden tune) */
    cfg->tc_min_n_q8 = 0;             /* a cable cannot push */
    cfg->preview_ticks = COMP_DEFAULT_PREVIEW_TICKS;
    cfg->lead_ticks = COMP_DEFAULT_LEAD_TICKS;
    cfg->ramp_ticks = COMP_DEFAULT_RAMP_TICKS;
    cfg->dead_zone_spread_q28 = 0;
    cfg->breakaway_q28 = 0;
    cfg->slack_tension_n_q8 = 0;
    cfg->mu_per_inlet_rate_q28 = 0;
}

/* mu * phi in Q3.28, in 64 bits for the range check. Scaling and overflow: Q3.28 * Q7.24 =
 * Q10.52, < 2^60 for mu <= 1 and phi <= 4*pi; >> 24 with rounding -> Q3.28. */
static int64_t exponent_q28(const comp_config_t *cfg)
{
    return ((int64_t)cfg->mu_q28 * cfg->phi_rad_q24 + (INT64_C(1) << 23)) >> 24;
}

/*
 * The gain tables G_up, G_dn at |T| = 2i N (comp.h). Returns COMP_ERR_MU_SLOPE when a gain leaves
 * [e^-4, e^4] or a denominator is not positive. Expects the fields already range-checked.
 * Scaling and overflow: E = exp(mu*phi) in UQ8.24 (<= 54.6 * 2^24 < 2^30); q = phi*(E-1)/(mu*phi)
 * in Q.24 (<= 4*pi * 13.4 = 168 rad: < 2^32 in int64); k = s*q in Q.52 per N (|s| <= 2^21 in Q3.28,
 * so |k| < 2^53.4); c = k*T (T <= 128 N) in Q.52, |c| < 2^60.4; the numerators E*2^28 (< 2^58) and
 * 2^52 and the denominators 2^52 - c and E*2^28 + c stay below 2^62 for fxp_div_uq8_24.
 */
int64_t comp_config_exponent_q28(const comp_config_t *cfg)
{
    return exponent_q28(cfg);
}

/* The dead-zone inverse's first play w_1 = W e^(sigma q_1) * h / mean_j(w_j) (comp.h), and the
 * rest of its constants when c is given. Scaling and overflow: sigma*q_j in Q3.28 (|.| <= 1.54,
 * the product < 2^58 in int64); e^(sigma q_j) in UQ8.24 (<= 4.7); w_j = W e^(...) in Q3.28 (W <= 4
 * and the widest strand checked <= 4: < 2^30); e^-+w_j in UQ8.24 (< 2^30), their sum over 8 < 2^33;
 * the means' logarithms a_up, a_dn in [0, 4] Q3.28; h / mean(w) by fxp_div_uq8_24 (< 1.5: the
 * arithmetic mean's branches lie within the strands' widths); the thresholds r'_i < 4 in Q3.28.
 * Configuration time only (17 exponentials, two logarithms, one division). */
static q3_28_t dz_constants(const comp_config_t *cfg, comp_t *c)
{
    static const int64_t q_q28[COMP_DZ_PLAYS] = COMP_DZ_QUANTILES_Q28;
    const int64_t x = exponent_q28(cfg);
    int64_t w[COMP_DZ_PLAYS];
    int64_t sum_w = 0;
    uint64_t sum_up = 0;
    uint64_t sum_dn = 0;
    for (int32_t j = 0; j < COMP_DZ_PLAYS; ++j) {
        int64_t sq = ((int64_t)cfg->dead_zone_spread_q28 * q_q28[j] + (INT64_C(1) << 27)) >> 28;
        w[j] = (x * (int64_t)fxp_exp_uq8_24((q3_28_t)sq) + (INT64_C(1) << 23)) >> 24;
        sum_w += w[j];
        sum_up += fxp_exp_uq8_24((q3_28_t)-w[j]);
        sum_dn += fxp_exp_uq8_24((q3_28_t)w[j]);
    }
    /* The means sum / 8 in UQ8.24: e^-w_j <= 1 and e^w_j <= e^4 (< 2^30). */
    int64_t a_up = -(int64_t)fxp_ln_q28((uq8_24_t)(sum_up >> 3));
    int64_t a_dn = fxp_ln_q28((uq8_24_t)(sum_dn >> 3));
    int64_t h2 = a_up + a_dn; /* 2h */
    /* k = h / mean(w) = 2h * 8 / (2 * sum_w) = 4 * 2h / sum_w, UQ8.24. */
    uq8_24_t k = fxp_div_uq8_24((uint64_t)h2 * 4U, (uint64_t)sum_w);
    for (int32_t j = 0; j < COMP_DZ_PLAYS; ++j) {
        w[j] = (w[j] * (int64_t)k + (INT64_C(1) << 23)) >> 24;
    }
    if (c != 0) {
        int64_t rsum = 0;
        c->dz_c_q28 = (q3_28_t)((a_dn - a_up) / 2);
        c->dz_r_q28[0] = 0;
        c->dz_p_q28[0] = 0; /* p'_1 = M, the linear part: implicit, as the weights sum to 1 */
        for (int32_t i = 1; i < COMP_DZ_PLAYS; ++i) {
            int64_t r = w[i] - w[0];
            rsum += r;
            /* r'_i = ((i + 1) r_i - sum_(j<=i) r_j) / M, M = 8: a shift. */
            c->dz_r_q28[i] = (q3_28_t)(((int64_t)(i + 1) * r - rsum + 4) >> 3);
            /* p'_i = -M / ((i + 1) i), rounded to Q3.28 (-4 .. -1/7). */
            int64_t den = (int64_t)(i + 1) * i;
            c->dz_p_q28[i] =
                (q3_28_t)(-(((int64_t)COMP_DZ_PLAYS * Q3_28_ONE + den / 2) / den));
        }
    }
    return (q3_28_t)w[0];
}

/* The first play's exponent: mu*phi without a spread, w_1 with one. */
static q3_28_t first_exponent_q28(const comp_config_t *cfg)
{
    if (cfg->dead_zone_spread_q28 == 0 || exponent_q28(cfg) == 0) {
        return (q3_28_t)exponent_q28(cfg);
    }
    return dz_constants(cfg, 0);
}

/* s*q of the slope's law (comp.h), q = phi (E - 1)/(mu phi), in Q.52 per N (|.| < 2^53): phi
 * (Q7.24) * (E-1)/x (UQ6.26) = Q.50 -> Q.24, times s in Q3.28. */
static int64_t slope_k52(const comp_config_t *cfg)
{
    q3_28_t x = (q3_28_t)exponent_q28(cfg);
    int64_t q24 = ((int64_t)cfg->phi_rad_q24 * fxp_expm1_x_uq6_26(x) + (INT64_C(1) << 25)) >> 26;
    return (int64_t)cfg->mu_slope_per_n_q28 * q24;
}

static int32_t build_tables(const comp_config_t *cfg, uq8_24_t *up, uq8_24_t *dn)
{
    q3_28_t x0 = (q3_28_t)exponent_q28(cfg); /* checked <= 4 */
    q3_28_t x1 = first_exponent_q28(cfg);    /* w_1 <= mu*phi */
    if (cfg->mu_slope_per_n_q28 == 0) {
        uq8_24_t e1 = fxp_exp_uq8_24(x1);
        uq8_24_t einv = fxp_exp_uq8_24(-x1);
        for (int32_t i = 0; i < COMP_TAB_NODES; ++i) {
            up[i] = e1;
            dn[i] = einv;
        }
        return COMP_OK;
    }
    const q3_28_t x = x0;
    uq8_24_t e = fxp_exp_uq8_24(x);
    int64_t k52 = slope_k52(cfg);
    int64_t e52 = (int64_t)e * (INT64_C(1) << 28);
    const int64_t one52 = INT64_C(1) << 52;
    for (int32_t i = 0; i < COMP_TAB_NODES; ++i) {
        /* The slope's law holds up to COMP_MU_SLOPE_RANGE_N (a node: 2 N steps); the gains stay
         * there above it, so the branches never cross where mu + s*T would turn negative. */
        int64_t t_n = (2 * i < COMP_MU_SLOPE_RANGE_N) ? 2 * i : COMP_MU_SLOPE_RANGE_N;
        int64_t c = k52 * t_n;
        int64_t d_up = one52 - c;
        int64_t d_dn = e52 + c;
        if (d_up <= 0 || d_dn <= 0) {
            return COMP_ERR_MU_SLOPE;
        }
        up[i] = fxp_div_uq8_24((uint64_t)e52, (uint64_t)d_up);
        dn[i] = fxp_div_uq8_24((uint64_t)one52, (uint64_t)d_dn);
        if (up[i] > COMP_GAIN_MAX || dn[i] < COMP_GAIN_MIN) {
            return COMP_ERR_MU_SLOPE;
        }
    }
    if (x1 != x0) {
        /* With a dead-zone spread the first play's jump is w_1, not mu*phi, and it carries the
         * whole slope factor of the sharp law (comp.h): G_up e^(w_1 - W), G_dn e^(W - w_1).
         * UQ8.24 * UQ8.24 < 2^60; G_up only shrinks and G_dn grows, both stay in [e^-4, e^4]. */
        uint64_t f_up = fxp_exp_uq8_24(x1 - x0);
        uint64_t f_dn = fxp_exp_uq8_24(x0 - x1);
        for (int32_t i = 0; i < COMP_TAB_NODES; ++i) {
            up[i] = (uq8_24_t)(((uint64_t)up[i] * f_up + (UINT64_C(1) << 23)) >> 24);
            dn[i] = (uq8_24_t)(((uint64_t)dn[i] * f_dn + (UINT64_C(1) << 23)) >> 24);
        }
    }
    return COMP_OK;
}

int32_t comp_check_preview(int32_t preview_ticks, int32_t lead_ticks, int32_t ramp_ticks)
{
    if (preview_ticks < 0 || preview_ticks > COMP_PREVIEW_MAX_TICKS) {
        return COMP_ERR_PREVIEW;
    }
    if (lead_ticks < 0 || lead_ticks > preview_ticks) {
        return COMP_ERR_LEAD;
    }
    if (ramp_ticks < 1 || ramp_ticks > COMP_RAMP_MAX_TICKS) {
        return COMP_ERR_RAMP;
    }
    return COMP_OK;
}

/* The checks of the fields alone (no table). */
static int32_t check_fields(const comp_config_t *cfg)
{
    if (cfg == 0) {
        return COMP_ERR_NULL;
    }
    if (cfg->mode != COMP_MODE_NONE && cfg->mode != COMP_MODE_PAPER &&
        cfg->mode != COMP_MODE_SMOOTH && cfg->mode != COMP_MODE_PREVIEW) {
        return COMP_ERR_MODE;
    }
    if (cfg->mu_q28 < 0 || cfg->mu_q28 > COMP_MU_MAX_Q28) {
        return COMP_ERR_MU;
    }
    if (cfg->phi_rad_q24 < 0 || cfg->phi_rad_q24 > COMP_PHI_MAX_Q24) {
        return COMP_ERR_PHI;
    }
    if (cfg->mu_slope_per_n_q28 < -COMP_MU_SLOPE_MAX_Q28 ||
        cfg->mu_slope_per_n_q28 > COMP_MU_SLOPE_MAX_Q28 ||
        (int64_t)cfg->mu_q28 + (int64_t)cfg->mu_slope_per_n_q28 * COMP_MU_SLOPE_RANGE_N < 0) {
        return COMP_ERR_MU_SLOPE;
    }
    if (exponent_q28(cfg) > COMP_EXPONENT_MAX_Q28) {
        return COMP_ERR_EXPONENT;
    }
    if (cfg->dead_zone_spread_q28 < 0 || cfg->dead_zone_spread_q28 > COMP_DZ_SPREAD_MAX_Q28) {
        return COMP_ERR_DEAD_ZONE;
    }
    if (cfg->dead_zone_spread_q28 != 0) {
        /* The widest strand W e^(sigma q_M) <= 4: UQ8.24 * Q3.28 products < 2^61. */
        int64_t sq = ((int64_t)cfg->dead_zone_spread_q28 * COMP_DZ_QUANTILES_MAX_Q28 +
                      (INT64_C(1) << 27)) >> 28;
        int64_t wmax = (exponent_q28(cfg) * (int64_t)fxp_exp_uq8_24((q3_28_t)sq) +
                        (INT64_C(1) << 23)) >> 24;
        if (wmax > COMP_EXPONENT_MAX_Q28) {
            return COMP_ERR_DEAD_ZONE;
        }
    }
    if (cfg->breakaway_q28 < 0 || cfg->breakaway_q28 > COMP_BRK_MAX_Q28) {
        return COMP_ERR_BREAKAWAY;
    }
    if (cfg->breakaway_q28 != 0) {
        /* (2 mu + 9/8 m_s)*phi <= 4 (the hold's exponent): Q3.28 sum < 2^31, times Q7.24 < 2^28
         * in int64. */
        int64_t xs = ((2 * (int64_t)cfg->mu_q28 + cfg->breakaway_q28 + cfg->breakaway_q28 / 8) *
                          cfg->phi_rad_q24 +
                      (INT64_C(1) << 23)) >> 24;
        if (xs > COMP_EXPONENT_MAX_Q28) {
            return COMP_ERR_BREAKAWAY;
        }
    }
    if (cfg->slack_tension_n_q8 < 0 || cfg->slack_tension_n_q8 > COMP_SLACK_MAX_Q8) {
        return COMP_ERR_SLACK;
    }
    if (cfg->mu_per_inlet_rate_q28 < 0 || cfg->mu_per_inlet_rate_q28 > COMP_VISC_MAX_Q28) {
        return COMP_ERR_VISCOUS;
    }
    if (cfg->offset_n_q8 < -COMP_OFFSET_MAX_Q8 || cfg->offset_n_q8 > COMP_OFFSET_MAX_Q8) {
        return COMP_ERR_OFFSET;
    }
    if (cfg->hysteresis_n_q8 < COMP_HYST_MIN_Q8 || cfg->hysteresis_n_q8 > COMP_HYST_MAX_Q8) {
        return COMP_ERR_HYSTERESIS;
    }
    if (cfg->band_n_q8 < COMP_BAND_MIN_Q8 || cfg->band_n_q8 > COMP_BAND_MAX_Q8) {
        return COMP_ERR_BAND;
    }
    if (cfg->tc_min_n_q8 < 0 || cfg->tc_min_n_q8 > COMP_TC_MIN_MAX_Q8) {
        return COMP_ERR_TC_MIN;
    }
    return comp_check_preview(cfg->preview_ticks, cfg->lead_ticks, cfg->ramp_ticks);
}

int32_t comp_config_check(const comp_config_t *cfg)
{
    int32_t err = check_fields(cfg);
    if (err != COMP_OK || cfg->mu_slope_per_n_q28 == 0) {
        return err;
    }
    uq8_24_t up[COMP_TAB_NODES];
    uq8_24_t dn[COMP_TAB_NODES];
    return build_tables(cfg, up, dn);
}

/*
 * inv_band = floor(2^(31+m) / B) with m = floor(log2 B), so inv_band lies in (2^30, 2^31] and
 * w = (s * inv_band) >> (m+1) is s/B in Q1.30, below the exact ratio by less than 2 LSB of Q1.30
 * (the floor of inv_band costs s/2^(31+m) < 1 LSB, the final shift < 1 LSB) for any B in [1, 2^15].
 * The dividend 2^(31+m) (up to 2^46) is divided in two 32-bit steps, because the target has no
 * 64-bit divide instruction: 2^(31+m) = N1 * 2^16 with N1 = 2^(15+m) <= 2^30, and the remainder
 * r1 < B <= 2^15 keeps r1 << 16 < 2^31.
 */
static void set_inv_band(comp_t *c, uint32_t band)
{
    uint32_t m = 0;
    while ((band >> (m + 1U)) != 0U) {
        ++m;
    }
    uint32_t n1 = UINT32_C(1) << (15U + m);
    uint32_t q1 = n1 / band;
    uint32_t r1 = n1 % band;
    c->inv_band = (q1 << 16) + ((r1 << 16) / band);
    c->band_shift = (int32_t)(m + 1U);
}

static void blend_to_branch(comp_t *c)
{
    c->blend = (c->dir > 0) ? c->blend_top : 0;
}

void comp_reset(comp_t *c)
{
    if (c == 0) {
        return;
    }
    c->prev_ref = 0;
    c->extreme = 0;
    c->dir = 1;
    c->started = 0;
    c->line_pos = 0;
    c->corr_q8 = 0;
    c->slk_held = 0;
    c->slk_dir = 1;
    c->slk_min_q8 = 0;
    c->slk_k_q16 = 0;
    c->applied_q8 = 0;
    c->dz_fresh = 1;
    c->brk_dir = 0; /* no reversal yet: the first branch carries no breakaway */
    c->brk_y_q8 = 0;
    c->brk_last_q8 = 0;
    c->vis_fresh = 1;
    c->vis_r_q16 = 0;
    blend_to_branch(c);
}

int32_t comp_configure(comp_t *c, const comp_config_t *cfg)
{
    if (c == 0) {
        return COMP_ERR_NULL;
    }
    int32_t err = check_fields(cfg);
    if (err != COMP_OK) {
        return err;
    }
    /* The tables depend on mu, phi and mu_slope alone: when those are the ones the tables in
     * force were built from, they are kept (a change of another field, such as the band, costs
     * no exponential and no division; the same words either way). */
    int32_t same_tables = c->tables_of_cfg != 0 && c->cfg.mu_q28 == cfg->mu_q28 &&
                          c->cfg.phi_rad_q24 == cfg->phi_rad_q24 &&
                          c->cfg.mu_slope_per_n_q28 == cfg->mu_slope_per_n_q28 &&
                          c->cfg.dead_zone_spread_q28 == cfg->dead_zone_spread_q28;
    if (same_tables == 0 && cfg->mu_slope_per_n_q28 == 0) {
        (void)build_tables(cfg, c->g_up, c->g_dn); /* constant gains: cannot fail, in place */
        c->tables_of_cfg = 1;
    } else if (same_tables == 0) {
        uq8_24_t up[COMP_TAB_NODES];
        uq8_24_t dn[COMP_TAB_NODES];
        err = build_tables(cfg, up, dn);
        if (err != COMP_OK) {
            return err;
        }
        for (int32_t i = 0; i < COMP_TAB_NODES; ++i) {
            c->g_up[i] = up[i];
            c->g_dn[i] = dn[i];
        }
        c->tables_of_cfg = 1;
    }
    int32_t new_line = (c->cfg.preview_ticks != cfg->preview_ticks);
    c->cfg = *cfg;
    c->dz_on = (cfg->dead_zone_spread_q28 != 0 && exponent_q28(cfg) != 0);
    c->brk_on = (cfg->breakaway_q28 != 0);
    c->slk_on = (cfg->slack_tension_n_q8 != 0);
    c->vis_on = (cfg->mu_per_inlet_rate_q28 != 0);
    c->kind = (cfg->mode == COMP_MODE_NONE)                          ? COMP_KIND_NONE
              : (c->brk_on != 0 || c->slk_on != 0 || c->vis_on != 0) ? COMP_KIND_BRK
              : (c->dz_on != 0)                                      ? COMP_KIND_DZ
                                                                     : COMP_KIND_SHARP;
    /* m_r * phi: Q3.28 * Q7.24 < 2^52 in int64 (m_r <= 1/16, phi <= 4 pi), rounded to Q3.28
     * (<= 0.79). The rate starts again from rest. */
    c->vis_k_q28 = (q3_28_t)(((int64_t)cfg->mu_per_inlet_rate_q28 * cfg->phi_rad_q24 +
                              (INT64_C(1) << 23)) >> 24);
    c->vis_fresh = 1;
    c->vis_r_q16 = 0;
    c->dz_fresh = 1;
    c->dz_c_q28 = 0;
    if (c->dz_on != 0) {
        c->dz_x1_q28 = dz_constants(cfg, c);
    }
    if (c->brk_on != 0) {
        /* b = m_s*phi in Q3.28; 2 w_1 + 9b/8 <= (2 mu + 9/8 m_s) phi <= 4 (checked); the four
         * factors in UQ8.24 (< 2^30). */
        q3_28_t b = (q3_28_t)(((int64_t)cfg->breakaway_q28 * cfg->phi_rad_q24 +
                               (INT64_C(1) << 23)) >> 24);
        q3_28_t x1 = (c->dz_on != 0) ? c->dz_x1_q28 : (q3_28_t)exponent_q28(cfg);
        q3_28_t hold = 2 * x1 + b + b / 8; /* b/8 past the breakaway level (comp.h) */
        c->brk_full = fxp_exp_uq8_24(-hold);
        c->brk_full_up = fxp_exp_uq8_24(hold);
        c->brk_half = fxp_exp_uq8_24(-(b / 2));
        c->brk_half_up = fxp_exp_uq8_24(b / 2);
        if (cfg->mu_slope_per_n_q28 == 0) {
            c->brk_f_dn = c->brk_full;
            c->brk_f_up = c->brk_full_up;
        } else {
            /* The constants of the hold's factor at a turn's tension (brk_turn): s*q as the
             * tables' rounded to Q7.24 per N (|s q| < 2^7: |.| < 2^31). */
            q3_28_t x0 = (q3_28_t)exponent_q28(cfg);
            c->brk_k_q24 = (int32_t)((slope_k52(cfg) + (INT64_C(1) << 27)) >> 28);
            c->brk_e = fxp_exp_uq8_24(x0);
            c->brk_dn_k = fxp_exp_uq8_24(-(x1 + b + b / 8));
            c->brk_up_k = fxp_exp_uq8_24(x1 - x0);
            c->brk_b98_up = fxp_exp_uq8_24(b + b / 8);
        }
    }
    int32_t top = (cfg->mode == COMP_MODE_PREVIEW) ? cfg->ramp_ticks : cfg->band_n_q8;
    if (c->inv_band == 0U || top != c->blend_top) { /* 0: not yet set (comp_init) */
        c->blend_top = top;
        set_inv_band(c, (uint32_t)top); /* three divisions: only for a new top */
    }
    blend_to_branch(c);
    if (new_line) {
        c->started = 0; /* a new horizon: the delay line refills at the next step */
    }
    return COMP_OK;
}

void comp_init(comp_t *c)
{
    if (c == 0) {
        return;
    }
    comp_config_t cfg;
    comp_config_default(&cfg);
    c->dir = 1;
    c->started = 0;
    c->tables_of_cfg = 0;
    c->inv_band = 0U;
    c->cfg.preview_ticks = cfg.preview_ticks;
    (void)comp_set_tick_rate_hz(c, 1000U); /* the firmware's default tick_rate_hz */
    (void)comp_configure(c, &cfg); /* the defaults are valid (unit-tested) */
    comp_reset(c);
}

/* Linear interpolation in a gain table at |T| = a LSB (a in [0, 32767]), UQ8.24.
 * Scaling and overflow: the node difference (< 2^30) times the fraction (< 2^9) is < 2^39 in int64;
 * the result lies between the two nodes. */
static inline uq8_24_t tab_interp(const uq8_24_t *tab, uint32_t a)
{
    uint32_t i = a >> COMP_TAB_SHIFT;
    int64_t frac = (int64_t)(a & ((1U << COMP_TAB_SHIFT) - 1U));
    int64_t lo = tab[i];
    return (uq8_24_t)(lo + (((int64_t)tab[i + 1U] - lo) * frac >> COMP_TAB_SHIFT));
}

/* The dead-zone inverse's part of a step (comp.h): T_c for T_eff and the first play's gain g. */
static int64_t dz_step(comp_t *c, int32_t t_eff, uq8_24_t g)
{
    /* The dead-zone inverse (comp.h): y = ln T_eff in Q3.28 (T_eff >= 1 LSB: |y| < 5.6);
     * d_i = u_i - y in [-r'_i, r'_i] (< 4), p'_i d_i < 2^60 in int64, each >> 28; the sum
     * of 7 terms and c clamped to [-4, 4]; F = e^L in UQ8.24 (< 2^30); G * F in UQ.48
     * (< 2^60) -> UQ.24 (< 2^36); T_eff * G F < 2^53 in int64. */
    q3_28_t y = fxp_ln_q28((uq8_24_t)((t_eff > 1) ? t_eff : 1) << 16); /* Q7.8 -> UQ8.24 */
    int64_t l = -(int64_t)c->dz_c_q28;
    /* The plays are held as d_i = u_i - y (in [-r'_i, r'_i], Q3.28), since u_i itself can
     * leave Q3.28's range (|y| + r'_i < 9.6); the step d_i + y_prev - y is exact in int64. */
    int64_t dy = (int64_t)c->dz_y_q28 - y;
    for (int32_t i = 1; i < COMP_DZ_PLAYS; ++i) {
        int64_t r = c->dz_r_q28[i];
        int64_t d = (c->dz_fresh != 0) ? ((c->dir > 0) ? -r : r) : c->dz_d_q28[i] + dy;
        d = (d < -r) ? -r : (d > r) ? r : d;
        c->dz_d_q28[i] = (q3_28_t)d;
        l += ((int64_t)c->dz_p_q28[i] * d) >> 28;
    }
    c->dz_y_q28 = y;
    c->dz_fresh = 0;
    if (l > COMP_EXPONENT_MAX_Q28) {
        l = COMP_EXPONENT_MAX_Q28;
    } else if (l < -COMP_EXPONENT_MAX_Q28) {
        l = -COMP_EXPONENT_MAX_Q28;
    }
    uint64_t gf = ((uint64_t)g * fxp_exp_uq8_24((q3_28_t)l) + (UINT64_C(1) << 23)) >> 24;
    return ((int64_t)t_eff * (int64_t)gf + (INT64_C(1) << 23)) >> 24;
}

/* The blend weight of s: 1 at the loading branch, 0 at the unloading one, s/B between (the
 * smoothstep of s/D in PREVIEW), Q1.30 in [0, 2^30]; the same words as the gain's blend. */
static inline uint64_t blend_weight(const comp_t *c, int32_t s)
{
    if (s >= c->blend_top) {
        return (uint64_t)Q1_30_ONE;
    }
    if (s <= 0) {
        return 0U;
    }
    uint64_t w = ((uint64_t)(uint32_t)s * c->inv_band) >> c->band_shift;
    if (c->cfg.mode == COMP_MODE_PREVIEW) {
        uint64_t w2 = (w * w) >> 30;
        uint64_t w3 = (w2 * w) >> 30;
        w = 3U * w2 - 2U * w3;
    }
    return w;
}

/* The breakaway term (comp.h) on T_c0, the step's T_c without it (Q7.8 in int64, |.| < 2^48):
 * the T_c the step puts out on the branch entered at the last reversal. Y (brk_y_q8) is the
 * extreme of the T_c put out since the detector turned, so Y times brk_full is the inlet
 * tension at which the cable, stuck at the output Y gave on the other branch, breaks loose.
 * Scaling and overflow: T_c0 is clamped to [0, 2^17) first (the step saturates to Q7.8 after
 * this, so a larger value gives the same word); times a factor in UQ8.24 (<= e^4 < 2^30) < 2^47;
 * Y (a Q7.8 word, < 2^15) times a factor < 2^45; each rounded back to Q7.8; the excess
 * (|.| < 2^20) times the weight (<= 2^30) < 2^50, rounded. */
#define BRK_TC_CAP_Q8 (INT64_C(1) << 17) /* 512 N: above Q7.8's full scale, below overflow */

/* The hold's factors at a turn where the friction has a slope (comp.h): the dead zone's width
 * at the turn's tension a (Q7.8, <= 127.996 N), G_up/G_dn of the first play, from the tables
 * and the slope's c = s*q*min(a, 48 N) (the tables' law), where it is wider than 2 w_1:
 *   unloading: min(G_dn/G_up e^-9b/8, brk_full),
 *              G_dn/G_up e^-9b/8 = D(a) (1 - c) e^-(w_1 + 9b/8)
 *   loading:   max(G_up/G_dn e^+9b/8, brk_full_up), at most e^4,
 *              G_up/G_dn e^+9b/8 = U(a) e^(w_1 - W) (E + c) e^(9b/8)
 * with D, U the tables' gains (G_dn e^(W - w_1), G_up e^(w_1 - W)) and E = e^W, W = mu*phi.
 * Scaling and overflow: c in Q7.24 (|s q| < 2^7 per N times a < 2^14 LSB: < 2^45 before the
 * shift); 1 - c in (0, E] and E + c in [1, E + 1] (the checks: 1 - c > 0 and mu + 48 s >= 0 give
 * c >= 1 - E), so both < 2^30 in UQ8.24; D, U < 2^30 (the gains within [e^-4, e^4]); D (1 - c)
 * < 2^60 -> < 2^36, times e^-(..) <= 1 (< 2^25) < 2^61, rounded, then at most brk_full (<= 1);
 * U e^(w_1 - W) < 2^30; (E + c) e^(9b/8) <= e^(W + 9b/8) + e^(9b/8) <= 2 e^4 (the
 * check (2 mu + 9/8 m_s) phi <= 4) < 2^31; their product < 2^61, rounded, clamped to e^4. */
static void brk_turn(comp_t *c, uint32_t a)
{
    const uint64_t r = UINT64_C(1) << 23;
    const uint32_t cap = (uint32_t)COMP_MU_SLOPE_RANGE_N << 8;
    int64_t c24 = ((int64_t)c->brk_k_q24 * (int64_t)((a < cap) ? a : cap) + 128) >> 8;
    uint64_t one_m_c = (uint64_t)((INT64_C(1) << 24) - c24);
    uint64_t e_p_c = (uint64_t)((int64_t)c->brk_e + c24);
    uint64_t dn = ((uint64_t)tab_interp(c->g_dn, a) * one_m_c + r) >> 24;
    dn = (dn * c->brk_dn_k + r) >> 24;
    c->brk_f_dn = (uq8_24_t)((dn < c->brk_full) ? dn : c->brk_full);
    uint64_t ua = ((uint64_t)tab_interp(c->g_up, a) * c->brk_up_k + r) >> 24;
    uint64_t eb = (e_p_c * c->brk_b98_up + r) >> 24;
    uint64_t up = (ua * eb + r) >> 24;
    up = (up > c->brk_full_up) ? up : c->brk_full_up;
    c->brk_f_up = (uq8_24_t)((up < COMP_GAIN_MAX) ? up : COMP_GAIN_MAX);
}

static int64_t brk_apply(comp_t *c, int64_t tc0, int32_t s, uint32_t a)
{
    const int32_t dir = c->dir;
    if (dir != c->brk_dir) {
        /* A new branch: before the first reversal (brk_dir 0) no branch was left, and Y = 0
         * keeps the first loading from rest free of any excess. */
        c->brk_y_q8 = (c->brk_dir == 0) ? 0 : c->brk_last_q8;
        c->brk_dir = dir;
        if (c->cfg.mu_slope_per_n_q28 != 0) {
            brk_turn(c, a);
        }
    }
    if (tc0 <= 0) {
        return tc0; /* a cable cannot push: nothing sticks below zero */
    }
    const int64_t r = INT64_C(1) << 23;
    int64_t t = (tc0 < BRK_TC_CAP_Q8) ? tc0 : BRK_TC_CAP_Q8;
    int64_t y = c->brk_y_q8;
    int64_t tb;
    int64_t weight;
    uint64_t w = blend_weight(c, s);
    if (dir < 0) {
        int64_t lo = (t * (int64_t)c->brk_half + r) >> 24;
        int64_t yb = (y * (int64_t)c->brk_f_dn + r) >> 24;
        tb = (yb < lo) ? lo : (yb > t) ? t : yb;
        weight = (int64_t)Q1_30_ONE - (int64_t)w;
    } else {
        int64_t hi = (t * (int64_t)c->brk_half_up + r) >> 24;
        int64_t yb = (y * (int64_t)c->brk_f_up + r) >> 24;
        tb = (yb < t) ? t : (yb > hi) ? hi : yb;
        weight = (int64_t)w;
    }
    return t + (((tb - t) * weight + (INT64_C(1) << 29)) >> 30);
}

/* Y follows the T_c put out: the largest on an unloading branch, the smallest on a loading one. */
static inline void brk_track(comp_t *c, int32_t tc)
{
    c->brk_last_q8 = tc;
    if (c->brk_dir != 0 && ((c->brk_dir < 0) ? (tc > c->brk_y_q8) : (tc < c->brk_y_q8))) {
        c->brk_y_q8 = tc;
    }
}

/* The viscous term (comp.h) on the blended gain g (UQ8.24, in [e^-4, e^4]) for the reference
 * T_eff the gain applies to and the blend position s: r_hat from G |dT_eff| f_tick, then
 * G e^((2w - 1) min(m_r phi r_hat, 1)). Scaling and overflow: |dT_eff| < 2^18 LSB times f_tick
 * (< 2^16) < 2^34, capped at VISC_REF_RATE_CAP_Q8; G times it < 2^58, rounded to UQ12.16 N/s and
 * saturated at COMP_VISC_RATE_FS_Q16 (2^28); (in - r_hat) times the weight (< 2^24) < 2^52;
 * m_r phi (< 2^28) times r_hat (<= 2^28) < 2^56; x (<= 2^28) times 2w - 1 (|.| <= 2^30) < 2^58;
 * G e^x < 2^30 * 2^25.5 before the shift, < 2^31.3 after it (uq8_24_t holds 2^32). */
#define VISC_REF_RATE_CAP_Q8 (UINT64_C(1) << 26) /* 262144 N/s: G >= e^-4 saturates r_hat above */

static uq8_24_t vis_gain(comp_t *c, int32_t t_eff, uq8_24_t g, int32_t s)
{
    uint64_t d = 0U;
    if (c->vis_fresh == 0) {
        int64_t diff = (int64_t)t_eff - c->vis_prev_q8;
        d = (uint64_t)((diff < 0) ? -diff : diff);
    }
    c->vis_fresh = 0;
    c->vis_prev_q8 = t_eff;
    uint64_t rate = d * c->tick_rate_hz; /* Q.8 N/s */
    if (rate > VISC_REF_RATE_CAP_Q8) {
        rate = VISC_REF_RATE_CAP_Q8;
    }
    int64_t in = (int64_t)(((uint64_t)g * rate + (UINT64_C(1) << 15)) >> 16); /* UQ12.16 N/s */
    if (in > COMP_VISC_RATE_FS_Q16) {
        in = COMP_VISC_RATE_FS_Q16;
    }
    int64_t r = c->vis_r_q16;
    /* A step of the filter moves r_hat towards in by less than in - r_hat: r_hat stays in
     * [0, 2^28]. */
    r += ((in - r) * (int64_t)c->vis_alpha_q24 + (INT64_C(1) << 23)) >> 24;
    c->vis_r_q16 = (int32_t)r;
    int64_t x = ((int64_t)c->vis_k_q28 * r + (INT64_C(1) << 15)) >> 16;
    if (x > COMP_VISC_X_MAX_Q28) {
        x = COMP_VISC_X_MAX_Q28;
    }
    int64_t sign = 2 * (int64_t)blend_weight(c, s) - (int64_t)Q1_30_ONE;
    x = (x * sign + (INT64_C(1) << 29)) >> 30;
    uint64_t e = fxp_exp_uq8_24((q3_28_t)x);
    return (uq8_24_t)(((uint64_t)g * e + (UINT64_C(1) << 23)) >> 24);
}

/* The slack's root (comp.h): the Q7.8 word nearest sqrt(x) for x = T_c1 * S, a Q14.16 product
 * (T_c1 < S <= 2^14 LSB: x < 2^28). The bits of the root one at a time from 2^13 (r < 2^14), then
 * rounded to the nearest: r + 1 when x - r^2 > r, as (r + 1/2)^2 = r^2 + r + 1/4 and x is an
 * integer (no ties). Every intermediate below 2^29 in 32 bits. */
static uint32_t slack_root_q8(uint32_t x)
{
    uint32_t r = 0;
    for (uint32_t bit = UINT32_C(1) << 13; bit != 0U; bit >>= 1) {
        uint32_t t = r | bit;
        if (t * t <= x) {
            r = t;
        }
    }
    return (x - r * r > r) ? r + 1U : r;
}

/* The slack's turn at a reversal (comp.h), after the root: on an unloading branch the least T_c
 * below S and its T_eff are kept; from the turn to loading, T_c is at most T_eff times their
 * ratio k while that is below S (the held friction output X = S / k passes T_in / S of itself
 * to the output), and the turn ends there. k in UQ16.16 by one 32-bit division at the turn:
 * T_c < S <= 64 N is below 2^14 LSB, so T_c << 16 < 2^30; a ratio below 255 or no turn;
 * T_eff * k < 2^15 * 2^24 in int64, rounded to Q7.8. */
static int64_t slack_turn(comp_t *c, int32_t t_eff, int64_t tc)
{
    const int32_t s_q8 = c->cfg.slack_tension_n_q8;
    if (c->dir < 0) {
        if (c->slk_dir > 0) { /* a new unloading branch */
            c->slk_min_q8 = 0;
            c->slk_k_q16 = 0;
        }
        c->slk_dir = -1;
        if (tc > 0 && tc < s_q8 && t_eff > 0 && (c->slk_min_q8 == 0 || tc <= c->slk_min_q8)) {
            c->slk_min_q8 = (int32_t)tc;
            c->slk_eff_q8 = t_eff;
        }
        return tc;
    }
    if (c->slk_dir < 0) { /* the turn to loading: the ratio, once */
        c->slk_dir = 1;
        c->slk_k_q16 = 0;
        if (c->slk_min_q8 > 0 && c->slk_min_q8 < 255 * c->slk_eff_q8) {
            c->slk_k_q16 = ((uint32_t)c->slk_min_q8 << 16) / (uint32_t)c->slk_eff_q8;
        }
    }
    if (c->slk_k_q16 != 0U) {
        int64_t cap = ((int64_t)t_eff * (int64_t)c->slk_k_q16 + (INT64_C(1) << 15)) >> 16;
        if (t_eff > 0 && cap < s_q8) {
            return (tc > cap) ? cap : tc;
        }
        c->slk_k_q16 = 0U; /* past X: the friction takes over */
    }
    return tc;
}

/* The step after the detector (PAPER, SMOOTH, PREVIEW), specialised by the compiler for dz = 0
 * (the sharp law, its instructions as before the dead-zone inverse) and dz = 1; always inlined
 * (a GCC attribute, as every toolchain of the firmware is GCC), since a call costs the sharp law
 * 8 instructions a step and the callgrind budget is 100. */
static inline __attribute__((always_inline)) q7_8_t step_modes(comp_t *c, int32_t ref,
                                                                int32_t diff, const int32_t dz,
                                                                const int32_t brk,
                                                                const int32_t slk,
                                                                const int32_t vis)
{
    const comp_config_t *cfg = &c->cfg;
    /* PREVIEW: the input is T_ref(t + P); the gain applies to T_ref(t + L), P - L inputs ago. */
    int32_t applied = ref;
    if (cfg->mode == COMP_MODE_PREVIEW) {
        const int32_t len = cfg->preview_ticks + 1;
        c->line_pos = (c->line_pos + 1 < len) ? c->line_pos + 1 : 0;
        c->line[c->line_pos] = ref;
        if (c->line_writes < len) {
            ++c->line_writes;
        }
        int32_t back = c->line_pos - (cfg->preview_ticks - cfg->lead_ticks);
        if (back < 0) {
            back += len;
        }
        /* Written since the start: slots 1 .. line_writes in order, then all of them. */
        int32_t written = (c->line_writes >= len) || (back >= 1 && back <= c->line_writes);
        applied = written ? c->line[back] : c->line_first;
    }

    /* Blend position s in [0, top]: PAPER jumps to the branch, SMOOTH travels |diff| towards it,
     * PREVIEW one per tick. */
    const int32_t top = c->blend_top;
    int32_t s;
    if (cfg->mode == COMP_MODE_PAPER) {
        s = (c->dir > 0) ? top : 0;
    } else {
        int32_t step = (cfg->mode == COMP_MODE_PREVIEW) ? 1 : (diff < 0) ? -diff : diff;
        if (c->dir > 0) {
            s = c->blend + step; /* < 2^17: no overflow */
            if (s > top) {
                s = top;
            }
        } else {
            s = c->blend - step;
            if (s < 0) {
                s = 0;
            }
        }
    }
    c->blend = s;
    c->applied_q8 = applied;

    /* |t_eff| <= 32768 + 16384 + 4096 */
    int32_t t_eff = applied - cfg->offset_n_q8 + c->corr_q8;
    uint32_t a = (uint32_t)((t_eff < 0) ? -t_eff : t_eff);
    if (a > (uint32_t)Q7_8_MAX) {
        a = (uint32_t)Q7_8_MAX; /* the gain tables end at 127.996 N (see comp.h) */
    }

    uq8_24_t g;
    if (s >= top) {
        g = tab_interp(c->g_up, a);
    } else if (s <= 0) {
        g = tab_interp(c->g_dn, a);
    } else {
        uq8_24_t gu = tab_interp(c->g_up, a);
        uq8_24_t gd = tab_interp(c->g_dn, a);
        /* w = s/B in Q1.30 (< 2^30, s < B here); s * inv_band < 2^46; (gu - gd) * w < 2^60;
         * the truncations cost < 1 LSB of UQ8.24. */
        uint64_t w = ((uint64_t)(uint32_t)s * c->inv_band) >> c->band_shift;
        if (cfg->mode == COMP_MODE_PREVIEW) {
            /* smoothstep w^2 (3 - 2w) in Q1.30: w^2, w^3 < 2^60 before the shifts; the result
             * lies in [0, 2^30] (a polynomial in [0, 1] on [0, 1]); truncations < 3 LSB. */
            uint64_t w2 = (w * w) >> 30;
            uint64_t w3 = (w2 * w) >> 30;
            w = 3U * w2 - 2U * w3;
        }
        g = gd + (uq8_24_t)(((uint64_t)(gu - gd) * w) >> 30);
    }
    if (vis != 0) {
        g = vis_gain(c, t_eff, g, s);
    }

    /* T_c = T_eff * G: Q7.8 (32-bit) * UQ8.24 = Q15.32 in int64 (< 2^47); round to Q7.8. */
    int64_t tc = (dz != 0) ? dz_step(c, t_eff, g)
                           : ((int64_t)t_eff * (int64_t)g + (INT64_C(1) << 23)) >> 24;
    if (brk != 0) {
        tc = brk_apply(c, tc, s, a);
    }
    if (tc > Q7_8_MAX) {
        tc = Q7_8_MAX;
    } else if (tc < cfg->tc_min_n_q8) {
        tc = cfg->tc_min_n_q8; /* the floor, >= 0 > Q7_8_MIN: also the low saturation */
    }
    if (brk != 0) {
        brk_track(c, (int32_t)tc);
    }
    if (slk != 0 && tc > 0 && tc < cfg->slack_tension_n_q8) {
        /* After the floor and the saturation: the root lies in [T_c1, S], within both. */
        tc = (int64_t)slack_root_q8((uint32_t)tc * (uint32_t)cfg->slack_tension_n_q8);
    }
    if (slk != 0) {
        tc = slack_turn(c, t_eff, tc);
    }
    return (q7_8_t)tc;
}

/* The step with the breakaway term, the slack's root or the viscous term (each, and the spread,
 * tested at run time): one copy for the target's code size, out of line so that its registers do
 * not burden the sharp law's path (inlined, the extra flags cost the sharp law 7 instructions a
 * step). */
static __attribute__((noinline)) q7_8_t step_ext(comp_t *c, int32_t ref, int32_t diff)
{
    return step_modes(c, ref, diff, c->dz_on, c->brk_on, c->slk_on != 0 && c->slk_held == 0,
                      c->vis_on);
}

q7_8_t comp_step_q7_8(comp_t *c, q7_8_t t_ref)
{
    const int32_t ref = t_ref;
    const comp_config_t *cfg = &c->cfg;
    if (c->started == 0) {
        c->started = 1;
        c->prev_ref = ref;
        c->extreme = ref;
        /* The delay line reads as a reference at rest (this first input) where this start has
         * not written it yet; no fill of its 129 slots here, so a run's first tick costs no more
         * than the others (the soft CPU's worst tick). */
        c->line_first = ref;
        c->line_writes = 0;
        c->line_pos = 0;
    }
    int32_t diff = ref - c->prev_ref; /* |diff| <= 65535 */
    c->prev_ref = ref;

    /* Direction detector with hysteresis H (Eq. 16; exact for H = 1 LSB). */
    if (c->dir > 0) {
        if (ref > c->extreme) {
            c->extreme = ref;
        } else if (c->extreme - ref >= cfg->hysteresis_n_q8) {
            c->dir = -1;
            c->extreme = ref;
        }
    } else {
        if (ref < c->extreme) {
            c->extreme = ref;
        } else if (ref - c->extreme >= cfg->hysteresis_n_q8) {
            c->dir = 1;
            c->extreme = ref;
        }
    }

    /* One test for both rarer paths (mode NONE, the dead-zone inverse), so that the sharp law
     * costs what it did (the callgrind budget). */
    if (c->kind != COMP_KIND_SHARP) {
        if (c->kind == COMP_KIND_NONE) {
            c->applied_q8 = ref;
            return (ref < cfg->tc_min_n_q8) ? (q7_8_t)cfg->tc_min_n_q8 : t_ref;
        }
        if (c->kind == COMP_KIND_BRK) {
            /* One copy for the breakaway, the slack's root and the viscous term with or without
             * a spread (each tested at run time): the target's code size, at a few tests per
             * step on this rarer path. */
            return step_ext(c, ref, diff);
        }
        return step_modes(c, ref, diff, 1, 0, 0, 0);
    }
    return step_modes(c, ref, diff, 0, 0, 0, 0);
}

int32_t comp_set_tick_rate_hz(comp_t *c, uint32_t hz)
{
    if (c == 0) {
        return COMP_ERR_NULL;
    }
    if (hz < 1U || hz > COMP_TICK_RATE_MAX_HZ) {
        return COMP_ERR_TICK_RATE;
    }
    /* 1/(tau f_tick) in Q.24 by one 32-bit division (100 * 2^24 < 2^31), rounded; held at 4
     * below 25 Hz (a tick longer than four time constants: the weight 1 - e^-4 = 0.98), so that
     * the exponential stays in fxp_exp_uq8_24's domain. */
    const uint32_t per_s = 1000U / COMP_VISC_TAU_MS; /* 1/tau in Hz */
    uint32_t q24 = ((per_s << 24) + hz / 2U) / hz;
    if (q24 > (4U << 24)) {
        q24 = 4U << 24;
    }
    c->tick_rate_hz = hz;
    c->vis_alpha_q24 = (UINT32_C(1) << 24) - fxp_exp_uq8_24(-(q3_28_t)(q24 << 4));
    return COMP_OK;
}

int32_t comp_set_exponent_q28(comp_t *c, q3_28_t x_q28)
{
    if (c == 0) {
        return COMP_ERR_NULL;
    }
    if (c->cfg.mu_slope_per_n_q28 != 0) {
        return COMP_ERR_MU_SLOPE;
    }
    if (x_q28 < 0 || x_q28 > COMP_EXPONENT_MAX_Q28) {
        return COMP_ERR_EXPONENT;
    }
    uq8_24_t e = fxp_exp_uq8_24(x_q28);
    uq8_24_t einv = fxp_exp_uq8_24(-x_q28);
    for (int32_t i = 0; i < COMP_TAB_NODES; ++i) {
        c->g_up[i] = e;
        c->g_dn[i] = einv;
    }
    c->tables_of_cfg = 0; /* the estimate's tables: the next comp_configure rebuilds cfg's */
    return COMP_OK;
}

void comp_set_correction_q8(comp_t *c, int32_t corr_q8)
{
    const int32_t m = 16 * Q7_8_ONE;
    c->corr_q8 = (corr_q8 > m) ? m : (corr_q8 < -m) ? -m : corr_q8;
}

void comp_hold_slack(comp_t *c, int32_t held)
{
    if (c->slk_held != (held != 0)) { /* a change (fw.c calls it every tick): the turn starts
                                         again at the next unloading branch */
        c->slk_dir = 1;
        c->slk_min_q8 = 0;
        c->slk_k_q16 = 0;
    }
    c->slk_held = (held != 0);
}

int32_t comp_applied_ref_q8(const comp_t *c)
{
    return c->applied_q8;
}

int32_t comp_direction(const comp_t *c)
{
    return c->dir;
}

int32_t comp_blend_q1_30(const comp_t *c)
{
    if (c->blend >= c->blend_top) {
        return (int32_t)Q1_30_ONE;
    }
    return (int32_t)(((uint64_t)(uint32_t)c->blend * c->inv_band) >> c->band_shift);
}
