/* fxp.c - integer-only exponential and sine; see fxp.h for formats and error bounds. */
#include "fxp.h"

/* 1/ln2 in Q2.30 (1.4426950408889634, rounded). */
#define INV_LN2_Q30 INT64_C(1549082005)
/* ln2 in Q0.60 (0.6931471805599453094..., rounded): the reduction keeps 60 fraction bits so the
 * error of k*ln2 (|k| <= 8) stays below 2^-56. */
#define LN2_Q60 INT64_C(799144290325165979)
/* pi/2 in Q1.30. */
#define HALF_PI_Q30 INT64_C(1686629713)

/* Arithmetic right shift with rounding to nearest (ties away from -inf), for int64. */
static int64_t shr_round_i64(int64_t v, unsigned s)
{
    return (v + (INT64_C(1) << (s - 1U))) >> s;
}

/* One step of exp's Horner form: 1 + r*p/n in Q1.30, r*p/n rounded to nearest (C division
 * truncates toward zero). Inlined with a constant n. */
static inline int32_t exp_term(int32_t r, int32_t p, int32_t n)
{
    int32_t rp = (int32_t)shr_round_i64((int64_t)r * p, 30U); /* |r*p| < 0.53 */
    int32_t q = (rp >= 0) ? (rp + n / 2) / n : -((-rp + n / 2) / n);
    return (int32_t)Q1_30_ONE + q;
}

uq8_24_t fxp_exp_uq8_24(q3_28_t x)
{
    if (x > FXP_EXP_X_MAX_Q28) {
        x = FXP_EXP_X_MAX_Q28;
    } else if (x < -FXP_EXP_X_MAX_Q28) {
        x = -FXP_EXP_X_MAX_Q28;
    }
    /* k = round(x / ln2): Q3.28 * Q2.30 = Q5.58, |k| <= 8. */
    int32_t k = (int32_t)shr_round_i64((int64_t)x * INV_LN2_Q30, 58U);
    /* r = x - k*ln2 in Q3.60: x << 32 < 2^63, k*ln2 < 2^63. */
    int64_t r60 = ((int64_t)x * (INT64_C(1) << 32)) - (int64_t)k * LN2_Q60;
    int32_t r = (int32_t)shr_round_i64(r60, 30U); /* Q1.30, |r| <= 0.347 */
    /* exp(r) = 1 + r(1 + r/2(1 + r/3(... (1 + r/11)))) in Q1.30; p stays in [0.7, 1.5]. Written
     * out term by term so that each divisor is a constant: a compiler divides by a constant with
     * a multiply (Hacker's Delight, 2nd ed., ch. 10), where a CPU without a divide instruction
     * would otherwise call its 32-bit division routine eleven times. Same quotients, same bits. */
    int32_t p = (int32_t)Q1_30_ONE;
    p = exp_term(r, p, 11);
    p = exp_term(r, p, 10);
    p = exp_term(r, p, 9);
    p = exp_term(r, p, 8);
    p = exp_term(r, p, 7);
    p = exp_term(r, p, 6);
    p = exp_term(r, p, 5);
    p = exp_term(r, p, 4);
    p = exp_term(r, p, 3);
    p = exp_term(r, p, 2);
    p = exp_term(r, p, 1);
    /* exp(x) = exp(r) * 2^k; Q1.30 -> UQ8.24 is a right shift by 6, so shift by k - 6. */
    int32_t shift = k - 6;
    uint64_t g;
    if (shift >= 0) {
        g = (uint64_t)p << (unsigned)shift;
    } else {
        g = (uint64_t)shr_round_i64(p, (unsigned)(-shift));
    }
    return g > UINT32_MAX ? UINT32_MAX : (uq8_24_t)g;
}

/* Q1.30 constants of the atanh series: 1/3, 1/5, 1/7, 1/9 (rounded). */
#define LN_C3 357913941LL
#define LN_C5 214748365LL
#define LN_C7 153391689LL
#define LN_C9 119304647LL
#define LN2_Q40 762123384786LL /* round(ln 2 * 2^40) */
#define SQRT2_Q30 1518500250U  /* round(sqrt(2) * 2^30) */

q3_28_t fxp_ln_q28(uq8_24_t v)
{
    if (v == 0U) {
        return (q3_28_t)(-8L * Q3_28_ONE);
    }
    int32_t msb = 31;
    while ((v >> msb) == 0U) {
        --msb;
    }
    /* m in [1, 2) as mant / 2^30 (the bit below 2^-30 is dropped when msb = 31). */
    uint32_t mant = (msb <= 30) ? (v << (30 - msb)) : (v >> 1);
    int32_t k = msb - 24;
    /* m > sqrt 2: use m/2, z = (m - 2)/(m + 2); else z = (m - 1)/(m + 1). Exact integers. */
    int64_t c = INT64_C(1) << 30;
    if (mant > SQRT2_Q30) {
        c <<= 1;
        k += 1;
    }
    int64_t num = (int64_t)mant - c; /* |num| < 2^30 */
    int64_t den = (int64_t)mant + c; /* < 2^32 */
    int64_t az = (int64_t)fxp_div_uq8_24((uint64_t)((num < 0) ? -num : num) << 6,
                                         (uint64_t)den); /* |z| in Q1.30, <= 0.1716 */
    int64_t z2 = (az * az + (INT64_C(1) << 29)) >> 30;
    int64_t p = LN_C9;
    p = LN_C7 + ((z2 * p + (INT64_C(1) << 29)) >> 30);
    p = LN_C5 + ((z2 * p + (INT64_C(1) << 29)) >> 30);
    p = LN_C3 + ((z2 * p + (INT64_C(1) << 29)) >> 30);
    p = (INT64_C(1) << 30) + ((z2 * p + (INT64_C(1) << 29)) >> 30);
    /* ln m = 2 z p: Q1.30 * Q1.30 = Q2.60 (< 2^59), * 2 / 2^32 -> Q3.28. */
    int64_t lnm = (az * p + (INT64_C(1) << 30)) >> 31;
    if (num < 0) {
        lnm = -lnm;
    }
    int64_t r = (((int64_t)k * LN2_Q40 + (INT64_C(1) << 11)) >> 12) + lnm;
    if (r < -8LL * Q3_28_ONE) {
        r = -8LL * Q3_28_ONE;
    } else if (r > (int64_t)INT32_MAX) {
        r = INT32_MAX;
    }
    return (q3_28_t)r;
}

uint32_t fxp_expm1_x_uq6_26(q3_28_t x)
{
    if (x < 0) {
        x = 0;
    } else if (x > 4 * (q3_28_t)Q3_28_ONE) {
        x = 4 * (q3_28_t)Q3_28_ONE;
    }
    const uint32_t one = UINT32_C(1) << 26;
    uint32_t p = one;
    for (uint32_t k = 30; k >= 2U; --k) {
        /* x (Q3.28, <= 2^30) * p (UQ6.26, < 13.5 * 2^26) >> 28 = x*p in UQ6.26 (< 54 * 2^26). */
        uint32_t xp = (uint32_t)(((uint64_t)(uint32_t)x * p + (UINT64_C(1) << 27)) >> 28);
        p = one + (xp + k / 2U) / k;
    }
    return p;
}

uq8_24_t fxp_div_uq8_24(uint64_t num, uint64_t den)
{
    if (den == 0U || den >= (UINT64_C(1) << 62)) {
        return UINT32_MAX;
    }
    /* floor(num * 2^25 / den), one quotient bit per step; the remainder stays below den < 2^62,
     * so shifting it left never overflows. 89 steps: 64 bits of num, then 25 zero bits. */
    uint64_t q = 0U;
    uint64_t r = 0U;
    for (int i = 63 + 25; i >= 0; --i) {
        uint64_t bit = (i >= 25) ? (num >> (unsigned)(i - 25)) & 1U : 0U;
        r = (r << 1) | bit;
        q <<= 1;
        if (r >= den) {
            r -= den;
            q |= 1U;
        }
        if (q >= (UINT64_C(1) << 33)) {
            return UINT32_MAX; /* ratio >= 256 */
        }
    }
    q = (q + 1U) >> 1; /* round the 25th bit */
    return (q > UINT32_MAX) ? UINT32_MAX : (uq8_24_t)q;
}

/* sin(a) for a in [0, pi/2] in Q1.30: a(1 - a^2/6(1 - a^2/20(1 - ... (1 - a^2/156)))).
 * a^2 <= (pi/2)^2 = 2.467 does not fit Q1.30, so it is kept in Q2.29; each a^2*p/den <= 0.42 is
 * formed in 64 bits (a^2 * p < 2^61) and divided by multiplying with 1/den in Q1.30. Every operand
 * is >= 0 and below 2^32 (a <= pi/2 * 2^30, a^2 < 2^31, p <= 2^30, a^2*p >> 29 < 2.5 * 2^30,
 * 1/den < 2^28), so each product is an unsigned 32 x 32 -> 64 bit one, with the same values as
 * in signed 64-bit arithmetic.
 *
 * Each rounded product (x * y + 2^(s-1)) >> s is taken as the high word of x * y scaled by
 * 2^(32-s) (the operands pre-scaled so that both stay below 2^32), plus the bit below it (bit 31
 * of the low word): floor(P / 2^s) + bit s-1 of P is the rounded quotient. A high word and a
 * sign test instead of a 64-bit shift: the same bits, and on the UP5K's soft CPU (two-stage
 * shifter) the shifts by 29 to 31 and the carries were some 300 of the sine's 976 clocks. */
/* The unsigned twin of fxp_mul_hi_round_i32 (fxp.h): operands up to 2^32. */
static inline uint32_t mul_hi_round_u32(uint32_t x, uint32_t y)
{
    const uint64_t p = (uint64_t)x * y;
    return (uint32_t)(p >> 32) + (((int32_t)(uint32_t)p < 0) ? 1U : 0U);
}

/* 1/den in Q1.30 scaled by 4 (< 2^30 * 4 / 6 < 2^32): (x * inv + 2^29) >> 30 for any x < 2^32. */
#define INV_Q30_X4(den) ((uint32_t)((((UINT64_C(1) << 30) + (den) / 2U) / (den)) << 2))
_Static_assert(INV_Q30_X4(6U) == 178956971U * 4U && INV_Q30_X4(20U) == 53687091U * 4U &&
                   INV_Q30_X4(42U) == 25565282U * 4U && INV_Q30_X4(72U) == 14913081U * 4U &&
                   INV_Q30_X4(110U) == 9761289U * 4U && INV_Q30_X4(156U) == 6882960U * 4U,
               "the series' reciprocals, 2^30/den rounded");

/* One step of the series: 1 - a^2 * p / den. a2x2 = 2 a^2 (Q2.29 doubled, < 2^32), p <= 2^30;
 * a^2 * p rounded >> 29 is (2 a^2) * (4 p) >> 32 rounded, and 4 p wraps to 0 only at p = 2^30,
 * where a^2 * p >> 29 is 2 a^2 exactly. */
static inline uint32_t sin_step(uint32_t a2x2, uint32_t p, uint32_t inv_den_x4)
{
    const uint32_t p4 = p << 2;
    const uint32_t a2p = (p4 != 0U) ? mul_hi_round_u32(a2x2, p4) : a2x2; /* Q.30, < 2.5 * 2^30 */
    return Q1_30_ONE - mul_hi_round_u32(a2p, inv_den_x4);
}

static q1_30_t sin_quarter_q1_30(uint32_t ua)
{
    /* 0 <= a <= pi/2 * 2^30 < 2^31: 2a < 2^32. a^2 (Q2.29, rounded >> 31) = (2a * a) >> 32. */
    const uint32_t ua2 = ua << 1;
    const uint32_t a2x2 = mul_hi_round_u32(ua2, ua) << 1;
    /* The innermost step's p is 1: a^2 * 2^30 rounded >> 29 is 2 a^2 exactly. The steps written
     * out, each 1/den a constant (no table load, no loop). */
    uint32_t p = Q1_30_ONE - mul_hi_round_u32(a2x2, INV_Q30_X4(156U));
    p = sin_step(a2x2, p, INV_Q30_X4(110U));
    p = sin_step(a2x2, p, INV_Q30_X4(72U));
    p = sin_step(a2x2, p, INV_Q30_X4(42U));
    p = sin_step(a2x2, p, INV_Q30_X4(20U));
    p = sin_step(a2x2, p, INV_Q30_X4(6U));
    return (q1_30_t)mul_hi_round_u32(ua2, p << 1); /* (a * p + 2^29) >> 30, p <= 2^30 */
}

q1_30_t fxp_sin_q1_30(uint32_t phase)
{
    uint32_t quadrant = phase >> 30;
    uint32_t frac = phase & 0x3FFFFFFFUL; /* UQ0.30 of a quarter turn */
    if ((quadrant & 1U) != 0U) {
        frac = 0x40000000UL - frac; /* sin(pi - a) = sin(a); frac may reach exactly 2^30 */
    }
    /* a = frac * pi/2 rounded >> 30 = (2 frac) * (2 pi/2) >> 32 rounded: 2 frac <= 2^31. */
    const uint32_t a = mul_hi_round_u32(frac << 1, (uint32_t)(2 * HALF_PI_Q30)); /* a <= pi/2 */
    q1_30_t s = sin_quarter_q1_30(a);
    return (quadrant >= 2U) ? -s : s;
}

q1_30_t fxp_triangle_q1_30(uint32_t phase)
{
    uint32_t quadrant = phase >> 30;
    int32_t frac = (int32_t)(phase & 0x3FFFFFFFUL);
    int32_t v = ((quadrant & 1U) != 0U) ? (int32_t)Q1_30_ONE - frac : frac;
    return (quadrant >= 2U) ? -v : v;
}
