/* wave.c - the reference generator of wave.h. */
#include "wave.h"

#include "fxp.h"

void wave_config_default(wave_config_t *cfg)
{
    if (cfg == 0) {
        return;
    }
    cfg->kind = WAVE_SINE;
    cfg->mean_n_q8 = (q7_8w_t)(15 * Q7_8_ONE / 2);
    cfg->amplitude_n_q8 = (q7_8w_t)(15 * Q7_8_ONE / 2);
    cfg->freq_hz_q16 = (uq16_16_t)(1UL << 15); /* 0.5 Hz */
    cfg->phase0 = 0U;
}

int32_t wave_config_check(const wave_config_t *cfg, uint32_t rate_hz)
{
    if (cfg == 0) {
        return WAVE_ERR_NULL;
    }
    if (cfg->kind < WAVE_CONSTANT || cfg->kind > WAVE_STEP) {
        return WAVE_ERR_KIND;
    }
    if (rate_hz < 1U || rate_hz > 65535U) {
        return WAVE_ERR_RATE;
    }
    /* freq <= rate / 2, in UQ16.16: freq_q16 <= rate * 2^15 (< 2^31). */
    if (cfg->freq_hz_q16 > rate_hz * 32768U) {
        return WAVE_ERR_FREQ;
    }
    if (cfg->mean_n_q8 < Q7_8_MIN || cfg->mean_n_q8 > Q7_8_MAX) {
        return WAVE_ERR_MEAN;
    }
    if (cfg->amplitude_n_q8 < 0 || cfg->amplitude_n_q8 > 128 * Q7_8_ONE) {
        return WAVE_ERR_AMPLITUDE;
    }
    return WAVE_OK;
}

int32_t wave_configure(wave_t *w, const wave_config_t *cfg, uint32_t rate_hz)
{
    if (w == 0) {
        return WAVE_ERR_NULL;
    }
    int32_t err = wave_config_check(cfg, rate_hz);
    if (err != WAVE_OK) {
        return err;
    }
    w->cfg = *cfg;
    w->phase = cfg->phase0;
    /* inc = floor(freq_q16 * 2^16 / rate) in two 32-bit divisions (no 64-bit divide on the
     * target): q1 = freq_q16 / rate <= 2^15 so q1 << 16 <= 2^31; r1 < rate < 2^16. */
    uint32_t q1 = cfg->freq_hz_q16 / rate_hz;
    uint32_t r1 = cfg->freq_hz_q16 % rate_hz;
    w->inc = (q1 << 16) + ((r1 << 16) / rate_hz);
    return WAVE_OK;
}

void wave_restart(wave_t *w)
{
    w->phase = w->cfg.phase0;
}

q7_8_t wave_next_q7_8(wave_t *w)
{
    q1_30_t shape = 0;
    if (w->cfg.kind == WAVE_SINE) {
        shape = fxp_sin_q1_30(w->phase);
    } else if (w->cfg.kind == WAVE_TRIANGLE) {
        shape = fxp_triangle_q1_30(w->phase);
    } else if (w->cfg.kind == WAVE_RAMP) {
        /* The phase read as a signed turn, halved: 0 .. 2^30 over the first half turn, then
         * -2^30 .. 0 (no implementation-defined unsigned -> signed conversion). */
        shape = (q1_30_t)(w->phase >> 1);
        if (shape >= (q1_30_t)Q1_30_ONE) {
            shape = shape - (q1_30_t)Q1_30_ONE - (q1_30_t)Q1_30_ONE;
        }
    } else if (w->cfg.kind == WAVE_STEP) {
        shape = (w->phase < 0x80000000UL) ? (q1_30_t)Q1_30_ONE : -(q1_30_t)Q1_30_ONE;
    }
    w->phase += w->inc; /* wraps modulo one turn by design */
    /* mean + (amplitude * shape + 2^29) >> 30 (arithmetic), as the rounded high word of
     * (4 amplitude) * shape (amplitude in [0, 2^15], checked: 4 amplitude < 2^31). */
    const int32_t scaled = fxp_mul_hi_round_i32(4 * w->cfg.amplitude_n_q8, shape);
    int32_t v = w->cfg.mean_n_q8 + scaled;
    if (v > Q7_8_MAX) {
        v = Q7_8_MAX;
    } else if (v < Q7_8_MIN) {
        v = Q7_8_MIN;
    }
    return (q7_8_t)v;
}
