/* emu.c - the emulator's closed loop of emu.h. */
#include "emu.h"

#include <math.h>

#include "bowden_regs.h"

/* --- the FPGA loop: cosim/parts/rtl_model.py TensionLoopModel, line by line ---------------------- */


static int64_t clamp64(int64_t v, int64_t lo, int64_t hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

static int32_t sat16(int64_t v)
{
    return (int32_t)clamp64(v, -32768, 32767);
}

/* A single-field register's value from its word: masked, sign-extended when the field's range is
 * signed (MIN < 0). */
static int32_t field_value(uint32_t word, uint32_t mask, int64_t min, int64_t max)
{
    int64_t v = (int64_t)(word & mask);
    if (min < 0 && v > max) {
        v -= (int64_t)mask + 1;
    }
    return (int32_t)v;
}

#define FIELD(reg, word) \
    field_value((word), BOWDEN_##reg##_MASK, BOWDEN_##reg##_MIN, BOWDEN_##reg##_MAX)

void emu_loop_reset(emu_loop_t *m)
{
    m->tc = BOWDEN_TC_RESET;
    m->kff = BOWDEN_KFF_RESET;
    m->kp = BOWDEN_KP_RESET;
    m->ki_ts = BOWDEN_KI_TS_RESET;
    m->i_limit = BOWDEN_I_LIMIT_RESET;
    m->slew = BOWDEN_SLEW_RESET;
    m->wdt_timeout = BOWDEN_WDT_TIMEOUT_RESET;
    m->adc_offset = BOWDEN_ADC_OFFSET_RESET;
    m->adc_gain = BOWDEN_ADC_GAIN_RESET;
    m->adc_min = BOWDEN_ADC_MIN_RESET;
    m->adc_max = BOWDEN_ADC_MAX_RESET;
    m->adc_stale = BOWDEN_ADC_STALE_RESET;
    m->oc_timeout = BOWDEN_OC_TIMEOUT_RESET;
    m->tc_min = BOWDEN_TC_MIN_RESET;
    m->uff = BOWDEN_UFF_RESET;
    m->enable = m->slew_en = 0U;
    m->raw = 0;
    m->fresh = m->tc_written = m->integ_reset_pending = m->fault_clear_pending = 0U;
    m->stale_cnt = m->wdt_cnt = m->oc_cnt = m->faults = m->sample_count = 0U;
    m->t_in = m->u = 0;
    m->out_en = m->saturated = m->sat_hi = m->sat_lo = m->wdt_ramp = 0U;
    m->integ = 0;
    m->tc_eff = 0;
    m->wdt_ramp_step = BOWDEN_WDT_RAMP_STEP; /* tension_loop's parameter (bowden_regs.h) */
}

void emu_loop_write(emu_loop_t *m, uint32_t addr, uint32_t w)
{
    switch (addr) {
    case BOWDEN_REG_CTRL:
        m->enable = (w & BOWDEN_CTRL_ENABLE_MASK) != 0U;
        m->slew_en = (w & BOWDEN_CTRL_SLEW_EN_MASK) != 0U;
        m->integ_reset_pending |= (w & BOWDEN_CTRL_INTEG_RESET_MASK) != 0U;
        m->fault_clear_pending |= (w & BOWDEN_CTRL_FAULT_CLEAR_MASK) != 0U;
        break;
    case BOWDEN_REG_TC:
        m->tc = FIELD(TC, w);
        m->tc_written = 1U;
        break;
    case BOWDEN_REG_KFF:
        m->kff = FIELD(KFF, w);
        break;
    case BOWDEN_REG_KP:
        m->kp = FIELD(KP, w);
        break;
    case BOWDEN_REG_KI_TS:
        m->ki_ts = FIELD(KI_TS, w);
        break;
    case BOWDEN_REG_I_LIMIT:
        m->i_limit = FIELD(I_LIMIT, w);
        break;
    case BOWDEN_REG_SLEW:
        m->slew = FIELD(SLEW, w);
        break;
    case BOWDEN_REG_WDT_TIMEOUT:
        m->wdt_timeout = FIELD(WDT_TIMEOUT, w);
        break;
    case BOWDEN_REG_ADC_OFFSET:
        m->adc_offset = FIELD(ADC_OFFSET, w);
        break;
    case BOWDEN_REG_ADC_GAIN:
        m->adc_gain = FIELD(ADC_GAIN, w);
        break;
    case BOWDEN_REG_ADC_MIN:
        m->adc_min = FIELD(ADC_MIN, w);
        break;
    case BOWDEN_REG_ADC_MAX:
        m->adc_max = FIELD(ADC_MAX, w);
        break;
    case BOWDEN_REG_ADC_STALE:
        m->adc_stale = FIELD(ADC_STALE, w);
        break;
    case BOWDEN_REG_OC_TIMEOUT:
        m->oc_timeout = FIELD(OC_TIMEOUT, w);
        break;
    case BOWDEN_REG_TC_MIN:
        m->tc_min = FIELD(TC_MIN, w);
        break;
    case BOWDEN_REG_UFF:
        m->uff = FIELD(UFF, w);
        break;
    default: /* read-only registers ignore writes, as the RTL does */
        break;
    }
}

void emu_loop_adc(emu_loop_t *m, int32_t code)
{
    m->raw = code;
    m->fresh = 1U;
}

void emu_loop_tick(emu_loop_t *m)
{
    m->sample_count += 1U;
    uint32_t fclr = m->fault_clear_pending;
    uint32_t stale_base = fclr ? 0U : m->stale_cnt;
    uint32_t wdt_base = fclr ? 0U : m->wdt_cnt;
    uint32_t oc_base = fclr ? 0U : m->oc_cnt;
    uint32_t stale_now = m->fresh ? 0U : (stale_base + 1U > 0xFFFFU ? 0xFFFFU : stale_base + 1U);
    uint32_t wdt_now = (!m->enable || m->tc_written)
                           ? 0U
                           : (wdt_base + 1U > 0xFFFFU ? 0xFFFFU : wdt_base + 1U);
    int range_bad = m->raw < m->adc_min || m->raw > m->adc_max;
    uint32_t detect = 0U;
    if (m->enable) {
        if (m->adc_stale != 0 && stale_now >= (uint32_t)m->adc_stale) {
            detect |= BOWDEN_FAULT_ADC_STALE_MASK;
        }
        if (range_bad) {
            detect |= BOWDEN_FAULT_ADC_RANGE_MASK;
        }
        if (m->wdt_timeout != 0 && wdt_now >= (uint32_t)m->wdt_timeout) {
            detect |= BOWDEN_FAULT_WATCHDOG_MASK;
        }
        if (m->oc_timeout != 0 && oc_base >= (uint32_t)m->oc_timeout) {
            detect |= BOWDEN_FAULT_OVERCURRENT_MASK;
        }
    }
    m->faults = (fclr ? 0U : m->faults) | detect;
    m->stale_cnt = stale_now;
    m->wdt_cnt = wdt_now;
    m->oc_cnt = oc_base;
    int run = m->enable && m->faults == 0U;
    int ramp = m->enable && m->faults == BOWDEN_FAULT_WATCHDOG_MASK;
    int64_t integ_prev = m->integ_reset_pending ? 0 : m->integ;
    m->fresh = m->tc_written = 0U;
    m->integ_reset_pending = m->fault_clear_pending = 0U;

    int64_t tce = m->tc;
    if (m->slew_en) {
        tce = clamp64(tce, (int64_t)m->tc_eff - m->slew, (int64_t)m->tc_eff + m->slew);
    }
    if (tce < m->tc_min) {
        tce = m->tc_min; /* the floor after the slew limit (TC_MIN), as the RTL */
    }
    m->t_in = sat16((((int64_t)m->raw - m->adc_offset) * m->adc_gain + (1 << 19)) >> 20);

    if (run) {
        int64_t lim = m->i_limit;
        int64_t e = sat16(tce - m->t_in);
        int64_t ff = tce * m->kff;
        int64_t pp = e * m->kp;
        int64_t pi = e * m->ki_ts;
        int windup = (m->sat_hi && pi > 0) || (m->sat_lo && pi < 0);
        /* A held integrator is clamped too: I_LIMIT may have been lowered since it was stored. */
        m->integ = clamp64(integ_prev + (windup ? 0 : pi), -(lim << 16), lim << 16);
        /* Arithmetic shifts of negative values floor, as Python's >> does (gcc, clang). */
        int64_t r_out = ((ff + pp + 256 + (m->integ >> 7)) >> 9) + m->uff; /* UFF outside the PI */
        m->u = (int32_t)clamp64(r_out, -lim, lim);
        m->sat_hi = r_out > lim;
        m->sat_lo = r_out < -lim;
        m->saturated = m->sat_hi || m->sat_lo;
        m->out_en = 1U;
        m->wdt_ramp = 0U;
        m->tc_eff = (int32_t)tce;
        m->oc_cnt = m->saturated ? (m->oc_cnt + 1U > 0xFFFFU ? 0xFFFFU : m->oc_cnt + 1U) : 0U;
    } else {
        int32_t u = 0;
        if (ramp) {
            int32_t step = m->wdt_ramp_step;
            u = m->u > step ? m->u - step : m->u < -step ? m->u + step : 0;
        }
        m->u = u;
        m->out_en = m->wdt_ramp = (ramp && u != 0) ? 1U : 0U;
        m->integ = 0;
        m->saturated = m->sat_hi = m->sat_lo = 0U;
        m->tc_eff = 0;
        m->oc_cnt = 0U;
    }
}

uint32_t emu_loop_status(const emu_loop_t *m)
{
    return (m->out_en ? BOWDEN_STATUS_OUT_EN_MASK : 0U) |
           (m->saturated ? BOWDEN_STATUS_SATURATED_MASK : 0U) |
           (m->faults != 0U ? BOWDEN_STATUS_FAULT_ACTIVE_MASK : 0U) |
           (m->wdt_ramp ? BOWDEN_STATUS_WDT_RAMP_MASK : 0U);
}

/* --- the chain ----------------------------------------------------------------------------- */

int32_t emu_adc_code(double tension_n, int32_t offset, int32_t gain)
{
    /* rtl_model.adc_code_from_tension: round(offset + T * 2^8 * 2^20 / gain), Python's round is
     * half to even, as nearbyint in the default rounding mode. */
    double code = nearbyint((double)offset + tension_n * 256.0 * 1048576.0 / (double)gain);
    if (!(code > -8388608.0)) { /* also NaN: a real converter clips */
        return -8388608;
    }
    if (code > 8388607.0) {
        return 8388607;
    }
    return (int32_t)code;
}

static int32_t tension_word(double tension_n)
{
    double w = nearbyint(tension_n * 256.0);
    if (!(w > -32768.0)) {
        return -32768;
    }
    return w > 32767.0 ? 32767 : (int32_t)w;
}

void emu_init(emu_t *e)
{
    emu_loop_reset(&e->loop);
    e->code = emu_adc_code(e->y[EMU_OUT_T_IN_MEAS], e->adc_offset, e->adc_gain);
    e->n_pending = 0U;
    e->pending_wait = 0U;
    e->log_dropped = 0U;
    e->fmi_error = 0U;
    e->samples = 0U;
    e->rec_len = 0U;
}

static int run_sample(emu_t *e)
{
    if (e->n_pending > 0U && e->pending_wait == 0U) {
        for (uint32_t i = 0; i < e->n_pending; ++i) {
            emu_loop_write(&e->loop, e->pending[i].addr, e->pending[i].value);
        }
        e->n_pending = 0U;
    }
    emu_loop_adc(&e->loop, e->code);
    emu_loop_tick(&e->loop);
    if (e->rec_u != 0 && e->rec_len < e->rec_cap) {
        e->rec_u[e->rec_len] = (int16_t)e->loop.u;
        e->rec_tc[e->rec_len] = (int16_t)e->loop.tc_eff;
        ++e->rec_len;
    }
    e->u[EMU_IN_CURRENT] = (double)e->loop.u / 4096.0;
    int st = e->set_real(e->component, e->in_vr, EMU_N_IN, e->u);
    if (st <= 1) {
        st = e->do_step(e->component, e->time_s, e->dt_s, 1);
    }
    e->time_s += e->dt_s;
    if (st <= 1) {
        st = e->get_real(e->component, e->out_vr, EMU_N_OUT, e->y);
    }
    if (st > 1) { /* fmi2Error, fmi2Fatal */
        e->fmi_error = (uint32_t)st;
        return st;
    }
    e->code = emu_adc_code(e->y[EMU_OUT_T_IN_MEAS], e->adc_offset, e->adc_gain);
    ++e->samples;
    if (e->pending_wait > 0U) {
        --e->pending_wait;
    }
    return 0;
}

int emu_step(emu_t *e, dev_host_t *h, uint32_t time_us)
{
    return emu_step_channels(e, 1U, h, time_us);
}

int emu_step_channels(emu_t *e, uint32_t n, dev_host_t *h, uint32_t time_us)
{
    int32_t t_out[BOWDEN_CHANNELS_MAX] = {0};
    if (n < 1U || n > h->channels) {
        return -1;
    }
    for (uint32_t c = 0; c < n; ++c) {
        /* T_out as the output load cell reads it at sample k0 (the plant output that also gave
         * the ADC code of sample k0). */
        t_out[c] = tension_word(e[c].y[EMU_OUT_T_OUT_MEAS]);
        /* ... and as the front-end's second channel codes it (the far-end load cell, ADS131M02
         * CH1, on the same calibration as CH0): the register the online friction estimate
         * reads. */
        int32_t code_out = emu_adc_code(e[c].y[EMU_OUT_T_OUT_MEAS], e[c].adc_offset,
                                        e[c].adc_gain);
        int st = run_sample(&e[c]);
        if (st != 0) {
            return st;
        }
        /* The firmware's tick reads the loop's registers after sample k0 (fw_tick: STATUS,
         * FAULT, T_IN, U, SAMPLE_COUNT, and T_OUT and ADC_FLAGS with the estimate on), then
         * writes TC: each channel's in its own bank. */
        hal_shadow_t *sh = &h->shadow[c];
        hal_shadow_set(sh, BOWDEN_REG_STATUS, emu_loop_status(&e[c].loop));
        hal_shadow_set(sh, BOWDEN_REG_FAULT, e[c].loop.faults);
        hal_shadow_set(sh, BOWDEN_REG_T_IN, (uint32_t)e[c].loop.t_in);
        hal_shadow_set(sh, BOWDEN_REG_U, (uint32_t)e[c].loop.u);
        hal_shadow_set(sh, BOWDEN_REG_SAMPLE_COUNT, e[c].loop.sample_count);
        hal_shadow_set(sh, BOWDEN_REG_T_OUT, (uint32_t)code_out & BOWDEN_T_OUT_MASK);
        hal_shadow_set(sh, BOWDEN_REG_ADC_FLAGS, 0U);
    }
    dev_tick_channels(&h->dev, time_us, t_out);
    for (uint32_t c = 0; c < n; ++c) {
        e[c].n_pending = hal_shadow_drain(&h->shadow[c], e[c].pending, HAL_LOG_CAPACITY);
        e[c].log_dropped = h->shadow[c].log_dropped;
        e[c].pending_wait = 1U; /* land before sample k0 + 2 */
        for (uint32_t j = 1; j < e[c].decimation; ++j) {
            int st = run_sample(&e[c]);
            if (st != 0) {
                return st;
            }
        }
    }
    return 0;
}
