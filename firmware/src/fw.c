/* fw.c - configuration, start-up and the periodic tick of fw.h. */
#include "fw.h"

#include "bowden_regs.h"

void fw_config_default(fw_config_t *cfg)
{
    if (cfg == 0) {
        return;
    }
    cfg->tick_rate_hz = 1000U;
    cfg->sample_rate_hz = 10000U;
    cfg->source = FW_SOURCE_HOST;
    comp_config_default(&cfg->comp);
    wave_config_default(&cfg->wave);
    cfg->loop.kff = BOWDEN_KFF_RESET;
    cfg->loop.kp = BOWDEN_KP_RESET;
    cfg->loop.ki_ts = BOWDEN_KI_TS_RESET;
    cfg->loop.i_limit = BOWDEN_I_LIMIT_RESET;
    cfg->loop.slew = BOWDEN_SLEW_RESET;
    cfg->loop.slew_en = BOWDEN_CTRL_SLEW_EN_RESET;
    cfg->loop.wdt_timeout = BOWDEN_WDT_TIMEOUT_RESET;
    cfg->loop.adc_offset = BOWDEN_ADC_OFFSET_RESET;
    cfg->loop.adc_gain = BOWDEN_ADC_GAIN_RESET;
    cfg->loop.adc_min = BOWDEN_ADC_MIN_RESET;
    cfg->loop.adc_max = BOWDEN_ADC_MAX_RESET;
    cfg->loop.adc_stale = BOWDEN_ADC_STALE_RESET;
    cfg->loop.oc_timeout = BOWDEN_OC_TIMEOUT_RESET;
    cfg->loop.kv = 0;
    cfg->loop.uff_limit = FW_UFF_LIMIT_DEFAULT;
    fric_est_config_default(&cfg->est);
    fric_corr_config_default(&cfg->corr);
}

/* v within [min, max] (bowden_regs.h: the field's range, or its documented LIMIT_MIN/MAX where
 * the register map gives them, e.g. gains >= 0), compared in 64 bits. */
static int in_field(int32_t v, int64_t min, int64_t max)
{
    return (int64_t)v >= min && (int64_t)v <= max;
}

static int32_t loop_config_check(const fw_loop_config_t *l, uint32_t samples_per_tick)
{
    if (!in_field(l->kff, BOWDEN_KFF_LIMIT_MIN, BOWDEN_KFF_LIMIT_MAX)) {
        return FW_ERR_KFF;
    }
    if (!in_field(l->kp, BOWDEN_KP_LIMIT_MIN, BOWDEN_KP_LIMIT_MAX)) {
        return FW_ERR_KP;
    }
    if (!in_field(l->ki_ts, BOWDEN_KI_TS_LIMIT_MIN, BOWDEN_KI_TS_LIMIT_MAX)) {
        return FW_ERR_KI_TS;
    }
    if (!in_field(l->i_limit, BOWDEN_I_LIMIT_MIN, BOWDEN_I_LIMIT_MAX)) {
        return FW_ERR_I_LIMIT;
    }
    if (!in_field(l->slew, BOWDEN_SLEW_MIN, BOWDEN_SLEW_MAX)) {
        return FW_ERR_SLEW;
    }
    if (l->slew_en != 0 && l->slew_en != 1) {
        return FW_ERR_SLEW_EN;
    }
    /* The watchdog must survive one late tick: timeout > 2 tick periods (0 disables it). */
    if (!in_field(l->wdt_timeout, BOWDEN_WDT_TIMEOUT_MIN, BOWDEN_WDT_TIMEOUT_MAX) ||
        (l->wdt_timeout != 0 && (uint32_t)l->wdt_timeout <= 2U * samples_per_tick)) {
        return FW_ERR_WDT_TIMEOUT;
    }
    if (!in_field(l->adc_offset, BOWDEN_ADC_OFFSET_MIN, BOWDEN_ADC_OFFSET_MAX)) {
        return FW_ERR_ADC_OFFSET;
    }
    if (!in_field(l->adc_gain, BOWDEN_ADC_GAIN_MIN, BOWDEN_ADC_GAIN_MAX)) {
        return FW_ERR_ADC_GAIN;
    }
    if (!in_field(l->adc_min, BOWDEN_ADC_MIN_MIN, BOWDEN_ADC_MIN_MAX)) {
        return FW_ERR_ADC_MIN;
    }
    if (!in_field(l->adc_max, BOWDEN_ADC_MAX_MIN, BOWDEN_ADC_MAX_MAX) || l->adc_max < l->adc_min) {
        return FW_ERR_ADC_MAX;
    }
    if (!in_field(l->adc_stale, BOWDEN_ADC_STALE_MIN, BOWDEN_ADC_STALE_MAX)) {
        return FW_ERR_ADC_STALE;
    }
    if (!in_field(l->oc_timeout, BOWDEN_OC_TIMEOUT_MIN, BOWDEN_OC_TIMEOUT_MAX)) {
        return FW_ERR_OC_TIMEOUT;
    }
    if (!in_field(l->kv, 0, FW_KV_MAX)) {
        return FW_ERR_KV;
    }
    if (!in_field(l->uff_limit, 0, BOWDEN_UFF_MAX)) {
        return FW_ERR_UFF_LIMIT;
    }
    return FW_OK;
}

int32_t fw_config_check(const fw_config_t *cfg)
{
    if (cfg == 0) {
        return FW_ERR_NULL;
    }
    if (cfg->sample_rate_hz < 1U || cfg->sample_rate_hz > 1000000U) {
        return FW_ERR_SAMPLE_RATE;
    }
    if (cfg->tick_rate_hz < 1U || cfg->tick_rate_hz > 65535U ||
        cfg->tick_rate_hz > cfg->sample_rate_hz) {
        return FW_ERR_TICK_RATE;
    }
    if (cfg->source != FW_SOURCE_HOST && cfg->source != FW_SOURCE_WAVE) {
        return FW_ERR_SOURCE;
    }
    int32_t err = comp_config_check(&cfg->comp);
    if (err != COMP_OK) {
        return err;
    }
    err = wave_config_check(&cfg->wave, cfg->tick_rate_hz);
    if (err != WAVE_OK) {
        return err;
    }
    /* Ceiling of the FPGA samples per tick. */
    uint32_t spt = (cfg->sample_rate_hz + cfg->tick_rate_hz - 1U) / cfg->tick_rate_hz;
    err = loop_config_check(&cfg->loop, spt);
    if (err != FW_OK) {
        return err;
    }
    err = fric_est_config_check(&cfg->est, comp_config_exponent_q28(&cfg->comp),
                                cfg->comp.mu_slope_per_n_q28);
    if (err != FE_OK) {
        return err;
    }
    return fric_corr_config_check(&cfg->corr);
}

/* The estimate starts from the configured mu*phi, and the compensator's tables hold it. */
static void est_restart(fw_t *fw)
{
    q3_28_t x0 = comp_config_exponent_q28(&fw->cfg.comp);
    fric_est_configure(&fw->est, &fw->cfg.est, x0);
    fw->est_applied_q28 = x0;
    fric_corr_configure(&fw->corr, &fw->cfg.corr, x0);
}

int32_t fw_configure(fw_t *fw, const fw_config_t *cfg)
{
    if (fw == 0) {
        return FW_ERR_NULL;
    }
    int32_t err = fw_config_check(cfg);
    if (err != FW_OK) {
        return err;
    }
    fw_configure_checked(fw, cfg);
    return FW_OK;
}

void fw_configure_checked(fw_t *fw, const fw_config_t *cfg)
{
    /* The configuration passed fw_config_check (the tick rate in [1, 65535] Hz among it), so
     * none of these can fail half-way. */
    (void)comp_set_tick_rate_hz(&fw->comp, cfg->tick_rate_hz); /* the viscous term's f_tick */
    (void)comp_configure(&fw->comp, &cfg->comp);
    (void)wave_configure(&fw->wave, &cfg->wave, cfg->tick_rate_hz);
    fw->cfg = *cfg;
    est_restart(fw); /* comp_configure rebuilt the tables from mu*phi */
}

void fw_init(fw_t *fw, const hal_t *hal)
{
    fw_config_t cfg;
    fw_config_default(&cfg);
    fw->hal = hal;
    fw->uff_prev_tc = 0;
    fw->uff_primed = 0;
    fw->uff_written = 0;
    comp_init(&fw->comp);
    (void)fw_configure(fw, &cfg); /* the defaults are valid (unit-tested) */
    fw->tel = (fw_telemetry_t){0};
}

static uint32_t ctrl_run_word(const fw_t *fw)
{
    return BOWDEN_CTRL_ENABLE_MASK |
           ((fw->cfg.loop.slew_en != 0) ? BOWDEN_CTRL_SLEW_EN_MASK : 0U);
}

/* Signed words are written sign-extended, as the registers read back (hdl/README.md, Register map). */
static void write_word(const fw_t *fw, uint32_t addr, int32_t value)
{
    hal_write(fw->hal, addr, (uint32_t)value);
}

void fw_start(fw_t *fw)
{
    const fw_loop_config_t *l = &fw->cfg.loop;
    write_word(fw, BOWDEN_REG_CTRL, 0);
    write_word(fw, BOWDEN_REG_KFF, l->kff);
    write_word(fw, BOWDEN_REG_KP, l->kp);
    write_word(fw, BOWDEN_REG_KI_TS, l->ki_ts);
    write_word(fw, BOWDEN_REG_I_LIMIT, l->i_limit);
    write_word(fw, BOWDEN_REG_SLEW, l->slew);
    write_word(fw, BOWDEN_REG_WDT_TIMEOUT, l->wdt_timeout);
    write_word(fw, BOWDEN_REG_ADC_OFFSET, l->adc_offset);
    write_word(fw, BOWDEN_REG_ADC_GAIN, l->adc_gain);
    write_word(fw, BOWDEN_REG_ADC_MIN, l->adc_min);
    write_word(fw, BOWDEN_REG_ADC_MAX, l->adc_max);
    write_word(fw, BOWDEN_REG_ADC_STALE, l->adc_stale);
    write_word(fw, BOWDEN_REG_OC_TIMEOUT, l->oc_timeout);
    write_word(fw, BOWDEN_REG_TC_MIN, fw->cfg.comp.tc_min_n_q8); /* the floor, in the FPGA too */
    if (l->kv != 0 || fw->uff_written != 0) { /* no feedforward left from an earlier run */
        write_word(fw, BOWDEN_REG_UFF, 0);
        fw->uff_written = 0;
    }
    fw->uff_primed = 0;
    write_word(fw, BOWDEN_REG_TC, 0);
    hal_write(fw->hal, BOWDEN_REG_CTRL,
              BOWDEN_CTRL_FAULT_CLEAR_MASK | BOWDEN_CTRL_INTEG_RESET_MASK);
    hal_write(fw->hal, BOWDEN_REG_CTRL, ctrl_run_word(fw));
    comp_reset(&fw->comp);
    if (fw->est_applied_q28 != comp_config_exponent_q28(&fw->cfg.comp)) {
        (void)comp_configure(&fw->comp, &fw->cfg.comp); /* the last run's estimate out */
    }
    /* The estimate from the configured mu*phi again, as est_restart, the configuration's bands
     * kept (fw_configure_checked configured both with fw->cfg: the only place that sets it). */
    const q3_28_t x0 = comp_config_exponent_q28(&fw->cfg.comp);
    fric_est_restart(&fw->est, x0);
    fw->est_applied_q28 = x0;
    fric_corr_restart(&fw->corr, x0);
    /* Phase to phase0: the generator was configured with fw->cfg's wave and rate by
     * fw_configure_checked, the only place that sets them. */
    wave_restart(&fw->wave);
    if (fw->cfg.source == FW_SOURCE_WAVE && fw->cfg.comp.mode == COMP_MODE_PREVIEW) {
        /* The generator runs P ticks ahead: its first P values fill the compensator's line. */
        for (int32_t i = 0; i < fw->cfg.comp.preview_ticks; ++i) {
            (void)comp_step_q7_8(&fw->comp, wave_next_q7_8(&fw->wave));
        }
    }
    fw->tel = (fw_telemetry_t){0};
}

void fw_stop(fw_t *fw)
{
    write_word(fw, BOWDEN_REG_TC, 0);
    write_word(fw, BOWDEN_REG_CTRL, 0);
    if (fw->uff_written != 0) {
        write_word(fw, BOWDEN_REG_UFF, 0);
        fw->uff_written = 0;
    }
}

/*
 * The rate feedforward word: UFF = clamp(round(kv * (T_c - T_c,prev) * f_tick), +-uff_limit), Q3.12 A.
 * Scaling and overflow: kv (Q7.24, <= 2^20) * dT_c (Q7.8, |.| < 2^17) * f_tick (< 2^16 Hz) is
 * below 2^53 in int64, in units of 2^-32 A; + 2^19 and >> 20 (floor) rounds to Q3.12 (half up).
 */
static int32_t uff_word(const fw_loop_config_t *l, int32_t dtc, uint32_t tick_rate_hz)
{
    int64_t v = ((int64_t)l->kv * dtc * (int64_t)tick_rate_hz + (INT64_C(1) << 19)) >> 20;
    if (v > l->uff_limit) {
        v = l->uff_limit;
    } else if (v < -(int64_t)l->uff_limit) {
        v = -(int64_t)l->uff_limit;
    }
    return (int32_t)v;
}

void fw_fault_clear(fw_t *fw)
{
    hal_write(fw->hal, BOWDEN_REG_CTRL, ctrl_run_word(fw) | BOWDEN_CTRL_FAULT_CLEAR_MASK);
}

/* Low 16 bits of a register word as a signed Q value. */
static int32_t word_s16(uint32_t w)
{
    return (int32_t)(int16_t)(uint16_t)(w & 0xFFFFU);
}

q7_8_t fw_tick(fw_t *fw, q7_8_t host_t_ref)
{
    fw_telemetry_t *t = &fw->tel;
    t->status = hal_read(fw->hal, BOWDEN_REG_STATUS);
    t->fault = hal_read(fw->hal, BOWDEN_REG_FAULT);
    t->t_in = word_s16(hal_read(fw->hal, BOWDEN_REG_T_IN));
    t->u = word_s16(hal_read(fw->hal, BOWDEN_REG_U));
    t->sample_count = hal_read(fw->hal, BOWDEN_REG_SAMPLE_COUNT);
    if (t->fault != 0U) {
        ++t->fault_ticks;
    }

    if (fw->cfg.est.enable != 0 || fw->cfg.corr.enable != 0) {
        const fw_loop_config_t *l = &fw->cfg.loop;
        uint32_t raw = hal_read(fw->hal, BOWDEN_REG_T_OUT) & BOWDEN_T_OUT_MASK;
        uint32_t flags = hal_read(fw->hal, BOWDEN_REG_ADC_FLAGS) &
                         (BOWDEN_ADC_FLAGS_DRDY_LOST_MASK | BOWDEN_ADC_FLAGS_CRC_ERR_MASK);
        int32_t code = (int32_t)(raw ^ 0x800000U) - 0x800000; /* sign-extend 24 bits */
        /* The RTL's T_IN conversion without its 16-bit saturation: (code - offset) < 2^25,
         * * gain (|gain| <= 2^15) < 2^40 in int64; Q(-5).20 -> >> 20 with rounding = Q7.8. */
        int32_t t_out = (int32_t)(((int64_t)(code - l->adc_offset) * l->adc_gain +
                                   (INT64_C(1) << 19)) >> 20);
        if (fw->cfg.est.enable != 0) {
            q3_28_t x = fric_est_step(&fw->est, t->t_in, t_out, code, l->adc_min, l->adc_max,
                                      flags);
            if (x != fw->est_applied_q28 &&
                comp_set_exponent_q28(&fw->comp, x) == COMP_OK) { /* x within the bounds */
                fw->est_applied_q28 = x;
            }
            t->est_faults = fw->est.g.faults;
        }
        if (fw->cfg.corr.enable != 0) {
            /* The command limits of the last tick: T_c at its floor or at Q7.8's top, U at the
             * drive's limit, or the loop faulted (the drive off: neither way). */
            uint32_t lim = 0U;
            if (t->t_c >= Q7_8_MAX || t->u >= l->i_limit) {
                lim |= FC_LIM_HI;
            }
            if (t->t_c <= fw->cfg.comp.tc_min_n_q8 || t->u <= -l->i_limit) {
                lim |= FC_LIM_LO;
            }
            if (t->fault != 0U) {
                lim |= FC_LIM_HI | FC_LIM_LO;
            }
            int32_t corr = fric_corr_step(&fw->corr, comp_applied_ref_q8(&fw->comp), t->t_in,
                                          t_out, code, l->adc_min, l->adc_max, flags,
                                          comp_blend_q1_30(&fw->comp), lim);
            const int32_t taring = (fw->corr.tared == 0 && fw->corr.faults == 0U);
            if (taring) {
                /* Until the far-end zero is taken the compensator aims without its tension
                 * offset: the tare needs a slack cable (T_in <= tare_max_n), and an offset of
                 * -0.52 N from calibrate lifted T_in to 0.97 N there, so that TARE latched and
                 * the correction stayed off for the whole run. |offset_n| <= 64 N. */
                corr = fw->cfg.comp.offset_n_q8;
            }
            /* ... and without the slack's root, which lifted fig14's first few mN to 0.5 N and
             * more (sqrt(T_c S)) with the slack of 3.6 N calibrate proposed: TARE again. */
            comp_hold_slack(&fw->comp, taring);
            comp_set_correction_q8(&fw->comp, corr);
            t->corr_n_q8 = corr;
            t->corr_faults = fw->corr.faults;
        }
        t->t_out = t_out;
    }
    t->est_mu_phi_q28 = fw->est_applied_q28;

    q7_8_t t_ref = (fw->cfg.source == FW_SOURCE_WAVE) ? wave_next_q7_8(&fw->wave) : host_t_ref;
    q7_8_t t_c = comp_step_q7_8(&fw->comp, t_ref);
    if (fw->cfg.corr.enable != 0 && fw->corr.tared == 0 && fw->corr.faults == 0U) {
        /* The far-end zero is taken at zero load: T_c at its floor (0 unless configured) until
         * the tare ends, the compensator stepping on so that its line and state stay the run's.
         * Driven, the cable carried the start-up's own tension (in host mode the preview's
         * line reads its first input, T_ref P ticks ahead, 0.07 N on fig14), which the tare took
         * for the cell's offset: the correction then held every output that much above its
         * reference (0.49 % RMS on a plant the compensator knows, 0.27 % without it). */
        t_c = (q7_8_t)fw->cfg.comp.tc_min_n_q8;
    }
    write_word(fw, BOWDEN_REG_TC, t_c); /* refreshes the watchdog */
    if (fw->cfg.loop.kv != 0 || fw->uff_written != 0) {
        /* The first tick after fw_start has no rate and feeds nothing; a feedforward switched
         * off by a new configuration is taken back at once. UFF is written when it changes. */
        const int32_t on = (fw->cfg.loop.kv != 0);
        int32_t w = (on && fw->uff_primed != 0)
                        ? uff_word(&fw->cfg.loop, t_c - fw->uff_prev_tc, fw->cfg.tick_rate_hz)
                        : 0;
        if (w != fw->uff_written) {
            write_word(fw, BOWDEN_REG_UFF, w);
            fw->uff_written = w;
        }
        fw->uff_prev_tc = t_c;
        fw->uff_primed = on;
    }

    ++t->ticks;
    t->t_ref = t_ref;
    t->t_c = t_c;
    t->direction = comp_direction(&fw->comp);
    t->blend_q30 = comp_blend_q1_30(&fw->comp);
    return t_c;
}

const char *fw_strerror(int32_t code)
{
    switch (code) {
    case FW_OK:
        return "ok";
    case COMP_ERR_NULL:
    case WAVE_ERR_NULL:
    case FW_ERR_NULL:
        return "null pointer";
    case COMP_ERR_MODE:
        return "comp.mode: must be 0 (none), 1 (paper), 2 (smooth) or 3 (preview)";
    case COMP_ERR_MU:
        return "comp.mu: outside [0, 1]";
    case COMP_ERR_PHI:
        return "comp.phi_rad: outside [0, 4*pi] rad";
    case COMP_ERR_MU_SLOPE:
        return "comp.mu_slope_per_n: outside [-1/128, 1/128] 1/N, mu + 48 N * slope < 0, or a "
               "gain beyond [exp(-4), exp(4)] below 128 N";
    case COMP_ERR_EXPONENT:
        return "comp.mu: mu * phi exceeds 4 (gain exp(4) = 54.6)";
    case COMP_ERR_OFFSET:
        return "comp.offset_n: outside [-64, 64] N";
    case COMP_ERR_HYSTERESIS:
        return "comp.hysteresis_n: outside [1/256, 32] N";
    case COMP_ERR_BAND:
        return "comp.band_n: outside [1/256, 128] N (a band of zero is not allowed)";
    case COMP_ERR_TC_MIN:
        return "comp.tc_min_n: outside [0, 64] N";
    case COMP_ERR_PREVIEW:
        return "comp.preview_ticks: outside [0, 128] ticks";
    case COMP_ERR_LEAD:
        return "comp.lead_ticks: outside [0, comp.preview_ticks] ticks";
    case COMP_ERR_RAMP:
        return "comp.ramp_ticks: outside [1, 256] ticks";
    case COMP_ERR_DEAD_ZONE:
        return "comp.dead_zone_spread: outside [0, 1], or the widest strand mu * phi * "
               "exp(1.534 * spread) exceeds 4";
    case COMP_ERR_BREAKAWAY:
        return "comp.breakaway: outside [0, 0.25], or (2 * mu + 9/8 * breakaway) * phi exceeds 4";
    case COMP_ERR_SLACK:
        return "comp.slack_tension_n: outside [0, 64] N";
    case COMP_ERR_VISCOUS:
        return "comp.mu_per_inlet_rate: outside [0, 1/16] s/N";
    case COMP_ERR_TICK_RATE:
        return "tick_rate_hz: the compensator's tick outside [1, 65535] Hz";
    case WAVE_ERR_KIND:
        return "wave.kind: must be 0 (constant), 1 (sine), 2 (triangle), 3 (ramp) or 4 (step)";
    case WAVE_ERR_RATE:
        return "wave.rate_hz: outside [1, 65535] Hz";
    case WAVE_ERR_FREQ:
        return "wave.freq_hz: above half the tick rate (Nyquist)";
    case WAVE_ERR_MEAN:
        return "wave.mean_n: outside [-128, 127.996] N";
    case WAVE_ERR_AMPLITUDE:
        return "wave.amplitude_n: outside [0, 128] N";
    case FW_ERR_SOURCE:
        return "source: must be 0 (host) or 1 (wave)";
    case FW_ERR_TICK_RATE:
        return "tick_rate_hz: outside [1, 65535] Hz or above sample_rate_hz";
    case FW_ERR_SAMPLE_RATE:
        return "sample_rate_hz: outside [1, 1000000] Hz";
    case FW_ERR_KFF:
        return "loop.kff: outside [0, 32767] (Q2.13 A/N; a negative gain is refused)";
    case FW_ERR_KP:
        return "loop.kp: outside [0, 32767] (Q2.13 A/N; a negative gain is refused)";
    case FW_ERR_KI_TS:
        return "loop.ki_ts: outside [0, 32767] (Q(-4).20 A/N; a negative gain is refused)";
    case FW_ERR_I_LIMIT:
        return "loop.i_limit: outside the I_LIMIT register [0, 32767] (UQ3.12 A)";
    case FW_ERR_SLEW:
        return "loop.slew: outside the SLEW register [0, 32767] (UQ7.8 N per sample)";
    case FW_ERR_SLEW_EN:
        return "loop.slew_en: must be 0 or 1";
    case FW_ERR_WDT_TIMEOUT:
        return "loop.wdt_timeout: outside [0, 65535] samples or not above two tick periods";
    case FW_ERR_ADC_OFFSET:
        return "loop.adc_offset: outside the 24-bit ADC_OFFSET register";
    case FW_ERR_ADC_GAIN:
        return "loop.adc_gain: outside the ADC_GAIN register [-32768, 32767]";
    case FW_ERR_ADC_MIN:
        return "loop.adc_min: outside the 24-bit ADC_MIN register";
    case FW_ERR_ADC_MAX:
        return "loop.adc_max: outside the 24-bit ADC_MAX register or below adc_min";
    case FW_ERR_ADC_STALE:
        return "loop.adc_stale: outside [0, 65535] samples";
    case FW_ERR_OC_TIMEOUT:
        return "loop.oc_timeout: outside [0, 65535] samples";
    case FW_ERR_KV:
        return "loop.kv: outside [0, 1/16] A s/N";
    case FW_ERR_UFF_LIMIT:
        return "loop.uff_limit: outside [0, 7.9998] A";
    case FE_ERR_NULL:
        return "null pointer";
    case FE_ERR_ENABLE:
        return "est.enable: must be 0 (off) or 1 (on)";
    case FE_ERR_TAU:
        return "est.tau_ticks: must be a power of two in [16, 32768] samples";
    case FE_ERR_RATE:
        return "est.rate: outside [0, 1/16] per tick";
    case FE_ERR_BOUNDS:
        return "est.mu_phi_min/max: outside [0, 4], min not below max, or comp.mu * comp.phi_rad "
               "outside them";
    case FE_ERR_T_MIN:
        return "est.t_min_n: outside [0, 64] N";
    case FE_ERR_SLOPE:
        return "est.enable: the online estimate needs comp.mu_slope_per_n = 0";
    case FC_ERR_ENABLE:
        return "corr.enable: must be 0 (off) or 1 (on)";
    case FC_ERR_KI:
        return "corr.ki_shift: outside [4, 16] (the rate 2^-ki_shift per tick)";
    case FC_ERR_HOLD:
        return "corr.hold_ticks: outside [0, 4096] ticks";
    case FC_ERR_LIMIT:
        return "corr.limit: outside [0, 1] (a relative gain correction)";
    case FC_ERR_TARE:
        return "corr.tare_ticks: must be a power of two in [1, 1024] ticks";
    case FC_ERR_TARE_MAX:
        return "corr.tare_max_n: outside [0, 8] N";
    case FC_ERR_GATE:
        return "corr.slide_gate: must be 0 (off) or 1 (on)";
    case FC_ERR_OFFSET:
        return "corr.offset_term: must be 0 (off) or 1 (on)";
    case FC_ERR_REV:
        return "corr.rev_*: rev_enable and rev_index 0 or 1, rev_ki_shift in [2, 16], rev_bin_shift "
               "in [0, 6] ([0, 7] with rev_index 1), rev_lead_ticks in [0, 64] (0 with rev_index "
               "1), rev_leak_shift in [2, 24]";
    case FC_ERR_REV_LIMIT:
        return "corr.rev_limit: outside [0, 8] N";
    case FC_ERR_KP:
        return "corr.kp: outside [0, 4]";
    default:
        return "unknown status code";
    }
}
