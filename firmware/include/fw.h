/*
 * fw.h - the processor's side of the FPGA: configuration of the tension loop, the periodic tick
 * that runs the friction compensator, and telemetry.
 *
 * Each tick (1 kHz by default, called from a timer interrupt or an RTOS task on the target, and by
 * the co-simulation on the host):
 *   1. read STATUS, FAULT, T_IN, U and SAMPLE_COUNT into the telemetry (the previous period);
 *   2. take T_ref from its source: the waveform generator (wave.h) or the value the host passes;
 *   3. T_c = comp_step_q7_8(T_ref) (comp.h);
 *   4. write T_c to TC, which also refreshes the FPGA's watchdog;
 *   5. with the rate feedforward on (loop.kv > 0): write UFF = clamp(round(kv * dT_c/dt),
 *      +-uff_limit), the current the drive needs to move the cable at T_c's rate (the motor's
 *      damping and the cable's stretch; firmware/README.md), outside the PI.
 * With the online friction estimate on (est.enable), between 1 and 3: read T_OUT and ADC_FLAGS,
 * convert T_OUT with the loop's ADC_OFFSET/ADC_GAIN (the far-end cell assumed of the same scale
 * as the drive's; an offset of it does not bias the estimate), step fric_est and hand its
 * mu*phi to the compensator (comp_set_exponent_q28) when it changed. With the far-end output
 * correction on (corr.enable), the same far-end word feeds fric_corr_step with the reference the
 * compensator applied at the last tick, its blend and the command limits reached (T_c at its
 * floor or Q7.8's top, U at +-I_LIMIT, a latched FAULT: both), and the correction goes to the
 * compensator (comp_set_correction_q8) before step 3; until the correction's tare has its last
 * reading, step 4 writes T_c at its floor (comp.tc_min_n), so that the far-end zero is taken at
 * zero load.
 * A latched fault is reported (telemetry fault word, fault_ticks) and never cleared by the tick:
 * clearing a safety latch is the operator's decision (fw_fault_clear). The tick keeps writing TC
 * while a fault is latched, so the watchdog does not add a second fault.
 */
#ifndef BOWDEN_FW_H
#define BOWDEN_FW_H

#include "bowden_q.h"
#include "comp.h"
#include "fric_est.h"
#include "hal.h"
#include "wave.h"

#define FW_SOURCE_HOST 0 /* T_ref passed to fw_tick by the caller */
#define FW_SOURCE_WAVE 1 /* T_ref from the waveform generator */

/* Status codes of fw_configure (COMP_ERR_* 1-9 and WAVE_ERR_* 20-25 pass through unchanged). */
#define FW_OK 0
#define FW_ERR_NULL 40
#define FW_ERR_SOURCE 41      /* source not HOST or WAVE */
#define FW_ERR_TICK_RATE 42   /* tick rate outside [1, 65535] Hz, or above the FPGA sample rate */
#define FW_ERR_SAMPLE_RATE 43 /* FPGA sample rate outside [1, 1e6] Hz */
#define FW_ERR_KFF 44
#define FW_ERR_KP 45
#define FW_ERR_KI_TS 46
#define FW_ERR_I_LIMIT 47
#define FW_ERR_SLEW 48
#define FW_ERR_WDT_TIMEOUT 49 /* outside the register, or not above two tick periods */
#define FW_ERR_ADC_OFFSET 50
#define FW_ERR_ADC_GAIN 51
#define FW_ERR_ADC_MIN 52
#define FW_ERR_ADC_MAX 53     /* outside the register, or below ADC_MIN */
#define FW_ERR_ADC_STALE 54
#define FW_ERR_OC_TIMEOUT 55
#define FW_ERR_SLEW_EN 56     /* not 0 or 1 */
#define FW_ERR_KV 57          /* rate feedforward gain outside [0, FW_KV_MAX] */
#define FW_ERR_UFF_LIMIT 58   /* rate feedforward limit outside [0, 32767] (UQ3.12 A) */

/* Rate feedforward (written to UFF at each tick, outside the PI): kv in A s/N, Q7.24, at most
 * 1/16 A s/N (2^20); its current is bounded by uff_limit (UQ3.12 A). Default off (kv 0). */
#define FW_KV_MAX 1048576
#define FW_UFF_LIMIT_DEFAULT 2048 /* 0.5 A */

/* Register words of the FPGA's loop, in the formats of bowden_regs.h (defaults: reset values). */
typedef struct {
    int32_t kff;          /* KFF, Q2.13 A/N */
    int32_t kp;           /* KP, Q2.13 A/N */
    int32_t ki_ts;        /* KI_TS, Q(-4).20 A/N per sample */
    int32_t i_limit;      /* I_LIMIT, UQ3.12 A */
    int32_t slew;         /* SLEW, UQ7.8 N per sample */
    int32_t slew_en;      /* CTRL.SLEW_EN, 0 or 1 */
    int32_t wdt_timeout;  /* WDT_TIMEOUT, samples (0 disables) */
    int32_t adc_offset;   /* ADC_OFFSET, code */
    int32_t adc_gain;     /* ADC_GAIN, Q(-5).20 */
    int32_t adc_min;      /* ADC_MIN, code */
    int32_t adc_max;      /* ADC_MAX, code */
    int32_t adc_stale;    /* ADC_STALE, samples */
    int32_t oc_timeout;   /* OC_TIMEOUT, samples */
    int32_t kv;           /* rate feedforward gain, A s/N, Q7.24, [0, 1/16] (FW_KV_MAX); 0: off */
    int32_t uff_limit;    /* |UFF| bound, UQ3.12 A, [0, 7.9998] (UFF's positive range) */
} fw_loop_config_t;

typedef struct {
    uint32_t tick_rate_hz;   /* processor tick, [1, 65535] Hz; default 1000 */
    uint32_t sample_rate_hz; /* FPGA loop sample rate, for the watchdog check, [1, 1000000] Hz;
                                default 10000 */
    int32_t source;          /* FW_SOURCE_* */
    comp_config_t comp;
    wave_config_t wave;
    fw_loop_config_t loop;
    fric_est_config_t est; /* online friction estimate (fric_est.h), off by default */
    fric_corr_config_t corr; /* far-end output correction (fric_est.h), off by default */
} fw_config_t;

/* Telemetry of the last tick (words as read from the FPGA, sign-extended where signed). */
typedef struct {
    uint32_t ticks;        /* ticks since fw_start */
    int32_t t_ref;         /* Q7.8 N */
    int32_t t_c;           /* Q7.8 N, written to TC */
    int32_t t_in;          /* T_IN, Q7.8 N */
    int32_t u;             /* U, Q3.12 A */
    uint32_t status;       /* STATUS */
    uint32_t fault;        /* FAULT (latched flags) */
    uint32_t sample_count; /* SAMPLE_COUNT */
    uint32_t fault_ticks;  /* ticks that saw a latched fault */
    int32_t direction;     /* compensator direction, +1 loading, -1 unloading */
    int32_t blend_q30;     /* compensator blend weight s/B, Q1.30 */
    int32_t t_out;         /* with the estimate on: T_OUT converted, Q7.8 N (32-bit), else 0 */
    int32_t est_mu_phi_q28; /* the compensator's mu*phi in force, Q3.28 */
    uint32_t est_faults;   /* FE_FAULT_* of the estimate (latched until fw_start) */
    int32_t corr_n_q8;     /* the far-end output correction in force, Q7.8 N (0 while off) */
    uint32_t corr_faults;  /* FC_FAULT_* of the correction (latched until fw_start) */
} fw_telemetry_t;

typedef struct {
    const hal_t *hal;
    fw_config_t cfg;
    comp_t comp;
    wave_t wave;
    fric_est_t est;
    fric_corr_t corr;        /* the far-end output correction */
    q3_28_t est_applied_q28; /* the exponent the compensator's tables hold */
    fw_telemetry_t tel;
    int32_t uff_prev_tc;     /* rate feedforward: the T_c of the previous tick, Q7.8 N */
    int32_t uff_primed;      /* a previous T_c exists since fw_start (the first tick feeds none) */
    int32_t uff_written;     /* the last UFF word written (0 after fw_stop) */
} fw_t;

/* Defaults: 1 kHz tick, 10 kHz FPGA, host source, comp/wave defaults, register reset values. */
void fw_config_default(fw_config_t *cfg);
/* COMP_OK/FW_OK (0) or the code of the first bad field. */
int32_t fw_config_check(const fw_config_t *cfg);
/* Bind to a HAL and apply the defaults. */
void fw_init(fw_t *fw, const hal_t *hal);
/* Apply a configuration; on error return its code and leave everything as it was. Takes effect
 * in the FPGA at the next fw_start. */
int32_t fw_configure(fw_t *fw, const fw_config_t *cfg);
/* fw_configure without its check, for a configuration fw_config_check has just accepted (the
 * device's settings after params_set or flash_load, which check them): the check runs once. */
void fw_configure_checked(fw_t *fw, const fw_config_t *cfg);
/* Disable the loop, write every loop register, TC = 0, clear faults and the integrator, enable. */
void fw_start(fw_t *fw);
/* TC = 0 and disable the loop (drive enable drops). */
void fw_stop(fw_t *fw);
/* Clear the latched faults (CTRL.FAULT_CLEAR pulse, keeping ENABLE and SLEW_EN). */
void fw_fault_clear(fw_t *fw);
/* The periodic tick (see above); host_t_ref is used when the source is FW_SOURCE_HOST. Returns
 * the T_c written to TC. */
q7_8_t fw_tick(fw_t *fw, q7_8_t host_t_ref);
/* A one-line description of a status code naming the field and its allowed range. */
const char *fw_strerror(int32_t code);

#endif /* BOWDEN_FW_H */
