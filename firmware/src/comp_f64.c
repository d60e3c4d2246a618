/* comp_f64.c - double twin of comp.c (host only); see comp_f64.h. */
#include "comp_f64.h"

#include <math.h>

#include "comp.h"

#define PI_D 3.14159265358979323846
#define Q7_8_MAX_N (32767.0 / 256.0)
#define Q7_8_MIN_N (-128.0)

void comp_f64_config_default(comp_f64_config_t *cfg)
{
    if (cfg == 0) {
        return;
    }
    cfg->mode = COMP_MODE_PAPER;
    cfg->mu = 0.075;
    cfg->phi_rad = 2.0 * PI_D;
    cfg->mu_slope_per_n = 0.0;
    cfg->offset_n = 0.0;
    cfg->hysteresis_n = 4.0 / 256.0;
    cfg->band_n = 0.5;
    cfg->tc_min_n = 0.0;
    cfg->preview_ticks = COMP_DEFAULT_PREVIEW_TICKS;
    cfg->lead_ticks = COMP_DEFAULT_LEAD_TICKS;
    cfg->ramp_ticks = COMP_DEFAULT_RAMP_TICKS;
    cfg->dead_zone_spread = 0.0;
    cfg->breakaway = 0.0;
    cfg->slack_tension_n = 0.0;
    cfg->mu_per_inlet_rate = 0.0;
}

/* s at the loading branch: B, or D ticks in PREVIEW (comp.h). */
static double blend_top(const comp_f64_config_t *cfg)
{
    return (cfg->mode == COMP_MODE_PREVIEW) ? (double)cfg->ramp_ticks : cfg->band_n;
}

/* G_up and G_dn at |T| = a (comp.h: the capstan relation with mu(T) = mu + s*T integrated). */
static void gains(const comp_f64_config_t *cfg, double a, double *gu, double *gd)
{
    double x = cfg->mu * cfg->phi_rad;
    double e = exp(x);
    double q = (x > 0.0) ? cfg->phi_rad * expm1(x) / x : cfg->phi_rad;
    /* The slope's law holds up to COMP_MU_SLOPE_RANGE_N; the gains stay there above it (comp.c). */
    double c = cfg->mu_slope_per_n * q * fmin(a, (double)COMP_MU_SLOPE_RANGE_N);
    *gu = e / (1.0 - c);
    *gd = 1.0 / (e + c);
}

/* The first play's gains: those above with the exponent w_1 in place of mu*phi, the slope's
 * factor kept whole (comp.h). */
static void gains_x(const comp_f64_config_t *cfg, double x1, double a, double *gu, double *gd)
{
    double x0 = cfg->mu * cfg->phi_rad;
    if (cfg->mu_slope_per_n == 0.0) {
        *gu = exp(x1);
        *gd = exp(-x1);
        return;
    }
    gains(cfg, a, gu, gd);
    *gu *= exp(x1 - x0);
    *gd *= exp(x0 - x1);
}


static const long DZ_Q_Q28[COMP_DZ_PLAYS] = COMP_DZ_QUANTILES_Q28;

/* The dead-zone inverse's constants (comp.h): w_1, the thresholds and weights of the inverse PI
 * model and the shift c, for the strands' widths of the configuration. */
static void dz_setup(comp_f64_t *c)
{
    const comp_f64_config_t *cfg = &c->cfg;
    double x = cfg->mu * cfg->phi_rad;
    c->dz_on = (cfg->dead_zone_spread > 0.0 && x > 0.0);
    c->dz_fresh = 1;
    if (c->dz_on == 0) {
        c->dz_x1 = x;
        c->dz_c = 0.0;
        return;
    }
    const int m = COMP_DZ_PLAYS;
    double w[COMP_DZ_PLAYS];
    double mean_w = 0.0;
    double mean_dn = 0.0;
    double mean_up = 0.0;
    for (int j = 0; j < m; ++j) {
        w[j] = x * exp(cfg->dead_zone_spread * (double)DZ_Q_Q28[j] / 268435456.0);
        mean_w += w[j] / m;
        mean_up += exp(-w[j]) / m;
        mean_dn += exp(w[j]) / m;
    }
    double a_up = -log(mean_up);
    double a_dn = log(mean_dn);
    double h = 0.5 * (a_up + a_dn);
    c->dz_c = 0.5 * (a_dn - a_up);
    double k = h / mean_w;
    double rsum = 0.0;
    for (int j = 0; j < m; ++j) {
        w[j] *= k;
    }
    c->dz_x1 = w[0];
    c->dz_r[0] = 0.0;
    c->dz_p[0] = (double)m;
    for (int i = 1; i < m; ++i) {
        double r = w[i] - w[0];
        rsum += r;
        c->dz_r[i] = ((double)(i + 1) * r - rsum) / m;
        c->dz_p[i] = -(double)m / ((double)(i + 1) * (double)i);
    }
}

/* !(lo <= v && v <= hi) is also true for NaN. */
static int out_of(double v, double lo, double hi)
{
    return !(lo <= v && v <= hi);
}

int32_t comp_f64_config_check(const comp_f64_config_t *cfg)
{
    if (cfg == 0) {
        return COMP_ERR_NULL;
    }
    if (cfg->mode != COMP_MODE_NONE && cfg->mode != COMP_MODE_PAPER &&
        cfg->mode != COMP_MODE_SMOOTH && cfg->mode != COMP_MODE_PREVIEW) {
        return COMP_ERR_MODE;
    }
    if (out_of(cfg->mu, 0.0, 1.0)) {
        return COMP_ERR_MU;
    }
    if (out_of(cfg->phi_rad, 0.0, 4.0 * PI_D)) {
        return COMP_ERR_PHI;
    }
    if (out_of(cfg->mu_slope_per_n, -1.0 / 128.0, 1.0 / 128.0) ||
        cfg->mu + (double)COMP_MU_SLOPE_RANGE_N * cfg->mu_slope_per_n < 0.0) {
        return COMP_ERR_MU_SLOPE;
    }
    if (cfg->mu * cfg->phi_rad > 4.0) {
        return COMP_ERR_EXPONENT;
    }
    if (out_of(cfg->dead_zone_spread, 0.0, 1.0) ||
        cfg->mu * cfg->phi_rad *
                exp(cfg->dead_zone_spread * (double)COMP_DZ_QUANTILES_MAX_Q28 / 268435456.0) >
            4.0) {
        return COMP_ERR_DEAD_ZONE;
    }
    if (out_of(cfg->breakaway, 0.0, 0.25) ||
        (cfg->breakaway > 0.0 && (2.0 * cfg->mu + 1.125 * cfg->breakaway) * cfg->phi_rad > 4.0)) {
        return COMP_ERR_BREAKAWAY;
    }
    if (out_of(cfg->slack_tension_n, 0.0, 64.0)) {
        return COMP_ERR_SLACK;
    }
    if (out_of(cfg->mu_per_inlet_rate, 0.0, 1.0 / 16.0)) {
        return COMP_ERR_VISCOUS;
    }
    if (cfg->mu_slope_per_n != 0.0) {
        /* Both gains are monotonic in |T|: check the end of the table (and its denominators). */
        double x = cfg->mu * cfg->phi_rad;
        double q = (x > 0.0) ? cfg->phi_rad * expm1(x) / x : cfg->phi_rad;
        double c = cfg->mu_slope_per_n * q * (double)COMP_MU_SLOPE_RANGE_N;
        double gu;
        double gd;
        gains(cfg, (double)COMP_MU_SLOPE_RANGE_N, &gu, &gd);
        if (1.0 - c <= 0.0 || exp(x) + c <= 0.0 || gu > exp(4.0) || gd < exp(-4.0)) {
            return COMP_ERR_MU_SLOPE;
        }
    }
    if (out_of(cfg->offset_n, -64.0, 64.0)) {
        return COMP_ERR_OFFSET;
    }
    if (out_of(cfg->hysteresis_n, 1.0 / 256.0, 32.0)) {
        return COMP_ERR_HYSTERESIS;
    }
    if (out_of(cfg->band_n, 1.0 / 256.0, 128.0)) {
        return COMP_ERR_BAND;
    }
    if (out_of(cfg->tc_min_n, 0.0, 64.0)) {
        return COMP_ERR_TC_MIN;
    }
    return comp_check_preview(cfg->preview_ticks, cfg->lead_ticks, cfg->ramp_ticks);
}

void comp_f64_reset(comp_f64_t *c)
{
    if (c == 0) {
        return;
    }
    c->prev_ref = 0.0;
    c->extreme = 0.0;
    c->dir = 1;
    c->started = 0;
    c->line_pos = 0;
    c->corr_n = 0.0;
    c->slk_held = 0;
    c->slk_dir = 1;
    c->slk_min = 0.0;
    c->slk_k = 0.0;
    c->dz_fresh = 1;
    c->brk_dir = 0;
    c->brk_y = 0.0;
    c->brk_last = 0.0;
    c->brk_full_dn = 0.0;
    c->brk_full_up = 0.0;
    c->vis_fresh = 1;
    c->vis_r = 0.0;
    c->blend = blend_top(&c->cfg);
}

int32_t comp_f64_set_tick_rate_hz(comp_f64_t *c, double hz)
{
    if (c == 0) {
        return COMP_ERR_NULL;
    }
    if (out_of(hz, 1.0, (double)COMP_TICK_RATE_MAX_HZ)) {
        return COMP_ERR_TICK_RATE;
    }
    c->tick_rate_hz = hz;
    return COMP_OK;
}

void comp_f64_set_correction(comp_f64_t *c, double corr_n)
{
    c->corr_n = fmin(16.0, fmax(-16.0, corr_n));
}

void comp_f64_hold_slack(comp_f64_t *c, int32_t held)
{
    if (c->slk_held != (held != 0)) { /* a change: the turn starts again at the next unloading
                                         branch (comp.c) */
        c->slk_dir = 1;
        c->slk_min = 0.0;
        c->slk_k = 0.0;
    }
    c->slk_held = (held != 0);
}

int32_t comp_f64_configure(comp_f64_t *c, const comp_f64_config_t *cfg)
{
    if (c == 0) {
        return COMP_ERR_NULL;
    }
    int32_t err = comp_f64_config_check(cfg);
    if (err != COMP_OK) {
        return err;
    }
    if (c->cfg.preview_ticks != cfg->preview_ticks) {
        c->started = 0; /* a new horizon: the delay line refills at the next step */
    }
    c->cfg = *cfg;
    c->blend = (c->dir > 0) ? blend_top(cfg) : 0.0;
    dz_setup(c);
    c->vis_fresh = 1; /* the viscous term's rate starts again from rest (comp.c) */
    c->vis_r = 0.0;
    return COMP_OK;
}

void comp_f64_init(comp_f64_t *c)
{
    if (c == 0) {
        return;
    }
    comp_f64_config_t cfg;
    comp_f64_config_default(&cfg);
    c->dir = 1;
    c->started = 0;
    c->cfg.preview_ticks = cfg.preview_ticks;
    c->tick_rate_hz = 1000.0; /* the firmware's default tick_rate_hz */
    (void)comp_f64_configure(c, &cfg);
    comp_f64_reset(c);
}

double comp_step_f64(comp_f64_t *c, double t_ref_n)
{
    const comp_f64_config_t *cfg = &c->cfg;
    if (c->started == 0) {
        c->started = 1;
        c->prev_ref = t_ref_n;
        c->extreme = t_ref_n;
        for (int32_t i = 0; i <= COMP_PREVIEW_MAX_TICKS; ++i) {
            c->line[i] = t_ref_n;
        }
        c->line_pos = 0;
    }
    double diff = t_ref_n - c->prev_ref;
    c->prev_ref = t_ref_n;

    if (c->dir > 0) {
        if (t_ref_n > c->extreme) {
            c->extreme = t_ref_n;
        } else if (c->extreme - t_ref_n >= cfg->hysteresis_n) {
            c->dir = -1;
            c->extreme = t_ref_n;
        }
    } else {
        if (t_ref_n < c->extreme) {
            c->extreme = t_ref_n;
        } else if (t_ref_n - c->extreme >= cfg->hysteresis_n) {
            c->dir = 1;
            c->extreme = t_ref_n;
        }
    }

    if (cfg->mode == COMP_MODE_NONE) {
        return fmax(t_ref_n, cfg->tc_min_n);
    }

    double applied = t_ref_n;
    if (cfg->mode == COMP_MODE_PREVIEW) {
        const int32_t len = cfg->preview_ticks + 1;
        c->line_pos = (c->line_pos + 1 < len) ? c->line_pos + 1 : 0;
        c->line[c->line_pos] = t_ref_n;
        int32_t back = c->line_pos - (cfg->preview_ticks - cfg->lead_ticks);
        applied = c->line[(back < 0) ? back + len : back];
    }

    const double top = blend_top(cfg);
    double s;
    if (cfg->mode == COMP_MODE_PAPER) {
        s = (c->dir > 0) ? top : 0.0;
    } else {
        double step = (cfg->mode == COMP_MODE_PREVIEW) ? 1.0 : fabs(diff);
        s = (c->dir > 0) ? fmin(top, c->blend + step) : fmax(0.0, c->blend - step);
    }
    c->blend = s;

    double t_eff = applied - cfg->offset_n + c->corr_n;
    double w = s / top;
    if (cfg->mode == COMP_MODE_PREVIEW) {
        w = w * w * (3.0 - 2.0 * w); /* smoothstep: no corner at either end of the ramp */
    }
    double a = fmin(fabs(t_eff), Q7_8_MAX_N); /* the fixed-point table ends there too */
    double gu;
    double gd;
    gains_x(cfg, c->dz_x1, a, &gu, &gd);
    double f = 1.0;
    if (c->dz_on != 0) {
        /* The inverse PI model of the strands (comp.h): plays on y = ln T_eff. */
        double y = log(fmax(t_eff, 1.0 / 256.0));
        double l = -c->dz_c;
        for (int i = 1; i < COMP_DZ_PLAYS; ++i) {
            if (c->dz_fresh != 0) {
                c->dz_u[i] = (c->dir > 0) ? y - c->dz_r[i] : y + c->dz_r[i];
            }
            c->dz_u[i] = fmin(y + c->dz_r[i], fmax(y - c->dz_r[i], c->dz_u[i]));
            l += c->dz_p[i] * (c->dz_u[i] - y);
        }
        c->dz_fresh = 0;
        f = exp(fmin(4.0, fmax(-4.0, l)));
    }
    double g = gd + (gu - gd) * w;
    if (cfg->mu_per_inlet_rate > 0.0) {
        /* The viscous term (comp.h): r_hat from G |dT_eff| f_tick, saturated and filtered with
         * the FMU's 10 ms; the exponent grows by at most COMP_VISC_X_MAX on the branch. */
        double d = (c->vis_fresh != 0) ? 0.0 : fabs(t_eff - c->vis_prev);
        c->vis_fresh = 0;
        c->vis_prev = t_eff;
        double rate_fs = (double)COMP_VISC_RATE_FS_Q16 / 65536.0;
        double in = fmin(g * d * c->tick_rate_hz, rate_fs);
        double ticks = fmin(1000.0 / ((double)COMP_VISC_TAU_MS * c->tick_rate_hz), 4.0);
        c->vis_r += (in - c->vis_r) * -expm1(-ticks); /* a tick in time constants, held at 4 */
        double x_max = (double)COMP_VISC_X_MAX_Q28 / 268435456.0;
        double x = fmin(cfg->mu_per_inlet_rate * cfg->phi_rad * c->vis_r, x_max);
        g *= exp((2.0 * w - 1.0) * x);
    }
    double tc = t_eff * g * f;
    if (cfg->breakaway > 0.0) {
        /* The breakaway term (comp.h): Y the extreme of T_c since the detector turned. */
        double b = cfg->breakaway * cfg->phi_rad;
        if (c->dir != c->brk_dir) {
            c->brk_y = (c->brk_dir == 0) ? 0.0 : c->brk_last;
            c->brk_dir = c->dir;
            if (cfg->mu_slope_per_n != 0.0) {
                /* The dead zone's width at the turn's tension (the first play's gains), where it
                 * is the wider of it and 2 w_1 (comp.h); the factor at most e^4. */
                double full = fmax(log(gu / gd), 2.0 * c->dz_x1) + 1.125 * b;
                c->brk_full_dn = exp(-full);
                c->brk_full_up = exp(fmin(full, 4.0));
            }
        }
        if (cfg->mu_slope_per_n == 0.0) {
            double full = 2.0 * c->dz_x1 + 1.125 * b; /* the hold: b/8 past the threshold */
            c->brk_full_dn = exp(-full);
            c->brk_full_up = exp(full);
        }
        if (tc > 0.0) {
            double t = fmin(tc, 512.0);
            double tb;
            if (c->dir < 0) {
                tb = fmin(t, fmax(t * exp(-0.5 * b), c->brk_y * c->brk_full_dn));
                tc = t + (tb - t) * (1.0 - w);
            } else {
                tb = fmin(t * exp(0.5 * b), fmax(t, c->brk_y * c->brk_full_up));
                tc = t + (tb - t) * w;
            }
        }
    }
    tc = fmin(Q7_8_MAX_N, fmax(cfg->tc_min_n, fmax(Q7_8_MIN_N, tc)));
    if (cfg->breakaway > 0.0) {
        c->brk_last = tc;
        if (c->brk_dir != 0 && ((c->brk_dir < 0) ? (tc > c->brk_y) : (tc < c->brk_y))) {
            c->brk_y = tc;
        }
    }
    if (c->slk_held == 0 && tc > 0.0 && tc < cfg->slack_tension_n) {
        tc = sqrt(tc * cfg->slack_tension_n); /* the slack's root (comp.h), in [T_c1, S] */
    }
    if (c->slk_held == 0 && cfg->slack_tension_n > 0.0) {
        /* The slack's turn (comp.h, comp.c slack_turn). */
        const double s_n = cfg->slack_tension_n;
        if (c->dir < 0) {
            if (c->slk_dir > 0) {
                c->slk_min = 0.0;
                c->slk_k = 0.0;
            }
            c->slk_dir = -1;
            if (tc > 0.0 && tc < s_n && t_eff > 0.0 && (c->slk_min == 0.0 || tc <= c->slk_min)) {
                c->slk_min = tc;
                c->slk_eff = t_eff;
            }
        } else {
            if (c->slk_dir < 0) {
                c->slk_dir = 1;
                c->slk_k = (c->slk_min > 0.0 && c->slk_min < 255.0 * c->slk_eff)
                               ? c->slk_min / c->slk_eff
                               : 0.0;
            }
            if (c->slk_k != 0.0) {
                double cap = t_eff * c->slk_k;
                if (t_eff > 0.0 && cap < s_n) {
                    tc = fmin(tc, cap);
                } else {
                    c->slk_k = 0.0;
                }
            }
        }
    }
    return tc;
}
