/*
 * emu.h - the emulator's closed loop in C: the bit-exact model of the FPGA's tension loop
 * (hdl/rtl/tension_loop.v, as cosim/parts/rtl_model.py defines it), the ideal load-cell ADC and the plant
 * FMU, around the bench device (firmware/host/dev_host.h), with the co-simulation's timing
 * (cosim/engines/reference.py::run_model_chain).
 *
 * Python at 10 kHz costs about 37 us per FPGA sample here (rtl_model + plant + ADC, measured under
 * load): a third of a core, which a loaded 2-core machine does not reliably give in real time. In
 * C, emu_step runs a whole firmware tick (D samples) per call. tests/bench holds emu_loop to
 * rtl_model.TensionLoopModel at every sample and the whole chain to its Python twin.
 */
#ifndef BOWDEN_EMU_H
#define BOWDEN_EMU_H

#include <stdint.h>

#include "dev_host.h"

/* --- the FPGA loop ------------------------------------------------------------------------- */

typedef struct {
    /* registers (field values, sign-extended) */
    int32_t tc, kff, kp, ki_ts, i_limit, slew, wdt_timeout, adc_offset, adc_gain, adc_min, adc_max,
        adc_stale, oc_timeout, tc_min, uff;
    uint32_t enable, slew_en;
    /* state */
    int32_t raw;
    uint32_t fresh, tc_written, integ_reset_pending, fault_clear_pending;
    uint32_t stale_cnt, wdt_cnt, oc_cnt, faults, sample_count;
    int32_t t_in, u;
    uint32_t out_en, saturated, sat_hi, sat_lo, wdt_ramp;
    int64_t integ;
    int32_t tc_eff;
    int32_t wdt_ramp_step;
} emu_loop_t;

void emu_loop_reset(emu_loop_t *m);
/* A register write as the bus carries it (byte address, 32-bit word). */
void emu_loop_write(emu_loop_t *m, uint32_t addr, uint32_t word);
void emu_loop_adc(emu_loop_t *m, int32_t code);
void emu_loop_tick(emu_loop_t *m);
/* The STATUS register word. */
uint32_t emu_loop_status(const emu_loop_t *m);

/* --- the chain ----------------------------------------------------------------------------- */

typedef int (*emu_fmi_set_real)(void *c, const uint32_t *vr, uint64_t n, const double *v);
typedef int (*emu_fmi_do_step)(void *c, double t, double h, int no_set_prior);
typedef int (*emu_fmi_get_real)(void *c, const uint32_t *vr, uint64_t n, double *v);

#define EMU_N_IN 5U
#define EMU_N_OUT 8U
/* Plant input and output indices (cosim.parts.plant.INPUT_NAMES / OUTPUT_NAMES order). */
#define EMU_IN_CURRENT 0U
#define EMU_OUT_T_IN_MEAS 2U
#define EMU_OUT_T_OUT_MEAS 3U

typedef struct {
    emu_fmi_set_real set_real;
    emu_fmi_do_step do_step;
    emu_fmi_get_real get_real;
    void *component;
    uint32_t in_vr[EMU_N_IN];
    uint32_t out_vr[EMU_N_OUT];
    double u[EMU_N_IN]; /* inputs held over a step: current, T_in_cmd, x, y, z */
    double y[EMU_N_OUT];
    double time_s;
    double dt_s;           /* FPGA sample period */
    uint32_t decimation;   /* FPGA samples per firmware tick */
    int32_t adc_offset;    /* the physical ADC's calibration (code at zero, gain) */
    int32_t adc_gain;
    emu_loop_t loop;
    int32_t code;          /* ADC code of the last plant output */
    hal_write_t pending[HAL_LOG_CAPACITY];
    uint32_t n_pending;
    uint32_t pending_wait; /* samples to run before the pending writes land */
    uint32_t log_dropped;  /* firmware writes lost (never expected) */
    uint32_t fmi_error;    /* first failing FMI status, 0 when none */
    uint64_t samples;
    /* Optional per-sample record (tests): the command word and T_c in force. */
    int16_t *rec_u;
    int16_t *rec_tc;
    uint32_t rec_cap;
    uint32_t rec_len;
} emu_t;

/* Ideal ADC: the code whose calibrated value is tension_n, rounded half to even, clipped to 24
 * bits (rtl_model.adc_code_from_tension). */
int32_t emu_adc_code(double tension_n, int32_t offset, int32_t gain);

/* Prepare after the caller filled the FMI pointers, value references, u, y, time, dt, decimation
 * and the ADC calibration. */
void emu_init(emu_t *e);
/* One firmware tick period: sample k0 = D*i, the device's tick, then samples k0+1 .. k0+D-1,
 * the firmware's register writes landing before sample k0+2 (TC_LATENCY_SAMPLES). Returns 0, or
 * the FMI status of a failing call (then e->fmi_error holds it). */
int emu_step(emu_t *e, dev_host_t *h, uint32_t time_us);
/* emu_step for the device's first n channels, e[0 .. n) (n <= the device's channels, else -1):
 * each channel's loop and plant take their sample, then one tick of every channel
 * (dev_tick_channels), then each channel's writes and the rest of its samples. emu_step is n = 1. */
int emu_step_channels(emu_t *e, uint32_t n, dev_host_t *h, uint32_t time_us);

#endif /* BOWDEN_EMU_H */
