/*
 * bowden_q.h - the fixed-point types of the firmware, defined once.
 *
 * Notation: Qm.n is a two's complement word with m integer bits (sign excluded) and n fraction
 * bits, so its value is word / 2^n; UQm.n is the unsigned counterpart. Every fixed-point function
 * of the firmware names its formats with these types and states its scaling and overflow.
 */
#ifndef BOWDEN_Q_H
#define BOWDEN_Q_H

#include <stdint.h>

/* Q7.8 tension in newtons: LSB 1/256 N (3.9 mN), range -128 .. +127.996 N. The word on the bus
 * between processor and FPGA (T_c written to TC, T_in read back from T_IN), per the register map
 * (hdl/README.md). */
typedef int16_t q7_8_t;

/* Q7.8 held in 32 bits: the same scaling as q7_8_t with headroom for sums, differences and
 * configuration fields that must be able to hold out-of-range values so they can be rejected. */
typedef int32_t q7_8w_t;

/* Q3.12 motor current in amperes: LSB 1/4096 A, range -8 .. +7.9998 A (the FPGA's U register). */
typedef int16_t q3_12_t;

/* Q3.28 dimensionless coefficient or exponent (mu, mu*phi, friction slope in 1/N):
 * LSB 2^-28 = 3.7e-9, range -8 .. +8. */
typedef int32_t q3_28_t;

/* Q7.24 angle in radians (phi): LSB 2^-24 = 6.0e-8 rad, range -128 .. +128 rad. */
typedef int32_t q7_24_t;

/* UQ8.24 gain (exp(+-mu*phi)): LSB 2^-24 = 6.0e-8, range 0 .. 256. */
typedef uint32_t uq8_24_t;

/* Q1.30 dimensionless value in [-2, 2) used inside the exponential and the sine generator:
 * LSB 2^-30 = 9.3e-10. */
typedef int32_t q1_30_t;

/* UQ16.16 frequency in hertz: LSB 1/65536 Hz. */
typedef uint32_t uq16_16_t;

/* Conversions between a real value and its word, for documentation and host tests only. */
#define Q7_8_ONE 256
#define Q3_28_ONE (1L << 28)
#define Q7_24_ONE (1L << 24)
#define UQ8_24_ONE (1UL << 24)
#define Q1_30_ONE (1L << 30)

#define Q7_8_MAX INT16_MAX
#define Q7_8_MIN INT16_MIN

#endif /* BOWDEN_Q_H */
