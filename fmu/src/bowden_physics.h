/* The plant's physics: ESCON-style current loop, RE25 motor with gearhead and spool, elastic
 * Dyneema cable through a sheath with distributed Coulomb friction, isometric output at a load
 * cell, tension sensors. The equations and every assumption are written out in fmu/README.md.
 *
 * Contract with the FMI plumbing (fmi2_plumbing.c), which holds nothing model specific:
 *   - BowdenModel holds p (parameters), u (inputs), y (outputs): the structs generated from the
 *     variable table in fmu/gen_model.py, addressed by value reference via BOWDEN_VAR_TABLE.
 *   - The whole model state is plain data inside BowdenModel (no pointers), so saving and
 *     restoring the FMU state is a copy of the struct.
 *   - bowden_model_defaults, bowden_model_init and bowden_model_step; init and step return 0 or
 *     write a message naming the variable and its allowed range and return non-zero.
 */
#ifndef BOWDEN_PHYSICS_H
#define BOWDEN_PHYSICS_H

#include <stddef.h>
#include <stdint.h>

#include "bowden_vars.h"

/* Sheath segments of the distributed friction model (README, "Sheath friction"). The
   exponential factors are exact per segment, so the quasi-static slopes do not depend on it;
   it sets how finely the tension profile, and so the sheath's stretch, is resolved. The
   convergence study (cosim/convergence, fmu/README.md) builds variants with -DBOWDEN_N_SEG=N. */
#ifndef BOWDEN_N_SEG
#define BOWDEN_N_SEG 32
#endif

/* Friction thresholds of the gradual dead zone (README, "Gradual dead zone"): the lumped
   capstan at BOWDEN_N_STRAND widths mu*phi*exp(dead_zone_spread*q_j), q_j the standard normal
   quantiles at (j + 1/2)/BOWDEN_N_STRAND. The same strands carry the breakaway friction
   (README, "Static friction"). 32 quantiles: the output then stays within about 8 mN RMS of
   the continuous distribution's at spreads up to 0.6 (README, "Convergence"). */
#define BOWDEN_N_STRAND 32

/* Delay line of the output sensor: a fixed grid of BOWDEN_DELAY_DT_S, long enough for the
   largest sensor_delay (0.2 s, gen_model.py) plus two samples of interpolation. */
#define BOWDEN_DELAY_DT_S 25e-6
#define BOWDEN_DELAY_LEN 8192

typedef struct {
    BowdenParams p;
    BowdenInputs u;
    BowdenOutputs y;

    /* state */
    double time_s;
    double current_a;                       /* drive current (first-order lag state) */
    double motor_angle_rad;                 /* motor shaft */
    double motor_speed_rad_s;
    double tension_n[BOWDEN_N_SEG + 1];     /* tension at the nodes, 0 = inlet .. N = outlet */
    double strand_n[BOWDEN_N_STRAND + 1];   /* lumped capstans of the spread thresholds; the
                                               last one at the mean width (the reference) */
    double strand_dir[BOWDEN_N_STRAND + 1]; /* each strand's last slide: +1 towards the
                                               end-effector, -1 back, 0 none yet (static
                                               friction holds a strand that must reverse) */
    double creep_lp_n;                      /* the load cell's creep state: T_out low-pass
                                               filtered with sensor_creep_tau */
    double inlet_disp_m;                    /* cable displacement at the sheath inlet */
    double cable_speed_m_s;                 /* d(inlet_disp_m)/dt */
    double tension_rate_n_s;                /* d(T_in)/dt, filtered as cable_speed_m_s */
    double start_time_s;                    /* time of the start (mu_warmup counts from it) */
    double sensor_lag_n;                    /* output sensor after its first-order lag */
    double sensor_lag2a_n, sensor_lag2b_n;  /* the two stages of its second-order lag */
    double delay_buf_n[BOWDEN_DELAY_LEN];   /* ring buffer of sensor_lag_n on the grid */
    double delay_t0_s;                      /* time of grid sample 0 */
    int64_t delay_count;                    /* grid samples written so far */
    uint64_t rng_state;                     /* xorshift64* state of the sensor noise */
    double noise_in_n, noise_out_n;         /* noise held over the communication step */

    /* caches of derived values (recomputed when their inputs change) */
    double geom_x_m, geom_y_m, geom_z_m;
    double phi_geom_rad;
    int geom_valid;
    double cache_h_s, alpha_current, alpha_sensor, alpha_creep, decay_sensor2;
    double cache_mu, cache_dphi, exp_plus, exp_minus;
} BowdenModel;

/* Parameters and inputs at their start values, state at rest. */
void bowden_model_defaults(BowdenModel *m);

/* Check the parameters and inputs, start the state at rest at time start_time_s (zero tension,
   or the prescribed input tension in drive_mode 1) and compute the outputs. */
int bowden_model_init(BowdenModel *m, double start_time_s, char *msg, size_t msg_len);

/* Advance by step_s with the inputs held, in internal steps of at most p.max_step. */
int bowden_model_step(BowdenModel *m, double step_s, char *msg, size_t msg_len);

/* Check a state that did not come from init and step (a deserialised FMU state): every real of
   the state and the outputs finite, tensions >= 0, counters and the noise generator in their
   domain. Parameters and inputs are checked against their ranges by the caller (the variable
   table). Returns 0, or writes a message naming the first bad member and returns non-zero. */
int bowden_model_check_state(const BowdenModel *m, char *msg, size_t msg_len);

#endif /* BOWDEN_PHYSICS_H */
