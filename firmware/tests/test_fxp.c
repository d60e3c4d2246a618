/* test_fxp.c - unit tests of the integer exponential and waveform shapes against libm. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "fxp.h"
#include "unit.h"

#define PI_D 3.14159265358979323846

/* Error of fxp_exp_uq8_24 against the exact exp(x), on a dense grid over the whole domain. */
static void test_exp_error_bound(void)
{
    double worst_ratio = 0.0;
    double worst_abs = 0.0;
    double worst_x = 0.0;
    const int32_t step = 4099; /* odd step: about 720k points over [-5.5, 5.5] */
    for (int64_t xi = -FXP_EXP_X_MAX_Q28; xi <= FXP_EXP_X_MAX_Q28; xi += step) {
        double x = (double)xi / 268435456.0;
        double exact = exp(x) * 16777216.0; /* in LSB of UQ8.24 */
        double err = fabs((double)fxp_exp_uq8_24((q3_28_t)xi) - exact);
        double bound = 0.5 + FXP_EXP_ERR_REL_PPB * 1e-9 * exact;
        if (err / bound > worst_ratio) {
            worst_ratio = err / bound;
            worst_x = x;
        }
        if (fabs(x) <= 4.0 && err > worst_abs) {
            worst_abs = err;
        }
    }
    printf("  fxp_exp_uq8_24: worst error / documented bound = %.5f (at x = %.4f); "
           "max |error| over [-4, 4] = %.2f LSB = %.2e\n",
           worst_ratio, worst_x, worst_abs, worst_abs / 16777216.0);
    CHECK(worst_ratio <= 1.0, "error %.3f of the bound at x = %.9f", worst_ratio, worst_x);
}

/* Special points: exp(0) = 1 exactly, and the values the compensator's defaults use. */
static void test_exp_exact_points(void)
{
    CHECK(fxp_exp_uq8_24(0) == UQ8_24_ONE, "exp(0) = %lu", (unsigned long)fxp_exp_uq8_24(0));
    /* mu*phi of the paper: 0.075 * 2*pi = 0.4712: exp = 1.60199, exp(-) = 0.62422. */
    q3_28_t x = (q3_28_t)llround(0.075 * 2.0 * PI_D * 268435456.0);
    double up = fxp_exp_uq8_24(x) / 16777216.0;
    double dn = fxp_exp_uq8_24(-x) / 16777216.0;
    CHECK(fabs(up - exp(0.075 * 2.0 * PI_D)) < 1e-7, "up %.9f", up);
    CHECK(fabs(dn - exp(-0.075 * 2.0 * PI_D)) < 1e-7, "dn %.9f", dn);
}

/* The documented clamp of the domain to [-5.5, 5.5], driven to the int32 limits. */
static void test_exp_saturates_at_domain_ends(void)
{
    uq8_24_t hi = fxp_exp_uq8_24(FXP_EXP_X_MAX_Q28);
    uq8_24_t lo = fxp_exp_uq8_24(-FXP_EXP_X_MAX_Q28);
    CHECK(fxp_exp_uq8_24(INT32_MAX) == hi, "exp(INT32_MAX) %lu != exp(5.5) %lu",
          (unsigned long)fxp_exp_uq8_24(INT32_MAX), (unsigned long)hi);
    CHECK(fxp_exp_uq8_24(INT32_MIN) == lo, "exp(INT32_MIN) %lu", (unsigned long)lo);
    CHECK(fxp_exp_uq8_24(FXP_EXP_X_MAX_Q28 + 1) == hi, "just above the domain");
    CHECK(fabs(hi / 16777216.0 - exp(5.5)) < 2e-7 * exp(5.5), "exp(5.5) = %.6f", hi / 16777216.0);
    CHECK(hi < UINT32_MAX, "exp(5.5) stays below the UQ8.24 ceiling");
}

/* exp is monotonic in fixed point too (the gain tables rely on G_up >= G_dn). */
static void test_exp_monotonic(void)
{
    uq8_24_t prev = fxp_exp_uq8_24(-FXP_EXP_X_MAX_Q28);
    int bad = 0;
    for (int64_t xi = -FXP_EXP_X_MAX_Q28; xi <= FXP_EXP_X_MAX_Q28; xi += 65537) {
        uq8_24_t g = fxp_exp_uq8_24((q3_28_t)xi);
        bad += (g < prev);
        prev = g;
    }
    CHECK(bad == 0, "%d decreasing steps", bad);
}

static void test_sin_and_triangle(void)
{
    double worst = 0.0;
    for (uint64_t ph = 0; ph <= UINT32_MAX; ph += 65521) {
        double exact = sin(2.0 * PI_D * (double)ph / 4294967296.0);
        double err = fabs(fxp_sin_q1_30((uint32_t)ph) / 1073741824.0 - exact);
        worst = err > worst ? err : worst;
    }
    printf("  fxp_sin_q1_30: max |error| = %.2e\n", worst);
    CHECK(worst < 1e-8, "sin worst %.3e", worst);
    /* Full scale at the quarter turns: exactly +-1.0 within rounding, never beyond. */
    CHECK(abs(fxp_sin_q1_30(0x40000000UL) - (int32_t)Q1_30_ONE) <= 4, "sin(pi/2) = %ld",
          (long)fxp_sin_q1_30(0x40000000UL));
    CHECK(fxp_sin_q1_30(0x40000000UL) <= (int32_t)Q1_30_ONE, "sin(pi/2) <= 1");
    CHECK(fxp_sin_q1_30(0xC0000000UL) >= -(int32_t)Q1_30_ONE, "sin(3pi/2) >= -1");
    CHECK(fxp_sin_q1_30(0) == 0, "sin(0)");
    CHECK(fxp_triangle_q1_30(0x40000000UL) == (int32_t)Q1_30_ONE, "tri peak");
    CHECK(fxp_triangle_q1_30(0xC0000000UL) == -(int32_t)Q1_30_ONE, "tri trough");
    CHECK(fxp_triangle_q1_30(0x20000000UL) == (int32_t)Q1_30_ONE / 2, "tri eighth");
    CHECK(fxp_triangle_q1_30(0x80000000UL) == 0, "tri half");
}

/* (e^x - 1)/x in UQ6.26 over [0, 4], its clamps at both ends of the domain, and the error claim. */
static void test_expm1_x(void)
{
    double worst = 0.0;
    for (int64_t xi = 0; xi <= 4 * (int64_t)Q3_28_ONE; xi += 1048573) {
        double x = (double)xi / 268435456.0;
        double exact = (xi == 0) ? 1.0 : expm1(x) / x;
        double err = fabs(fxp_expm1_x_uq6_26((q3_28_t)xi) / 67108864.0 - exact) * 67108864.0;
        worst = err > worst ? err : worst;
    }
    printf("  fxp_expm1_x_uq6_26: max |error| = %.1f LSB of UQ6.26\n", worst);
    CHECK(worst <= 30.0, "worst %.1f LSB", worst);
    CHECK(fxp_expm1_x_uq6_26(0) == (1U << 26), "f(0) = 1 exactly");
    CHECK(fxp_expm1_x_uq6_26(-5) == (1U << 26) && fxp_expm1_x_uq6_26(INT32_MIN) == (1U << 26),
          "clamped below 0");
    CHECK(fxp_expm1_x_uq6_26(INT32_MAX) == fxp_expm1_x_uq6_26(4 * (q3_28_t)Q3_28_ONE),
          "clamped above 4");
}

/* The long division against exact ratios, its rounding, and its saturation at 256 and den = 0. */
static void test_div_uq8_24(void)
{
    uint32_t rng = 12345U;
    int bad = 0;
    for (int i = 0; i < 200000; ++i) {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        uint64_t den = ((uint64_t)rng << 22) | (rng & 0x3FFFFFU); /* up to 2^54 */
        den = den ? den : 1U;
        uint64_t num = den * (rng % 250U) + (den >> (rng % 7U));
        double exact = (double)num / (double)den * 16777216.0;
        bad += fabs((double)fxp_div_uq8_24(num, den) - exact) > 0.5 + exact * 1e-15 + 1e-9;
    }
    CHECK(bad == 0, "%d ratios off by more than half an LSB", bad);
    CHECK(fxp_div_uq8_24(3, 2) == 25165824U, "1.5");
    CHECK(fxp_div_uq8_24(1, 3) == 5592405U, "1/3 rounds down");
    CHECK(fxp_div_uq8_24(2, 3) == 11184811U, "2/3 rounds up");
    CHECK(fxp_div_uq8_24(256, 1) == UINT32_MAX, "ratio 256 saturates");
    CHECK(fxp_div_uq8_24(UINT64_MAX, 3) == UINT32_MAX, "huge ratio saturates");
    CHECK(fxp_div_uq8_24(255, 1) == 255U << 24, "ratio 255 fits");
    CHECK(fxp_div_uq8_24(5, 0) == UINT32_MAX, "den = 0 saturates");
    CHECK(fxp_div_uq8_24((UINT64_C(1) << 61) * 3, UINT64_C(1) << 61) == 3U << 24, "large operands");
}

/* The sine's series as first written, every rounded product a 64-bit shift: (x * y + 2^(s-1)) >>
 * s. fxp.c forms the same products from high words (cheaper on the soft CPU); the outputs must
 * stay these, bit for bit (the telemetry and the T_c words depend on them). */
static uint32_t ref_mul_shr_round(uint32_t x, uint32_t y, unsigned s)
{
    return (uint32_t)(((uint64_t)x * y + (UINT64_C(1) << (s - 1U))) >> s);
}

static int32_t ref_sin_q1_30(uint32_t phase)
{
    static const uint32_t inv[5] = {9761289U, 14913081U, 25565282U, 53687091U, 178956971U};
    const uint32_t quadrant = phase >> 30;
    uint32_t frac = phase & 0x3FFFFFFFUL;
    if ((quadrant & 1U) != 0U) {
        frac = 0x40000000UL - frac;
    }
    const uint32_t a = ref_mul_shr_round(frac, 1686629713U, 30U);
    const uint32_t a2 = ref_mul_shr_round(a, a, 31U);
    uint32_t p = Q1_30_ONE - ref_mul_shr_round(2U * a2, 6882960U, 30U);
    for (uint32_t k = 0; k < 5U; ++k) {
        p = Q1_30_ONE - ref_mul_shr_round(ref_mul_shr_round(a2, p, 29U), inv[k], 30U);
    }
    const int32_t s = (int32_t)ref_mul_shr_round(a, p, 30U);
    return (quadrant >= 2U) ? -s : s;
}

static void test_sin_bit_for_bit(void)
{
    uint32_t bad = 0U, n = 0U;
    for (uint64_t ph = 0; ph <= UINT32_MAX; ph += 4093U) { /* a prime stride: every residue */
        bad += fxp_sin_q1_30((uint32_t)ph) != ref_sin_q1_30((uint32_t)ph);
        ++n;
    }
    for (uint32_t q = 0; q < 4U; ++q) { /* around each quarter turn, where p reaches 1 */
        for (int32_t d = -5000; d <= 5000; ++d) {
            const uint32_t ph = (q << 30) + (uint32_t)d;
            bad += fxp_sin_q1_30(ph) != ref_sin_q1_30(ph);
            ++n;
        }
    }
    CHECK(bad == 0U, "%u of %u phases differ from the 64-bit-shift series", bad, n);
}

const unit_test_t fxp_tests[] = {
    {"expm1_x", test_expm1_x},
    {"div_uq8_24", test_div_uq8_24},
    {"exp_error_bound", test_exp_error_bound},
    {"exp_exact_points", test_exp_exact_points},
    {"exp_saturates_at_domain_ends", test_exp_saturates_at_domain_ends},
    {"exp_monotonic", test_exp_monotonic},
    {"sin_and_triangle", test_sin_and_triangle},
    {"sin_bit_for_bit", test_sin_bit_for_bit},
};
const int fxp_tests_count = (int)(sizeof fxp_tests / sizeof fxp_tests[0]);
