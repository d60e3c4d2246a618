/*
 * soc_api.h - the full-system co-simulation's C interface (build/soc_sim/libbowden_soc_sim.so),
 * mirrored by cosim/bench/emulate/soc/harness.py (ctypes). One call, soc_run(), runs the Verilated
 * soc_tb (hdl/soc/sim/soc_tb.v: bowden_soc executing the firmware image, with its SPI flash
 * model) until `stop` is set, with every pin of the board driven at bit level in C++:
 *
 *   - the UART (8N1 at the SoC's bit time) bridged to a pseudo-terminal's master side;
 *   - the SPI flash's array loaded from `flash_path` and written back to it (temp + rename)
 *     whenever the firmware has erased or programmed it and the flash is idle, and at the end;
 *   - the ADS131M0x at its pins (DRDY, SPI mode 1 frames with the CRC), two channels a cable:
 *     CH 2k = cable k's T_in, CH 2k + 1 its T_out (the ADS131M02 for one cable, the ADS131M04
 *     for two, the ADS131M08 for four);
 *   - each cable's PWM pin measured over each PWM period into its ESCON's current set value;
 *   - each cable's plant: either constant tensions, or an FMI 2.0 instance the caller
 *     initialised (stepped every loop sample with that cable's ESCON current), as
 *     cosim/engines/native does.
 *
 * The library is built for one cable count (the SoC's CHANNELS, SOC_CHANNELS here); `channels`
 * must equal it.
 *
 * Every pointer is owned by the caller; soc_run writes only the outputs.
 */
#ifndef BOWDEN_SOC_API_H
#define BOWDEN_SOC_API_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SOC_API_VERSION 2
#define SOC_MAX_CHANNELS 4 /* bowden_soc's CHANNELS: 1, 2 or 4 */

#define SOC_N_IN 5  /* cosim.parts.plant.INPUT_NAMES */
#define SOC_N_OUT 8 /* cosim.parts.plant.OUTPUT_NAMES */
#define SOC_OUT_T_IN_MEAS 2
#define SOC_OUT_T_OUT_MEAS 3

/* One cable's plant (fmu_component NULL: constant tensions); cosim.parts.plant.FMU_LINK_FIELDS. */
typedef struct {
    void *fmu_component;
    void *fmu_set_real, *fmu_do_step, *fmu_get_real; /* fmi2SetReal / fmi2DoStep / fmi2GetReal */
    uint32_t in_vr[SOC_N_IN], out_vr[SOC_N_OUT];
    double u0[SOC_N_IN];  /* inputs as the instance holds them (x, y, z stay) */
    double y0[SOC_N_OUT]; /* outputs after initialisation */
    double time0_s;
} soc_plant_t;

typedef struct {
    /* --- run ------------------------------------------------------------------------------- */
    int32_t pty_fd;          /* master side of the pty (non-blocking); -1: no serial link */
    const char *flash_path;  /* the flash's content (raw, 2^21 bytes); NULL: blank, not kept */
    double max_sim_s;        /* stop after this much simulated time; <= 0: until `stop` */
    int32_t realtime;        /* 1: never ahead of the wall clock; 0: as fast as it goes */
    volatile int32_t stop;   /* set by the caller (another thread) to end the run */
    volatile int32_t clear_stats; /* set by the caller: the tick and receive figures restart */
    int32_t channels;        /* cables: the library's SOC_CHANNELS (soc_channels()) */
    /* --- sensors: the ADC's codes of a tension, round(offset + T * 2^28 / gain) ----------------- */
    int32_t adc_offset, adc_gain;
    double const_t_in_n, const_t_out_n; /* without plants: every cable's two tensions, N */
    /* --- plants: cable k's in plant[k] (every cable with one, or none) ---------------------- */
    soc_plant_t plant[SOC_MAX_CHANNELS];
    double escon_imax_a;  /* each ESCON's current at 90 % duty */
    /* --- outputs --------------------------------------------------------------------------- */
    int64_t clocks;           /* SoC clocks simulated */
    int64_t boot_clks;        /* reset to the firmware's main loop (its first IDLE phase) */
    int64_t ticks;            /* firmware ticks seen (phase TICK) */
    int64_t tick_worst_clks;  /* the longest tick, clocks */
    int64_t tick_median_clks; /* the median tick, clocks */
    int64_t rx_worst_clks;    /* the longest handling of received bytes (phase RX), clocks */
    int64_t tick_gap_worst_clks; /* the longest time from one tick's start to the next's */
    int64_t uart_rx_bytes, uart_tx_bytes, uart_frame_errors;
    int64_t adc_frames;       /* ADS131M0x frames read by the SoC */
    int64_t flash_saves;
    int64_t plant_steps;      /* FMU steps, every cable's */
    int32_t cpu_trap;
    double wall_s;
    double fmu_s;             /* wall time in the FMU's steps */
    char error[256];
} soc_spec_t;

int32_t soc_api_version(void);
uint32_t soc_spec_size(void);
int32_t soc_clk_hz(void);
/* The cables of the SoC this library simulates. */
int32_t soc_channels(void);
/* The ADS131M0x model's frame CRC of n bits (0 or 1 each, MSB first). */
uint16_t soc_adc_crc(const uint8_t *bits, int32_t n);
/* 0 on a run that ended on `stop` or max_sim_s; 1 with `error` set otherwise. */
int32_t soc_run(soc_spec_t *spec);

#ifdef __cplusplus
}
#endif

#endif /* BOWDEN_SOC_API_H */
