/*
 * wave.h - fixed-point reference generator for the tick: constant, sine, triangle, ramp or step
 * T_ref.
 * No libm: the sine is fxp_sin_q1_30. The phase is a 32-bit turn counter advanced once per tick.
 *   T_ref[k] = sat_Q7.8( mean + amplitude * shape(phase0 + k * inc) ),  inc = freq / rate * 2^32
 * Phase increment: floor(freq_q16 * 2^16 / rate), so the frequency error is below
 * rate / 2^32 Hz (2.3e-7 Hz at 1 kHz) and the waveform repeats exactly after 2^32 / gcd ticks.
 */
#ifndef BOWDEN_WAVE_H
#define BOWDEN_WAVE_H

#include "bowden_q.h"

#define WAVE_CONSTANT 0
#define WAVE_SINE 1
#define WAVE_TRIANGLE 2
#define WAVE_RAMP 3 /* sawtooth: rises from the mean to mean + amplitude, jumps to mean - amplitude */
#define WAVE_STEP 4 /* square: mean + amplitude for the first half period, then mean - amplitude */

/* Status codes (0 is success), numbered apart from COMP_ERR_* so one code names one field. */
#define WAVE_OK 0
#define WAVE_ERR_NULL 20
#define WAVE_ERR_KIND 21      /* kind not CONSTANT, SINE, TRIANGLE, RAMP or STEP */
#define WAVE_ERR_RATE 22      /* tick rate outside [1, 65535] Hz */
#define WAVE_ERR_FREQ 23      /* frequency above rate / 2 (Nyquist) */
#define WAVE_ERR_MEAN 24      /* mean outside [-128, 127.996] N */
#define WAVE_ERR_AMPLITUDE 25 /* amplitude outside [0, 128] N */

typedef struct {
    int32_t kind;             /* WAVE_* */
    q7_8w_t mean_n_q8;        /* Q7.8 N, [-128, 127.996] */
    q7_8w_t amplitude_n_q8;   /* Q7.8 N, [0, 128]; mean +- amplitude saturates to Q7.8 */
    uq16_16_t freq_hz_q16;    /* UQ16.16 Hz, [0, rate/2] */
    uint32_t phase0;          /* initial phase, UQ0.32 turns */
} wave_config_t;

typedef struct {
    wave_config_t cfg;
    uint32_t phase;
    uint32_t inc;
} wave_t;

/* Defaults: the paper's Fig. 14 reference, a 0 .. 15 N sine (mean 7.5 N, amplitude 7.5 N) at
 * 0.5 Hz, starting at its mean going up. */
void wave_config_default(wave_config_t *cfg);
int32_t wave_config_check(const wave_config_t *cfg, uint32_t rate_hz);
/* Apply a configuration for a tick rate; on error nothing changes. */
int32_t wave_configure(wave_t *w, const wave_config_t *cfg, uint32_t rate_hz);
/* Back to the configured phase0, the rest as configured: what wave_configure with the same
 * configuration and rate would give, without its divisions (the soft CPU's are a routine). */
void wave_restart(wave_t *w);
/*
 * The value at the current phase, then advance the phase by one tick.
 * Scaling and overflow: amplitude (Q7.8, <= 2^15) * shape (Q1.30, |.| <= 2^30) < 2^45 in int64,
 * rounded to Q7.8; mean + that (|.| < 2^16) saturates to [-128, 127.996] N.
 */
q7_8_t wave_next_q7_8(wave_t *w);

#endif /* BOWDEN_WAVE_H */
