/*
 * bn_api.h - the native closed loop's C interface (libbowden_native.so), mirrored by
 * cosim/engines/native/engine.py (ctypes). One call, bn_run(), runs a whole scenario: the Verilated
 * cosim_top, the firmware (libbowden_fw.so, linked) and the plant FMU (an instance the caller
 * set up through the FMI 2.0 C API, handed over as its component and function pointers), with
 * the timing of the cocotb harness (cosim/engines/cocotb/tb_closed_loop.py, lean AXI4-Lite driver).
 *
 * Every array is owned by the caller; bn_run only writes the outputs and the counters.
 */
#ifndef BOWDEN_NATIVE_API_H
#define BOWDEN_NATIVE_API_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define BN_API_VERSION 9

/* Interface stages (cosim/parts/interface.py). */
#define BN_IFACE_IDEAL 0
#define BN_IFACE_ADC 1
#define BN_IFACE_BOARD 2

#define BN_N_IN 5   /* cosim.parts.plant.INPUT_NAMES */
#define BN_N_OUT 8  /* cosim.parts.plant.OUTPUT_NAMES */
#define BN_OUT_T_OUT 1
#define BN_OUT_T_IN_MEAS 2
#define BN_OUT_T_OUT_MEAS 3

typedef struct {
    /* --- run ------------------------------------------------------------------------------ */
    int64_t n;                  /* samples */
    int32_t decimation;         /* FPGA samples per firmware tick */
    int32_t clks_per_sample;    /* must equal the build's CLKS_PER_SAMPLE */
    int32_t tc_latency_samples; /* cosim.engines.harness.TC_LATENCY_SAMPLES */
    int32_t shadow_refresh_ticks;
    double slew_n;              /* SLEW in N per sample when CTRL.SLEW_EN, else 0 */
    double floor_n;             /* T_c floor (TC_MIN) in N after the slew limit; -inf: none */
    const int16_t *t_ref_word;  /* n: T_ref as the firmware's Q7.8 host word */
    const double *x_m, *y_m, *z_m; /* n: end-effector path */
    /* --- firmware: a configured fw_host_t (cosim.parts.firmware.Firmware's buffer) --------------- */
    void *fw_host;
    /* --- plant: an initialised FMI 2.0 instance ------------------------------------------ */
    void *fmu_component;
    void *fmu_set_real, *fmu_do_step, *fmu_get_real; /* fmi2SetReal / fmi2DoStep / fmi2GetReal */
    uint32_t in_vr[BN_N_IN], out_vr[BN_N_OUT];
    double u0[BN_N_IN];         /* inputs as the instance holds them */
    double y0[BN_N_OUT];        /* outputs after initialisation */
    double time0_s;
    /* --- interface stage (values computed by cosim.parts.interface, so both sides share them) --- */
    int32_t iface;
    int32_t adc_offset, adc_gain; /* calibration for the ideal ADC's code */
    double dt_s;                  /* 1 / sample rate (as the Python stage computes it) */
    double adc_period_s, adc_phase_s, adc_read_s;
    int32_t adc_kernel_n;
    const double *adc_offsets_s, *adc_weights;
    int32_t pwm_ratio, pwm_period_clks, pwm_imax_q12;
    double escon_imax_a, escon_duty_error, escon_duty_resolution, escon_frac;
    /* --- the far-end load cell for the online friction estimate (fric_est.h) ---------------
     * est_feed 1: T_out_meas through a second ADC of the same kernel (the ADS131M02 samples both
     * channels at once), and at every firmware tick the shadow's T_IN (the last code as the RTL
     * converts it), T_OUT (raw code) and ADC_FLAGS (0) are the fresh values a board's MMIO reads
     * would give (the far-end output correction reads the same). Far-end failures: from t_out_stuck_s the code holds; from t_out_absent_s it
     * sits at the positive rail (an open bridge); negative: never. */
    int32_t est_feed;
    double t_out_stuck_s, t_out_absent_s;
    int32_t *out_est_q28; /* n: the firmware's mu*phi in force (telemetry), held between ticks */
    uint32_t est_faults;  /* the estimate's fault bits at the end */
    int32_t *out_corr_q8; /* n: the far-end output correction in force (telemetry), Q7.8 N */
    uint32_t corr_faults; /* the correction's fault bits at the end */
    /* --- outputs -------------------------------------------------------------------------- */
    double *out_tc_n;     /* n: T_c in force in the RTL (after its slew limit) */
    double *out_current_a;/* n: command, A */
    int32_t *out_u_word;  /* n: command word, Q3.12 */
    double *out_rows;     /* n x BN_N_OUT: plant outputs at t_k */
    /* counters and figures */
    int64_t late_writes, tc_mismatch, tc_checks, firmware_ticks;
    uint32_t fault_word, status_word;
    double rtl_s, fmu_s, firmware_s, total_s;
    /* progress (samples done, updated every 1024) and a stop request, both shared with a
     * watching thread */
    volatile int64_t progress;
    volatile int32_t stop;
    char error[256];
    /* the FMU input end_displacement's value reference (bn_run_pair sets it per sample) */
    uint32_t end_vr;
} bn_spec_t;

/* The joint of bn_run_pair (cosim.parts.joint.Joint): its exact step for held inputs, computed
 * by the caller, and the joint's record. */
typedef struct {
    double radius_m;            /* r */
    double phi[4], gam[2];      /* [theta, omega]' = Phi [theta, omega] + Gamma tau (row major) */
    const double *tau_load_n_m; /* n: the load torque at each sample */
    int32_t hold;               /* 1: both far ends held at 0 (the joint still moves) */
    double *theta_rad, *omega_rad_s; /* n: the joint at t_k */
} bn_joint_t;

/* The pair's loop in bn_run_pair: both cables' drive from one Verilated bowden_core_mc (N = 2,
 * one safety group; cosim_pair_top), each firmware's writes landed in its cable's register bank
 * over the core's AXI4-Lite bus before the tick PairSim gives them to the loop's model, both
 * ADC samples as one conversion (one cable's alone when the other's stopped), each bank's
 * TC_EFF and FAULT read back; a load-cell fault per cable. */
typedef struct {
    int32_t fault_kind[2];   /* 0: none, 1: stale (no more samples), 2: open (code 2^23 - 1) */
    int64_t fault_k[2];      /* the fault holds for the ADC delivery of ticks k >= fault_k */
    int32_t *out_faults;     /* n x 2 (row major): each channel's FAULT after tick k */
    uint8_t *out_en;         /* n x 2: its drive enable */
    uint8_t *out_grp_stop;   /* n x 2: its group stop */
    double rtl_s;            /* out: the pair's RTL (clocks and bus) */
    int64_t least_slack_clks; /* out: the fewest clocks between a tick's last write or ADC
                                 strobe and the tick */
} bn_pair_loop_t;

/* BN_API_VERSION, and sizeof(bn_spec_t) so the ctypes mirror can check itself. */
int32_t bn_api_version(void);
uint32_t bn_spec_size(void);
/* The CLKS_PER_SAMPLE the RTL was built with. */
int32_t bn_clks_per_sample(void);
/* math.fsum of x[0..n) as the interface stage's ADC takes it (closed_loop.cpp, fsum_fast);
 * *decided = 0 when the exact fallback (CPython's algorithm) decided (tests/native). */
double bn_fsum(const double *x, int32_t n, int32_t *decided);
/* Run; 0 on success, else non-zero with spec->error set (one line). */
int32_t bn_run(bn_spec_t *spec);
/* Two cables side by side on one joint (cosim/engines/antagonist.py): cable a's far end at
 * -r*theta, b's at +r*theta, the joint driven by their true T_out. With m == NULL each cable's
 * firmware talks to its own cosim_top over AXI4-Lite as in bn_run, whose loop drives it; else
 * the pair's core of bn_pair_loop_t drives both and no cosim_top runs. 0 on success, else non-zero
 * with a->error set. */
int32_t bn_run_pair(bn_spec_t *a, bn_spec_t *b, bn_joint_t *j, bn_pair_loop_t *m);

#ifdef __cplusplus
}
#endif

#endif /* BOWDEN_NATIVE_API_H */
