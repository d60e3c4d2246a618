/* test_comp.c - unit tests of the fixed-point compensator against its double twin. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "comp.h"
#include "comp_f64.h"
#include "unit.h"

#define PI_D 3.14159265358979323846
#define LSB_N (1.0 / 256.0)
/* PREVIEW applies the same gain law as SMOOTH: the same bound (comp.h, COMP_ERR_BOUND_LSB). */
#define ERR_BOUND_LSB_PREVIEW ((double)COMP_ERR_BOUND_LSB)

/* A configuration in both forms: the twin gets exactly the quantized parameters. */
typedef struct {
    comp_config_t q;
    comp_f64_config_t d;
} cfg_pair_t;

static cfg_pair_t make_cfg(int32_t mode, double mu, double phi, double slope, double offset_n,
                           double hyst_n, double band_n)
{
    cfg_pair_t p;
    memset(&p, 0, sizeof p); /* every field a test does not set is off (0) */
    p.q.mode = mode;
    p.q.mu_q28 = (q3_28_t)llround(mu * 268435456.0);
    p.q.phi_rad_q24 = (q7_24_t)llround(phi * 16777216.0);
    p.q.mu_slope_per_n_q28 = (q3_28_t)llround(slope * 268435456.0);
    p.q.offset_n_q8 = (q7_8w_t)llround(offset_n * 256.0);
    p.q.hysteresis_n_q8 = (q7_8w_t)llround(hyst_n * 256.0);
    p.q.band_n_q8 = (q7_8w_t)llround(band_n * 256.0);
    p.d.mode = mode;
    p.d.mu = p.q.mu_q28 / 268435456.0;
    p.d.phi_rad = p.q.phi_rad_q24 / 16777216.0;
    p.d.mu_slope_per_n = p.q.mu_slope_per_n_q28 / 268435456.0;
    p.d.offset_n = p.q.offset_n_q8 * LSB_N;
    p.d.hysteresis_n = p.q.hysteresis_n_q8 * LSB_N;
    p.d.band_n = p.q.band_n_q8 * LSB_N;
    p.q.tc_min_n_q8 = 0;
    p.d.tc_min_n = 0.0;
    p.q.preview_ticks = p.d.preview_ticks = 0;
    p.q.lead_ticks = p.d.lead_ticks = 0;
    p.q.ramp_ticks = p.d.ramp_ticks = 1;
    return p;
}

/* The same pair with a floor (N, a whole number of LSB) and a preview horizon and lead. */
static cfg_pair_t with_floor_preview(cfg_pair_t p, double tc_min_n, int32_t preview_ticks,
                                     int32_t lead_ticks)
{
    p.q.tc_min_n_q8 = (q7_8w_t)llround(tc_min_n * 256.0);
    p.d.tc_min_n = p.q.tc_min_n_q8 * LSB_N;
    p.q.preview_ticks = p.d.preview_ticks = preview_ticks;
    p.q.lead_ticks = p.d.lead_ticks = lead_ticks;
    return p;
}

static uint32_t rng_state = 2463534242UL;
static uint32_t rng(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return rng_state;
}

static int configure_both(comp_t *c, comp_f64_t *d, const cfg_pair_t *p)
{
    comp_init(c);
    comp_f64_init(d);
    int32_t e1 = comp_configure(c, &p->q);
    int32_t e2 = comp_f64_configure(d, &p->d);
    CHECK(e1 == COMP_OK && e2 == COMP_OK, "configure: fixed %ld twin %ld", (long)e1, (long)e2);
    return e1 == COMP_OK && e2 == COMP_OK;
}

/* Gains of the twin's law (comp.h) and their first and second derivatives in |T|, scanned over
 * [0, 128] N for the documented bounds. */
typedef struct {
    double gu_max;     /* largest G_up */
    double spread_max; /* largest G_up - G_dn */
    double d1_max;     /* largest |dG/dT| of either branch, 1/N */
    double d2_max;     /* largest |d2G/dT2| of either branch, 1/N^2 */
} gain_stats_t;

static gain_stats_t gain_stats(const comp_f64_config_t *d)
{
    gain_stats_t g = {0.0, 0.0, 0.0, 0.0};
    double x = d->mu * d->phi_rad;
    double e = exp(x);
    double q = (x > 0.0) ? d->phi_rad * expm1(x) / x : d->phi_rad;
    double k = d->mu_slope_per_n * q;
    for (double a = 0.0; a <= 128.0; a += 0.25) {
        double du = 1.0 - k * a;
        double dd = e + k * a;
        double gu = e / du;
        double gd = 1.0 / dd;
        g.gu_max = fmax(g.gu_max, gu);
        g.spread_max = fmax(g.spread_max, gu - gd);
        g.d1_max = fmax(g.d1_max, fmax(fabs(e * k / (du * du)), fabs(k / (dd * dd))));
        g.d2_max = fmax(g.d2_max, fmax(fabs(2 * e * k * k / (du * du * du)),
                                       fabs(2 * k * k / (dd * dd * dd))));
    }
    return g;
}

/* Documented bound of |fixed - twin| in LSB (comp.h): 1 LSB plus the table interpolation. */
static double err_bound_lsb(const comp_f64_config_t *d)
{
    const double h = 2.0;
    return COMP_ERR_BOUND_LSB + 128.0 * h * h / 8.0 * gain_stats(d).d2_max * 256.0;
}

/* Documented per-tick bound of |dT_c| in N in SMOOTH mode (comp.h). */
static double step_bound_n(const comp_f64_config_t *d, const gain_stats_t *gs, double dref_n,
                           double tmax_n)
{
    const gain_stats_t g = *gs;
    return fabs(dref_n) * (g.gu_max + tmax_n * (g.spread_max / d->band_n + g.d1_max)) +
           2.0 * LSB_N;
}

/* Run a reference sequence through both and return the worst |fixed - twin| in LSB. */
static double run_compare(const cfg_pair_t *p, const int16_t *ref, int n)
{
    comp_t c;
    comp_f64_t d;
    if (!configure_both(&c, &d, p)) {
        return 1e9;
    }
    double worst = 0.0;
    for (int i = 0; i < n; ++i) {
        double fx = comp_step_q7_8(&c, ref[i]);
        double fd = comp_step_f64(&d, ref[i] * LSB_N) * 256.0;
        double e = fabs(fx - fd);
        worst = e > worst ? e : worst;
        if (c.dir != d.dir) {
            return 1e9; /* detectors must agree exactly on Q7.8 references */
        }
    }
    return worst;
}

#define NSEQ 40000
static int16_t seq[NSEQ];

static void seq_random_walk(int32_t max_step)
{
    int32_t v = 0;
    for (int i = 0; i < NSEQ; ++i) {
        v += (int32_t)(rng() % (uint32_t)(2 * max_step + 1)) - max_step;
        v = v > INT16_MAX ? INT16_MAX : (v < INT16_MIN ? INT16_MIN : v);
        seq[i] = (int16_t)v;
    }
}

static void seq_random_full_scale(void)
{
    for (int i = 0; i < NSEQ; ++i) {
        seq[i] = (int16_t)(rng() & 0xFFFFU);
    }
}

static void seq_sine(double amp_n, double mean_n, double freq_hz, double rate_hz)
{
    for (int i = 0; i < NSEQ; ++i) {
        double v = mean_n + amp_n * sin(2.0 * PI_D * freq_hz * i / rate_hz);
        seq[i] = (int16_t)lround(v * 256.0);
    }
}

static void test_defaults_valid(void)
{
    comp_config_t cfg;
    comp_config_default(&cfg);
    CHECK(comp_config_check(&cfg) == COMP_OK, "defaults rejected");
    CHECK(cfg.mode == COMP_MODE_PAPER, "default mode");
    CHECK(fabs(cfg.mu_q28 / 268435456.0 - 0.075) < 1e-8, "default mu");
    CHECK(fabs(cfg.phi_rad_q24 / 16777216.0 - 2.0 * PI_D) < 1e-7, "default phi");
    comp_f64_config_t d;
    comp_f64_config_default(&d);
    CHECK(comp_f64_config_check(&d) == COMP_OK, "twin defaults rejected");
    CHECK(d.hysteresis_n * 256.0 == cfg.hysteresis_n_q8 && d.band_n * 256.0 == cfg.band_n_q8,
          "defaults of the twin differ");
}

/* Every bad field returns its own code and leaves configuration and state untouched. */
static void test_bad_config_rejected_and_previous_kept(void)
{
    typedef struct {
        const char *what;
        cfg_pair_t p;
        int32_t code;
    } bad_t;
    const double tiny_q28 = 1.0 / 268435456.0;
    const double tiny_q24 = 1.0 / 16777216.0;
    bad_t bad[] = {
        {"mode 4", make_cfg(4, 0.075, 6.0, 0, 0, 0.01, 2), COMP_ERR_MODE},
        {"mode -1", make_cfg(-1, 0.075, 6.0, 0, 0, 0.01, 2), COMP_ERR_MODE},
        {"mu < 0", make_cfg(1, -tiny_q28, 6.0, 0, 0, 0.01, 2), COMP_ERR_MU},
        {"mu > 1", make_cfg(1, 1.0 + tiny_q28, 1.0, 0, 0, 0.01, 2), COMP_ERR_MU},
        {"phi < 0", make_cfg(1, 0.075, -tiny_q24, 0, 0, 0.01, 2), COMP_ERR_PHI},
        {"phi > 4pi", make_cfg(1, 0.075, 4.0 * PI_D + 2 * tiny_q24, 0, 0, 0.01, 2), COMP_ERR_PHI},
        {"slope > 1/128", make_cfg(1, 0.075, 1.0, 1.0 / 128 + tiny_q28, 0, 0.01, 2),
         COMP_ERR_MU_SLOPE},
        {"mu_eff < 0 at 48 N", make_cfg(1, 3.0 / 32, 1.0, -1.0 / 512 - tiny_q28, 0, 0.01, 2),
         COMP_ERR_MU_SLOPE},
        {"mu*phi > 4", make_cfg(1, 0.5, 8.1, 0, 0, 0.01, 2), COMP_ERR_EXPONENT},
        {"capstan diverges below 48 N", make_cfg(1, 0.1, 4.0 * PI_D, 0.002, 0, 0.01, 2),
         COMP_ERR_MU_SLOPE},
        {"gain > e^4 at 48 N", make_cfg(1, 0.3, 4.0 * PI_D, 4e-5, 0, 0.01, 2), COMP_ERR_MU_SLOPE},
        {"offset > 64 N", make_cfg(1, 0.075, 6.0, 0, 64.0 + LSB_N, 0.01, 2), COMP_ERR_OFFSET},
        {"offset < -64 N", make_cfg(1, 0.075, 6.0, 0, -64.0 - LSB_N, 0.01, 2), COMP_ERR_OFFSET},
        {"hysteresis 0", make_cfg(1, 0.075, 6.0, 0, 0, 0.0, 2), COMP_ERR_HYSTERESIS},
        {"hysteresis > 32 N", make_cfg(1, 0.075, 6.0, 0, 0, 32.0 + LSB_N, 2),
         COMP_ERR_HYSTERESIS},
        {"band 0", make_cfg(2, 0.075, 6.0, 0, 0, 0.01, 0.0), COMP_ERR_BAND},
        {"band < 0", make_cfg(2, 0.075, 6.0, 0, 0, 0.01, -1.0), COMP_ERR_BAND},
        {"band > 128 N", make_cfg(2, 0.075, 6.0, 0, 0, 0.01, 128.0 + LSB_N), COMP_ERR_BAND},
        {"floor < 0", with_floor_preview(make_cfg(1, 0.075, 6.0, 0, 0, 0.01, 2), -LSB_N, 0, 0),
         COMP_ERR_TC_MIN},
        {"floor > 64 N",
         with_floor_preview(make_cfg(1, 0.075, 6.0, 0, 0, 0.01, 2), 64.0 + LSB_N, 0, 0),
         COMP_ERR_TC_MIN},
        {"preview < 0", with_floor_preview(make_cfg(3, 0.075, 6.0, 0, 0, 0.01, 2), 0, -1, 0),
         COMP_ERR_PREVIEW},
        {"preview > 128", with_floor_preview(make_cfg(3, 0.075, 6.0, 0, 0, 0.01, 2), 0, 129, 0),
         COMP_ERR_PREVIEW},
        {"lead < 0", with_floor_preview(make_cfg(3, 0.075, 6.0, 0, 0, 0.01, 2), 0, 8, -1),
         COMP_ERR_LEAD},
        {"lead > preview", with_floor_preview(make_cfg(3, 0.075, 6.0, 0, 0, 0.01, 2), 0, 8, 9),
         COMP_ERR_LEAD},
    };
    comp_t c;
    comp_f64_t d;
    cfg_pair_t good = make_cfg(COMP_MODE_SMOOTH, 0.1, 5.0, 0.0, 0.5, 0.02, 1.5);
    configure_both(&c, &d, &good);
    for (int i = 0; i < 300; ++i) { /* some history, so the state is not trivial */
        (void)comp_step_q7_8(&c, (int16_t)(i * 7 % 1000));
        (void)comp_step_f64(&d, (i * 7 % 1000) * LSB_N);
    }
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        comp_t before = c;
        comp_f64_t before_d = d;
        int32_t e = comp_configure(&c, &bad[i].p.q);
        int32_t ed = comp_f64_configure(&d, &bad[i].p.d);
        CHECK(e == bad[i].code, "%s: code %ld, expected %ld", bad[i].what, (long)e,
              (long)bad[i].code);
        CHECK(ed == bad[i].code, "%s: twin code %ld", bad[i].what, (long)ed);
        CHECK(memcmp(&before, &c, sizeof c) == 0, "%s: fixed state changed", bad[i].what);
        CHECK(memcmp(&before_d, &d, sizeof d) == 0, "%s: twin state changed", bad[i].what);
    }
    CHECK(comp_configure(0, &good.q) == COMP_ERR_NULL, "null compensator");
    CHECK(comp_configure(&c, 0) == COMP_ERR_NULL, "null config");
    comp_f64_config_t nan_cfg = good.d;
    nan_cfg.mu = NAN;
    CHECK(comp_f64_configure(&d, &nan_cfg) == COMP_ERR_MU, "NaN mu in the twin");
}

/* The limits themselves are accepted. */
static void test_limits_accepted(void)
{
    cfg_pair_t ok[] = {
        make_cfg(COMP_MODE_PAPER, 0.0, 0.0, 0.0, 0.0, LSB_N, LSB_N),
        make_cfg(COMP_MODE_PAPER, 1.0, 4.0, 0.0, 64.0, 32.0, 128.0),
        make_cfg(COMP_MODE_SMOOTH, 0.3, 4.0 * PI_D, 0.0, -64.0, 1.0, 128.0),
        make_cfg(COMP_MODE_SMOOTH, 1.0 / 128, 0.5, 1.0 / 128, 0.0, 1.0, 1.0),
        make_cfg(COMP_MODE_SMOOTH, 0.5, 1.0, -1.0 / 256, 0.0, 1.0, 1.0),
        /* mu + 48 N * slope = 0 exactly (3/32 and -1/512 are exact in Q3.28) */
        make_cfg(COMP_MODE_SMOOTH, 3.0 / 32, 1.0, -1.0 / 512, 0.0, 1.0, 1.0),
        /* a gain that would pass e^4 only above 48 N, where the tables hold it */
        make_cfg(COMP_MODE_SMOOTH, 0.3, 4.0 * PI_D, 2e-5, 0.0, 1.0, 1.0),
        /* a measured slope the 128 N rule refused: mu 0.075 at loop routing, -0.0008 /N */
        make_cfg(COMP_MODE_PREVIEW, 0.075, 2.0 * PI_D, -0.0008, 0.0, 1.0, 1.0),
        make_cfg(COMP_MODE_NONE, 0.075, 2.0 * PI_D, 0.0, 0.0, 1.0, 1.0),
        with_floor_preview(make_cfg(COMP_MODE_PREVIEW, 0.075, 2.0 * PI_D, 0, 0, 1.0, 1.0), 64.0,
                           COMP_PREVIEW_MAX_TICKS, COMP_PREVIEW_MAX_TICKS),
        with_floor_preview(make_cfg(COMP_MODE_PREVIEW, 0.075, 2.0 * PI_D, 0, 0, 1.0, 1.0), 0.0,
                           COMP_PREVIEW_MAX_TICKS, 0),
    };
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; ++i) {
        CHECK(comp_config_check(&ok[i].q) == COMP_OK, "limit set %zu rejected: %ld", i,
              (long)comp_config_check(&ok[i].q));
        CHECK(comp_f64_config_check(&ok[i].d) == COMP_OK, "twin limit set %zu rejected", i);
    }
}

static const struct {
    const char *name;
    int32_t mode;
    double mu, phi, slope, offset, hyst, band;
} twin_cfgs[] = {
    {"paper default", COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0, 4 * LSB_N, 2},
    {"paper H=1", COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0, LSB_N, 2},
    {"smooth default", COMP_MODE_SMOOTH, 0.075, 2 * PI_D, 0, 0, 4 * LSB_N, 2},
    {"smooth max exponent", COMP_MODE_SMOOTH, 1.0 / 3.0, 12.0, 0, 0, LSB_N, 0.5},
    {"smooth band 1 LSB", COMP_MODE_SMOOTH, 0.2, 4 * PI_D, 0, 0, LSB_N, LSB_N},
    {"smooth band 128 N", COMP_MODE_SMOOTH, 0.3, 4 * PI_D, 0, 0, 0.1, 128},
    {"smooth band 3.3 N", COMP_MODE_SMOOTH, 0.11, 5.5, 0, 0, 0.05, 3.3},
    {"paper offset", COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0.5, LSB_N, 2},
    {"smooth offset -64", COMP_MODE_SMOOTH, 0.075, 2 * PI_D, 0, -64.0, LSB_N, 2},
    {"smooth slope", COMP_MODE_SMOOTH, 0.075, 2 * PI_D, 0.0005, 0.5, LSB_N, 2},
    {"paper slope max", COMP_MODE_PAPER, 0.02, 0.5, 1.0 / 128, 0, LSB_N, 2},
    {"smooth slope offset -64", COMP_MODE_SMOOTH, 0.075, 2 * PI_D, 0.0005, -64.0, LSB_N, 3},
    {"smooth slope negative", COMP_MODE_SMOOTH, 0.2, 2 * PI_D, -0.001, 0, LSB_N, 5},
    {"smooth slope measured", COMP_MODE_SMOOTH, 0.075, 2 * PI_D, -0.0008, 0, LSB_N, 5},
    {"none", COMP_MODE_NONE, 0.075, 2 * PI_D, 0, 0.5, LSB_N, 2},
};

/* Fixed point against the double twin over random walks, random full-scale jumps and sines. */
static void test_matches_twin_random_and_full_scale(void)
{
    for (size_t k = 0; k < sizeof twin_cfgs / sizeof twin_cfgs[0]; ++k) {
        cfg_pair_t p = make_cfg(twin_cfgs[k].mode, twin_cfgs[k].mu, twin_cfgs[k].phi,
                                twin_cfgs[k].slope, twin_cfgs[k].offset, twin_cfgs[k].hyst,
                                twin_cfgs[k].band);
        double bound = err_bound_lsb(&p.d);
        double worst = 0.0;
        const int32_t steps[] = {3, 40, 700};
        for (size_t s = 0; s < 3; ++s) {
            seq_random_walk(steps[s]);
            double e = run_compare(&p, seq, NSEQ);
            worst = e > worst ? e : worst;
        }
        seq_random_full_scale();
        double e = run_compare(&p, seq, NSEQ);
        worst = e > worst ? e : worst;
        seq_sine(127.0, 0.0, 3.0, 1000.0);
        e = run_compare(&p, seq, NSEQ);
        worst = e > worst ? e : worst;
        printf("  %-22s max |fixed - twin| = %.3f LSB (bound %.3f)\n", twin_cfgs[k].name, worst,
               bound);
        CHECK(worst <= bound, "%s: %.3f LSB > bound %.3f", twin_cfgs[k].name, worst, bound);
    }
}

/* Saturation of T_c: at the top of the Q7.8 range and at the floor (a cable cannot push), driven
 * to both ends with the largest gain and offsets, the floor at 0 and at its maximum, 64 N. */
static void test_output_saturates_at_full_scale(void)
{
    const double offsets[3] = {0.0, -64.0, 64.0};
    for (int k = 0; k < 6; ++k) {
        const double floor_n = (k < 3) ? 0.0 : 64.0;
        cfg_pair_t p = with_floor_preview(
            make_cfg(COMP_MODE_PAPER, 1.0 / 3.0, 12.0, 0, offsets[k % 3], LSB_N, 2), floor_n, 0,
            0);
        comp_t c;
        comp_f64_t d;
        configure_both(&c, &d, &p);
        /* Loading (the initial direction) with G = e^4: the top saturates, the bottom floors. */
        CHECK(comp_step_q7_8(&c, INT16_MIN) == (int16_t)(floor_n * 256.0),
              "offset %g: full-scale negative input not at the floor %g N", offsets[k % 3],
              floor_n);
        CHECK(comp_step_q7_8(&c, INT16_MAX) == INT16_MAX, "offset %g: positive saturation",
              offsets[k % 3]);
        /* Alternate full-scale jumps: every step reverses; the result never wraps around. */
        configure_both(&c, &d, &p);
        int bad = 0;
        for (int i = 0; i < 1000; ++i) {
            int16_t r = (i & 1) ? INT16_MIN : INT16_MAX;
            double want = comp_step_f64(&d, r * LSB_N);
            int16_t t = comp_step_q7_8(&c, r);
            bad += fabs(t * LSB_N - want) > LSB_N;
            bad += t < p.q.tc_min_n_q8;
        }
        CHECK(bad == 0, "offset %g floor %g: %d full-scale steps differ from the twin or fall "
              "below the floor", offsets[k % 3], floor_n, bad);
    }
}

/* Eq. 16: the sign of delta is held when delta = 0. */
static void test_sign_held_when_delta_zero(void)
{
    cfg_pair_t p = make_cfg(COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0, LSB_N, 2);
    comp_t c;
    comp_f64_t d;
    configure_both(&c, &d, &p);
    double gu = exp(0.075 * 2 * PI_D);
    double gd = exp(-0.075 * 2 * PI_D);
    int16_t t = 0;
    for (int16_t r = 0; r <= 2560; r += 10) {
        t = comp_step_q7_8(&c, r);
    }
    int bad = 0;
    for (int i = 0; i < 500; ++i) { /* hold at 10 N: loading branch kept */
        t = comp_step_q7_8(&c, 2560);
        bad += abs(t - (int)lround(2560 * gu)) > 1 || c.dir != 1;
    }
    CHECK(bad == 0, "%d steps left the loading branch while delta = 0 (T_c %d)", bad, t);
    for (int16_t r = 2550; r >= 1280; r -= 10) {
        t = comp_step_q7_8(&c, r);
    }
    bad = 0;
    for (int i = 0; i < 500; ++i) { /* hold at 5 N: unloading branch kept */
        t = comp_step_q7_8(&c, 1280);
        bad += abs(t - (int)lround(1280 * gd)) > 1 || c.dir != -1;
    }
    CHECK(bad == 0, "%d steps left the unloading branch while delta = 0 (T_c %d)", bad, t);
}

/* With H = 1 LSB the detector is exactly Eq. 16, checked against a plain sign(diff) that holds. */
static void test_hysteresis_one_lsb_is_eq16(void)
{
    cfg_pair_t p = make_cfg(COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0, LSB_N, 2);
    comp_t c;
    comp_f64_t d;
    configure_both(&c, &d, &p);
    int32_t v = 1000;
    int32_t prev = v;
    int32_t sign = 1;
    int bad = 0;
    for (int i = 0; i < 100000; ++i) {
        uint32_t r = rng() % 5U; /* many zero differences on purpose */
        v += (r == 0) ? 0 : (r == 1) ? 0 : (r == 2) ? 1 : (r == 3) ? -1 : (int32_t)(rng() % 7) - 3;
        v = v < -30000 ? -30000 : (v > 30000 ? 30000 : v);
        (void)comp_step_q7_8(&c, (int16_t)v);
        int32_t delta = (i == 0) ? 0 : v - prev;
        sign = (delta > 0) ? 1 : (delta < 0) ? -1 : sign;
        prev = v;
        bad += (c.dir != sign);
    }
    CHECK(bad == 0, "%d steps where the detector differs from sign(delta)", bad);
}

/* A noisy constant with peak-to-peak noise below H never flips the direction; with H = 1 LSB it
 * would (the test can fail). */
static void test_no_chatter_on_noisy_constant(void)
{
    const double gu = exp(0.075 * 2 * PI_D);
    for (int h = 1; h <= 4; h += 3) {
        cfg_pair_t p = make_cfg(COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0, h * LSB_N, 2);
        comp_t c;
        comp_f64_t d;
        configure_both(&c, &d, &p);
        for (int16_t r = 0; r <= 2560; r += 8) {
            (void)comp_step_q7_8(&c, r);
        }
        int flips = 0;
        int32_t last_dir = c.dir;
        int16_t tmin = INT16_MAX;
        int16_t tmax = INT16_MIN;
        for (int i = 0; i < 100000; ++i) {
            /* 10 N with dither of +-1 LSB (3 LSB peak to peak: 10 N - 1 .. 10 N + 1). */
            int16_t r = (int16_t)(2560 + (int32_t)(rng() % 3U) - 1);
            int16_t t = comp_step_q7_8(&c, r);
            flips += (c.dir != last_dir);
            last_dir = c.dir;
            tmin = t < tmin ? t : tmin;
            tmax = t > tmax ? t : tmax;
        }
        if (h == 4) {
            CHECK(flips == 0, "H = 4 LSB: %d direction flips on a 2 LSB p-p dither", flips);
            CHECK(tmax - tmin <= (int)ceil(2 * gu) + 1, "T_c wanders %d LSB", tmax - tmin);
        } else {
            printf("  H = 1 LSB on the same dither: %d direction flips (the band is needed)\n",
                   flips);
            CHECK(flips > 1000, "H = 1 LSB should chatter on a dither, got %d flips", flips);
        }
    }
}

/* SMOOTH: no step of T_c larger than the documented bound; PAPER jumps far beyond it. */
static void test_smooth_inverse_step_bound(void)
{
    const struct {
        double amp, mean, freq, band, slope, offset;
    } cases[] = {
        {7.5, 7.5, 0.5, 2.0, 0.0, 0.0},     /* the paper's 0..15 N sine */
        {7.5, 7.5, 5.0, 0.5, 0.0, 0.0},     /* ten times faster, narrow band */
        {60.0, 0.0, 2.0, 1.0, 0.0005, 0.5}, /* large, with the extensions */
        {127.0, 0.0, 1.0, LSB_N, 0.0, 0.0}, /* the narrowest band */
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        cfg_pair_t p = make_cfg(COMP_MODE_SMOOTH, 0.075, 2 * PI_D, cases[k].slope,
                                cases[k].offset, LSB_N, cases[k].band);
        cfg_pair_t pp = p;
        pp.q.mode = COMP_MODE_PAPER;
        comp_t c;
        comp_t cp;
        comp_f64_t d;
        configure_both(&c, &d, &p);
        configure_both(&cp, &d, &pp);
        const gain_stats_t gs = gain_stats(&p.d);
        seq_sine(cases[k].amp, cases[k].mean, cases[k].freq, 1000.0);
        int16_t prev = comp_step_q7_8(&c, seq[0]);
        int16_t prevp = comp_step_q7_8(&cp, seq[0]);
        double worst_ratio = 0.0;
        int worst_jump = 0;
        int worst_jump_paper = 0;
        for (int i = 1; i < NSEQ; ++i) {
            int16_t t = comp_step_q7_8(&c, seq[i]);
            int16_t tp = comp_step_q7_8(&cp, seq[i]);
            double dref = (seq[i] - seq[i - 1]) * LSB_N;
            double tmax = fmax(fabs(seq[i] * LSB_N - p.d.offset_n),
                               fabs(seq[i - 1] * LSB_N - p.d.offset_n));
            double bound = step_bound_n(&p.d, &gs, dref, tmax);
            double jump = fabs((t - prev) * LSB_N);
            worst_ratio = fmax(worst_ratio, jump / bound);
            worst_jump = abs(t - prev) > worst_jump ? abs(t - prev) : worst_jump;
            worst_jump_paper = abs(tp - prevp) > worst_jump_paper ? abs(tp - prevp) : worst_jump_paper;
            prev = t;
            prevp = tp;
        }
        printf("  sine %.1f N at %.1f Hz, B = %.3f N: max step smooth %.3f N (%.2f of bound), "
               "paper %.3f N\n",
               cases[k].amp, cases[k].freq, cases[k].band, worst_jump * LSB_N, worst_ratio,
               worst_jump_paper * LSB_N);
        CHECK(worst_ratio <= 1.0, "case %zu: a step exceeds the bound by %.3f", k, worst_ratio);
        if (cases[k].band >= 0.5) {
            CHECK(worst_jump_paper > 2 * worst_jump, "case %zu: paper %d vs smooth %d LSB", k,
                  worst_jump_paper, worst_jump);
        }
    }
    /* Random walks too, with the widest and narrowest bands. */
    const double bands[] = {LSB_N, 0.3, 7.0, 128.0};
    for (size_t k = 0; k < 4; ++k) {
        cfg_pair_t p = make_cfg(COMP_MODE_SMOOTH, 0.2, 4 * PI_D, 0, 0, 0.02, bands[k]);
        comp_t c;
        comp_f64_t d;
        configure_both(&c, &d, &p);
        const gain_stats_t gs = gain_stats(&p.d);
        seq_random_walk(300);
        int16_t prev = comp_step_q7_8(&c, seq[0]);
        double worst_ratio = 0.0;
        for (int i = 1; i < NSEQ; ++i) {
            int16_t t = comp_step_q7_8(&c, seq[i]);
            double tmax = fmax(fabs(seq[i] * LSB_N), fabs(seq[i - 1] * LSB_N));
            double bound = step_bound_n(&p.d, &gs, (seq[i] - seq[i - 1]) * LSB_N, tmax);
            worst_ratio = fmax(worst_ratio, fabs((t - prev) * LSB_N) / bound);
            prev = t;
        }
        CHECK(worst_ratio <= 1.0, "random walk, B = %.3f: ratio %.3f", bands[k], worst_ratio);
    }
}

/* The blend saturates at both branches: after B of travel SMOOTH equals PAPER exactly. */
static void test_blend_saturates_at_branches(void)
{
    cfg_pair_t p = make_cfg(COMP_MODE_SMOOTH, 0.075, 2 * PI_D, 0, 0, LSB_N, 1.0);
    cfg_pair_t pp = p;
    pp.q.mode = COMP_MODE_PAPER;
    comp_t c;
    comp_t cp;
    comp_f64_t d;
    configure_both(&c, &d, &p);
    configure_both(&cp, &d, &pp);
    int diff_after = 0;
    int mid_seen = 0;
    for (int cycle = 0; cycle < 4; ++cycle) {
        for (int i = 0; i <= 800; ++i) { /* up 0 -> 20 N, then down, 25 LSB per step */
            int16_t r = (int16_t)((cycle % 2 == 0) ? i * 5 : 4000 - i * 5);
            int16_t t = comp_step_q7_8(&c, r);
            int16_t tp = comp_step_q7_8(&cp, r);
            int32_t w = comp_blend_q1_30(&c);
            if (i > 60) { /* 300 LSB of travel > B = 256 LSB after the reversal */
                diff_after += (t != tp);
                CHECK(w == (cycle % 2 == 0 ? (int32_t)Q1_30_ONE : 0), "blend not at a branch");
            } else if (cycle > 0 && w > 0 && w < (int32_t)Q1_30_ONE) {
                ++mid_seen;
            }
        }
    }
    CHECK(diff_after == 0, "%d steps where SMOOTH differs from PAPER after the band", diff_after);
    CHECK(mid_seen > 20, "the blend was seen between branches only %d times", mid_seen);
}

/* w = s/B in Q1.30 for every band: within 2 LSB of Q1.30 of the exact ratio. */
static void test_blend_weight_precision_every_band(void)
{
    comp_t c;
    comp_init(&c);
    comp_config_t cfg;
    comp_config_default(&cfg);
    cfg.mode = COMP_MODE_SMOOTH;
    int bad = 0;
    for (int32_t b = 1; b <= COMP_BAND_MAX_Q8; ++b) {
        cfg.band_n_q8 = b;
        if (comp_configure(&c, &cfg) != COMP_OK) {
            ++bad;
            continue;
        }
        const int32_t probes[3] = {b - 1, b / 2, b / 3};
        for (int k = 0; k < 3; ++k) {
            c.blend = probes[k];
            double exact = (double)probes[k] / b * 1073741824.0;
            bad += fabs(comp_blend_q1_30(&c) - exact) > 2.0;
        }
    }
    CHECK(bad == 0, "%d blend weights off by more than 2 LSB of Q1.30", bad);
}

/* Reconfiguring keeps the direction and puts the blend on its branch. */
static void test_reconfigure_keeps_direction(void)
{
    comp_t c;
    comp_init(&c);
    for (int16_t r = 0; r < 1000; r += 10) {
        (void)comp_step_q7_8(&c, r);
    }
    for (int16_t r = 1000; r > 500; r -= 10) {
        (void)comp_step_q7_8(&c, r);
    }
    CHECK(c.dir == -1, "unloading expected");
    comp_config_t cfg;
    comp_config_default(&cfg);
    cfg.mode = COMP_MODE_SMOOTH;
    CHECK(comp_configure(&c, &cfg) == COMP_OK, "reconfigure");
    CHECK(c.dir == -1 && c.blend == 0, "dir %ld blend %ld", (long)c.dir, (long)c.blend);
    comp_reset(&c);
    CHECK(c.dir == 1 && c.blend == cfg.band_n_q8 && c.started == 0, "reset");
}

/* comp_configure keeps the tables when mu, phi and mu_slope are those they were built from, and
 * rebuilds them otherwise: after comp_set_exponent_q28 (the estimate's tables) and after a
 * change of mu, the tables equal a fresh compensator's of the same configuration, word for word;
 * a change of the band alone keeps them and moves 1/band. */
static void test_reconfigure_tables_follow_mu_phi(void)
{
    comp_config_t cfg;
    comp_config_default(&cfg);
    comp_t c;
    comp_t fresh;
    comp_init(&c);
    CHECK(comp_set_exponent_q28(&c, Q3_28_ONE) == COMP_OK, "estimate");
    CHECK(comp_configure(&c, &cfg) == COMP_OK, "configure after the estimate");
    comp_init(&fresh);
    CHECK(memcmp(c.g_up, fresh.g_up, sizeof c.g_up) == 0 &&
              memcmp(c.g_dn, fresh.g_dn, sizeof c.g_dn) == 0,
          "the estimate's tables kept");
    cfg.mu_q28 += Q3_28_ONE / 64;
    CHECK(comp_configure(&c, &cfg) == COMP_OK && comp_configure(&fresh, &cfg) == COMP_OK, "mu");
    comp_t other;
    comp_init(&other);
    CHECK(memcmp(c.g_up, other.g_up, sizeof c.g_up) != 0, "mu did not change the tables");
    CHECK(memcmp(c.g_up, fresh.g_up, sizeof c.g_up) == 0, "tables after a change of mu");
    uint32_t inv_band = c.inv_band;
    cfg.band_n_q8 *= 3; /* not a power of two: 1/band's word moves, not only its shift */
    CHECK(comp_configure(&c, &cfg) == COMP_OK, "band");
    CHECK(memcmp(c.g_up, fresh.g_up, sizeof c.g_up) == 0 && c.inv_band != inv_band &&
              c.blend_top == cfg.band_n_q8,
          "band: tables kept, 1/band moved");
}

/* NONE passes T_ref through for every input word at or above the floor, and gives the floor
 * below it (floors 0 and 64 N). */
static void test_mode_none_passthrough(void)
{
    comp_t c;
    comp_init(&c);
    comp_config_t cfg;
    comp_config_default(&cfg);
    cfg.mode = COMP_MODE_NONE;
    cfg.offset_n_q8 = 100;
    for (int32_t floor_q8 = 0; floor_q8 <= COMP_TC_MIN_MAX_Q8; floor_q8 += COMP_TC_MIN_MAX_Q8) {
        cfg.tc_min_n_q8 = floor_q8;
        CHECK(comp_configure(&c, &cfg) == COMP_OK, "configure NONE");
        int bad = 0;
        for (int32_t r = INT16_MIN; r <= INT16_MAX; ++r) {
            bad += comp_step_q7_8(&c, (int16_t)r) != ((r < floor_q8) ? floor_q8 : r);
        }
        CHECK(bad == 0, "floor %ld: %d words not passed through or floored", (long)floor_q8, bad);
    }
}

/* PREVIEW, fed x[k + P]: its detector flips at the same step as a PAPER compensator fed the
 * same x[k + P] (the change of branch starts P ticks before the reversal reaches x[k]); after a
 * flip the blend moves by exactly 1/D per tick to the other branch; on a branch the output is
 * the branch's gain applied to x[k + L], word for word what PAPER gives for x[k + L] there. */
static void test_preview_blend_moves_in_time(void)
{
    enum { P = 8, D = 20 };
    seq_sine(7.5, 7.5, 0.5, 1000.0);
    for (int32_t lead = 0; lead <= P; lead += P) {
        cfg_pair_t pv = with_floor_preview(
            make_cfg(COMP_MODE_PREVIEW, 0.075, 2 * PI_D, 0, 0, 4 * LSB_N, 1.0), 0.0, P, lead);
        pv.q.ramp_ticks = pv.d.ramp_ticks = D;
        cfg_pair_t pa = make_cfg(COMP_MODE_PAPER, 0.075, 2 * PI_D, 0, 0, 4 * LSB_N, 1.0);
        comp_t cp;
        comp_t ca;
        comp_t cb;
        comp_f64_t d;
        configure_both(&cp, &d, &pv);
        configure_both(&ca, &d, &pa); /* detector on x[k + P] */
        configure_both(&cb, &d, &pa); /* output on x[k + L] */
        int bad_dir = 0;
        int bad_ramp = 0;
        int bad_out = 0;
        int flips = 0;
        int on_branch = 0;
        int32_t prev_blend = cp.blend;
        int32_t prev_dir = cp.dir;
        for (int i = 0; i + P < NSEQ; ++i) {
            int16_t tp = comp_step_q7_8(&cp, seq[i + P]);
            (void)comp_step_q7_8(&ca, seq[i + P]);
            int16_t tb = comp_step_q7_8(&cb, seq[i + lead]);
            bad_dir += cp.dir != ca.dir;
            flips += cp.dir != prev_dir;
            /* the blend moves one tick towards the branch of the direction, and stops there */
            int32_t want = prev_blend + ((cp.dir > 0) ? 1 : -1);
            want = want < 0 ? 0 : want > D ? D : want;
            bad_ramp += cp.blend != want;
            prev_blend = cp.blend;
            prev_dir = cp.dir;
            /* past the line's fill, on a branch both agree on: the same gain on x[k + L] */
            if (i >= P && (cp.blend == 0 || cp.blend == D) && cb.dir == cp.dir) {
                bad_out += tp != tb;
                ++on_branch;
            }
        }
        CHECK(flips >= 2, "lead %d: only %d reversals", (int)lead, flips);
        CHECK(bad_dir == 0, "lead %d: detector differs from PAPER's at %d steps", (int)lead,
              bad_dir);
        CHECK(bad_ramp == 0, "lead %d: blend not one tick per step at %d steps", (int)lead,
              bad_ramp);
        CHECK(on_branch > NSEQ / 2 && bad_out == 0, "lead %d: %d outputs off the branch law",
              (int)lead, bad_out);
    }
}

/* PREVIEW against its double twin over sines, random walks and full-scale jumps, for short and
 * the longest horizons and a floor; the floor holds at every step. */
static void test_preview_matches_twin(void)
{
    const int32_t pl[4][3] = {{8, 2, 40}, {8, 8, 1}, {COMP_PREVIEW_MAX_TICKS, 0, COMP_RAMP_MAX_TICKS},
                              {1, 0, 7}};
    for (int k = 0; k < 4; ++k) {
        cfg_pair_t p = with_floor_preview(
            make_cfg(COMP_MODE_PREVIEW, 0.075, 2 * PI_D, 0, 0, 4 * LSB_N, 1.0),
            (k == 3) ? 2.0 : 0.0, pl[k][0], pl[k][1]);
        p.q.ramp_ticks = p.d.ramp_ticks = pl[k][2];
        double worst = 0.0;
        seq_sine(15.0, 7.5, 0.5, 1000.0);
        double e = run_compare(&p, seq, NSEQ);
        worst = e > worst ? e : worst;
        seq_random_walk(40);
        e = run_compare(&p, seq, NSEQ);
        worst = e > worst ? e : worst;
        seq_random_full_scale();
        e = run_compare(&p, seq, NSEQ);
        worst = e > worst ? e : worst;
        CHECK(worst <= ERR_BOUND_LSB_PREVIEW, "P %ld L %ld: %.3f LSB from the twin",
              (long)pl[k][0], (long)pl[k][1], worst);
        comp_t c;
        comp_f64_t d;
        configure_both(&c, &d, &p);
        int below = 0;
        for (int i = 0; i < NSEQ; ++i) {
            below += comp_step_q7_8(&c, seq[i]) < p.q.tc_min_n_q8;
        }
        CHECK(below == 0, "P %ld: %d outputs below the floor", (long)pl[k][0], below);
    }
}

const unit_test_t comp_tests[] = {
    {"defaults_valid", test_defaults_valid},
    {"bad_config_rejected_and_previous_kept", test_bad_config_rejected_and_previous_kept},
    {"limits_accepted", test_limits_accepted},
    {"matches_twin_random_and_full_scale", test_matches_twin_random_and_full_scale},
    {"output_saturates_at_full_scale", test_output_saturates_at_full_scale},
    {"sign_held_when_delta_zero", test_sign_held_when_delta_zero},
    {"hysteresis_one_lsb_is_eq16", test_hysteresis_one_lsb_is_eq16},
    {"no_chatter_on_noisy_constant", test_no_chatter_on_noisy_constant},
    {"smooth_inverse_step_bound", test_smooth_inverse_step_bound},
    {"blend_saturates_at_branches", test_blend_saturates_at_branches},
    {"blend_weight_precision_every_band", test_blend_weight_precision_every_band},
    {"reconfigure_keeps_direction", test_reconfigure_keeps_direction},
    {"reconfigure_tables_follow_mu_phi", test_reconfigure_tables_follow_mu_phi},
    {"mode_none_passthrough", test_mode_none_passthrough},
    {"preview_blend_moves_in_time", test_preview_blend_moves_in_time},
    {"preview_matches_twin", test_preview_matches_twin},
};
const int comp_tests_count = (int)(sizeof comp_tests / sizeof comp_tests[0]);
