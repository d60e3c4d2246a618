/*
 * comp_f64.h - the double-precision twin of the compensator (host only: it uses libm's exp).
 *
 * The same law as comp.h (Eq. 15-16, the hysteresis detector, the smooth inverse and the audit's
 * extensions) in double, without quantization: it is the oracle the fixed-point compensator is
 * held against, and the compensator of the co-simulation's float reference. Its configuration
 * uses SI units and is checked against the same limits, returning the same COMP_ERR_* codes.
 * Differences from the fixed-point step, by design: no quantization of T_c (only the saturation
 * to the Q7.8 range [-128, 127.99609375] N is kept), gains G_up and G_dn (comp.h) evaluated
 * exactly at |T_eff| rather than interpolated from a table.
 */
#ifndef BOWDEN_COMP_F64_H
#define BOWDEN_COMP_F64_H

#include <stdint.h>

#include "comp.h"

typedef struct {
    int32_t mode;              /* COMP_MODE_* (comp.h) */
    double mu;                 /* [0, 1] */
    double phi_rad;            /* [0, 4*pi] */
    double mu_slope_per_n;     /* [-1/128, 1/128] 1/N, with mu + 48*slope >= 0 */
    double offset_n;           /* [-64, 64] N */
    double hysteresis_n;       /* [1/256, 32] N */
    double band_n;             /* [1/256, 128] N */
    double tc_min_n;           /* floor of T_c, [0, 64] N */
    int32_t preview_ticks;     /* PREVIEW: P, [0, COMP_PREVIEW_MAX_TICKS] ticks */
    int32_t lead_ticks;        /* PREVIEW: L, [0, P] ticks */
    int32_t ramp_ticks;        /* PREVIEW: D, [1, COMP_RAMP_MAX_TICKS] ticks */
    double dead_zone_spread;   /* log std of the friction thresholds, [0, 1] */
    double breakaway;          /* static friction's excess over mu after a reversal, [0, 0.25] */
    double slack_tension_n;    /* input tension below which pretension is lost, [0, 64] N */
    double mu_per_inlet_rate;  /* friction's rise per inlet tension rate, [0, 1/16] s/N */
} comp_f64_config_t;

typedef struct {
    comp_f64_config_t cfg;
    double prev_ref;
    double extreme;
    double blend;   /* s in [0, top]: B (N), or D (ticks) in PREVIEW */
    int32_t dir;
    int32_t started;
    double line[COMP_PREVIEW_MAX_TICKS + 1]; /* PREVIEW: the last P + 1 inputs */
    int32_t line_pos;
    double corr_n; /* the far-end output correction added to T_eff, N (0 after a reset) */
    int32_t slk_held; /* 1 while the slack's root is held off (0 after a reset) */
    int32_t slk_dir;  /* the detector's direction the slack's turn last saw */
    double slk_min;   /* the least T_c below S on the unloading branch, N (0: none) */
    double slk_eff;   /* T_eff at that T_c, N */
    double slk_k;     /* the turn's ratio T_c / T_eff there (0: none) */
    int32_t dz_on;    /* the dead-zone inverse in force (comp.h) */
    int32_t dz_fresh; /* 1 until the plays are set at the next step */
    double dz_r[COMP_DZ_PLAYS]; /* thresholds r'_i of the inverse PI model (i >= 1) */
    double dz_p[COMP_DZ_PLAYS]; /* weights p'_i (i >= 1) */
    double dz_u[COMP_DZ_PLAYS]; /* play states u_i, ln N (i >= 1) */
    double dz_c;                /* the arithmetic mean's shift c */
    double dz_x1;               /* the first play's exponent w_1 */
    int32_t brk_dir;            /* the branch the breakaway's extreme belongs to (0: none yet) */
    double brk_y;               /* Y: the extreme of T_c on that branch, N */
    double brk_last;            /* the last T_c put out, N */
    double brk_full_dn;         /* the hold's factor on Y, unloading (comp.h; with a slope the
                                   turn's, else the configuration's) */
    double brk_full_up;         /* the same, loading */
    int32_t vis_fresh;          /* 1 until the next step sets vis_prev (no rate yet) */
    double vis_prev;            /* T_eff of the last step, N */
    double vis_r;               /* r_hat: the filtered predicted inlet rate, N/s */
    double tick_rate_hz;        /* f_tick, [1, 65535] Hz (comp_f64_set_tick_rate_hz) */
} comp_f64_t;

/* Same defaults as comp_config_default. */
void comp_f64_config_default(comp_f64_config_t *cfg);
/* COMP_OK or the COMP_ERR_* of the first bad field (NaN is out of every range). */
int32_t comp_f64_config_check(const comp_f64_config_t *cfg);
void comp_f64_init(comp_f64_t *c);
int32_t comp_f64_configure(comp_f64_t *c, const comp_f64_config_t *cfg);
void comp_f64_reset(comp_f64_t *c);
/* The far-end output correction (comp_set_correction_q8's twin): T_eff = T_ref - offset + corr,
 * corr clamped to [-16, 16] N; not in mode NONE. */
void comp_f64_set_correction(comp_f64_t *c, double corr_n);
/* comp_hold_slack's twin: the slack's root held off (held != 0) or in force (0) from the next
 * step; in force after a reset. */
void comp_f64_hold_slack(comp_f64_t *c, int32_t held);
/* comp_set_tick_rate_hz's twin: f_tick in Hz, [1, 65535] (COMP_ERR_TICK_RATE outside); 1000 Hz
 * after comp_f64_init. */
int32_t comp_f64_set_tick_rate_hz(comp_f64_t *c, double hz);
/* One step: T_ref in N (any finite value) -> T_c in N, saturated to [-128, 127.99609375]. */
double comp_step_f64(comp_f64_t *c, double t_ref_n);

#endif /* BOWDEN_COMP_F64_H */
