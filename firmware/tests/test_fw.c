/* test_fw.c - unit tests of the HAL back ends, the waveform generator and the firmware tick. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bowden_regs.h"
#include "fw.h"
#include "fxp.h"
#include "hal.h"
#include "unit.h"
#include "wave.h"

#define PI_D 3.14159265358979323846

static void test_wave_sine_matches_double(void)
{
    wave_t w;
    wave_config_t cfg;
    wave_config_default(&cfg); /* 7.5 + 7.5 sin(2 pi 0.5 t), 1 kHz */
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "defaults");
    int worst = 0;
    int16_t lo = INT16_MAX;
    int16_t hi = INT16_MIN;
    for (int k = 0; k < 20000; ++k) {
        int16_t v = wave_next_q7_8(&w);
        double exact = (7.5 + 7.5 * sin(2.0 * PI_D * 0.5 * k / 1000.0)) * 256.0;
        int e = abs(v - (int)lround(exact));
        worst = e > worst ? e : worst;
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
    }
    CHECK(worst <= 1, "sine off by %d LSB", worst);
    CHECK(lo == 0 && hi == 15 * 256, "range %d .. %d LSB", lo, hi);
}

/* Every kind's output is mean + (amplitude * shape + 2^29) >> 30 in 64 bits, saturated to Q7.8:
 * wave.c forms the product's rounded high part without a 64-bit shift; the words stay these. */
static void test_wave_output_bit_for_bit(void)
{
    static const int32_t amps[] = {0, 1, 255, 256 * 6, 12345, 128 * 256 - 1, 128 * 256};
    static const int32_t means[] = {-128 * 256, -1, 0, 8 * 256, 127 * 256 + 255};
    static const uint32_t kinds[] = {WAVE_SINE, WAVE_TRIANGLE, WAVE_RAMP, WAVE_STEP};
    uint32_t bad = 0U, n = 0U;
    for (uint32_t k = 0; k < sizeof kinds / sizeof kinds[0]; ++k) {
        for (uint32_t i = 0; i < sizeof amps / sizeof amps[0]; ++i) {
            for (uint32_t j = 0; j < sizeof means / sizeof means[0]; ++j) {
                wave_t w;
                wave_config_t cfg;
                wave_config_default(&cfg);
                cfg.kind = kinds[k];
                cfg.amplitude_n_q8 = amps[i];
                cfg.mean_n_q8 = means[j];
                cfg.freq_hz_q16 = 7919U << 8; /* some 31 Hz: phases all over the turn */
                CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "config");
                for (int t = 0; t < 400; ++t) {
                    const uint32_t phase = w.phase;
                    const q1_30_t shape = (kinds[k] == WAVE_SINE)       ? fxp_sin_q1_30(phase)
                                          : (kinds[k] == WAVE_TRIANGLE) ? fxp_triangle_q1_30(phase)
                                                                        : 0;
                    const int16_t v = wave_next_q7_8(&w);
                    if (kinds[k] == WAVE_SINE || kinds[k] == WAVE_TRIANGLE) {
                        int64_t want = (int64_t)means[j] +
                                       (((int64_t)amps[i] * shape + (INT64_C(1) << 29)) >> 30);
                        want = (want > Q7_8_MAX) ? Q7_8_MAX : (want < Q7_8_MIN) ? Q7_8_MIN : want;
                        bad += v != (int16_t)want;
                        ++n;
                    }
                }
            }
        }
    }
    CHECK(bad == 0U && n > 0U, "%u of %u samples differ from the 64-bit form", bad, n);
}

static void test_wave_triangle_constant_and_saturation(void)
{
    wave_t w;
    wave_config_t cfg;
    wave_config_default(&cfg);
    cfg.kind = WAVE_TRIANGLE;
    cfg.mean_n_q8 = 0;
    cfg.amplitude_n_q8 = 10 * 256;
    cfg.freq_hz_q16 = 250U << 16; /* a quarter turn per tick at 1 kHz */
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "triangle");
    const int16_t want[5] = {0, 2560, 0, -2560, 0};
    for (int k = 0; k < 5; ++k) {
        int16_t v = wave_next_q7_8(&w);
        CHECK(v == want[k], "triangle tick %d: %d", k, v);
    }
    cfg.kind = WAVE_CONSTANT;
    cfg.mean_n_q8 = -300;
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "constant");
    CHECK(wave_next_q7_8(&w) == -300 && wave_next_q7_8(&w) == -300, "constant value");
    /* mean + amplitude beyond full scale saturates at both ends (documented in wave.h). */
    cfg.kind = WAVE_SINE;
    cfg.mean_n_q8 = 0;
    cfg.amplitude_n_q8 = 128 * 256;
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "full-scale sine");
    int16_t v[4];
    for (int k = 0; k < 4; ++k) {
        v[k] = wave_next_q7_8(&w);
    }
    CHECK(v[1] == INT16_MAX && v[3] == INT16_MIN, "saturation: %d %d", v[1], v[3]);
    cfg.mean_n_q8 = 100 * 256;
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "offset sine");
    (void)wave_next_q7_8(&w);
    CHECK(wave_next_q7_8(&w) == INT16_MAX, "mean + amplitude clamps to +127.996 N");
}

static void test_wave_bad_config(void)
{
    wave_t w;
    wave_config_t good;
    wave_config_default(&good);
    CHECK(wave_configure(&w, &good, 1000U) == WAVE_OK, "good");
    (void)wave_next_q7_8(&w);
    wave_t before = w;
    wave_config_t bad = good;
    bad.kind = 7;
    CHECK(wave_configure(&w, &bad, 1000U) == WAVE_ERR_KIND, "kind");
    CHECK(wave_configure(&w, &good, 0U) == WAVE_ERR_RATE, "rate 0");
    CHECK(wave_configure(&w, &good, 65536U) == WAVE_ERR_RATE, "rate 65536");
    bad = good;
    bad.freq_hz_q16 = (500U << 16) + 1U;
    CHECK(wave_configure(&w, &bad, 1000U) == WAVE_ERR_FREQ, "above Nyquist");
    bad.freq_hz_q16 = 500U << 16;
    CHECK(wave_config_check(&bad, 1000U) == WAVE_OK, "Nyquist itself is allowed");
    bad = good;
    bad.mean_n_q8 = 32768;
    CHECK(wave_configure(&w, &bad, 1000U) == WAVE_ERR_MEAN, "mean");
    bad = good;
    bad.amplitude_n_q8 = -1;
    CHECK(wave_configure(&w, &bad, 1000U) == WAVE_ERR_AMPLITUDE, "amplitude < 0");
    bad.amplitude_n_q8 = 128 * 256 + 1;
    CHECK(wave_configure(&w, &bad, 1000U) == WAVE_ERR_AMPLITUDE, "amplitude > 128 N");
    CHECK(memcmp(&before, &w, sizeof w) == 0, "a rejected configuration changed the generator");
    /* Frequency resolution: after 1000 ticks of 0.5 Hz the phase is half a turn within 1e-6. */
    CHECK(wave_configure(&w, &good, 1000U) == WAVE_OK, "again");
    for (int k = 0; k < 1000; ++k) {
        (void)wave_next_q7_8(&w);
    }
    CHECK(fabs(w.phase / 4294967296.0 - 0.5) < 1e-6, "phase %.9f", w.phase / 4294967296.0);
}

static void test_hal_shadow_log(void)
{
    hal_t h;
    static hal_shadow_t s;
    hal_init_shadow(&h, &s);
    hal_shadow_set(&s, BOWDEN_REG_T_IN, 0xFFFFFF00UL);
    CHECK(hal_read(&h, BOWDEN_REG_T_IN) == 0xFFFFFF00UL, "shadow read");
    CHECK(s.log_len == 0U, "hal_shadow_set must not log");
    hal_write(&h, BOWDEN_REG_TC, 0x123U);
    hal_write(&h, BOWDEN_REG_KP, 0x456U);
    CHECK(hal_read(&h, BOWDEN_REG_TC) == 0x123U, "writes update the shadow");
    hal_write_t out[HAL_LOG_CAPACITY];
    CHECK(hal_shadow_drain(&s, out, 1U) == 1U && out[0].addr == BOWDEN_REG_TC, "oldest first");
    CHECK(hal_shadow_drain(&s, out, 8U) == 1U && out[0].addr == BOWDEN_REG_KP &&
              out[0].value == 0x456U,
          "the rest kept");
    CHECK(hal_shadow_drain(&s, out, 8U) == 0U, "empty after draining");
    for (uint32_t i = 0; i < HAL_LOG_CAPACITY + 5U; ++i) {
        hal_write(&h, BOWDEN_REG_TC, i);
    }
    CHECK(s.log_len == HAL_LOG_CAPACITY && s.log_dropped == 5U, "full log: %lu kept %lu dropped",
          (unsigned long)s.log_len, (unsigned long)s.log_dropped);
    hal_write(&h, 2U, 1U);
    hal_write(&h, HAL_SHADOW_WORDS * 4U, 1U);
    CHECK(hal_read(&h, 0x1001U) == 0U && s.bad_access == 3U, "bad accesses %lu",
          (unsigned long)s.bad_access);
}

static uint32_t fake_regs[HAL_SHADOW_WORDS];
static int transport_calls;
static uint32_t fake_read(void *ctx, uint32_t addr)
{
    ++transport_calls;
    return ((uint32_t *)ctx)[addr / 4U];
}
static void fake_write(void *ctx, uint32_t addr, uint32_t value)
{
    ++transport_calls;
    ((uint32_t *)ctx)[addr / 4U] = value;
}

static void test_hal_mmio_and_transport(void)
{
    hal_t h;
    memset(fake_regs, 0, sizeof fake_regs);
    hal_init_mmio(&h, fake_regs);
    hal_write(&h, BOWDEN_REG_TC, 0xABCDU);
    CHECK(fake_regs[BOWDEN_REG_TC / 4U] == 0xABCDU, "MMIO write lands at base + offset");
    fake_regs[BOWDEN_REG_U / 4U] = 77U;
    CHECK(hal_read(&h, BOWDEN_REG_U) == 77U, "MMIO read");
    hal_init_transport(&h, fake_read, fake_write, fake_regs);
    transport_calls = 0;
    hal_write(&h, BOWDEN_REG_KP, 5U);
    CHECK(hal_read(&h, BOWDEN_REG_KP) == 5U && transport_calls == 2, "transport");
}

static void fw_on_shadow(fw_t *fw, hal_t *h, hal_shadow_t *s)
{
    hal_init_shadow(h, s);
    fw_init(fw, h);
}

static void test_fw_start_sequence(void)
{
    static hal_shadow_t s;
    hal_t h;
    fw_t fw;
    fw_on_shadow(&fw, &h, &s);
    fw_config_t cfg;
    fw_config_default(&cfg);
    cfg.loop.kp = -7; /* a gain of the wrong sign: refused (bowden_regs.json: KP min 0) */
    CHECK(fw_configure(&fw, &cfg) == FW_ERR_KP, "negative KP refused");
    cfg.loop.kp = BOWDEN_KP_RESET;
    cfg.loop.adc_offset = -7;
    cfg.loop.slew_en = 1;
    cfg.comp.tc_min_n_q8 = 3 * 256;
    CHECK(fw_configure(&fw, &cfg) == FW_OK, "configure");
    fw_start(&fw);
    hal_write_t w[HAL_LOG_CAPACITY];
    uint32_t n = hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
    CHECK(n == 17U, "%lu writes at start", (unsigned long)n);
    CHECK(w[0].addr == BOWDEN_REG_CTRL && w[0].value == 0U, "disable first");
    CHECK(w[7].addr == BOWDEN_REG_ADC_OFFSET && w[7].value == 0xFFFFFFF9UL,
          "ADC_OFFSET sign-extended");
    CHECK(w[13].addr == BOWDEN_REG_TC_MIN && w[13].value == 3U * 256U,
          "the compensator's floor into TC_MIN");
    CHECK(w[14].addr == BOWDEN_REG_TC && w[14].value == 0U, "TC = 0 before enabling");
    CHECK(w[15].value == (BOWDEN_CTRL_FAULT_CLEAR_MASK | BOWDEN_CTRL_INTEG_RESET_MASK),
          "fault clear and integrator reset");
    CHECK(w[16].addr == BOWDEN_REG_CTRL &&
              w[16].value == (BOWDEN_CTRL_ENABLE_MASK | BOWDEN_CTRL_SLEW_EN_MASK),
          "enable last: 0x%lx", (unsigned long)w[16].value);
    fw_stop(&fw);
    n = hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
    CHECK(n == 2U && w[0].addr == BOWDEN_REG_TC && w[1].addr == BOWDEN_REG_CTRL &&
              w[1].value == 0U,
          "stop");
}

static void test_fw_tick_host_source(void)
{
    static hal_shadow_t s;
    hal_t h;
    fw_t fw;
    fw_on_shadow(&fw, &h, &s);
    fw_start(&fw);
    hal_write_t w[HAL_LOG_CAPACITY];
    (void)hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
    comp_t ref;
    comp_init(&ref);
    hal_shadow_set(&s, BOWDEN_REG_T_IN, 0x0000FF00UL); /* -1 N, not sign-extended */
    hal_shadow_set(&s, BOWDEN_REG_U, 0xFFFFF000UL);    /* -1 A, sign-extended */
    hal_shadow_set(&s, BOWDEN_REG_STATUS, BOWDEN_STATUS_OUT_EN_MASK);
    hal_shadow_set(&s, BOWDEN_REG_SAMPLE_COUNT, 1234U);
    int bad = 0;
    for (int k = 0; k < 3000; ++k) {
        int16_t r = (int16_t)(1280 + 1280 * sin(2 * PI_D * k / 1000.0));
        int16_t tc = fw_tick(&fw, r);
        bad += tc != comp_step_q7_8(&ref, r);
        uint32_t n = hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
        bad += n != 1U || w[0].addr != BOWDEN_REG_TC || w[0].value != (uint32_t)(int32_t)tc;
    }
    CHECK(bad == 0, "%d ticks where T_c or the TC write differ", bad);
    CHECK(fw.tel.ticks == 3000U && fw.tel.t_in == -256 && fw.tel.u == -4096, "telemetry %ld %ld",
          (long)fw.tel.t_in, (long)fw.tel.u);
    CHECK(fw.tel.sample_count == 1234U && fw.tel.status == BOWDEN_STATUS_OUT_EN_MASK,
          "status and sample count");
    CHECK(fw.tel.fault == 0U && fw.tel.fault_ticks == 0U, "no fault");
}

static void test_fw_tick_wave_source_and_fault(void)
{
    static hal_shadow_t s;
    hal_t h;
    fw_t fw;
    fw_on_shadow(&fw, &h, &s);
    fw_config_t cfg;
    fw_config_default(&cfg);
    cfg.source = FW_SOURCE_WAVE;
    cfg.comp.mode = COMP_MODE_SMOOTH;
    CHECK(fw_configure(&fw, &cfg) == FW_OK, "configure");
    fw_start(&fw);
    hal_write_t w[HAL_LOG_CAPACITY];
    (void)hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
    wave_t wave;
    comp_t comp;
    (void)wave_configure(&wave, &cfg.wave, 1000U);
    comp_init(&comp);
    (void)comp_configure(&comp, &cfg.comp);
    int bad = 0;
    for (int k = 0; k < 2500; ++k) {
        if (k == 1000) {
            hal_shadow_set(&s, BOWDEN_REG_FAULT, BOWDEN_FAULT_WATCHDOG_MASK);
        }
        int16_t tc = fw_tick(&fw, 9999); /* host value ignored with the wave source */
        int16_t r = wave_next_q7_8(&wave);
        bad += tc != comp_step_q7_8(&comp, r) || fw.tel.t_ref != r;
        uint32_t n = hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
        bad += n != 1U || w[0].addr != BOWDEN_REG_TC; /* never clears the fault by itself */
    }
    CHECK(bad == 0, "%d ticks differ from wave + compensator", bad);
    CHECK(fw.tel.fault_ticks == 1500U && fw.tel.fault == BOWDEN_FAULT_WATCHDOG_MASK,
          "fault ticks %lu", (unsigned long)fw.tel.fault_ticks);
    fw_fault_clear(&fw);
    uint32_t n = hal_shadow_drain(&s, w, HAL_LOG_CAPACITY);
    CHECK(n == 1U && w[0].addr == BOWDEN_REG_CTRL &&
              w[0].value == (BOWDEN_CTRL_ENABLE_MASK | BOWDEN_CTRL_FAULT_CLEAR_MASK),
          "fault clear keeps the loop enabled");
}

/* PREVIEW with the waveform source: the generator runs P ticks ahead from fw_start, so that
 * tick k hands the compensator T_ref(k + P) and its line holds T_ref(k .. k + P). */
static void test_fw_wave_preview_runs_ahead(void)
{
    static hal_shadow_t s;
    hal_t h;
    fw_t fw;
    fw_on_shadow(&fw, &h, &s);
    fw_config_t cfg;
    fw_config_default(&cfg);
    cfg.source = FW_SOURCE_WAVE;
    cfg.comp.mode = COMP_MODE_PREVIEW;
    cfg.comp.preview_ticks = 8;
    cfg.comp.lead_ticks = 0;
    CHECK(fw_configure(&fw, &cfg) == FW_OK, "configure");
    fw_start(&fw);
    wave_t wave;
    comp_t comp;
    (void)wave_configure(&wave, &cfg.wave, 1000U);
    comp_init(&comp);
    (void)comp_configure(&comp, &cfg.comp);
    int16_t ahead[8];
    for (int i = 0; i < 8; ++i) {
        ahead[i] = wave_next_q7_8(&wave);
        (void)comp_step_q7_8(&comp, ahead[i]);
    }
    int bad = 0;
    for (int k = 0; k < 3000; ++k) {
        int16_t tc = fw_tick(&fw, 0);
        int16_t r = wave_next_q7_8(&wave);
        bad += tc != comp_step_q7_8(&comp, r) || fw.tel.t_ref != r;
    }
    CHECK(bad == 0, "%d ticks differ from the wave run ahead + compensator", bad);
    CHECK(ahead[0] == cfg.wave.mean_n_q8 || ahead[0] != ahead[7], "the pre-roll moved the wave");
}

static void test_fw_bad_config(void)
{
    static hal_shadow_t s;
    hal_t h;
    fw_t fw;
    fw_on_shadow(&fw, &h, &s);
    fw_config_t good;
    fw_config_default(&good);
    CHECK(fw_config_check(&good) == FW_OK, "defaults: %s", fw_strerror(fw_config_check(&good)));
    fw_t before = fw;
    struct {
        const char *what;
        fw_config_t cfg;
        int32_t code;
    } bad[30];
    int nb = 0;
#define BAD(field, value, err)                                                                  \
    do {                                                                                        \
        bad[nb].what = #field " = " #value;                                                     \
        bad[nb].cfg = good;                                                                     \
        bad[nb].cfg.field = (value);                                                            \
        bad[nb].code = (err);                                                                   \
        ++nb;                                                                                   \
    } while (0)
    BAD(source, 2, FW_ERR_SOURCE);
    BAD(tick_rate_hz, 0U, FW_ERR_TICK_RATE);
    BAD(tick_rate_hz, 20000U, FW_ERR_TICK_RATE);
    BAD(sample_rate_hz, 0U, FW_ERR_SAMPLE_RATE);
    BAD(comp.mu_q28, -1, COMP_ERR_MU);
    BAD(comp.band_n_q8, 0, COMP_ERR_BAND);
    BAD(comp.dead_zone_spread_q28, Q3_28_ONE + 1, COMP_ERR_DEAD_ZONE);
    BAD(comp.dead_zone_spread_q28, -1, COMP_ERR_DEAD_ZONE);
    BAD(comp.breakaway_q28, COMP_BRK_MAX_Q28 + 1, COMP_ERR_BREAKAWAY);
    BAD(comp.breakaway_q28, -1, COMP_ERR_BREAKAWAY);
    BAD(comp.slack_tension_n_q8, COMP_SLACK_MAX_Q8 + 1, COMP_ERR_SLACK);
    BAD(comp.slack_tension_n_q8, -1, COMP_ERR_SLACK);
    BAD(comp.mu_per_inlet_rate_q28, COMP_VISC_MAX_Q28 + 1, COMP_ERR_VISCOUS);
    BAD(comp.mu_per_inlet_rate_q28, -1, COMP_ERR_VISCOUS);
    BAD(wave.kind, 9, WAVE_ERR_KIND);
    BAD(loop.kff, 32768, FW_ERR_KFF);
    BAD(loop.kp, -32769, FW_ERR_KP);
    BAD(loop.ki_ts, 40000, FW_ERR_KI_TS);
    BAD(loop.i_limit, -1, FW_ERR_I_LIMIT);
    BAD(loop.slew, 32768, FW_ERR_SLEW);
    BAD(loop.slew_en, 2, FW_ERR_SLEW_EN);
    BAD(loop.wdt_timeout, 20, FW_ERR_WDT_TIMEOUT); /* = 2 ticks of 10 samples */
    BAD(loop.wdt_timeout, 65536, FW_ERR_WDT_TIMEOUT);
    BAD(loop.adc_offset, 8388608, FW_ERR_ADC_OFFSET);
    BAD(loop.adc_gain, -32769, FW_ERR_ADC_GAIN);
    BAD(loop.adc_min, -8388609, FW_ERR_ADC_MIN);
    BAD(loop.adc_max, -8388607 - 1, FW_ERR_ADC_MAX); /* below adc_min */
    BAD(loop.adc_stale, 65536, FW_ERR_ADC_STALE);
    BAD(loop.oc_timeout, -1, FW_ERR_OC_TIMEOUT);
#undef BAD
    for (int i = 0; i < nb; ++i) {
        int32_t e = fw_configure(&fw, &bad[i].cfg);
        CHECK(e == bad[i].code, "%s: %ld (%s)", bad[i].what, (long)e, fw_strerror(e));
        CHECK(memcmp(&before, &fw, sizeof fw) == 0, "%s changed the firmware", bad[i].what);
        CHECK(strcmp(fw_strerror(e), "unknown status code") != 0, "%s: no message", bad[i].what);
    }
    fw_config_t edge = good;
    edge.loop.wdt_timeout = 21;
    CHECK(fw_config_check(&edge) == FW_OK, "wdt 21 samples > 2 ticks accepted");
    edge.loop.wdt_timeout = 0;
    CHECK(fw_config_check(&edge) == FW_OK, "wdt disabled accepted");
    CHECK(fw_configure(0, &good) == FW_ERR_NULL && fw_configure(&fw, 0) == FW_ERR_NULL, "null");
    for (int32_t code = 1; code <= 56; ++code) {
        const char *m = fw_strerror(code);
        int known = (code <= 18) || (code >= 20 && code <= 25) || (code >= 40);
        CHECK(known == (strcmp(m, "unknown status code") != 0), "code %ld: %s", (long)code, m);
    }
}

/* Ramp (sawtooth) and step (square): the values at eighth turns, and saturation at full scale. */
static void test_wave_ramp_and_step(void)
{
    wave_t w;
    wave_config_t cfg;
    wave_config_default(&cfg);
    cfg.kind = WAVE_RAMP;
    cfg.mean_n_q8 = 0;
    cfg.amplitude_n_q8 = 8 * 256;
    cfg.freq_hz_q16 = 125U << 16; /* an eighth of a turn per tick at 1 kHz */
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "ramp");
    const int16_t ramp[9] = {0, 512, 1024, 1536, -2048, -1536, -1024, -512, 0};
    for (int k = 0; k < 9; ++k) {
        int16_t v = wave_next_q7_8(&w);
        CHECK(v == ramp[k], "ramp tick %d: %d", k, v);
    }
    cfg.kind = WAVE_STEP;
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "step");
    for (int k = 0; k < 8; ++k) {
        int16_t v = wave_next_q7_8(&w);
        CHECK(v == (k < 4 ? 2048 : -2048), "step tick %d: %d", k, v);
    }
    cfg.mean_n_q8 = 100 * 256;
    cfg.amplitude_n_q8 = 128 * 256;
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_OK, "full-scale step");
    CHECK(wave_next_q7_8(&w) == INT16_MAX, "step saturates high");
    for (int k = 0; k < 3; ++k) {
        (void)wave_next_q7_8(&w);
    }
    CHECK(wave_next_q7_8(&w) == -28 * 256, "then mean - amplitude");
    cfg.kind = WAVE_STEP + 1;
    CHECK(wave_configure(&w, &cfg, 1000U) == WAVE_ERR_KIND, "the kind after step is refused");
}

const unit_test_t fw_tests[] = {
    {"wave_sine_matches_double", test_wave_sine_matches_double},
    {"wave_output_bit_for_bit", test_wave_output_bit_for_bit},
    {"wave_triangle_constant_and_saturation", test_wave_triangle_constant_and_saturation},
    {"wave_bad_config", test_wave_bad_config},
    {"wave_ramp_and_step", test_wave_ramp_and_step},
    {"hal_shadow_log", test_hal_shadow_log},
    {"hal_mmio_and_transport", test_hal_mmio_and_transport},
    {"fw_start_sequence", test_fw_start_sequence},
    {"fw_tick_host_source", test_fw_tick_host_source},
    {"fw_tick_wave_source_and_fault", test_fw_tick_wave_source_and_fault},
    {"fw_bad_config", test_fw_bad_config},
    {"fw_wave_preview_runs_ahead", test_fw_wave_preview_runs_ahead},
};
const int fw_tests_count = (int)(sizeof fw_tests / sizeof fw_tests[0]);
