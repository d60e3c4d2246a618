`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Fixed-point PI + feedforward tension loop with ADC calibration, faults and watchdog.
 *
 * Every sample tick (one-clock pulse on `tick`):
 *   T_in = sat16(round((raw - ADC_OFFSET) * ADC_GAIN / 2^20))          Q7.8 N
 *   T_c' = max(T_c, or T_c'[n-1] moved towards T_c by at most SLEW (SLEW_EN), TC_MIN)  Q7.8 N
 *   e    = sat16(T_c' - T_in)                                          Q7.8 N
 *   I'   = clamp(I + KI_TS*e, +-I_LIMIT), or clamp(I, +-I_LIMIT) when the previous output
 *          was saturated in the direction KI_TS*e pushes (conditional integration)     Q3.28 A
 *   u    = clamp(round(Kff*T_c' + Kp*e + I') + UFF, +-I_LIMIT)           Q3.12 A
 * UFF (Q3.12 A) is a current feedforward the processor writes (its rate feedforward): added
 * outside the PI, so the integrator never sees it; exact (a whole number of output LSB).
 * The exact bit-level definition is the Python model cosim/parts/rtl_model.py; hdl/README.md
 * has the formats and why this anti-windup scheme.
 *
 * Two registered multipliers (mul_s16) compute the five products in a fixed schedule; the
 * results appear LATENCY (15) clocks after the tick, marked by `out_valid`. Ticks must be at least
 * LATENCY clocks apart. All configuration is taken at the tick edge: a register updated on an
 * edge before it is used by that sample, one updated on the tick edge or later by the next
 * (write pulses such as the TC strobe follow the same rule). An ADC sample whose valid clock is
 * the tick clock counts for that tick.
 *
 * SNAPSHOT 1 (the default, the external-MCU boards): the configuration is copied at the tick
 * into snapshot registers that the later clocks of the sample use. SNAPSHOT 0 (bowden_soc, where
 * the UP5K has no room for the 226 snapshot flip-flops): the sample reads the live register
 * outputs, and `cfg_busy` (the tick clock and the 13 after it) tells the register bus to hold
 * any write until the sample no longer reads them, so the same rule holds: a write held over
 * the tick lands after it and is used by the next sample (property tl_cfg_held).
 */
module tension_loop #(
    parameter [15:0] WDT_RAMP_STEP = 16'd41, // watchdog ramp-down of u, Q3.12 A per sample
                                             // (41/4096 A: 4 A reach zero in 40 ms at 10 kHz)
    parameter SNAPSHOT = 1                   // 1: configuration snapshot at the tick; 0: the
                                             // live registers, writes held by cfg_busy
) (
    input  wire        clk,
    input  wire        rst,

    /*
     * Sample timing
     */
    input  wire        tick,        // start of a sample, one clock, >= LATENCY clocks apart

    /*
     * Raw load-cell ADC stream
     */
    input  wire        adc_valid,   // a new sample on adc_data
    input  wire [23:0] adc_data,    // signed 24-bit two's complement code

    /*
     * Configuration (register fields)
     */
    input  wire        enable,       // CTRL.ENABLE
    input  wire        slew_en,      // CTRL.SLEW_EN
    input  wire        integ_reset,  // CTRL.INTEG_RESET write pulse
    input  wire        fault_clear,  // CTRL.FAULT_CLEAR write pulse
    input  wire        tc_wr,        // TC written (watchdog refresh)
    input  wire [15:0] tc,           // Q7.8 N
    input  wire [15:0] tc_min,       // Q7.8 N, floor of T_c' (a cable cannot push)
    input  wire [15:0] kff,          // Q2.13 A/N
    input  wire [15:0] uff,          // Q3.12 A, added to u outside the PI
    input  wire [15:0] kp,           // Q2.13 A/N
    input  wire [15:0] ki_ts,        // 2^-20 A/N per sample
    input  wire [14:0] i_limit,      // UQ3.12 A
    input  wire [14:0] slew,         // UQ7.8 N per sample
    input  wire [15:0] wdt_timeout,  // samples, 0 = off
    input  wire [23:0] adc_offset,   // code
    input  wire [15:0] adc_gain,     // 2^-20 Q7.8-LSB per code
    input  wire [23:0] adc_min,      // code
    input  wire [23:0] adc_max,      // code
    input  wire [15:0] adc_stale,    // samples, 0 = off
    input  wire [15:0] oc_timeout,   // samples, 0 = off
    output wire        cfg_busy,     // SNAPSHOT 0: the configuration is in use, hold writes

    /*
     * Drive command
     */
    output wire [15:0] u,            // Q3.12 A current command
    output wire        out_en,       // drive enable
    output wire        out_valid,    // one clock: u, out_en and the read-backs are new

    /*
     * Status and read-back
     */
    output wire        saturated,
    output wire        wdt_ramp,
    output wire [3:0]  faults,       // {overcurrent, watchdog, adc_range, adc_stale}
    output wire [15:0] t_in,         // Q7.8 N
    output wire [31:0] integ,        // Q3.28 A
    output wire [15:0] tc_eff,       // Q7.8 N
    output wire [31:0] sample_count
);

localparam LATENCY = 15;  // clocks from tick to out_valid; documented minimum tick spacing

localparam [3:0] F_WDT = 4'b0100;  // fault bits: {overcurrent, watchdog, adc_range, adc_stale}

// Schedule: seq_reg[k] is high in clock k+1 after the tick (clock 0). Every stage has at most
// one carry chain between registers, so that the iCE40 UP5K meets 48 MHz.
reg  [LATENCY-2:0] seq_reg, seq_next;

// Events between ticks, consumed at the tick.
reg  [23:0] raw_reg, raw_next;
reg         fresh_reg, fresh_next;
reg         tcw_pend_reg, tcw_pend_next;
reg         irst_pend_reg, irst_pend_next;
reg         fclr_pend_reg, fclr_pend_next;

// Counters and latched faults.
reg  [16:0] stale_cnt_reg, stale_cnt_next;
reg  [16:0] wdt_cnt_reg, wdt_cnt_next;
reg  [16:0] oc_cnt_reg, oc_cnt_next;
reg  [3:0]  fault_reg, fault_next;
reg  [31:0] sample_cnt_reg, sample_cnt_next;

// Snapshot at the tick: everything the later clocks of the sample use.
reg         en_s_reg, en_s_next;
reg         slew_en_s_reg, slew_en_s_next;
reg  [15:0] tc_s_reg, tc_s_next;
reg  [15:0] tcmin_s_reg, tcmin_s_next;
reg  [15:0] kff_s_reg, kff_s_next;
reg  [15:0] uff_s_reg, uff_s_next;
reg  [15:0] kp_s_reg, kp_s_next;
reg  [15:0] ki_s_reg, ki_s_next;
reg  [15:0] gain_s_reg, gain_s_next;
reg  [14:0] lim_s_reg, lim_s_next;
reg  [15:0] nlim_reg, nlim_next;  // -I_LIMIT, computed once per sample off the critical paths
reg  [15:0] stale_to_s_reg, stale_to_s_next;
reg  [15:0] wdt_to_s_reg, wdt_to_s_next;
reg  [15:0] oc_to_s_reg, oc_to_s_next;
reg  [23:0] raw_s_reg, raw_s_next;
reg  [23:0] min_s_reg, min_s_next;
reg  [23:0] max_s_reg, max_s_next;
reg         lo_bad_reg, lo_bad_next;
reg         hi_bad_reg, hi_bad_next;
reg  [3:0]  fbase_s_reg, fbase_s_next;
reg  [24:0] diff_reg, diff_next;
reg  [16:0] hi_s_reg, hi_s_next;
reg  [16:0] lo_s_reg, lo_s_next;
reg  [31:0] iprev_reg, iprev_next;
reg         iphi_reg, iphi_next;  // I entering the sample > +I_LIMIT (I_LIMIT lowered)
reg         iplo_reg, iplo_next;  // I entering the sample < -I_LIMIT
reg  [31:0] ihold_reg, ihold_next;  // clamp(I, +-I_LIMIT): the integrator when it holds

// The configuration the sample uses: the snapshot (SNAPSHOT 1), or the live registers, which
// cfg_busy keeps stable from the tick to the last clock that reads them (SNAPSHOT 0; the
// snapshot registers then have no load and synthesis removes them).
wire        en_cfg = (SNAPSHOT != 0) ? en_s_reg : enable;
wire        slew_en_cfg = (SNAPSHOT != 0) ? slew_en_s_reg : slew_en;
wire [15:0] tc_cfg = (SNAPSHOT != 0) ? tc_s_reg : tc;              // Q7.8 N
wire [15:0] tcmin_cfg = (SNAPSHOT != 0) ? tcmin_s_reg : tc_min;    // Q7.8 N
wire [15:0] kff_cfg = (SNAPSHOT != 0) ? kff_s_reg : kff;           // Q2.13 A/N
wire [15:0] uff_cfg = (SNAPSHOT != 0) ? uff_s_reg : uff;           // Q3.12 A
wire [15:0] kp_cfg = (SNAPSHOT != 0) ? kp_s_reg : kp;              // Q2.13 A/N
wire [15:0] ki_cfg = (SNAPSHOT != 0) ? ki_s_reg : ki_ts;           // 2^-20 A/N per sample
wire [15:0] gain_cfg = (SNAPSHOT != 0) ? gain_s_reg : adc_gain;    // 2^-20 Q7.8-LSB per code
wire [14:0] lim_cfg = (SNAPSHOT != 0) ? lim_s_reg : i_limit;       // UQ3.12 A
wire [15:0] stale_to_cfg = (SNAPSHOT != 0) ? stale_to_s_reg : adc_stale;
wire [15:0] wdt_to_cfg = (SNAPSHOT != 0) ? wdt_to_s_reg : wdt_timeout;
wire [15:0] oc_to_cfg = (SNAPSHOT != 0) ? oc_to_s_reg : oc_timeout;
wire [23:0] min_cfg = (SNAPSHOT != 0) ? min_s_reg : adc_min;       // Q23.0 code
wire [23:0] max_cfg = (SNAPSHOT != 0) ? max_s_reg : adc_max;       // Q23.0 code

// Pipeline.
reg  [3:0]  det_reg, det_next;
reg         cmp_hi_reg, cmp_hi_next;
reg         cmp_lo_reg, cmp_lo_next;
reg         run_reg, run_next;
reg         ramp_reg, ramp_next;
reg  [15:0] tce_s_reg, tce_s_next;   // T_c after the slew limit (clock 2), then the floor (3)
reg  [40:0] cal_acc_reg, cal_acc_next;
reg  [40:0] cal_sum_reg, cal_sum_next;
reg  [33:0] ff_reg, ff_next;
reg  [15:0] e_reg, e_next;
reg  [33:0] fp_reg, fp_next;
reg  [32:0] isum_reg, isum_next;
reg         pi_pos_reg, pi_pos_next;
reg         pi_neg_reg, pi_neg_next;
reg         ihi_reg, ihi_next;
reg         ilo_reg, ilo_next;
reg  [31:0] inew_reg, inew_next;
reg  [24:0] r_reg, r_next;
reg         rhi_reg, rhi_next;
reg         rlo_reg, rlo_next;
reg  [15:0] u_ramp_reg, u_ramp_next;
reg         ramp_nz_reg, ramp_nz_next;
reg         ugt_reg, ugt_next;
reg         ult_reg, ult_next;
reg  [15:0] u_dn_reg, u_dn_next;
reg  [15:0] u_up_reg, u_up_next;

// Results.
reg  [15:0] t_in_reg, t_in_next;
reg  [15:0] u_reg, u_next;
reg         out_en_reg, out_en_next;
reg         sat_hi_reg, sat_hi_next;
reg         sat_lo_reg, sat_lo_next;
reg         ramp_st_reg, ramp_st_next;
reg  [31:0] integ_reg, integ_next;
reg  [15:0] tc_eff_reg, tc_eff_next;
reg         out_valid_reg, out_valid_next;

// Multiplier operands.
reg  [15:0] m1_a, m1_b, m2_a, m2_b;
wire signed [31:0] m1_p, m2_p;

mul_s16 mul1 (.clk(clk), .a(m1_a), .b(m1_b), .p(m1_p));
mul_s16 mul2 (.clk(clk), .a(m2_a), .b(m2_b), .p(m2_p));

// --- clock 0 (tick) -------------------------------------------------------------------------

// Sample at or before the tick edge; events of the tick clock itself count.
wire [23:0] raw_now = adc_valid ? adc_data : raw_reg;
wire        fresh_now = fresh_reg | adc_valid;
wire        fclr_now = fclr_pend_reg | fault_clear;
wire        tcw_now = tcw_pend_reg | tc_wr;
wire        irst_now = irst_pend_reg | integ_reset;

// Counters stop at 2^16 so a long fault never wraps to "fine"; every threshold is below 2^16,
// so for the checks (count >= threshold) this equals the model's saturation at 2^16 - 1.
// A fault clear restarts a counter from zero: the increment is computed in parallel and the
// clear chooses 1 after it, which keeps the clear off the carry chain.
wire [16:0] stale_inc = stale_cnt_reg + {16'd0, !stale_cnt_reg[16]};
wire [16:0] wdt_inc = wdt_cnt_reg + {16'd0, !wdt_cnt_reg[16]};
wire [16:0] stale_now = fresh_now ? 17'd0 : fclr_now ? 17'd1 : stale_inc;
wire [16:0] wdt_now = (!enable || tcw_now) ? 17'd0 : fclr_now ? 17'd1 : wdt_inc;

// --- later clocks ---------------------------------------------------------------------------

// Clock 1: range check of the sample. Clock 2: fault detection on the snapshot (thresholds
// of 0 switch a check off).
wire [24:0] below_min = {raw_s_reg[23], raw_s_reg} - {min_cfg[23], min_cfg};
wire [24:0] above_max = {max_cfg[23], max_cfg} - {raw_s_reg[23], raw_s_reg};
wire [3:0] detect = {(oc_to_cfg != 16'd0) && (oc_cnt_reg >= {1'b0, oc_to_cfg}),
                     (wdt_to_cfg != 16'd0) && (wdt_cnt_reg >= {1'b0, wdt_to_cfg}),
                     lo_bad_reg || hi_bad_reg,
                     (stale_to_cfg != 16'd0) && (stale_cnt_reg >= {1'b0, stale_to_cfg})};
wire [3:0] faults_now = fbase_s_reg | det_reg;

// Clock 2: slew limit, T_c' = clamp(T_c, T_c'[n-1] - SLEW, T_c'[n-1] + SLEW); the result lies
// between T_c'[n-1] and T_c, both Q7.8, so its low 16 bits are exact.
wire [17:0] tc_above = {hi_s_reg[16], hi_s_reg} - {{2{tc_cfg[15]}}, tc_cfg};
wire [17:0] tc_below = {{2{tc_cfg[15]}}, tc_cfg} - {lo_s_reg[16], lo_s_reg};
wire [16:0] tce_slew = cmp_hi_reg ? hi_s_reg : cmp_lo_reg ? lo_s_reg : {tc_cfg[15], tc_cfg};
// Clock 3: the floor, T_c' = max(slew result, TC_MIN), on registered values: one carry chain
// (the sign of T_s - TC_MIN, both Q7.8) and a select, a stage of its own (the feedforward
// product starts a clock later for it, in clock 4).
wire [16:0] tce_flr = {tce_s_reg[15], tce_s_reg} - {tcmin_cfg[15], tcmin_cfg};

// Clock 5: round(x / 2^20) fits Q7.8 unless bits 40..35 differ: saturate to the Q7.8 range.
wire cal_ovf = !((&cal_sum_reg[40:35]) || !(|cal_sum_reg[40:35]));
wire [15:0] t_in_now = cal_ovf ? {cal_sum_reg[40], {15{~cal_sum_reg[40]}}} : cal_sum_reg[35:20];

// Clock 6: error in 17 bits, saturated to Q7.8 (beyond +-128 N only the integration rate is
// limited).
wire signed [16:0] e_full = $signed({tce_s_reg[15], tce_s_reg}) -
                            $signed({t_in_reg[15], t_in_reg});
wire e_ovf = e_full[16] != e_full[15];
wire [15:0] e_now = e_ovf ? {e_full[16], {15{~e_full[16]}}} : e_full[15:0];

// Clocks 10-11: integrator, clamped to +-I_LIMIT in Q3.28 (33-bit compare, exact), held while
// the previous output was saturated in the direction KI_TS*e pushes (conditional integration).
wire signed [32:0] lim28 = $signed({2'b00, lim_cfg, 16'd0});
wire signed [32:0] nlim28 = $signed({nlim_reg[15], nlim_reg, 16'd0});
wire [33:0] i_above = {lim28[32], lim28} - {isum_reg[32], isum_reg};
wire [33:0] i_below = {isum_reg[32], isum_reg} - {nlim28[32], nlim28};
wire [32:0] i_clamped = ihi_reg ? lim28 : ilo_reg ? nlim28 : isum_reg;
wire windup = (sat_hi_reg && pi_pos_reg) || (sat_lo_reg && pi_neg_reg);
// A held integrator is clamped too: I_LIMIT may have been lowered since I was stored (found by
// the formal proof of hdl/formal/tension_loop.sby), so I' = clamp(I + (windup ? 0 : KI_TS*e)).
wire [33:0] ip_above = {lim28[32], lim28} - {{2{iprev_reg[31]}}, iprev_reg};
wire [33:0] ip_below = {{2{iprev_reg[31]}}, iprev_reg} - {nlim28[32], nlim28};

// Clock 12: rounded sum, Q3.12 in 25 bits: |fp| < 2^32 + 2^25, |I >> 7| < 2^24, so 34 bits hold
// it (the +2^8 in ff_reg turns the arithmetic shift's floor into rounding).
wire signed [33:0] v_sum = $signed(fp_reg) + $signed({{9{inew_reg[31]}}, inew_reg[31:7]});

// Clocks 13-14: output saturation at +-I_LIMIT.
wire signed [24:0] lim12 = $signed({10'd0, lim_cfg});
wire signed [24:0] nlim12 = $signed({{9{nlim_reg[15]}}, nlim_reg});
// Comparisons as subtractions, whose sign bit comes out of one carry chain (yosys otherwise
// builds some of them from LUT trees on the iCE40): r > lim <=> lim - r < 0.
wire [25:0] r_above = {lim12[24], lim12} - {r_reg[24], r_reg};
wire [25:0] r_below = {r_reg[24], r_reg} - {nlim12[24], nlim12};
wire [15:0] u_sat = rhi_reg ? {1'b0, lim_cfg} : rlo_reg ? nlim_reg : r_reg[15:0];

// Watchdog ramp of the previous command towards zero: comparisons and both steps in clock 12,
// the choice in clock 13 (u_ramp is nonzero exactly when |u| > step).
wire signed [15:0] step = $signed(WDT_RAMP_STEP);
wire [15:0] u_ramp = ugt_reg ? u_dn_reg : ult_reg ? u_up_reg : 16'd0;

// Bits dropped on purpose: the fraction below the rounding point, and the sign bit of values
// proven in range (slew result between two Q7.8 values, clamped integrator within +-2^31).
wire unused_bits = &{1'b0, tce_slew[16], below_min[23:0], above_max[23:0], cal_sum_reg[19:0], i_clamped[32], v_sum[8:0],
                     r_above[24:0], r_below[24:0], i_above[32:0], i_below[32:0],
                     ip_above[32:0], ip_below[32:0],
                     tc_above[16:0], tc_below[16:0], tce_flr[15:0]};

always @* begin
    seq_next = {seq_reg[LATENCY-3:0], tick};

    raw_next = raw_now;
    fresh_next = tick ? 1'b0 : fresh_now;
    tcw_pend_next = tick ? 1'b0 : tcw_now;
    irst_pend_next = tick ? 1'b0 : irst_now;
    fclr_pend_next = tick ? 1'b0 : fclr_now;

    stale_cnt_next = stale_cnt_reg;
    wdt_cnt_next = wdt_cnt_reg;
    oc_cnt_next = oc_cnt_reg;
    fault_next = fault_reg;
    sample_cnt_next = sample_cnt_reg;

    en_s_next = en_s_reg;
    slew_en_s_next = slew_en_s_reg;
    tc_s_next = tc_s_reg;
    tcmin_s_next = tcmin_s_reg;
    kff_s_next = kff_s_reg;
    uff_s_next = uff_s_reg;
    kp_s_next = kp_s_reg;
    ki_s_next = ki_s_reg;
    gain_s_next = gain_s_reg;
    lim_s_next = lim_s_reg;
    nlim_next = nlim_reg;
    stale_to_s_next = stale_to_s_reg;
    wdt_to_s_next = wdt_to_s_reg;
    oc_to_s_next = oc_to_s_reg;
    raw_s_next = raw_s_reg;
    min_s_next = min_s_reg;
    max_s_next = max_s_reg;
    lo_bad_next = lo_bad_reg;
    hi_bad_next = hi_bad_reg;
    fbase_s_next = fbase_s_reg;
    diff_next = diff_reg;
    hi_s_next = hi_s_reg;
    lo_s_next = lo_s_reg;
    iprev_next = iprev_reg;
    iphi_next = iphi_reg;
    iplo_next = iplo_reg;
    ihold_next = ihold_reg;

    det_next = det_reg;
    cmp_hi_next = cmp_hi_reg;
    cmp_lo_next = cmp_lo_reg;
    run_next = run_reg;
    ramp_next = ramp_reg;
    tce_s_next = tce_s_reg;
    cal_acc_next = cal_acc_reg;
    cal_sum_next = cal_sum_reg;
    ff_next = ff_reg;
    e_next = e_reg;
    fp_next = fp_reg;
    isum_next = isum_reg;
    pi_pos_next = pi_pos_reg;
    pi_neg_next = pi_neg_reg;
    ihi_next = ihi_reg;
    ilo_next = ilo_reg;
    inew_next = inew_reg;
    r_next = r_reg;
    rhi_next = rhi_reg;
    rlo_next = rlo_reg;
    u_ramp_next = u_ramp_reg;
    ramp_nz_next = ramp_nz_reg;
    ugt_next = ugt_reg;
    ult_next = ult_reg;
    u_dn_next = u_dn_reg;
    u_up_next = u_up_reg;

    t_in_next = t_in_reg;
    u_next = u_reg;
    out_en_next = out_en_reg;
    sat_hi_next = sat_hi_reg;
    sat_lo_next = sat_lo_reg;
    ramp_st_next = ramp_st_reg;
    integ_next = integ_reg;
    tc_eff_next = tc_eff_reg;
    out_valid_next = 1'b0;

    m1_a = 16'd0;
    m1_b = 16'd0;
    m2_a = 16'd0;
    m2_b = 16'd0;

    // Clock 0: the tick. Counters, snapshot, raw - offset (25 bits: exact for 24-bit codes).
    if (tick) begin
        sample_cnt_next = sample_cnt_reg + 32'd1;
        stale_cnt_next = stale_now;
        wdt_cnt_next = wdt_now;
        oc_cnt_next = fclr_now ? 17'd0 : oc_cnt_reg;
        en_s_next = enable;
        slew_en_s_next = slew_en;
        tc_s_next = tc;
        tcmin_s_next = tc_min;
        kff_s_next = kff;
        uff_s_next = uff;
        kp_s_next = kp;
        ki_s_next = ki_ts;
        gain_s_next = adc_gain;
        lim_s_next = i_limit;
        stale_to_s_next = adc_stale;
        wdt_to_s_next = wdt_timeout;
        oc_to_s_next = oc_timeout;
        raw_s_next = raw_now;
        min_s_next = adc_min;
        max_s_next = adc_max;
        fbase_s_next = fclr_now ? 4'd0 : fault_reg;
        diff_next = $signed({raw_now[23], raw_now}) - $signed({adc_offset[23], adc_offset});
        hi_s_next = $signed({tc_eff_reg[15], tc_eff_reg}) + $signed({2'b00, slew});
        lo_s_next = $signed({tc_eff_reg[15], tc_eff_reg}) - $signed({2'b00, slew});
        iprev_next = irst_now ? 32'd0 : integ_reg;
    end

    // Clock 1: range, slew comparisons, high part of the difference times the gain.
    if (seq_reg[0]) begin
        lo_bad_next = below_min[24];  // raw < ADC_MIN
        hi_bad_next = above_max[24];  // raw > ADC_MAX
        cmp_hi_next = tc_above[17];
        cmp_lo_next = tc_below[17];
        m1_a = diff_reg[24:9];
        m1_b = gain_cfg;
        nlim_next = -{1'b0, lim_cfg};
    end

    // Clock 2: detection, T_c' before the floor (slew limit), the held integrator's clamp comparisons; low 9 bits of the difference (non-negative) times the gain.
    if (seq_reg[1]) begin
        det_next = en_cfg ? detect : 4'd0;
        iphi_next = ip_above[33];  // I > +I_LIMIT
        iplo_next = ip_below[33];  // I < -I_LIMIT
        tce_s_next = slew_en_cfg ? tce_slew[15:0] : tc_cfg;
        m1_a = {7'd0, diff_reg[8:0]};
        m1_b = gain_cfg;
    end

    // Clock 3: faults latch and the mode; the floor on T_c'; high partial product arrives
    // (+ 2^19: round at >> 20); the held integrator, clamped.
    if (seq_reg[2]) begin
        fault_next = faults_now;
        run_next = en_cfg && (faults_now == 4'd0);
        ramp_next = en_cfg && (faults_now == F_WDT);
        tce_s_next = tce_flr[16] ? tcmin_cfg : tce_s_reg;  // T_s < TC_MIN: the floor
        cal_acc_next = {m1_p, 9'd0} + 41'd524288;
        ihold_next = iphi_reg ? lim28[31:0] : iplo_reg ? nlim28[31:0] : iprev_reg;
    end

    // Clock 4: calibration sum, (hi*g << 9) + lo*g + 2^19, 41 bits exact (|diff*g| < 2^40);
    // feedforward product of the floored T_c'.
    if (seq_reg[3]) begin
        cal_sum_next = cal_acc_reg + {{9{m1_p[31]}}, m1_p};
        m2_a = tce_s_reg;
        m2_b = kff_cfg;
    end

    // Clock 5: T_in.
    if (seq_reg[4]) begin
        t_in_next = t_in_now;
    end

    // Clock 6: error; feedforward plus UFF << 9 (Q3.12 -> Q.21) and the rounding half of the
    // final >> 9, one addend {UFF, 9'h100} (exact: 256 < 2^9): |ff| < 2^31 + 2^24 + 2^8.
    if (seq_reg[5]) begin
        e_next = e_now;
        ff_next = {{2{m2_p[31]}}, m2_p} + {{9{uff_cfg[15]}}, uff_cfg, 9'h100};
    end

    // Clock 7: P and I products.
    if (seq_reg[6]) begin
        m1_a = e_reg;
        m1_b = kp_cfg;
        m2_a = e_reg;
        m2_b = ki_cfg;
    end

    // Clock 9: feedforward + proportional (34 bits), integrator sum (33 bits), both exact.
    if (seq_reg[8]) begin
        fp_next = ff_reg + {{2{m1_p[31]}}, m1_p};
        isum_next = {iprev_reg[31], iprev_reg} + {m2_p[31], m2_p};
        pi_pos_next = !m2_p[31] && (m2_p != 32'd0);
        pi_neg_next = m2_p[31];
    end

    // Clock 10: integrator clamp comparisons.
    if (seq_reg[9]) begin
        ihi_next = i_above[33];
        ilo_next = i_below[33];
    end

    // Clock 11: new integrator.
    if (seq_reg[10]) begin
        inew_next = windup ? ihold_reg : i_clamped[31:0];
    end

    // Clock 12: rounded output before saturation.
    if (seq_reg[11]) begin
        r_next = v_sum[33:9];
        ugt_next = $signed(u_reg) > step;
        ult_next = $signed(u_reg) < -step;
        u_dn_next = u_reg - step;
        u_up_next = u_reg + step;
    end

    // Clock 13: saturation comparisons.
    if (seq_reg[12]) begin
        rhi_next = r_above[25];
        rlo_next = r_below[25];
        u_ramp_next = u_ramp;
        ramp_nz_next = ugt_reg || ult_reg;
    end

    // Clock 14: saturate, apply the mode.
    if (seq_reg[13]) begin
        out_valid_next = 1'b1;
        if (run_reg) begin
            u_next = u_sat;
            integ_next = inew_reg;
            sat_hi_next = rhi_reg;
            sat_lo_next = rlo_reg;
            out_en_next = 1'b1;
            ramp_st_next = 1'b0;
            tc_eff_next = tce_s_reg;
            // Consecutive saturated samples, stopping at 2^16.
            oc_cnt_next = !(rhi_reg || rlo_reg) ? 17'd0 :
                          oc_cnt_reg + {16'd0, !oc_cnt_reg[16]};
        end else begin
            u_next = ramp_reg ? u_ramp_reg : 16'd0;
            out_en_next = ramp_reg && ramp_nz_reg;
            ramp_st_next = ramp_reg && ramp_nz_reg;
            integ_next = 32'd0;
            sat_hi_next = 1'b0;
            sat_lo_next = 1'b0;
            tc_eff_next = 16'd0;
            oc_cnt_next = 17'd0;
        end
    end
end

always @(posedge clk) begin
    seq_reg <= seq_next;
    raw_reg <= raw_next;
    fresh_reg <= fresh_next;
    tcw_pend_reg <= tcw_pend_next;
    irst_pend_reg <= irst_pend_next;
    fclr_pend_reg <= fclr_pend_next;
    stale_cnt_reg <= stale_cnt_next;
    wdt_cnt_reg <= wdt_cnt_next;
    oc_cnt_reg <= oc_cnt_next;
    fault_reg <= fault_next;
    sample_cnt_reg <= sample_cnt_next;
    en_s_reg <= en_s_next;
    slew_en_s_reg <= slew_en_s_next;
    tc_s_reg <= tc_s_next;
    tcmin_s_reg <= tcmin_s_next;
    kff_s_reg <= kff_s_next;
    uff_s_reg <= uff_s_next;
    kp_s_reg <= kp_s_next;
    ki_s_reg <= ki_s_next;
    gain_s_reg <= gain_s_next;
    lim_s_reg <= lim_s_next;
    nlim_reg <= nlim_next;
    stale_to_s_reg <= stale_to_s_next;
    wdt_to_s_reg <= wdt_to_s_next;
    oc_to_s_reg <= oc_to_s_next;
    raw_s_reg <= raw_s_next;
    min_s_reg <= min_s_next;
    max_s_reg <= max_s_next;
    lo_bad_reg <= lo_bad_next;
    hi_bad_reg <= hi_bad_next;
    fbase_s_reg <= fbase_s_next;
    diff_reg <= diff_next;
    hi_s_reg <= hi_s_next;
    lo_s_reg <= lo_s_next;
    iprev_reg <= iprev_next;
    iphi_reg <= iphi_next;
    iplo_reg <= iplo_next;
    ihold_reg <= ihold_next;
    det_reg <= det_next;
    cmp_hi_reg <= cmp_hi_next;
    cmp_lo_reg <= cmp_lo_next;
    run_reg <= run_next;
    ramp_reg <= ramp_next;
    tce_s_reg <= tce_s_next;
    cal_acc_reg <= cal_acc_next;
    cal_sum_reg <= cal_sum_next;
    ff_reg <= ff_next;
    e_reg <= e_next;
    fp_reg <= fp_next;
    isum_reg <= isum_next;
    pi_pos_reg <= pi_pos_next;
    pi_neg_reg <= pi_neg_next;
    ihi_reg <= ihi_next;
    ilo_reg <= ilo_next;
    inew_reg <= inew_next;
    r_reg <= r_next;
    rhi_reg <= rhi_next;
    rlo_reg <= rlo_next;
    u_ramp_reg <= u_ramp_next;
    ramp_nz_reg <= ramp_nz_next;
    ugt_reg <= ugt_next;
    ult_reg <= ult_next;
    u_dn_reg <= u_dn_next;
    u_up_reg <= u_up_next;
    t_in_reg <= t_in_next;
    u_reg <= u_next;
    out_en_reg <= out_en_next;
    sat_hi_reg <= sat_hi_next;
    sat_lo_reg <= sat_lo_next;
    ramp_st_reg <= ramp_st_next;
    integ_reg <= integ_next;
    tc_eff_reg <= tc_eff_next;
    out_valid_reg <= out_valid_next;

    if (rst) begin
        seq_reg <= {(LATENCY-1){1'b0}};
        raw_reg <= 24'd0;
        fresh_reg <= 1'b0;
        tcw_pend_reg <= 1'b0;
        irst_pend_reg <= 1'b0;
        fclr_pend_reg <= 1'b0;
        stale_cnt_reg <= 17'd0;
        wdt_cnt_reg <= 17'd0;
        oc_cnt_reg <= 17'd0;
        fault_reg <= 4'd0;
        sample_cnt_reg <= 32'd0;
        run_reg <= 1'b0;
        ramp_reg <= 1'b0;
        t_in_reg <= 16'd0;
        u_reg <= 16'd0;
        out_en_reg <= 1'b0;
        sat_hi_reg <= 1'b0;
        sat_lo_reg <= 1'b0;
        ramp_st_reg <= 1'b0;
        integ_reg <= 32'd0;
        tc_eff_reg <= 16'd0;
        out_valid_reg <= 1'b0;
    end
end

// The tick clock and the next 13 read the configuration (clock 14 still reads I_LIMIT, so a
// write in clock 13 would be too late): a write is held through them, 14 clocks at most.
assign cfg_busy = (SNAPSHOT == 0) && (tick || (|seq_reg[LATENCY-3:0]));

assign u = u_reg;
assign out_en = out_en_reg;
assign out_valid = out_valid_reg;
assign saturated = sat_hi_reg | sat_lo_reg;
assign wdt_ramp = ramp_st_reg;
assign faults = fault_reg;
assign t_in = t_in_reg;
assign integ = integ_reg;
assign tc_eff = tc_eff_reg;
assign sample_count = sample_cnt_reg;

`ifdef FORMAL
// --- formal properties (hdl/formal/tension_loop.sby; hdl/README.md says what is proven) ----
//
// The loop's safety properties tl_* (current, integrator, faults) against a spec-level shadow
// of the inputs (f_* registers, written from the ports, not from the pipeline). The environment (reset at
// start, ticks at least LATENCY clocks apart) is assumed when this module is the top of the
// proof and asserted when it sits inside bowden_core, which must then guarantee it.
`ifdef FORMAL_TENSION_LOOP_TOP
`define TL_ENV assume
`else
`define TL_ENV assert
`endif

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;

always @* if (!f_past_valid) assume(rst);

// Clocks since the last tick, saturating at LATENCY (LATENCY also after reset: idle).
localparam [3:0] F_LAT = LATENCY;
reg [3:0] f_since_tick = F_LAT;
always @(posedge clk) begin
    if (rst) f_since_tick <= F_LAT;
    else if (tick) f_since_tick <= 4'd1;
    else if (f_since_tick != F_LAT) f_since_tick <= f_since_tick + 4'd1;
end
// property tl_tick_spacing: ticks come at least LATENCY clocks apart (assumed when tension_loop is the top, asserted inside bowden_core)
always @* if (f_past_valid && !rst && tick) tl_tick_spacing: `TL_ENV(f_since_tick == F_LAT);

// A sample is in flight: the clocks after its tick up to the one that sets u.
wire f_busy = f_since_tick != F_LAT;

// SNAPSHOT 0: the configuration a sample reads does not change from its tick to its end, which
// the register bus guarantees by holding writes while cfg_busy (assumed when tension_loop is
// the top, asserted inside bowden_core). With it, the live registers are the snapshot.
wire [263:0] f_cfg = {enable, slew_en, tc, tc_min, kff, uff, kp, ki_ts, i_limit, slew,
                      wdt_timeout, adc_offset, adc_gain, adc_min, adc_max, adc_stale, oc_timeout};
generate
    if (SNAPSHOT == 0) begin : g_f_cfg_held
        // property tl_cfg_held: while a sample is in flight the configuration it reads does not change (SNAPSHOT 0; assumed when tension_loop is the top, asserted inside bowden_core)
        always @(posedge clk) if (f_past_valid && !rst && f_busy)
            tl_cfg_held: `TL_ENV(f_cfg == $past(f_cfg));
        // The hold is not vacuous: the configuration changes on the clock after a sample.
        always @(posedge clk) if (f_past_valid && !rst && !$past(rst))
            cover(!f_busy && $past(f_busy) && f_cfg != $past(f_cfg));
    end
endgenerate

// One sample in flight at a time: the schedule is the position in the sample.
wire [LATENCY-2:0] f_seq_exp = (f_since_tick == F_LAT) ? {(LATENCY-1){1'b0}} :
                               {{(LATENCY-2){1'b0}}, 1'b1} << (f_since_tick - 4'd1);
// property tl_one_sample_in_flight: the schedule register is the position in the sample (induction helper)
always @* if (f_past_valid) tl_one_sample_in_flight: assert(seq_reg == f_seq_exp);

// --- shadow of the events of a sample (taken from the ports) ------------------------------

reg        f_fresh, f_tcw, f_fclr, f_irst; // since the last tick
reg [23:0] f_raw;                          // latest ADC sample
reg        f_en_s, f_fclr_s;               // snapshot at the tick
reg [23:0] f_raw_s, f_min_s, f_max_s;
reg [15:0] f_stale_to_s, f_wdt_to_s, f_oc_to_s;
reg [14:0] f_lim_s;
reg [15:0] f_tcmin_s;                      // TC_MIN at the tick
reg [15:0] f_stale, f_wdt, f_oc;          // the counters as the register map defines them
reg [3:0]  f_fault_tick;                   // FAULT at the tick
reg [14:0] f_ulim;                         // I_LIMIT of the sample that made u (run)
reg        f_sat_hi, f_sat_lo;             // the last command was clipped high / low
reg signed [31:0] f_pi;                    // integrator increment KI_TS*e of this sample
reg [31:0] f_iprev;                        // integrator entering this sample

wire [23:0] f_raw_now = adc_valid ? adc_data : f_raw;
wire        f_fresh_now = f_fresh || adc_valid;
wire        f_tcw_now = f_tcw || tc_wr;
wire        f_fclr_now = f_fclr || fault_clear;
wire        f_irst_now = f_irst || integ_reset;
wire [15:0] f_stale_base = f_fclr_now ? 16'd0 : f_stale;
wire [15:0] f_wdt_base = f_fclr_now ? 16'd0 : f_wdt;
wire [15:0] f_stale_now = f_fresh_now ? 16'd0 :
                          f_stale_base + {15'd0, f_stale_base != 16'hFFFF};
wire [15:0] f_wdt_now = (!enable || f_tcw_now) ? 16'd0 :
                        f_wdt_base + {15'd0, f_wdt_base != 16'hFFFF};
// Detection from the snapshot: the register map's definition of each fault.
wire f_range_bad = ($signed(f_raw_s) < $signed(f_min_s)) || ($signed(f_raw_s) > $signed(f_max_s));
wire [3:0] f_detect = {(f_oc_to_s != 16'd0) && (f_oc >= f_oc_to_s),
                      (f_wdt_to_s != 16'd0) && (f_wdt >= f_wdt_to_s),
                      f_range_bad,
                      (f_stale_to_s != 16'd0) && (f_stale >= f_stale_to_s)};
wire [3:0] f_fault_exp = (f_fclr_s ? 4'd0 : f_fault_tick) | (f_en_s ? f_detect : 4'd0);

// The watchdog ramp of a command: towards zero by WDT_RAMP_STEP, never past it.
function [15:0] f_ramp;
    input [15:0] x;
    begin
        if ($signed(x) > $signed(WDT_RAMP_STEP)) f_ramp = x - WDT_RAMP_STEP;
        else if ($signed(x) < -$signed(WDT_RAMP_STEP)) f_ramp = x + WDT_RAMP_STEP;
        else f_ramp = 16'd0;
    end
endfunction

wire f_run_done = seq_reg[13] && run_reg;   // the clock a running sample sets u
wire f_stop_done = seq_reg[13] && !run_reg;

always @(posedge clk) begin
    f_fresh <= tick ? 1'b0 : f_fresh_now;
    f_tcw <= tick ? 1'b0 : f_tcw_now;
    f_fclr <= tick ? 1'b0 : f_fclr_now;
    f_irst <= tick ? 1'b0 : f_irst_now;
    f_raw <= f_raw_now;
    if (tick) begin
        f_en_s <= enable;
        f_fclr_s <= f_fclr_now;
        f_raw_s <= f_raw_now;
        f_min_s <= adc_min;
        f_max_s <= adc_max;
        f_stale_to_s <= adc_stale;
        f_wdt_to_s <= wdt_timeout;
        f_oc_to_s <= oc_timeout;
        f_lim_s <= i_limit;
        f_tcmin_s <= tc_min;
        f_stale <= f_stale_now;
        f_wdt <= f_wdt_now;
        if (f_fclr_now) f_oc <= 16'd0;
        f_fault_tick <= fault_reg;
        f_iprev <= f_irst_now ? 32'd0 : integ_reg;
    end
    if (seq_reg[8]) f_pi <= m2_p;
    if (f_run_done) begin
        f_ulim <= lim_cfg;
        f_sat_hi <= rhi_reg;
        f_sat_lo <= rlo_reg;
        f_oc <= (rhi_reg || rlo_reg) ? f_oc + {15'd0, f_oc != 16'hFFFF} : 16'd0;
    end
    if (f_stop_done) begin
        f_sat_hi <= 1'b0;
        f_sat_lo <= 1'b0;
        f_oc <= 16'd0;
    end
    if (rst) begin
        f_fresh <= 1'b0;
        f_tcw <= 1'b0;
        f_fclr <= 1'b0;
        f_irst <= 1'b0;
        f_raw <= 24'd0;
        f_stale <= 16'd0;
        f_wdt <= 16'd0;
        f_oc <= 16'd0;
        f_ulim <= 15'd0;
        f_sat_hi <= 1'b0;
        f_sat_lo <= 1'b0;
    end
end

// The shadow counters are the RTL's (which stop at 2^16, above every threshold).
always @* if (f_past_valid && !rst) begin
    // property tl_shadow_counters: the RTL's fault counters and pending flags equal the shadow's; never clipped high and low at once (induction helper)
    tl_shadow_counters: assert(f_stale == (stale_cnt_reg[16] ? 16'hFFFF : stale_cnt_reg[15:0]));
    tl_shadow_counters_2: assert(f_wdt == (wdt_cnt_reg[16] ? 16'hFFFF : wdt_cnt_reg[15:0]));
    tl_shadow_counters_3: assert(f_oc == (oc_cnt_reg[16] ? 16'hFFFF : oc_cnt_reg[15:0]));
    tl_shadow_counters_4: assert(raw_reg == f_raw);
    tl_shadow_counters_5: assert(fresh_reg == f_fresh && tcw_pend_reg == f_tcw && fclr_pend_reg == f_fclr);
    tl_shadow_counters_6: assert(irst_pend_reg == f_irst);
    tl_shadow_counters_7: assert(sat_hi_reg == f_sat_hi && sat_lo_reg == f_sat_lo);
    tl_shadow_counters_8: assert(!(sat_hi_reg && sat_lo_reg));
end

// While a sample is in flight its snapshot is the shadow's (helpers for the induction).
always @* if (f_past_valid && !rst && f_busy) begin
    // property tl_snapshot: while a sample is in flight its register snapshot is the shadow's (induction helper)
    tl_snapshot: assert(en_cfg == f_en_s && lim_cfg == f_lim_s && iprev_reg == f_iprev);
    tl_snapshot_2: assert(fbase_s_reg == (f_fclr_s ? 4'd0 : f_fault_tick));
    if (f_since_tick >= 4'd2) tl_snapshot_3: assert(nlim_reg == -{1'b0, lim_cfg});
    if (f_since_tick >= 4'd10) begin
        tl_snapshot_4: assert(pi_pos_reg == ($signed(f_pi) > 0));
        tl_snapshot_5: assert(pi_neg_reg == ($signed(f_pi) < 0));
    end
    if (f_since_tick <= 4'd3) tl_snapshot_6: assert(fault_reg == f_fault_tick);
end

// --- the current command (tl_current_limit .. tl_floor) -----------------------------------

wire signed [15:0] f_u = $signed(u_reg);
wire signed [16:0] f_lim_pos = $signed({2'b00, f_ulim});
always @* if (f_past_valid) begin
    // Never beyond the I_LIMIT it was computed with (a watchdog ramp only shrinks it).
    // property tl_current_limit: u never beyond +-I_LIMIT of the sample that made it (a watchdog ramp only shrinks it)
    tl_current_limit: assert(f_u <= f_lim_pos && f_u >= -f_lim_pos);
    // Zero whenever the drive is disabled.
    // property tl_zero_when_disabled: u is 0 whenever the drive is disabled
    if (!out_en_reg) tl_zero_when_disabled: assert(u_reg == 16'd0);
end

// A running sample clips to the I_LIMIT taken at its tick.
// property tl_run_sample_limit: a running sample enables the drive and clips to the I_LIMIT taken at its tick
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(f_run_done)) begin
    tl_run_sample_limit: assert(out_en_reg);
    tl_run_sample_limit_2: assert(f_ulim == $past(f_lim_s));
end

// A stopped sample: zero, or one ramp step towards zero under a watchdog-only fault.
// property tl_stop_zero_or_ramp: a stopped sample gives u = 0 and the drive off, or under a watchdog-only fault one WDT_RAMP_STEP towards zero, the drive off once u is 0
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(f_stop_done)) begin
    if ($past(f_en_s) && $past(fault_reg) == F_WDT) begin
        tl_stop_zero_or_ramp: assert(u_reg == f_ramp($past(u_reg)));
        tl_stop_zero_or_ramp_2: assert(out_en_reg == (u_reg != 16'd0));
        tl_stop_zero_or_ramp_3: assert(ramp_st_reg == out_en_reg);
    end else begin
        tl_stop_zero_or_ramp_4: assert(u_reg == 16'd0 && !out_en_reg && !ramp_st_reg);
    end
end

// u and the drive enable change only when a sample ends (or at reset).
// property tl_change_at_sample_end: u, the drive enable and the integrator change only when a sample ends (or at reset)
always @(posedge clk) if (f_past_valid && !$past(rst) && !$past(seq_reg[13])) begin
    tl_change_at_sample_end: assert($stable(u_reg) && $stable(out_en_reg) && $stable(integ_reg));
end

// The floor: a running sample never commands a tension below the TC_MIN taken at its tick.
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(f_run_done))
    // property tl_floor: a running sample never leaves TC_EFF below the TC_MIN taken at its tick
    tl_floor: assert($signed(tc_eff_reg) >= $signed($past(f_tcmin_s)));

// --- the integrator (tl_integ_clamp, tl_integ_zero_when_stopped, tl_anti_windup) ----------

wire signed [32:0] f_ilim = $signed({2'b00, f_ulim, 16'd0});
always @* if (f_past_valid) begin
    // property tl_integ_clamp: the integrator stays within +-I_LIMIT << 16
    tl_integ_clamp: assert($signed(integ_reg) <= f_ilim && $signed(integ_reg) >= -f_ilim);
    // property tl_integ_zero_when_stopped: the integrator is 0 while the drive is disabled or ramping
    if (!out_en_reg || wdt_ramp) tl_integ_zero_when_stopped: assert(integ_reg == 32'd0);
end

// Anti-windup: after a command clipped high, no integration upwards (and low, downwards): the
// integrator holds, only clamped to the sample's I_LIMIT.
wire signed [32:0] f_ilim_s = $signed({2'b00, f_lim_s, 16'd0});
wire signed [32:0] f_iprev_c = ($signed(f_iprev) > f_ilim_s) ? f_ilim_s :
                               ($signed(f_iprev) < -f_ilim_s) ? -f_ilim_s : $signed(f_iprev);
wire f_hold = (f_sat_hi && $signed(f_pi) > 0) || (f_sat_lo && $signed(f_pi) < 0);
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(f_run_done) && $past(f_hold))
    // property tl_anti_windup: after a command clipped high (low) and a positive (negative) KI_TS*e the integrator holds, only clamped
    tl_anti_windup: assert(integ_reg == $past(f_iprev_c[31:0]));

// --- faults (tl_fault_definition, tl_hard_fault_safe, tl_reset_safe) ----------------------

// FAULT changes only on the third clock of a sample, to exactly the register map's definition:
// latched bits stay until FAULT_CLEAR, new bits come only while enabled.
// property tl_fault_definition: FAULT changes only on the third clock of a sample, to exactly the register map's definition (latched until FAULT_CLEAR, new bits only while enabled)
always @(posedge clk) if (f_past_valid && !$past(rst)) begin
    if ($past(seq_reg[2])) tl_fault_definition: assert(fault_reg == $past(f_fault_exp));
    else tl_fault_definition_2: assert($stable(fault_reg));
end

// Any fault but the watchdog alone: u = 0 and the drive disabled within F_SAFE_CLKS clocks of
// latching (the end of the sample that found it, 15 clocks after its tick), ramp or not.
localparam F_SAFE_CLKS = 11;
reg [3:0] f_hard_age;
always @(posedge clk) begin
    if (rst || (fault_reg & ~F_WDT) == 4'd0) f_hard_age <= 4'd0;
    else if (f_hard_age != 4'd15) f_hard_age <= f_hard_age + 4'd1;
end
// property tl_hard_fault_safe: any fault but the watchdog alone gives u = 0 and the drive off within 11 clocks of latching, ramp or not
always @* if (f_past_valid && !rst && f_hard_age >= F_SAFE_CLKS)
    tl_hard_fault_safe: assert(u_reg == 16'd0 && !out_en_reg && !ramp_st_reg);

// Reset: outputs safe on the next clock.
// property tl_reset_safe: the clock after reset: u = 0, drive off, no faults, integrator 0
always @(posedge clk) if (f_past_valid && $past(rst)) begin
    tl_reset_safe: assert(u_reg == 16'd0 && !out_en_reg && fault_reg == 4'd0 && integ_reg == 32'd0);
end

// --- covers: each property's interesting case is reachable ---------------------------------

always @(posedge clk) if (f_past_valid && !rst && !$past(rst)) begin
    cover(out_en_reg && f_ulim != 15'd0 && f_u == f_lim_pos);             // clipped high
    cover(out_en_reg && f_ulim != 15'd0 && f_u == -f_lim_pos);            // clipped low
    cover(f_ulim != 15'd0 && $signed(integ_reg) == f_ilim);               // integrator clamp
    cover($past(f_run_done) && $past(f_sat_hi) && $signed($past(f_pi)) > 0 &&
          integ_reg != 32'd0 && integ_reg == $past(f_iprev));            // windup held
    cover($past(f_run_done) && $past(f_hold) && integ_reg != $past(f_iprev)); // held, clamped
    cover($past(f_run_done) && $signed($past(tc_cfg)) < $signed($past(f_tcmin_s)) &&
          tc_eff_reg == $past(f_tcmin_s) && $signed(tc_eff_reg) > 0);      // floor applied
    cover($rose(fault_reg[0]));                                           // ADC stale
    cover($rose(fault_reg[1]));                                           // ADC range
    cover($rose(fault_reg[3]));                                           // over-current
    cover($rose(fault_reg[2]) && out_en_reg && u_reg != 16'd0);           // watchdog trips
    cover(ramp_st_reg && $past(ramp_st_reg) && $changed(u_reg));          // ramping
    cover(fault_reg == F_WDT && $fell(out_en_reg) && $past(ramp_st_reg)); // ramp done
    cover(fault_reg == (F_WDT | 4'b0010) && $fell(out_en_reg));           // watchdog + range
    cover($past(fault_reg) != 4'd0 && fault_reg == 4'd0);                 // fault cleared
end

`undef TL_ENV
`endif

endmodule

`resetall
