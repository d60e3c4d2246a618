/* The plant's physics; equations and assumptions in fmu/README.md (section numbers below). */
#include "bowden_physics.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bowden_geometry.h"

#define TWO_PI 6.283185307179586476925286766559

/* At most this many internal steps per communication step (1 s at a 1e-7 s max_step... the
   bound only stops a runaway request, such as a step of a year). */
#define BOWDEN_MAX_SUBSTEPS 100000000.0

/* Newton iterations of the cable compatibility (README, "Cable compatibility"). The residual
   is piecewise linear in T_in, so Newton ends in (number of kinks crossed + 1) iterations; the
   bracket turns any cycling into bisection, which 60 iterations take below 1e-18 of the range. */
#define BOWDEN_NEWTON_MAX 60

/* Time constant of the cable-speed and tension-rate estimates that mu_viscous and
   mu_viscous_tension_rate use [s] (assumed; README). */
#define BOWDEN_SPEED_TAU_S 0.01

void bowden_model_defaults(BowdenModel *m)
{
    const BowdenParams p = BOWDEN_PARAMS_DEFAULT;
    const BowdenInputs u = BOWDEN_INPUTS_DEFAULT;
    memset(m, 0, sizeof(*m));
    m->p = p;
    m->u = u;
}

/* ---- sensor noise: xorshift64* seeded through splitmix64, Box-Muller (README, "Sensors") -- */

static uint64_t splitmix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
}

static uint64_t rng_next(uint64_t *state)
{
    uint64_t x = *state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *state = x;
    return x * 0x2545F4914F6CDD1DULL;
}

/* Uniform in (0, 1]: the top 53 bits plus one, so that log() never sees 0. */
static double rng_uniform(uint64_t *state)
{
    return ((double)(rng_next(state) >> 11) + 1.0) * (1.0 / 9007199254740992.0);
}

static void rng_gauss_pair(uint64_t *state, double *g1, double *g2)
{
    double r = sqrt(-2.0 * log(rng_uniform(state)));
    double a = TWO_PI * rng_uniform(state);
    *g1 = r * cos(a);
    *g2 = r * sin(a);
}

/* ---- geometry ----------------------------------------------------------------------------- */

static int update_geometry(BowdenModel *m, char *msg, size_t msg_len)
{
    double phi;
    BowdenGeomStatus st;
    if (m->geom_valid && m->u.x == m->geom_x_m && m->u.y == m->geom_y_m &&
        m->u.z == m->geom_z_m) {
        return 0;
    }
    st = bowden_geometry_phi(m->u.x, m->u.y, m->u.z, m->p.sheath_length, m->p.loop_routing,
                             &phi);
    if (st != BOWDEN_GEOM_OK) {
        if (st == BOWDEN_GEOM_OUTSIDE) {
            snprintf(msg, msg_len,
                     "position x, y, z = (%g, %g, %g) m is outside the reachable workspace: "
                     "allowed is sqrt(x^2 + y^2 + z^2) <= sheath_length = %g m and y >= 0 "
                     "(paper Eq. 13, half-sphere in front of the actuator)",
                     m->u.x, m->u.y, m->u.z, m->p.sheath_length);
        } else {
            snprintf(msg, msg_len, "position x, y, z = (%g, %g, %g) m must be finite", m->u.x,
                     m->u.y, m->u.z);
        }
        m->geom_valid = 0;
        return 1;
    }
    m->geom_x_m = m->u.x;
    m->geom_y_m = m->u.y;
    m->geom_z_m = m->u.z;
    m->phi_geom_rad = phi;
    m->geom_valid = 1;
    return 0;
}

/* Bending angle seen by the friction: geometry plus the bending error along x, y and z and its
   quadratic surface (README, "Bending angle error"). */
static double effective_phi(const BowdenModel *m)
{
    const double x = m->u.x, y = m->u.y, z = m->u.z;
    double phi = m->phi_geom_rad + m->p.phi_offset_per_x * x + m->p.phi_offset_per_y * y
                 + m->p.phi_offset_per_z * z;
    if (m->p.phi_offset_per_xx != 0.0 || m->p.phi_offset_per_yy != 0.0
        || m->p.phi_offset_per_zz != 0.0 || m->p.phi_offset_per_xy != 0.0
        || m->p.phi_offset_per_xz != 0.0 || m->p.phi_offset_per_yz != 0.0) {
        /* only when set: without the surface phi is bit for bit what it was */
        phi += m->p.phi_offset_per_xx * x * x + m->p.phi_offset_per_yy * y * y
               + m->p.phi_offset_per_zz * z * z + m->p.phi_offset_per_xy * x * y
               + m->p.phi_offset_per_xz * x * z + m->p.phi_offset_per_yz * y * z;
    }
    return phi > 0.0 ? phi : 0.0;
}

/* ---- sheath friction (README, "Sheath friction") ------------------------------------------ */

typedef struct {
    double mu;          /* friction coefficient of the step, >= 0, without the tension part */
    double dphi;        /* bending per segment [rad] */
    double mu_base;     /* friction coefficient before the tension-dependent part */
    double slope;       /* mu_tension_slope [1/N] */
    double e_plus;      /* exp(+mu dphi), valid when slope == 0 */
    double e_minus;     /* exp(-mu dphi) */
} Friction;

/* The drift's free form (README, "Friction drift"): mu's change read from the table of
   BOWDEN_DRIFT_KNOTS knots, linear between them and held flat outside; 0 with every knot 0. */
static double drift_table(const BowdenModel *m)
{
    const double knots[BOWDEN_DRIFT_KNOTS] = BOWDEN_DRIFT_TABLE(m->p);
    double s = (m->time_s - m->p.mu_drift_table_t0) / m->p.mu_drift_table_dt;
    int i;
    if (!(s > 0.0)) {
        return knots[0];
    }
    if (s >= (double)(BOWDEN_DRIFT_KNOTS - 1)) {
        return knots[BOWDEN_DRIFT_KNOTS - 1];
    }
    i = (int)s; /* 0 <= s < BOWDEN_DRIFT_KNOTS - 1: in range */
    return knots[i] + (s - (double)i) * (knots[i + 1] - knots[i]);
}

static Friction friction_now(BowdenModel *m)
{
    double table;
    Friction f;
    double mu = m->p.mu + m->p.mu_viscous * fabs(m->cable_speed_m_s) +
                m->p.mu_viscous_tension_rate * fabs(m->tension_rate_n_s) +
                m->p.mu_drift * m->time_s;
    /* the drift's other forms (README, "Friction drift") */
    if (m->p.mu_warmup != 0.0) {
        mu += m->p.mu_warmup * (1.0 - exp(-(m->time_s - m->start_time_s) / m->p.mu_warmup_tau));
    }
    if (m->p.mu_step != 0.0 && m->time_s >= m->p.mu_step_time) {
        mu += m->p.mu_step;
    }
    table = drift_table(m);
    if (table != 0.0) { /* an empty table leaves mu as it was, bit for bit */
        mu += table;
    }
    f.dphi = effective_phi(m) / BOWDEN_N_SEG;
    f.mu_base = mu;
    f.slope = m->p.mu_tension_slope;
    if (mu < 0.0) {
        mu = 0.0; /* a drifting or negative-slope coefficient stops at frictionless */
    }
    f.mu = mu;
    if (mu != m->cache_mu || f.dphi != m->cache_dphi) {
        m->cache_mu = mu;
        m->cache_dphi = f.dphi;
        m->exp_plus = exp(mu * f.dphi);
        m->exp_minus = 1.0 / m->exp_plus;
    }
    f.e_plus = m->exp_plus;
    f.e_minus = m->exp_minus;
    return f;
}

/* Tension profile for inlet tension t_in_n given the previous profile `old` (Eq. 1-3 on each
 * segment): node k stays where it was unless that violates the capstan bound to node k-1,
 * T_{k-1} exp(-mu dphi) <= T_k <= T_{k-1} exp(+mu dphi), in which case it slips to the bound.
 * Writes the profile to out[] and d out / d t_in_n to dout[]; returns the stretch
 * integral ds * sum of segment means (trapezoid) in N m. */
static double profile(const Friction *f, const double *old, double t_in_n, double ds_m,
                      double *out, double *dout)
{
    double sum = 0.0;
    int k;
    out[0] = t_in_n;
    dout[0] = 1.0;
    for (k = 1; k <= BOWDEN_N_SEG; k++) {
        double ep = f->e_plus, em = f->e_minus;
        double lo, hi;
        if (f->slope != 0.0) {
            double mu = f->mu_base + f->slope * out[k - 1];
            ep = exp((mu > 0.0 ? mu : 0.0) * f->dphi);
            em = 1.0 / ep;
        }
        lo = out[k - 1] * em;
        hi = out[k - 1] * ep;
        if (old[k] < lo) {
            out[k] = lo;
            dout[k] = dout[k - 1] * em;
        } else if (old[k] > hi) {
            out[k] = hi;
            dout[k] = dout[k - 1] * ep;
        } else {
            out[k] = old[k];
            dout[k] = 0.0;
        }
        sum += 0.5 * (out[k - 1] + out[k]);
    }
    return sum * ds_m;
}

/* Gradual dead zone (README, "Gradual dead zone"): BOWDEN_N_STRAND lumped capstans on the inlet
 * tension, strand j of width w_j = mu*phi*exp(spread*q_j), q_j the standard normal quantiles at
 * (j + 1/2)/N_STRAND (a log-normal distribution of friction thresholds with median mu*phi and
 * log standard deviation dead_zone_spread), and one of width mu*phi; each holds its tension
 * unless T_in exp(-w) <= T <= T_in exp(+w) is violated, then slides to the bound (the lumped
 * form of Eq. 1-3). Only when dead_zone_spread > 0. */
static const double STRAND_Q[BOWDEN_N_STRAND] = {
    -2.1538746940614564, -1.6759397227734438, -1.4177971379962671, -1.229858759216589,
    -1.0775155670402803, -0.94678175630104566, -0.83051087820539926, -0.72451438349236541,
    -0.62609901234642118, -0.53340970624128059, -0.44509652498551638, -0.36012989178956945,
    -0.27769043982157676, -0.1970990842943123, -0.1177698745790953, -0.039176085503097625,
    0.039176085503097625, 0.1177698745790953, 0.1970990842943123, 0.27769043982157676,
    0.36012989178956945, 0.44509652498551638, 0.53340970624128059, 0.62609901234642118,
    0.72451438349236541, 0.83051087820539926, 0.94678175630104566, 1.0775155670402803,
    1.229858759216589, 1.4177971379962671, 1.6759397227734438, 2.1538746940614564};

/* The strands are followed when the dead zone is gradual or the friction has a breakaway
   part (README, "Static friction"); otherwise the output is the sheath's outlet node. */
static int strands_active(const BowdenModel *m)
{
    return m->p.dead_zone_spread > 0.0 || m->p.mu_static_excess > 0.0;
}

/* A strand's bounds with a tension slope (README, "Gradual dead zone"): the capstan of Eq. 1 with
 * the strand's coefficient (mu + slope T) sc integrated along the whole bend phi,
 *   pulled:   lo = T_in / (E + sl qf T_in),   released: hi = T_in E / (1 - sl qf T_in),
 * with E = exp(mu sc phi) (`e`), sl = slope sc and qf = (E - 1) / (mu sc) (phi at mu = 0): the
 * bounds the sheath's segments reach on each branch, so the reference strand turns with the
 * outlet node. A coefficient that the slope would take below zero is held at frictionless
 * (lo <= T_in, hi >= T_in), as the segments hold theirs; a released bound that grows without
 * limit (a positive slope where 1 - sl qf T_in <= 0) holds any strand. */
static void strand_bounds_sloped(double t_in_n, double e, double mu_sc, double sl, double phi,
                                 double *lo, double *hi)
{
    const double qf = mu_sc > 0.0 ? (e - 1.0) / mu_sc : phi;
    const double den_lo = e + sl * qf * t_in_n;
    const double den_hi = 1.0 - sl * qf * t_in_n;
    *lo = t_in_n / (den_lo > 1.0 ? den_lo : 1.0);
    if (den_hi <= 0.0) {
        *hi = DBL_MAX;
    } else {
        const double g = e / den_hi;
        *hi = t_in_n * (g > 1.0 ? g : 1.0);
    }
}

/* Static friction (README, "Static friction"): a strand that last slid one way and must now
 * slide the other way is held by the breakaway width ws_j = (mu + mu_static_excess) phi
 * exp(spread q_j) instead of w_j; once it breaks loose it slides to the kinetic bound (a jump:
 * stick-slip), and keeps the kinetic width while it goes on sliding the same way. The reference
 * strand has no breakaway part, so the output carries the strands' stick-slip. With a tension
 * slope every width follows the tension as the segments' do (strand_bounds_sloped): with the
 * strands at the slope-free widths, the outlet node (sloped) and the reference strand turned at
 * different inlet tensions, and a breakaway lifted the output above its level at a reversal
 * while the inlet tension fell. */
static void strands_update(BowdenModel *m, const Friction *f, double t_in_n)
{
    const double phi = f->dphi * BOWDEN_N_SEG;
    const double w = f->mu * phi;
    const double ws = (f->mu + m->p.mu_static_excess) * phi;
    const double slope = f->slope;
    int j;
    if (!strands_active(m)) {
        return;
    }
    for (j = 0; j <= BOWDEN_N_STRAND; j++) {
        double q = j < BOWDEN_N_STRAND ? STRAND_Q[j] : 0.0;
        double s = exp(m->p.dead_zone_spread * q);
        const int brk = j < BOWDEN_N_STRAND && m->p.mu_static_excess > 0.0;
        double e = exp(w * s);
        double es = brk ? exp(ws * s) : e;
        double klo, khi, slo, shi, lo, hi;
        if (slope != 0.0) {
            strand_bounds_sloped(t_in_n, e, f->mu * s, slope * s, phi, &klo, &khi);
            if (brk) {
                strand_bounds_sloped(t_in_n, es, (f->mu + m->p.mu_static_excess) * s,
                                     slope * s, phi, &slo, &shi);
            } else {
                slo = klo;
                shi = khi;
            }
        } else {
            /* products with the inverse factors, as the audit's twin computes them (without a
               breakaway part es is e: one division) */
            double ie = 1.0 / e, ies = es == e ? ie : 1.0 / es;
            klo = t_in_n * ie;
            khi = t_in_n * e;
            slo = t_in_n * ies;
            shi = t_in_n * es;
        }
        lo = m->strand_dir[j] > 0.0 ? klo : slo;
        hi = m->strand_dir[j] < 0.0 ? khi : shi;
        if (m->strand_n[j] < lo) {
            m->strand_n[j] = klo;
            m->strand_dir[j] = 1.0;
        } else if (m->strand_n[j] > hi) {
            m->strand_n[j] = khi;
            m->strand_dir[j] = -1.0;
        }
    }
}

/* The slack's free form (README, "Slack"): the share of the output lost at the input tension
   T_in, read from the table of BOWDEN_SLACK_KNOTS knots at T_in = i * slack_table_dt, linear
   between them and to 0 at T_in = BOWDEN_SLACK_KNOTS * slack_table_dt, 0 above and the first
   knot's below 0; 0 with every knot 0 (then 1 - 0 leaves the output bit for bit). */
static double slack_table(const BowdenModel *m)
{
    const double knots[BOWDEN_SLACK_KNOTS] = BOWDEN_SLACK_TABLE(m->p);
    double s = m->tension_n[0] / m->p.slack_table_dt;
    double next;
    int i;
    if (!(s > 0.0)) {
        return knots[0];
    }
    if (s >= (double)BOWDEN_SLACK_KNOTS) {
        return 0.0;
    }
    i = (int)s; /* 0 <= s < BOWDEN_SLACK_KNOTS: in range */
    next = i + 1 < BOWDEN_SLACK_KNOTS ? knots[i + 1] : 0.0;
    return knots[i] + (s - (double)i) * (next - knots[i]);
}

/* The output tension: the sheath's outlet node, times the strands' mean over the reference
 * strand (1 without spread and breakaway): the strands shape the transition through the dead
 * zone and keep the sheath's profile, which sets the stretch (README, assumption A16); below
 * slack_tension the cable has lost part of its pretension (README, "Slack"). */
static double output_tension(const BowdenModel *m)
{
    double sum = 0.0, ref = m->strand_n[BOWDEN_N_STRAND], out = m->tension_n[BOWDEN_N_SEG];
    int j;
    if (strands_active(m) && ref > 0.0) {
        for (j = 0; j < BOWDEN_N_STRAND; j++) {
            sum += m->strand_n[j];
        }
        out *= (sum / BOWDEN_N_STRAND) / ref;
    }
    if (m->p.slack_tension > 0.0 && m->tension_n[0] < m->p.slack_tension) {
        out *= m->tension_n[0] / m->p.slack_tension;
    }
    return out * (1.0 - slack_table(m));
}

/* The load cell's reading of a true output tension after its creep (README, "Load-cell
   creep"): a share sensor_creep of a change is read only as creep_lp_n follows it. */
static double creep_reading(const BowdenModel *m, double t_out_n)
{
    return t_out_n - m->p.sensor_creep * (t_out_n - m->creep_lp_n);
}

/* The output sensor's full scale (README, "Sensor saturation"): a hard clip at
   sensor_full_scale, or with a knee k > 0 the hyperbolic turn
   0.5 (r + F - sqrt((r - F)^2 + k^2)) shifted so that a zero reading stays zero. */
static double saturate(const BowdenModel *m, double r)
{
    const double fs = m->p.sensor_full_scale, k = m->p.sensor_saturation_knee;
    if (fs <= 0.0) {
        return r;
    }
    if (k <= 0.0) {
        return r < fs ? r : fs;
    }
    return 0.5 * (r + fs - sqrt((r - fs) * (r - fs) + k * k)) + 0.5 * (sqrt(fs * fs + k * k) - fs);
}

/* Cable displacement at the inlet relative to the sheath: the stretch of the cable inside the
   sheath plus the deflection of the load cell that holds its end. */
static double inlet_displacement(const BowdenModel *m, double stretch_nm, double t_out_n)
{
    return stretch_nm / m->p.cable_EA + t_out_n / m->p.loadcell_stiffness;
}

/* Drive mode 0: find T_in and the profile such that the spool take-up equals the stretch of
 * the free cable plus the inlet displacement (README, "Cable compatibility"), where the take-up
 * itself depends on T_in through the implicit motor step: take_up = take_up0 - compliance*T_in
 * (compliance = 0 gives the take-up as fixed). Returns T_in; take_up0 <= 0: slack cable. */
static double solve_tension(BowdenModel *m, const Friction *f, double take_up0_m,
                            double compliance_m_n)
{
    double trial[BOWDEN_N_SEG + 1], dtrial[BOWDEN_N_SEG + 1];
    const double ea = m->p.cable_EA;
    const double ds = m->p.sheath_length / BOWDEN_N_SEG;
    double lo = 0.0, hi, t;
    int it;

    if (take_up0_m <= 0.0) {
        memset(m->tension_n, 0, sizeof(m->tension_n));
        return 0.0;
    }
    /* g(T) >= T*(free_length/EA + compliance) - take_up0, so g(hi) >= 0 */
    hi = take_up0_m / (m->p.free_length / ea + compliance_m_n);
    t = m->tension_n[0];
    if (!(t > lo && t < hi)) {
        t = 0.5 * hi;
    }
    for (it = 0; it < BOWDEN_NEWTON_MAX; it++) {
        double stretch = profile(f, m->tension_n, t, ds, trial, dtrial);
        double dsum = 0.0, g, dg, t_next;
        int k;
        g = t * (m->p.free_length / ea + compliance_m_n) +
            inlet_displacement(m, stretch, trial[BOWDEN_N_SEG]) - take_up0_m;
        for (k = 1; k <= BOWDEN_N_SEG; k++) {
            dsum += 0.5 * (dtrial[k - 1] + dtrial[k]);
        }
        dg = m->p.free_length / ea + compliance_m_n + dsum * ds / ea +
             dtrial[BOWDEN_N_SEG] / m->p.loadcell_stiffness;
        if (g > 0.0) {
            hi = t;
        } else {
            lo = t;
        }
        t_next = t - g / dg;
        if (!(t_next > lo && t_next < hi)) {
            t_next = 0.5 * (lo + hi);
        }
        if (fabs(t_next - t) <= 1e-12 * (1.0 + t)) {
            break; /* trial[] is the profile of t, which the next step would not change */
        }
        t = t_next;
    }
    if (it == BOWDEN_NEWTON_MAX) {
        profile(f, m->tension_n, t, ds, trial, dtrial);
    }
    memcpy(m->tension_n, trial, sizeof(m->tension_n));
    return t;
}

/* ---- sensors ------------------------------------------------------------------------------ */

/* Write the grid samples of the lagged output-sensor signal that fall in (ta, tb]. */
static void delay_push(BowdenModel *m, double ta_s, double ya, double tb_s, double yb)
{
    for (;;) {
        double tg = m->delay_t0_s + (double)m->delay_count * BOWDEN_DELAY_DT_S;
        double frac;
        if (tg > tb_s) {
            break;
        }
        frac = tb_s > ta_s ? (tg - ta_s) / (tb_s - ta_s) : 1.0;
        m->delay_buf_n[m->delay_count % BOWDEN_DELAY_LEN] = ya + (yb - ya) * frac;
        m->delay_count++;
    }
}

/* The lagged signal sensor_delay ago, interpolated linearly on the grid. */
static double delay_read(const BowdenModel *m)
{
    double td, kf, frac;
    int64_t k0, last;
    if (m->p.sensor_delay <= 0.0) {
        return m->sensor_lag_n;
    }
    td = m->time_s - m->p.sensor_delay - m->delay_t0_s;
    if (td <= 0.0) {
        return m->delay_buf_n[0]; /* before the start the sensor read the initial value */
    }
    kf = td / BOWDEN_DELAY_DT_S;
    k0 = (int64_t)floor(kf);
    last = m->delay_count - 1;
    if (k0 >= last) {
        double t_last = (double)last * BOWDEN_DELAY_DT_S;
        double span = (m->time_s - m->delay_t0_s) - t_last;
        double y_last = m->delay_buf_n[last % BOWDEN_DELAY_LEN];
        frac = span > 0.0 ? (td - t_last) / span : 1.0;
        return y_last + (m->sensor_lag_n - y_last) * frac;
    }
    frac = kf - (double)k0;
    return m->delay_buf_n[k0 % BOWDEN_DELAY_LEN] +
           (m->delay_buf_n[(k0 + 1) % BOWDEN_DELAY_LEN] - m->delay_buf_n[k0 % BOWDEN_DELAY_LEN]) *
               frac;
}

static void compute_outputs(BowdenModel *m)
{
    double phi = effective_phi(m);
    m->y.T_in = m->tension_n[0];
    m->y.T_out = output_tension(m);
    m->y.T_in_meas = m->y.T_in + m->noise_in_n;
    m->y.T_out_meas =
        saturate(m, m->p.sensor_gain * delay_read(m) + m->p.sensor_offset) + m->noise_out_n;
    m->y.phi = phi;
    m->y.motor_angle = m->motor_angle_rad;
    m->y.motor_speed = m->motor_speed_rad_s;
    m->y.current = m->current_a;
}

static int outputs_finite(const BowdenModel *m, char *msg, size_t msg_len)
{
    const double v[] = {m->y.T_in,  m->y.T_out,       m->y.T_in_meas,   m->y.T_out_meas,
                        m->y.phi,   m->y.motor_angle, m->y.motor_speed, m->y.current};
    size_t i;
    for (i = 0; i < sizeof(v) / sizeof(v[0]); i++) {
        if (!isfinite(v[i])) {
            snprintf(msg, msg_len,
                     "numerical failure at t = %g s: an output is not finite; reduce max_step "
                     "(allowed 1e-07 .. 0.001 s, now %g s)",
                     m->time_s, m->p.max_step);
            return 1;
        }
    }
    return 0;
}

/* ---- drive, motor, cable (README, "Drive and motor", "Cable compatibility") ---------------- */

/* Quasi-static current that holds T_in against the gearhead (the inverse of Kff). */
static double holding_current(const BowdenModel *m, double t_in_n)
{
    return t_in_n * m->p.spool_radius /
           (m->p.gear_ratio * m->p.gear_efficiency * m->p.torque_constant);
}

/* Motor angle at which the cable takes up `take_up_m` at the spool. */
static double angle_from_take_up(const BowdenModel *m, double take_up_m)
{
    return take_up_m * m->p.gear_ratio / m->p.spool_radius;
}

/* Drive mode 1: the inlet tension is prescribed; the motor follows kinematically. */
static void prescribed_tension_substep(BowdenModel *m, const Friction *f, double h)
{
    double trial[BOWDEN_N_SEG + 1], dtrial[BOWDEN_N_SEG + 1];
    const double ds = m->p.sheath_length / BOWDEN_N_SEG;
    double t_in = m->u.T_in_cmd > 0.0 ? m->u.T_in_cmd : 0.0; /* a cable cannot push */
    double stretch = profile(f, m->tension_n, t_in, ds, trial, dtrial);
    double disp = inlet_displacement(m, stretch, trial[BOWDEN_N_SEG]);
    double angle = angle_from_take_up(
        m, t_in * m->p.free_length / m->p.cable_EA + disp - m->u.end_displacement);
    memcpy(m->tension_n, trial, sizeof(m->tension_n));
    m->motor_speed_rad_s = h > 0.0 ? (angle - m->motor_angle_rad) / h : 0.0;
    m->motor_angle_rad = angle;
    m->current_a = holding_current(m, t_in);
}

static void current_command_substep(BowdenModel *m, const Friction *f, double h)
{
    const BowdenParams *p = &m->p;
    const double lever = p->spool_radius / p->gear_ratio;       /* cable m per motor rad */
    const double load_gain = lever / p->gear_efficiency;        /* motor N m per N of T_in */
    double target = m->u.current_cmd;
    double stiff, angle_free, angle_per_n, t_in, angle;
    if (target > p->current_limit) {
        target = p->current_limit;
    } else if (target < -p->current_limit) {
        target = -p->current_limit;
    }
    /* current loop: first-order lag, exact for a command held over the step */
    m->current_a += (target - m->current_a) * m->alpha_current;
    /* Motor, gearhead and spool by backward Euler, coupled implicitly to the cable (README,
       "Integration"): with w' = (a' - a)/h,
         J (w' - w)/h = k_t i - load_gain T_in(a') - b w'
       gives a' = angle_free - angle_per_n * T_in(a'), solved together with the cable. */
    stiff = p->motor_inertia / (h * h) + p->motor_damping / h;
    angle_free = m->motor_angle_rad +
                 (p->motor_inertia * m->motor_speed_rad_s / h + p->torque_constant * m->current_a) /
                     stiff;
    angle_per_n = load_gain / stiff;
    /* the far end's base moving away by end_displacement stretches the cable as much as the
       spool taking up as much would (README, "Cable compatibility") */
    t_in = solve_tension(m, f, lever * angle_free + m->u.end_displacement, lever * angle_per_n);
    angle = angle_free - angle_per_n * t_in;
    m->motor_speed_rad_s = (angle - m->motor_angle_rad) / h;
    m->motor_angle_rad = angle;
}

static void substep(BowdenModel *m, double h)
{
    const double ds = m->p.sheath_length / BOWDEN_N_SEG;
    Friction f = friction_now(m);
    double t0 = m->time_s, y0 = m->sensor_lag_n, stretch = 0.0, t_out, reading;
    int k;

    if (m->p.drive_mode == 1) {
        prescribed_tension_substep(m, &f, h);
    } else {
        current_command_substep(m, &f, h);
    }
    for (k = 1; k <= BOWDEN_N_SEG; k++) {
        stretch += 0.5 * (m->tension_n[k - 1] + m->tension_n[k]);
    }
    m->inlet_disp_m =
        inlet_displacement(m, stretch * ds, m->tension_n[BOWDEN_N_SEG]) - m->u.end_displacement;
    strands_update(m, &f, m->tension_n[0]);
    m->time_s = t0 + h;
    t_out = output_tension(m);
    m->creep_lp_n += (t_out - m->creep_lp_n) * m->alpha_creep;
    reading = creep_reading(m, t_out);
    if (m->p.sensor_tau2 > 0.0) {
        /* the second-order lag (README, "Sensor dynamics"): two equal first-order stages,
           exact for their input held over the step (the second sees the first move) */
        const double a = m->decay_sensor2, c = h / m->p.sensor_tau2, x1 = m->sensor_lag2a_n;
        m->sensor_lag2b_n = reading + a * (m->sensor_lag2b_n - reading) + c * a * (x1 - reading);
        m->sensor_lag2a_n = reading + a * (x1 - reading);
        reading = m->sensor_lag2b_n;
    }
    m->sensor_lag_n += (reading - m->sensor_lag_n) * m->alpha_sensor;
    delay_push(m, t0, y0, m->time_s, m->sensor_lag_n);
}

static void update_step_constants(BowdenModel *m, double h)
{
    if (h == m->cache_h_s) {
        return;
    }
    m->cache_h_s = h;
    m->alpha_current = 1.0 - exp(-h * TWO_PI * m->p.current_bandwidth);
    m->alpha_sensor = m->p.sensor_tau > 0.0 ? 1.0 - exp(-h / m->p.sensor_tau) : 1.0;
    m->alpha_creep = 1.0 - exp(-h / m->p.sensor_creep_tau);
    m->decay_sensor2 = m->p.sensor_tau2 > 0.0 ? exp(-h / m->p.sensor_tau2) : 0.0;
}

/* ---- public ------------------------------------------------------------------------------- */

int bowden_model_init(BowdenModel *m, double start_time_s, char *msg, size_t msg_len)
{
    double stretch = 0.0;
    int k;
    if (!isfinite(start_time_s)) {
        snprintf(msg, msg_len, "startTime = %g must be finite", start_time_s);
        return 1;
    }
    m->time_s = start_time_s;
    m->start_time_s = start_time_s;
    m->geom_valid = 0;
    m->cache_h_s = -1.0;
    m->cache_mu = -1.0;
    m->cache_dphi = -1.0;
    if (update_geometry(m, msg, msg_len)) {
        return 1;
    }
    m->current_a = 0.0;
    m->motor_angle_rad = 0.0;
    m->motor_speed_rad_s = 0.0;
    m->cable_speed_m_s = 0.0;
    m->tension_rate_n_s = 0.0;
    memset(m->tension_n, 0, sizeof(m->tension_n));
    memset(m->strand_n, 0, sizeof(m->strand_n));
    memset(m->strand_dir, 0, sizeof(m->strand_dir));
    m->rng_state = splitmix64((uint64_t)(uint32_t)m->p.seed);
    if (m->rng_state == 0) {
        m->rng_state = 0x9E3779B97F4A7C15ULL; /* xorshift must not start at 0 */
    }
    m->noise_in_n = 0.0;
    m->noise_out_n = 0.0;
    if (m->p.drive_mode == 1) {
        /* the prescribed tension was applied by loading from rest */
        Friction f = friction_now(m);
        prescribed_tension_substep(m, &f, 0.0);
        strands_update(m, &f, m->tension_n[0]);
        m->motor_speed_rad_s = 0.0;
    }
    for (k = 1; k <= BOWDEN_N_SEG; k++) {
        stretch += 0.5 * (m->tension_n[k - 1] + m->tension_n[k]);
    }
    m->inlet_disp_m =
        inlet_displacement(m, stretch * m->p.sheath_length / BOWDEN_N_SEG, m->tension_n[BOWDEN_N_SEG]) -
        m->u.end_displacement;
    m->creep_lp_n = output_tension(m); /* the initial load has settled on the load cell */
    m->sensor_lag_n = output_tension(m);
    m->sensor_lag2a_n = m->sensor_lag_n;
    m->sensor_lag2b_n = m->sensor_lag_n;
    m->delay_t0_s = start_time_s;
    m->delay_buf_n[0] = m->sensor_lag_n;
    m->delay_count = 1;
    compute_outputs(m);
    return outputs_finite(m, msg, msg_len);
}

int bowden_model_step(BowdenModel *m, double step_s, char *msg, size_t msg_len)
{
    double n_sub_f, h, disp0, t_in0, alpha_rate;
    long n_sub, i;
    if (!(step_s > 0.0) || !isfinite(step_s)) {
        snprintf(msg, msg_len, "communicationStepSize = %g s must be > 0 and finite", step_s);
        return 1;
    }
    n_sub_f = ceil(step_s / m->p.max_step - 1e-9);
    if (n_sub_f > BOWDEN_MAX_SUBSTEPS) {
        snprintf(msg, msg_len,
                 "communicationStepSize = %g s needs more than 1e8 internal steps of max_step = "
                 "%g s; allowed communicationStepSize <= %g s",
                 step_s, m->p.max_step, BOWDEN_MAX_SUBSTEPS * m->p.max_step);
        return 1;
    }
    if (update_geometry(m, msg, msg_len)) {
        return 1;
    }
    n_sub = n_sub_f < 1.0 ? 1 : (long)n_sub_f;
    h = step_s / (double)n_sub;
    update_step_constants(m, h);
    disp0 = m->inlet_disp_m;
    t_in0 = m->tension_n[0];
    for (i = 0; i < n_sub; i++) {
        substep(m, h);
    }
    /* Cable speed for mu_viscous: the mean over the communication step (inputs are held, so in
       drive mode 1 the cable moves in the first internal step only), low-pass filtered with
       BOWDEN_SPEED_TAU_S. Unfiltered, the explicit speed -> friction -> stretch coupling
       chatters between stick and slip from one step to the next. */
    alpha_rate = 1.0 - exp(-step_s / BOWDEN_SPEED_TAU_S);
    m->cable_speed_m_s += ((m->inlet_disp_m - disp0) / step_s - m->cable_speed_m_s) * alpha_rate;
    /* The inlet tension's rate for mu_viscous_tension_rate (README, "Viscous friction"): the
       same mean over the communication step and the same filter. */
    m->tension_rate_n_s += ((m->tension_n[0] - t_in0) / step_s - m->tension_rate_n_s) * alpha_rate;
    if (m->p.noise_std > 0.0) {
        double g1, g2;
        rng_gauss_pair(&m->rng_state, &g1, &g2);
        m->noise_in_n = m->p.noise_std * g1;
        m->noise_out_n = m->p.noise_std * g2;
    }
    compute_outputs(m);
    return outputs_finite(m, msg, msg_len);
}

int bowden_model_check_state(const BowdenModel *m, char *msg, size_t msg_len)
{
    const struct {
        const char *name;
        double value;
    } reals[] = {
        {"time_s", m->time_s},
        {"current_a", m->current_a},
        {"motor_angle_rad", m->motor_angle_rad},
        {"motor_speed_rad_s", m->motor_speed_rad_s},
        {"inlet_disp_m", m->inlet_disp_m},
        {"cable_speed_m_s", m->cable_speed_m_s},
        {"tension_rate_n_s", m->tension_rate_n_s},
        {"start_time_s", m->start_time_s},
        {"sensor_lag_n", m->sensor_lag_n},
        {"sensor_lag2a_n", m->sensor_lag2a_n},
        {"sensor_lag2b_n", m->sensor_lag2b_n},
        {"creep_lp_n", m->creep_lp_n},
        {"delay_t0_s", m->delay_t0_s},
        {"noise_in_n", m->noise_in_n},
        {"noise_out_n", m->noise_out_n},
        {"geom_x_m", m->geom_x_m},
        {"geom_y_m", m->geom_y_m},
        {"geom_z_m", m->geom_z_m},
        {"phi_geom_rad", m->phi_geom_rad},
        {"cache_h_s", m->cache_h_s},
        {"alpha_current", m->alpha_current},
        {"alpha_sensor", m->alpha_sensor},
        {"decay_sensor2", m->decay_sensor2},
        {"alpha_creep", m->alpha_creep},
        {"cache_mu", m->cache_mu},
        {"cache_dphi", m->cache_dphi},
        {"exp_plus", m->exp_plus},
        {"exp_minus", m->exp_minus},
        {"T_in", m->y.T_in},
        {"T_out", m->y.T_out},
        {"T_in_meas", m->y.T_in_meas},
        {"T_out_meas", m->y.T_out_meas},
        {"phi", m->y.phi},
        {"motor_angle", m->y.motor_angle},
        {"motor_speed", m->y.motor_speed},
        {"current", m->y.current},
    };
    size_t i;
    for (i = 0; i < sizeof(reals) / sizeof(reals[0]); i++) {
        if (!isfinite(reals[i].value)) {
            snprintf(msg, msg_len, "state member %s = %g is not finite", reals[i].name,
                     reals[i].value);
            return 1;
        }
    }
    for (i = 0; i <= BOWDEN_N_SEG; i++) {
        /* A11: tension is >= 0 everywhere. */
        if (!isfinite(m->tension_n[i]) || m->tension_n[i] < 0.0) {
            snprintf(msg, msg_len, "state member tension_n[%u] = %g is not a tension >= 0",
                     (unsigned)i, m->tension_n[i]);
            return 1;
        }
    }
    for (i = 0; i <= BOWDEN_N_STRAND; i++) {
        if (!isfinite(m->strand_n[i]) || m->strand_n[i] < 0.0) {
            snprintf(msg, msg_len, "state member strand_n[%u] = %g is not a tension >= 0",
                     (unsigned)i, m->strand_n[i]);
            return 1;
        }
    }
    for (i = 0; i <= BOWDEN_N_STRAND; i++) {
        const double d = m->strand_dir[i];
        if (d != 0.0 && d != 1.0 && d != -1.0) {
            snprintf(msg, msg_len, "state member strand_dir[%u] = %g must be -1, 0 or 1",
                     (unsigned)i, d);
            return 1;
        }
    }
    for (i = 0; i < BOWDEN_DELAY_LEN; i++) {
        if (!isfinite(m->delay_buf_n[i])) {
            snprintf(msg, msg_len, "state member delay_buf_n[%u] = %g is not finite", (unsigned)i,
                     m->delay_buf_n[i]);
            return 1;
        }
    }
    /* The delay line is indexed with delay_count - 1 and grows from 1 at init. */
    if (m->delay_count < 1) {
        snprintf(msg, msg_len, "state member delay_count = %lld must be >= 1",
                 (long long)m->delay_count);
        return 1;
    }
    if (m->rng_state == 0) {
        snprintf(msg, msg_len, "state member rng_state = 0 (xorshift64* never reaches 0)");
        return 1;
    }
    if (m->geom_valid != 0 && m->geom_valid != 1) {
        snprintf(msg, msg_len, "state member geom_valid = %d must be 0 or 1", m->geom_valid);
        return 1;
    }
    return 0;
}
