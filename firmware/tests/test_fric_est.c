/*
 * test_fric_est.c - the online friction estimate (fric_est.h) against a capstan plant with its
 * dead zone (Jeong & Cho 2015, Eq. 1-3), its double twin and its faults; and the combined loop
 * (estimate -> compensator -> tension loop -> plant) for the stability argument of
 * firmware/README.md, "Online friction estimate".
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "bowden_regs.h"
#include "comp.h"
#include "fric_est.h"
#include "fric_est_f64.h"
#include "fw.h"
#include "fxp.h"
#include "hal.h"
#include "unit.h"

#define PI_D 3.14159265358979323846
#define X0 (0.075 * 2.0 * PI_D) /* the paper's mu * phi with loop routing */
#define Q28 268435456.0
/* Tolerance of the converged estimate in these noise-free runs: 1 % of mu*phi. */
#define CONV_TOL_REL 0.01

/* Capstan plant: T_out holds inside [T_in e^-x, T_in e^x] (dead zone), else slides onto the
 * nearer branch. Sensor: T_out * gain + offset, quantized to Q7.8 (round half up). */
typedef struct {
    double x;      /* the plant's mu*phi */
    double t_out;  /* true far-end tension, N */
    double offset; /* far-end sensor offset, N */
    double gain;   /* far-end sensor scale */
} plant_t;

static void plant_step(plant_t *p, double t_in)
{
    double lo = t_in * exp(-p->x);
    double hi = t_in * exp(p->x);
    if (p->t_out < lo) {
        p->t_out = lo; /* loading: T_out = T_in e^-x */
    } else if (p->t_out > hi) {
        p->t_out = hi; /* unloading: T_out = T_in e^x */
    }
}

static int32_t q8(double v)
{
    return (int32_t)floor(v * 256.0 + 0.5);
}

/* fig14's reference: 2 .. 15 N at 0.5 Hz after a 0.5 s raised-cosine ease-in (1 kHz ticks). */
static double fig14_n(int32_t k)
{
    double t = (double)k / 1000.0;
    double a = (t < 0.5) ? t / 0.5 : 1.0;
    double ease = 0.5 - 0.5 * cos(PI_D * a);
    return (8.5 - 6.5 * cos(2.0 * PI_D * 0.5 * t)) * ease;
}

/* Code of a tension with the default conversion (ADC gain 2048: 512 codes per Q7.8 LSB). */
static int32_t code_of(int32_t t_q8)
{
    return t_q8 * 512;
}

#define CODE_MIN (-8388607)
#define CODE_MAX 8388606

static fric_est_config_t on_config(void)
{
    fric_est_config_t c;
    fric_est_config_default(&c);
    c.enable = 1;
    return c;
}

/* Runs fig14's T_in for `ticks` against a plant of exponent x_plant from the estimate at X0;
 * returns the final estimate and checks it against the twin at every tick. */
static double run_open(const fric_est_config_t *cfg, plant_t *p, int32_t ticks, uint32_t *faults,
                       double *max_err_lsb)
{
    fric_est_t e;
    fric_est_f64_t f;
    q3_28_t x0 = (q3_28_t)floor(X0 * Q28 + 0.5);
    fric_est_configure(&e, cfg, x0);
    fric_est_f64_configure(&f, cfg, (double)x0 / Q28);
    double worst = 0.0;
    for (int32_t k = 0; k < ticks; ++k) {
        int32_t tin = q8(fig14_n(k));
        plant_step(p, (double)tin / 256.0);
        int32_t tout = q8(p->t_out * p->gain + p->offset);
        q3_28_t x = fric_est_step(&e, tin, tout, code_of(tout), CODE_MIN, CODE_MAX, 0U);
        double xf = fric_est_f64_step(&f, tin, tout, code_of(tout), CODE_MIN, CODE_MAX, 0U);
        double d = fabs((double)x - xf * Q28);
        if (d > worst) {
            worst = d;
        }
    }
    *faults = e.g.faults | (f.g.faults << 8);
    if (max_err_lsb != 0) {
        *max_err_lsb = worst;
    }
    return (double)e.x / Q28;
}

static void test_ln_accuracy(void)
{
    double worst = 0.0;
    uint32_t v = 1U;
    int32_t n = 0;
    /* Every power of two and a geometric grid of ratio ~1.0001 over (0, 256) in UQ8.24. */
    for (double r = 1.0; r < 4294967295.0; r *= 1.0001, ++n) {
        v = (uint32_t)r;
        double exact = log((double)v / 16777216.0);
        if (exact < -8.0) {
            continue;
        }
        double got = (double)fric_est_ln_q28(v);
        double d = fabs(got - exact * Q28);
        if (d > worst) {
            worst = d;
        }
    }
    CHECK(worst <= 4.0, "ln: %.2f LSB of Q3.28 worst over %d points (bound 4)", worst, n);
    CHECK(fric_est_ln_q28(1U << 24) == 0, "ln(1) = %ld", (long)fric_est_ln_q28(1U << 24));
    CHECK(fric_est_ln_q28(0U) == (q3_28_t)(-8L * Q3_28_ONE), "ln(0) clamps to -8");
    CHECK(fric_est_ln_q28(0xFFFFFFFFU) > (q3_28_t)(5.545 * Q28), "ln(256-) = 5.545");
}

static void test_converges_off_calibration(void)
{
    /* The plant's mu 20 % below and above the calibration, and at it. */
    const double rel[] = {0.8, 1.0, 1.2};
    fric_est_config_t cfg = on_config();
    for (int32_t i = 0; i < 3; ++i) {
        plant_t p = {X0 * rel[i], 0.0, 0.0, 1.0};
        uint32_t faults = 0;
        double worst = 0.0;
        double x = run_open(&cfg, &p, 6000, &faults, &worst);
        CHECK(fabs(x - p.x) <= CONV_TOL_REL * p.x, "plant x %.4f: estimate %.4f after 6 s", p.x, x);
        CHECK(faults == 0U, "plant x %.4f: faults 0x%x", p.x, faults);
        CHECK(worst <= FE_ERR_BOUND_LSB, "plant x %.4f: fixed vs twin %.1f LSB (bound %d)", p.x,
              worst, FE_ERR_BOUND_LSB);
    }
}

static void test_offset_does_not_bias(void)
{
    /* A 0.5 N offset on the far-end sensor (the paper's Fig. 11 rollers): every increment is the
     * same, so the estimate is the same word for word. */
    fric_est_config_t cfg = on_config();
    plant_t a = {X0 * 1.2, 0.0, 0.0, 1.0};
    plant_t b = {X0 * 1.2, 0.0, 0.5, 1.0};
    uint32_t fa = 0;
    uint32_t fb = 0;
    double xa = run_open(&cfg, &a, 6000, &fa, 0);
    double xb = run_open(&cfg, &b, 6000, &fb, 0);
    /* The only samples that differ are those the t_min gate admits during the ease-in. */
    CHECK(fabs(xa - xb) <= 1e-5, "offset 0.5 N moved the estimate: %.9f vs %.9f", xb, xa);
    CHECK(fabs(xb - b.x) <= CONV_TOL_REL * b.x, "with offset: %.4f vs %.4f", xb, b.x);
    CHECK(fa == 0U && fb == 0U, "faults 0x%x 0x%x", fa, fb);
}

static void test_scale_error_cancels(void)
{
    /* A far-end scale error of 5 %: the two branches' logs shift by -ln g and +ln g. */
    fric_est_config_t cfg = on_config();
    plant_t p = {X0, 0.0, 0.0, 1.05};
    uint32_t faults = 0;
    double x = run_open(&cfg, &p, 8000, &faults, 0);
    CHECK(fabs(x - p.x) <= 2.0 * CONV_TOL_REL * p.x, "scale 1.05: %.4f vs %.4f", x, p.x);
    CHECK(faults == 0U, "faults 0x%x", faults);
}

static void test_twin_budget_over_configs(void)
{
    /* Fixed point against the twin: time constants 16 .. 32768, plants x 0.2 .. 2. */
    const int32_t taus[] = {16, 64, 256, 4096, 32768};
    const double xs[] = {0.2, 0.47, 1.0, 1.9};
    double worst_all = 0.0;
    for (int32_t i = 0; i < 5; ++i) {
        for (int32_t j = 0; j < 4; ++j) {
            fric_est_config_t cfg = on_config();
            cfg.tau_ticks = taus[i];
            cfg.rate_q28 = (q3_28_t)(Q3_28_ONE / 64);
            plant_t p = {xs[j], 0.0, 0.0, 1.0};
            uint32_t faults = 0;
            double worst = 0.0;
            (void)run_open(&cfg, &p, 5000, &faults, &worst);
            CHECK(faults == 0U, "tau %d x %.2f: faults 0x%x", taus[i], xs[j], faults);
            if (worst > worst_all) {
                worst_all = worst;
            }
        }
    }
    CHECK(worst_all <= FE_ERR_BOUND_LSB, "fixed vs twin %.1f LSB (bound %d)", worst_all,
          FE_ERR_BOUND_LSB);
    printf("  fric_est: fixed vs double twin, worst %.1f LSB of Q3.28 over 20 configurations\n",
           worst_all);
}

/* A run that goes bad at tick k_fault in the way `kind` says; checks freeze and flag. */
static void fault_case(int32_t kind, uint32_t want)
{
    fric_est_config_t cfg = on_config();
    fric_est_t e;
    q3_28_t x0 = (q3_28_t)floor(X0 * Q28 + 0.5);
    fric_est_configure(&e, &cfg, x0);
    plant_t p = {X0 * 1.2, 0.0, 0.0, 1.0};
    const int32_t k_fault = 2500;
    int32_t held_code = 0;
    q3_28_t x_at_fault = 0;
    int32_t k_flag = -1;
    int32_t moved_after = 0;
    for (int32_t k = 0; k < 6000; ++k) {
        int32_t tin = q8(fig14_n(k));
        plant_step(&p, (double)tin / 256.0);
        int32_t tout = q8(p.t_out);
        int32_t code = code_of(tout);
        uint32_t flags = 0U;
        if (k == k_fault) {
            x_at_fault = e.x;
            held_code = code;
        }
        if (k >= k_fault) {
            if (kind == 0) {
                flags = 0x2U; /* CRC error of the front-end */
            } else if (kind == 1) {
                code = CODE_MAX + 1; /* an absent cell: its channel at the rail */
                tout = (int32_t)(((int64_t)code * 2048 + (1 << 19)) >> 20);
            } else if (kind == 2) {
                code = held_code; /* stuck */
                tout = held_code / 512;
            } else {
                tout = 0; /* (kind 3 uses its own plant below) */
            }
        }
        q3_28_t x = fric_est_step(&e, tin, tout, code, CODE_MIN, CODE_MAX, flags);
        if (k_flag < 0 && (e.g.faults & want) != 0U) {
            k_flag = k;
            x_at_fault = x;
        }
        if (k_flag >= 0 && x != x_at_fault) {
            moved_after = 1;
        }
    }
    CHECK(e.g.faults == want, "kind %d: faults 0x%x, want 0x%x", kind, e.g.faults, want);
    CHECK(k_flag >= k_fault, "kind %d: flagged at %d before the fault at %d", kind, k_flag,
          k_fault);
    /* ADC flags and range are seen at once; a stuck code once T_in leaves the band (well within
     * one half period of fig14, 1 s). */
    CHECK(k_flag >= 0 && k_flag - k_fault <= ((kind == 2) ? 1000 : 0), "kind %d: flagged %d ticks "
          "after the fault", kind, k_flag - k_fault);
    CHECK(moved_after == 0, "kind %d: the estimate moved after the flag", kind);
}

static void test_faults_freeze_and_flag(void)
{
    fault_case(0, FE_FAULT_ADC);
    fault_case(1, FE_FAULT_RANGE);
    fault_case(2, FE_FAULT_STUCK);
}

static void test_bound_fault(void)
{
    /* A plant far beyond the upper bound: the estimate stops inside it and says so. */
    fric_est_config_t cfg = on_config();
    cfg.mu_phi_max_q28 = (q3_28_t)(0.6 * Q28);
    plant_t p = {0.9, 0.0, 0.0, 1.0};
    uint32_t faults = 0;
    double x = run_open(&cfg, &p, 6000, &faults, 0);
    CHECK((faults & 0xFFU) == FE_FAULT_BOUND, "faults 0x%x", faults);
    CHECK(x <= 0.6 && x >= 0.05, "estimate %.4f outside the bounds", x);
}

static void test_no_update_in_dead_zone_or_slack(void)
{
    /* A constant T_in and a slack cable give no sample; nor does T_in swinging inside the dead
     * zone (T_out held): the estimate stays at its start value. */
    fric_est_config_t cfg = on_config();
    fric_est_t e;
    fric_est_configure(&e, &cfg, (q3_28_t)(0.3 * Q28));
    int32_t accepted = 0;
    for (int32_t k = 0; k < 4000; ++k) {
        int32_t tin = q8(8.0 + 1.0 * sin(2.0 * PI_D * (double)k / 1000.0)); /* 7 .. 9 N */
        int32_t tout = q8(8.0);                                              /* held */
        (void)fric_est_step(&e, tin, tout, code_of(tout) + (k & 1), CODE_MIN, CODE_MAX, 0U);
        accepted += e.g.accepted;
    }
    CHECK(accepted == 0, "%d samples accepted inside the dead zone", accepted);
    CHECK(e.x == (q3_28_t)(0.3 * Q28) && e.g.faults == 0U, "x %ld faults 0x%x", (long)e.x,
          e.g.faults);
    fric_est_reset(&e, (q3_28_t)(0.3 * Q28));
    for (int32_t k = 0; k < 4000; ++k) {
        int32_t tin = q8(0.4 * (1.0 - cos(2.0 * PI_D * (double)k / 1000.0)) / 2.0); /* < t_min */
        (void)fric_est_step(&e, tin, tin / 2, code_of(tin / 2), CODE_MIN, CODE_MAX, 0U);
        accepted += e.g.accepted;
    }
    CHECK(accepted == 0, "%d samples accepted below t_min", accepted);
}

static void test_full_scale_inputs(void)
{
    /* Full-scale squares and random words on both cells (also under UBSan/ASan): the estimate
     * stays in its bounds or a fault freezes it. */
    fric_est_config_t cfg = on_config();
    cfg.tau_ticks = 16;
    cfg.rate_q28 = (q3_28_t)(Q3_28_ONE / 16);
    cfg.mu_phi_min_q28 = 0;
    cfg.mu_phi_max_q28 = FE_X_MAX_Q28;
    cfg.t_min_n_q8 = 0;
    fric_est_t e;
    fric_est_configure(&e, &cfg, (q3_28_t)(1.0 * Q28));
    uint32_t s = 12345U;
    for (int32_t k = 0; k < 200000; ++k) {
        s = s * 1664525U + 1013904223U;
        int32_t tin = (k & 64) ? INT16_MAX : 0;
        int32_t tout = (k & 64) ? INT16_MAX : 0;
        if (k > 100000) {
            tin = (int32_t)(int16_t)(s >> 16);
            tout = (int32_t)(int16_t)(s & 0xFFFFU);
        }
        q3_28_t x = fric_est_step(&e, tin, tout, code_of(tout) / 2, CODE_MIN, CODE_MAX, 0U);
        CHECK(x >= 0 && x <= FE_X_MAX_Q28, "tick %d: x %ld", k, (long)x);
        if (x < 0 || x > FE_X_MAX_Q28) {
            break;
        }
    }
    /* Out-of-Q7.8 tensions are a range fault, not a wrap. */
    fric_est_reset(&e, (q3_28_t)(1.0 * Q28));
    (void)fric_est_step(&e, 100, 40000, 0, CODE_MIN, CODE_MAX, 0U);
    CHECK(e.g.faults == FE_FAULT_RANGE, "T_out 156 N: faults 0x%x", e.g.faults);
}

static void test_config_check(void)
{
    q3_28_t x0 = (q3_28_t)floor(X0 * Q28 + 0.5);
    fric_est_config_t c;
    fric_est_config_default(&c);
    CHECK(c.enable == 0, "off by default");
    CHECK(fric_est_config_check(&c, x0, 0) == FE_OK, "defaults valid");
    CHECK(fric_est_config_check(0, x0, 0) == FE_ERR_NULL, "null");
    c.enable = 2;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_ENABLE, "enable 2");
    c = on_config();
    c.tau_ticks = 100;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_TAU, "tau 100");
    c.tau_ticks = 8;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_TAU, "tau 8");
    c.tau_ticks = 65536;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_TAU, "tau 65536");
    c.tau_ticks = 32768;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_OK, "tau 32768");
    c = on_config();
    c.rate_q28 = -1;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_RATE, "rate < 0");
    c.rate_q28 = (q3_28_t)(Q3_28_ONE / 16) + 1;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_RATE, "rate > 1/16");
    c = on_config();
    c.mu_phi_min_q28 = c.mu_phi_max_q28;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_BOUNDS, "min = max");
    c = on_config();
    c.mu_phi_max_q28 = FE_X_MAX_Q28 + 1;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_BOUNDS, "max > 4");
    c = on_config();
    c.mu_phi_min_q28 = -1;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_BOUNDS, "min < 0");
    c = on_config();
    c.mu_phi_max_q28 = x0 - 1;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_BOUNDS, "start above max");
    c.enable = 0;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_OK, "off: the start value is not checked");
    c = on_config();
    c.t_min_n_q8 = FE_TMIN_MAX_Q8 + 1;
    CHECK(fric_est_config_check(&c, x0, 0) == FE_ERR_T_MIN, "t_min 64+ N");
    c = on_config();
    CHECK(fric_est_config_check(&c, x0, 1) == FE_ERR_SLOPE, "slope with the estimate on");
}

/*
 * The combined loop: fig14's T_ref -> compensator (paper mode, gains exp(+-x_hat)) -> tension loop
 * (first order, bandwidth f_bw) -> capstan plant -> estimate -> compensator. The estimate's
 * measurement depends on the plant, not on T_c (the ratio of increments on a sliding branch is
 * E whatever drives it), so the cascade has no loop through x_hat at low frequency; the coupling
 * left is the tension loop's lag, which a time constant tau much longer than 1/(2 pi f_bw) makes
 * negligible. Held here, with a tension loop of 20 Hz (time constant 8 ticks) and a fast rate
 * bound (2^-8 per tick, so that tau sets the pace): for tau from 64 to 4096 samples the estimate
 * converges to the plant's x within 1 % and never passes it by more than 5 % (the excursion is
 * the first, low-tension samples of the ease-in); at tau = 16, two loop time constants, it is
 * still bounded and converges within 2 %, passing by up to 10 % (the noise of a short memory).
 */
static void test_combined_loop_stable(void)
{
    const int32_t taus[] = {16, 64, 256, 1024, 4096};
    const double f_bw = 20.0; /* Hz: slower than the FPGA loop's (hdl/README.md) */
    const double a = 1.0 - exp(-2.0 * PI_D * f_bw / 1000.0);
    for (int32_t i = 0; i < 5; ++i) {
        for (int32_t sgn = -1; sgn <= 1; sgn += 2) {
            fric_est_config_t cfg = on_config();
            cfg.tau_ticks = taus[i];
            cfg.rate_q28 = (q3_28_t)(Q3_28_ONE / 256); /* fast: let tau set the pace */
            comp_t c;
            comp_init(&c);
            fric_est_t e;
            q3_28_t x0 = (q3_28_t)comp_config_exponent_q28(&c.cfg);
            fric_est_configure(&e, &cfg, x0);
            plant_t p = {X0 * (1.0 + 0.2 * sgn), 0.0, 0.0, 1.0};
            double tin = 0.0;
            double over = 0.0;
            int32_t ticks = 8000 + 6 * taus[i];
            for (int32_t k = 0; k < ticks; ++k) {
                int32_t tc = comp_step_q7_8(&c, (q7_8_t)q8(fig14_n(k)));
                tin += a * ((double)tc / 256.0 - tin);
                plant_step(&p, tin);
                int32_t tout = q8(p.t_out);
                q3_28_t x = fric_est_step(&e, q8(tin), tout, code_of(tout), CODE_MIN, CODE_MAX,
                                          0U);
                (void)comp_set_exponent_q28(&c, x);
                double rel = ((double)x / Q28 - p.x) / p.x * (double)sgn;
                if (rel > over) {
                    over = rel;
                }
            }
            double x = (double)e.x / Q28;
            CHECK(e.g.faults == 0U, "tau %d: faults 0x%x", taus[i], e.g.faults);
            double tol = (taus[i] < 64) ? 2.0 * CONV_TOL_REL : CONV_TOL_REL;
            double over_max = (taus[i] < 64) ? 0.10 : 0.05;
            CHECK(fabs(x - p.x) <= tol * p.x, "tau %d plant %.4f: estimate %.4f", taus[i], p.x, x);
            CHECK(over <= over_max, "tau %d plant %.4f: passes it by %.2f %%", taus[i], p.x,
                  100 * over);
        }
    }
}

/*
 * fw_tick with the estimate on: it reads T_OUT (raw code, converted with the loop's ADC words)
 * and ADC_FLAGS, and the compensator's gain follows the estimate; off (the default), the tick
 * keeps the configured mu*phi whatever T_OUT reads.
 */
static void test_fw_tick_feeds_compensator(void)
{
    for (int32_t on = 0; on <= 1; ++on) {
        static hal_shadow_t s;
        hal_t h;
        fw_t fw;
        hal_init_shadow(&h, &s);
        fw_init(&fw, &h);
        fw_config_t cfg;
        fw_config_default(&cfg);
        cfg.est.enable = on;
        CHECK(fw_configure(&fw, &cfg) == FW_OK, "configure, estimate %d", on);
        fw_start(&fw);
        q3_28_t x0 = (q3_28_t)comp_config_exponent_q28(&cfg.comp);
        plant_t p = {X0 * 1.2, 0.0, 0.0, 1.0};
        int32_t tc = 0;
        int32_t tref = 0;
        for (int32_t k = 0; k < 6000; ++k) {
            int32_t tin = q8(fig14_n(k));
            plant_step(&p, (double)tin / 256.0);
            int32_t code = code_of(q8(p.t_out));
            hal_shadow_set(&s, BOWDEN_REG_T_IN, (uint32_t)tin);
            hal_shadow_set(&s, BOWDEN_REG_T_OUT, (uint32_t)code & BOWDEN_T_OUT_MASK);
            hal_shadow_set(&s, BOWDEN_REG_ADC_FLAGS, 0U);
            tref = q8(fig14_n(k));
            tc = fw_tick(&fw, (q7_8_t)tref);
            hal_write_t w[HAL_LOG_CAPACITY];
            (void)hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
        }
        double x = (double)fw.tel.est_mu_phi_q28 / Q28;
        if (on != 0) {
            CHECK(fabs(x - p.x) <= CONV_TOL_REL * p.x, "fw: estimate %.4f, plant %.4f", x, p.x);
            CHECK(fw.tel.est_faults == 0U, "fw: faults 0x%x", fw.tel.est_faults);
            CHECK(fw.tel.t_out == code_of(q8(p.t_out)) / 512, "fw: T_out %d", fw.tel.t_out);
        } else {
            CHECK(fw.tel.est_mu_phi_q28 == x0, "fw off: mu*phi moved to %.4f", x);
        }
        /* Paper mode (the default): T_c = T_ref e^(+-x) of the estimate, within the 1 LSB of the
         * compensator's bound plus the gain's rounding. */
        double g = exp((double)comp_direction(&fw.comp) * (double)fw.tel.est_mu_phi_q28 / Q28);
        CHECK(fabs((double)tc - (double)tref * g) <= 1.0, "fw: T_c %d vs T_ref e^x %.2f", tc,
              (double)tref * g);
        /* A start forgets the estimate: the tables hold mu*phi again. */
        fw_start(&fw);
        CHECK(fw.est_applied_q28 == x0 && fw.est.x == x0, "fw_start: estimate not reset");
        CHECK(fw.comp.g_up[0] == fxp_exp_uq8_24(x0), "fw_start: the gain table kept the estimate");
    }
}

const unit_test_t fric_est_tests[] = {
    {"fric_est_fw_tick_feeds_compensator", test_fw_tick_feeds_compensator},
    {"fric_est_ln_accuracy", test_ln_accuracy},
    {"fric_est_converges_off_calibration", test_converges_off_calibration},
    {"fric_est_offset_does_not_bias", test_offset_does_not_bias},
    {"fric_est_scale_error_cancels", test_scale_error_cancels},
    {"fric_est_twin_budget_over_configs", test_twin_budget_over_configs},
    {"fric_est_faults_freeze_and_flag", test_faults_freeze_and_flag},
    {"fric_est_bound_fault", test_bound_fault},
    {"fric_est_no_update_in_dead_zone_or_slack", test_no_update_in_dead_zone_or_slack},
    {"fric_est_full_scale_inputs", test_full_scale_inputs},
    {"fric_est_config_check", test_config_check},
    {"fric_est_combined_loop_stable", test_combined_loop_stable},
};
const int fric_est_tests_count = (int)(sizeof fric_est_tests / sizeof fric_est_tests[0]);
