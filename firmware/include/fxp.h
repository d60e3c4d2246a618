/*
 * fxp.h - integer-only elementary functions (no libm, no floating point): the exponential used to
 * compute the compensator's gains at configuration and the sine of the waveform generator.
 */
#ifndef BOWDEN_FXP_H
#define BOWDEN_FXP_H

#include "bowden_q.h"

/* Domain of fxp_exp_uq8_24: |x| <= 5.5 keeps exp(x) = 244.7 below the UQ8.24 ceiling of 256. */
#define FXP_EXP_X_MAX_Q28 ((q3_28_t)(5.5 * (1L << 28)))

/*
 * Error bound of fxp_exp_uq8_24 against the exact exponential, over the whole domain:
 *   |fxp_exp_uq8_24(x) / 2^24 - exp(x)| <= 2^-25 + FXP_EXP_ERR_REL_PPB * 1e-9 * exp(x),
 * half an LSB of UQ8.24 for the final rounding plus 2 parts per billion from the Q1.30 polynomial
 * (scaled up by 2^k for k > 6). Over the compensator's exponents [-4, 4] that is at most 2.4 LSB
 * = 1.4e-7 absolute. Checked on a grid of 720k points by the unit tests (measured: 1.0e-9
 * relative beyond the half LSB).
 */
#define FXP_EXP_ERR_REL_PPB 2

/*
 * exp(x) for x in Q3.28, returned in UQ8.24.
 * Scaling and overflow: x is clamped to [-5.5, +5.5] (Q3.28), so the result lies in
 * [exp(-5.5), exp(5.5)] = [0.0041, 244.7], inside UQ8.24 (< 256). Range reduction x = k*ln2 + r
 * with |r| <= ln2/2 is done in Q3.60 (int64, ln2 to 60 fraction bits), exp(r) by a degree-11
 * Horner polynomial in Q1.30 (truncation error < 1e-14), then scaled by 2^k with rounding.
 * Every intermediate fits its word: |r*p| < 2^61 in int64, each Horner term < 2^31.
 * Runs at configuration time only (about 150 instructions), never in the per-step path.
 */
uq8_24_t fxp_exp_uq8_24(q3_28_t x);

/*
 * (exp(x) - 1) / x for x in Q3.28, x in [0, 4] (1 at x = 0), returned in UQ6.26.
 * Scaling and overflow: x is clamped to [0, 4], so the result lies in [1, 13.4] (< 64); Horner
 * form 1 + x/2(1 + x/3(1 + ... x/30)), truncation error < 1e-15; each x*p/2^28 < 54 * 2^26 fits
 * uint32 before the 32-bit division by k; rounding error below 30 LSB of UQ6.26 (5e-7).
 * Configuration time only.
 */
uint32_t fxp_expm1_x_uq6_26(q3_28_t x);

/*
 * ln(v) for v in UQ8.24 (v > 0), in Q3.28, clamped to [-8, 8 - 2^-28] (0 gives -8).
 * v = m 2^k with m in [2^-1/2, 2^1/2); ln m = 2 atanh(z), z = (m - 1)/(m + 1), |z| <= 0.1716, by
 * its odd series to z^9 (truncation < 7e-10); z in Q1.30 by the long division; k ln 2 from ln 2
 * in Q.40. |error| <= 4 LSB of Q3.28 (unit test against libm over the whole range). Used by the
 * online estimate (fric_est_ln_q28) and, once a step, by the compensator's dead-zone inverse.
 */
q3_28_t fxp_ln_q28(uq8_24_t v);

/*
 * round(num / den) in UQ8.24, for 64-bit num and den with den in (0, 2^62): bit-serial long
 * division (no 64-bit divide instruction or run-time helper on the target). Saturates to
 * UINT32_MAX (255.99999994) when the ratio reaches 256 or den is 0. Configuration time only.
 */
uq8_24_t fxp_div_uq8_24(uint64_t num, uint64_t den);

/*
 * sin(2*pi*phase/2^32) in Q1.30, for a phase in turns as an unsigned 32-bit fraction (UQ0.32).
 * Scaling and overflow: quarter-wave symmetry maps the phase to a = [0, pi/2] in Q1.30 (pi/2 =
 * 1.5708 < 2); a degree-13 Taylor polynomial in Horner form with Q1.30 products (each < 2^61 in
 * int64) gives |error| < 4e-9 + rounding; the result is within [-2^30, 2^30].
 */
q1_30_t fxp_sin_q1_30(uint32_t phase);

/*
 * Triangle wave in Q1.30 with the phase convention of fxp_sin_q1_30: 0 at phase 0, +1 at a
 * quarter turn, 0 at half, -1 at three quarters. Exact (no rounding): |result| <= 2^30.
 */
q1_30_t fxp_triangle_q1_30(uint32_t phase);

/*
 * (x * y + 2^31) >> 32 (arithmetic): the high word of the 64-bit product, floor(x * y / 2^32),
 * plus the bit below it (bit 31 of the low word), the product rounded to the nearest. A high word
 * and a sign test instead of a 64-bit shift: on the UP5K's soft CPU (two-stage shifter) the
 * shifts and carries of a rounded >> 20 or >> 30 cost more than the product. A caller scales an
 * operand by 2^(32 - s) beforehand (within 32 bits) to round a product >> s.
 */
static inline int32_t fxp_mul_hi_round_i32(int32_t x, int32_t y)
{
    const int64_t p = (int64_t)x * y;
    return (int32_t)(p >> 32) + (((int32_t)(uint32_t)p < 0) ? 1 : 0);
}

#endif /* BOWDEN_FXP_H */
