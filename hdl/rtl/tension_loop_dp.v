`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * The datapath of one sample of one tension loop: calibration, slew limit, floor, PI +
 * feedforward, conditional integration, faults and the watchdog ramp, in a fixed 15-clock
 * schedule on two registered multipliers, and the loop's state between samples (the fault
 * counters and latches, u, the integrator, T_c', the read-backs). The one copy of the loop's
 * arithmetic: tension_loop runs it once per tick, tension_loop_mc once per channel in turn.
 * The formats and why each step is exact are in hdl/README.md ("The loop"); the bit-exact
 * definition is cosim/parts/rtl_model.py.
 *
 * `start` is clock 0 of a sample; the results appear at the edge that ends clock 14 (seq[13]).
 *
 * PRELOAD 0 (tension_loop): clock 0 reads the events (`ev_*`) and the configuration as they are
 * in that clock; later clocks read the configuration from snapshot registers taken at `start`
 * (SNAPSHOT 1) or the live ports, which the caller then holds stable (SNAPSHOT 0). The state
 * registers are the loop's.
 *
 * PRELOAD 1 (tension_loop_mc): everything a sample reads, its events, configuration and state
 * (`ld_state`), is taken into this module's registers at `ld`, the clock before `start`, so no
 * multiplexer in front of the datapath sits before a carry chain; the sample reads nothing else.
 * `state_res` is the state the sample leaves (valid in its last clock: the channel's new state),
 * and `ld` in that same clock loads the next channel in its place.
 *
 * PRELOAD 2 (tension_loop_mc with CFG_RAM 1): as PRELOAD 1, but the configuration words (all
 * but `enable` and `slew_en`, which it loads as PRELOAD 1 does) are already what a load gives:
 * the output register of the caller's block RAM, read at `ld` and held through the sample, so
 * this module keeps no copy of them.
 *
 * LIVE 1 (with PRELOAD 1 or 2; tension_loop_mc with CFG_RAM 1): the events and the state are not
 * loaded: `ev_*` and `ld_state` are the slot's channel's, read through the caller's multiplexer
 * in every clock of the sample, and `state_res` is the state at the next edge, which the caller
 * writes into that channel's word in every clock of the sample (this module keeps no copy:
 * 139 + 29 flip-flops fewer). The configuration is loaded as PRELOAD 1 or 2 loads it.
 *
 * The state word (state, state_res, ld_state), from bit 0: stale counter [16:0], watchdog
 * counter [33:17], over-current counter [50:34], FAULT [54:51], T_in [70:55] (Q7.8 N), u [86:71]
 * (Q3.12 A), drive enable [87], clipped high [88], clipped low [89], ramping [90], integrator
 * [122:91] (Q3.28 A), T_c' [138:123] (Q7.8 N).
 */
module tension_loop_dp #(
    parameter [15:0] WDT_RAMP_STEP = 16'd41, // watchdog ramp-down of u, Q3.12 A per sample
                                             // (41/4096 A: 4 A reach zero in 40 ms at 10 kHz)
    parameter SNAPSHOT = 1,                  // PRELOAD 0: 1 snapshot at start, 0 live ports
    parameter PRELOAD = 0,                   // 1: events, configuration, state loaded at ld;
                                             // 2: the same, the configuration by the caller
    parameter LIVE = 0                       // PRELOAD 1, 2: 1 the events and the state read
                                             // from the caller in every clock, not loaded
) (
    input  wire         clk,
    input  wire         rst,

    /*
     * Schedule
     */
    input  wire         start,        // clock 0 of a sample
    input  wire         ld,           // PRELOAD 1: load the next sample's inputs at this edge
    output wire [13:0]  seq,          // seq[k] high in clock k+1 of the sample

    /*
     * Events since the last sample
     */
    input  wire [23:0]  ev_raw,       // the latest ADC sample, signed 24-bit code
    input  wire         ev_fresh,     // an ADC sample came
    input  wire         ev_tcw,       // TC was written (watchdog refresh)
    input  wire         ev_irst,      // CTRL.INTEG_RESET pulse
    input  wire         ev_fclr,      // CTRL.FAULT_CLEAR pulse
    input  wire         ev_grp,       // group stop: run as under a watchdog-only fault

    /*
     * Configuration (register fields)
     */
    input  wire         enable,       // CTRL.ENABLE
    input  wire         slew_en,      // CTRL.SLEW_EN
    input  wire [15:0]  tc,           // Q7.8 N
    input  wire [15:0]  tc_min,       // Q7.8 N, floor of T_c' (a cable cannot push)
    input  wire [15:0]  kff,          // Q2.13 A/N
    input  wire [15:0]  uff,          // Q3.12 A, added to u outside the PI
    input  wire [15:0]  kp,           // Q2.13 A/N
    input  wire [15:0]  ki_ts,        // 2^-20 A/N per sample
    input  wire [14:0]  i_limit,      // UQ3.12 A
    input  wire [14:0]  slew,         // UQ7.8 N per sample
    input  wire [15:0]  wdt_timeout,  // samples, 0 = off
    input  wire [23:0]  adc_offset,   // code
    input  wire [15:0]  adc_gain,     // 2^-20 Q7.8-LSB per code
    input  wire [23:0]  adc_min,      // code
    input  wire [23:0]  adc_max,      // code
    input  wire [15:0]  adc_stale,    // samples, 0 = off
    input  wire [15:0]  oc_timeout,   // samples, 0 = off

    /*
     * State (layout above)
     */
    input  wire [138:0] ld_state,     // PRELOAD 1: the next channel's state, loaded at ld
    output wire [138:0] state,        // the state now
    output wire [138:0] state_res     // the state the sample leaves (valid in its last clock)
`ifdef FORMAL
    ,
    /*
     * Formal only: the sample's registers, for the properties of tension_loop and
     * tension_loop_mc
     */
    output wire [31:0]  f_cfg,        // {ENABLE, I_LIMIT, TC} as the later clocks read them
    output wire [31:0]  f_iprev,      // the integrator entering the sample
    output wire [3:0]   f_fbase,      // FAULT kept from before the sample
    output wire [15:0]  f_nlim,       // -I_LIMIT
    output wire [1:0]   f_pi_sign,    // {KI_TS*e > 0, KI_TS*e < 0}
    output wire [63:0]  f_prod,       // {mul1's, mul2's product}
    output wire [3:0]   f_mode,       // {run, clipped high, clipped low, group stop}
    output wire [11*128-1:0] f_pipe,  // the pipeline by the clock that writes it (0 1 2 3 4 6
                                      // 9 10 11 12 13), group 0 in the top bits (T_in,
                                      // written in clock 5, with clock 6's; clock 3's
                                      // held integrator and clock 12's u - step and
                                      // u + step, once registers, as wires of registers
                                      // that hold to the sample's end)
    output wire [431:0] f_load        // what ld loads: events, configuration, state (T_in, the
                                      // drive enable and the ramp flag are not loaded: 0);
                                      // with LIVE the caller's events and state
`endif
);

localparam LATENCY = 15;  // clocks from start to the results (seq[LATENCY-2])

localparam [3:0] F_WDT = 4'b0100;  // fault bits: {overcurrent, watchdog, adc_range, adc_stale}

// Schedule: seq_reg[k] is high in clock k+1 after start (clock 0). Every stage has at most one
// carry chain between registers, so that the iCE40 UP5K meets 48 MHz.
reg  [LATENCY-2:0] seq_reg, seq_next;

// The state between samples: this module's register (st_q_reg), or with LIVE the caller's word.
reg  [138:0] st_q_reg;
wire [16:0] stale_cnt_reg;
wire [16:0] wdt_cnt_reg;
wire [16:0] oc_cnt_reg;
wire [3:0]  fault_reg;
wire [15:0] t_in_reg;
wire [15:0] u_reg;
wire        out_en_reg;
wire        sat_hi_reg;
wire        sat_lo_reg;
wire        ramp_st_reg;
wire [31:0] integ_reg;
wire [15:0] tc_eff_reg;
reg  [16:0] stale_cnt_next;
reg  [16:0] wdt_cnt_next;
reg  [16:0] oc_cnt_next;
reg  [3:0]  fault_next;
reg  [15:0] t_in_next;
reg  [15:0] u_next;
reg         out_en_next;
reg         sat_hi_next;
reg         sat_lo_next;
reg         ramp_st_next;
reg  [31:0] integ_next;
reg  [15:0] tc_eff_next;
localparam LIVE_ST = (PRELOAD != 0) && (LIVE != 0);
assign {tc_eff_reg, integ_reg, ramp_st_reg, sat_lo_reg, sat_hi_reg, out_en_reg, u_reg, t_in_reg,
        fault_reg, oc_cnt_reg, wdt_cnt_reg, stale_cnt_reg} = LIVE_ST ? ld_state : st_q_reg;

// The events, and the snapshot of the configuration: loaded at ld (PRELOAD 1) or at start.
reg  [23:0] raw_l_reg, raw_l_next;
reg         fresh_l_reg, fresh_l_next;
reg         tcw_l_reg, tcw_l_next;
reg         irst_l_reg, irst_l_next;
reg         fclr_l_reg, fclr_l_next;
reg         grp_l_reg, grp_l_next;
reg         en_s_reg, en_s_next;
reg         slew_en_s_reg, slew_en_s_next;
reg  [15:0] tc_s_reg, tc_s_next;
reg  [15:0] tcmin_s_reg, tcmin_s_next;
reg  [15:0] kff_s_reg, kff_s_next;
reg  [15:0] uff_s_reg, uff_s_next;
reg  [15:0] kp_s_reg, kp_s_next;
reg  [15:0] ki_s_reg, ki_s_next;
reg  [14:0] lim_s_reg, lim_s_next;
reg  [14:0] slew_s_reg, slew_s_next;
reg  [15:0] wdt_to_s_reg, wdt_to_s_next;
reg  [23:0] offset_s_reg, offset_s_next;
reg  [15:0] gain_s_reg, gain_s_next;
reg  [23:0] min_s_reg, min_s_next;
reg  [23:0] max_s_reg, max_s_next;
reg  [15:0] stale_to_s_reg, stale_to_s_next;
reg  [15:0] oc_to_s_reg, oc_to_s_next;

wire load = (PRELOAD != 0) ? ld : start;
localparam SNAP = (PRELOAD == 1) || (PRELOAD == 0 && SNAPSHOT != 0);
localparam SNAP_CTRL = (PRELOAD != 0) || (SNAPSHOT != 0);  // ENABLE, SLEW_EN

// What clock 0 reads: the loaded registers (PRELOAD 1) or the inputs as they are (PRELOAD 0,
// LIVE).
localparam EV_LD = (PRELOAD != 0) && (LIVE == 0);
wire [23:0] raw_c = EV_LD ? raw_l_reg : ev_raw;
wire        fresh_c = EV_LD ? fresh_l_reg : ev_fresh;
wire        tcw_c = EV_LD ? tcw_l_reg : ev_tcw;
wire        irst_c = EV_LD ? irst_l_reg : ev_irst;
wire        fclr_c = EV_LD ? fclr_l_reg : ev_fclr;
// PRELOAD 2: the configuration words' ports are the loaded configuration.
wire        en_0 = (PRELOAD != 0) ? en_s_reg : enable;
wire [14:0] slew_0 = (PRELOAD == 1) ? slew_s_reg : slew;              // UQ7.8 N
wire [23:0] offset_0 = (PRELOAD == 1) ? offset_s_reg : adc_offset;    // Q23.0 code
// The group stop, read in clock 3: from its register, or with LIVE the caller's.
wire        grp_c = LIVE_ST ? ev_grp : grp_l_reg;

// What the later clocks read: the snapshot, or the live ports (SNAPSHOT 0, held by the caller;
// PRELOAD 2, loaded by the caller; the snapshot registers then have no reader and synthesis
// removes them).
wire        en_cfg = SNAP_CTRL ? en_s_reg : enable;
wire        slew_en_cfg = SNAP_CTRL ? slew_en_s_reg : slew_en;
wire [15:0] tc_cfg = SNAP ? tc_s_reg : tc;                    // Q7.8 N
wire [15:0] tcmin_cfg = SNAP ? tcmin_s_reg : tc_min;          // Q7.8 N
wire [15:0] kff_cfg = SNAP ? kff_s_reg : kff;                 // Q2.13 A/N
wire [15:0] uff_cfg = SNAP ? uff_s_reg : uff;                 // Q3.12 A
wire [15:0] kp_cfg = SNAP ? kp_s_reg : kp;                    // Q2.13 A/N
wire [15:0] ki_cfg = SNAP ? ki_s_reg : ki_ts;                 // 2^-20 A/N per sample
wire [15:0] gain_cfg = SNAP ? gain_s_reg : adc_gain;          // 2^-20 Q7.8-LSB per code
wire [14:0] lim_cfg = SNAP ? lim_s_reg : i_limit;             // UQ3.12 A
wire [15:0] stale_to_cfg = SNAP ? stale_to_s_reg : adc_stale;
wire [15:0] wdt_to_cfg = SNAP ? wdt_to_s_reg : wdt_timeout;
wire [15:0] oc_to_cfg = SNAP ? oc_to_s_reg : oc_timeout;
wire [23:0] min_cfg = SNAP ? min_s_reg : adc_min;             // Q23.0 code
wire [23:0] max_cfg = SNAP ? max_s_reg : adc_max;             // Q23.0 code

// Pipeline.
reg  [23:0] raw_s_reg, raw_s_next;
reg         lo_bad_reg, lo_bad_next;
reg         hi_bad_reg, hi_bad_next;
reg  [3:0]  fbase_s_reg, fbase_s_next;
reg  [24:0] diff_reg, diff_next;
reg  [16:0] hi_s_reg, hi_s_next;
reg  [16:0] lo_s_reg, lo_s_next;
reg  [15:0] nlim_reg, nlim_next;  // -I_LIMIT, computed once per sample off the critical paths
reg  [31:0] iprev_reg, iprev_next;
reg         iphi_reg, iphi_next;  // I entering the sample > +I_LIMIT (I_LIMIT lowered)
reg         iplo_reg, iplo_next;  // I entering the sample < -I_LIMIT
reg  [3:0]  det_reg, det_next;
reg         cmp_hi_reg, cmp_hi_next;
reg         cmp_lo_reg, cmp_lo_next;
reg         run_reg, run_next;
reg         ramp_reg, ramp_next;
reg  [15:0] tce_s_reg, tce_s_next;   // T_c after the slew limit (clock 2)
reg  [15:0] tcf_reg, tcf_next;       // T_c' = max(that, TC_MIN), the floor (clock 3)
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

// Multiplier operands.
reg  [15:0] m1_a, m1_b, m2_a, m2_b;
wire signed [31:0] m1_p, m2_p;

mul_s16 mul1 (.clk(clk), .a(m1_a), .b(m1_b), .p(m1_p));
mul_s16 mul2 (.clk(clk), .a(m2_a), .b(m2_b), .p(m2_p));

// --- clock 0 --------------------------------------------------------------------------------

// Counters stop at 2^16 so a long fault never wraps to "fine"; every threshold is below 2^16,
// so for the checks (count >= threshold) this equals the model's saturation at 2^16 - 1.
// A fault clear restarts a counter from zero: the increment is computed in parallel and the
// clear chooses 1 after it, which keeps the clear off the carry chain.
wire [16:0] stale_inc = stale_cnt_reg + {16'd0, !stale_cnt_reg[16]};
wire [16:0] wdt_inc = wdt_cnt_reg + {16'd0, !wdt_cnt_reg[16]};
wire [16:0] stale_now = fresh_c ? 17'd0 : fclr_c ? 17'd1 : stale_inc;
wire [16:0] wdt_now = (!en_0 || tcw_c) ? 17'd0 : fclr_c ? 17'd1 : wdt_inc;

// --- later clocks ---------------------------------------------------------------------------

// Clock 1: range check of the sample. Clock 2: fault detection on the snapshot (thresholds
// of 0 switch a check off).
// The sample's code: taken at start (PRELOAD 0), or the loaded one (or with LIVE the caller's),
// which holds through the sample (PRELOAD 1, 2: the copy would be 24 flip-flops of the same bits;
// synthesis removes it).
wire [23:0] raw_s = (PRELOAD != 0) ? raw_c : raw_s_reg;
wire [24:0] below_min = {raw_s[23], raw_s} - {min_cfg[23], min_cfg};
wire [24:0] above_max = {max_cfg[23], max_cfg} - {raw_s[23], raw_s};
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
// product starts a clock later for it, in clock 4), into a register of its own, so that the sign
// picks a value instead of driving the clock enable of T_s's register.
wire [16:0] tce_flr = {tce_s_reg[15], tce_s_reg} - {tcmin_cfg[15], tcmin_cfg};

// Clock 5: round(x / 2^20) fits Q7.8 unless bits 40..35 differ: saturate to the Q7.8 range.
wire cal_ovf = !((&cal_sum_reg[40:35]) || !(|cal_sum_reg[40:35]));
wire [15:0] t_in_now = cal_ovf ? {cal_sum_reg[40], {15{~cal_sum_reg[40]}}} : cal_sum_reg[35:20];

// Clock 6: error in 17 bits, saturated to Q7.8 (beyond +-128 N only the integration rate is
// limited).
wire signed [16:0] e_full = $signed({tcf_reg[15], tcf_reg}) -
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
// clamp(I, +-I_LIMIT), the integrator when it holds: from clock 3 on (clock 2's comparisons),
// chosen in clock 11 with the sum's clamp (no register of its own).
wire [31:0] ihold = iphi_reg ? lim28[31:0] : iplo_reg ? nlim28[31:0] : iprev_reg;
wire [33:0] ip_above = {lim28[32], lim28} - {{2{iprev_reg[31]}}, iprev_reg};
wire [33:0] ip_below = {{2{iprev_reg[31]}}, iprev_reg} - {nlim28[32], nlim28};

// Clock 12: rounded sum, Q3.12 in 25 bits: |fp| < 2^32 + 2^25, |I >> 7| < 2^24, so 34 bits hold
// it (the +2^8 in ff_reg turns the arithmetic shift's floor into rounding).
wire signed [33:0] v_sum = $signed(fp_reg) + $signed({{9{inew_reg[31]}}, inew_reg[31:7]});

// Clocks 13-14: output saturation at +-I_LIMIT.
// Comparisons as subtractions, whose sign bit comes out of one carry chain (yosys otherwise
// builds some of them from LUT trees on the iCE40): r > lim <=> lim - r < 0. With PRELOAD 1 and
// 2 (tension_loop_mc, the SoCs at 24 MHz and below) only the bits that can decide take the
// chain: r > I_LIMIT (15 bits) when r >= 0 and r >= 2^15 or r[14:0] > I_LIMIT; r < -I_LIMIT
// (>= -32767) when r < 0 and r < -2^15 or, r in [-2^15, 0), its 16 bits as a signed word
// < -I_LIMIT. With PRELOAD 0 (tension_loop, the external-MCU tops at 48 MHz) the 26-bit chains:
// the narrow form's test of r[23:15] after its chain was that top's critical path on the UP5K.
localparam NARROW_R = (PRELOAD != 0);
wire signed [24:0] lim12 = $signed({10'd0, lim_cfg});
wire signed [24:0] nlim12 = $signed({{9{nlim_reg[15]}}, nlim_reg});
wire [25:0] r_above_w = {lim12[24], lim12} - {r_reg[24], r_reg};
wire [25:0] r_below_w = {r_reg[24], r_reg} - {nlim12[24], nlim12};
wire [15:0] r_above = {1'b0, lim_cfg} - {1'b0, r_reg[14:0]};
wire [16:0] r_below = {r_reg[15], r_reg[15:0]} - {nlim_reg[15], nlim_reg};
wire r_gt_lim = NARROW_R ? (!r_reg[24] && ((|r_reg[23:15]) || r_above[15])) : r_above_w[25];
wire r_lt_nlim = NARROW_R ? (r_reg[24] && (!(&r_reg[23:15]) || r_below[16])) : r_below_w[25];
wire [15:0] u_sat = rhi_reg ? {1'b0, lim_cfg} : rlo_reg ? nlim_reg : r_reg[15:0];

// Watchdog ramp of the previous command towards zero: the comparisons in clock 12, the step in
// clock 13 on one adder, u - step or u + step as the comparison chose (u_ramp is nonzero exactly
// when |u| > step). The comparisons with the constant are logic on u's bits, not carry chains.
wire signed [15:0] step = $signed(WDT_RAMP_STEP);
// x > k for 16-bit two's complement x and constant k: unsigned with the sign bits flipped.
function gt_s16;
    input [15:0] x;
    input [15:0] k;
    reg [15:0] xu, ku;
    reg gt, eq;
    integer i;
    begin
        xu = x ^ 16'h8000;
        ku = k ^ 16'h8000;
        gt = 1'b0;
        eq = 1'b1;
        for (i = 15; i >= 0; i = i - 1) begin
            gt = gt | (eq & xu[i] & ~ku[i]);
            eq = eq & (xu[i] == ku[i]);
        end
        gt_s16 = gt;
    end
endfunction
wire [15:0] u_step = u_reg + (ugt_reg ? -step : step);
wire [15:0] u_ramp = (ugt_reg || ult_reg) ? u_step : 16'd0;

// Bits dropped on purpose: the fraction below the rounding point, and the sign bit of values
// proven in range (slew result between two Q7.8 values, clamped integrator within +-2^31).
wire unused_bits = &{1'b0, tce_slew[16], below_min[23:0], above_max[23:0], cal_sum_reg[19:0], i_clamped[32], v_sum[8:0],
                     r_above[14:0], r_below[15:0], r_above_w[24:0], r_below_w[24:0], i_above[32:0], i_below[32:0],
                     ip_above[32:0], ip_below[32:0],
                     tc_above[16:0], tc_below[16:0], tce_flr[15:0]};

wire [138:0] state_next = {tc_eff_next, integ_next, ramp_st_next, sat_lo_next, sat_hi_next,
                          out_en_next, u_next, t_in_next, fault_next, oc_cnt_next, wdt_cnt_next,
                          stale_cnt_next};
// The state the sample leaves, for its last clock: the fields that clock writes, and the
// registers of the ones written earlier (so no earlier clock's logic reaches the caller's). With
// LIVE the state at the next edge, for every clock of the sample.
assign state_res = LIVE_ST ? state_next :
                   {tc_eff_next, integ_next, ramp_st_next, sat_lo_next, sat_hi_next,
                    out_en_next, u_next, t_in_reg, fault_reg, oc_cnt_next, wdt_cnt_reg,
                    stale_cnt_reg};
// The state at the next edge: the sample's, or the next channel's at a load (PRELOAD 1). T_in,
// the drive enable and the ramp flag are not loaded: every sample writes them before it reads
// them (clocks 5 and 14), so they keep the load's multiplexer off T_in's saturation path.
localparam [138:0] LD_MASK = ~{48'd0, 1'b1, 2'd0, 1'b1, 16'd0, 16'hFFFF, 55'd0};
wire [138:0] state_d = (PRELOAD != 0 && ld) ? ((ld_state & LD_MASK) | (state_next & ~LD_MASK)) :
                                              state_next;

always @* begin
    seq_next = {seq_reg[LATENCY-3:0], start};

    stale_cnt_next = stale_cnt_reg;
    wdt_cnt_next = wdt_cnt_reg;
    oc_cnt_next = oc_cnt_reg;
    fault_next = fault_reg;
    t_in_next = t_in_reg;
    u_next = u_reg;
    out_en_next = out_en_reg;
    sat_hi_next = sat_hi_reg;
    sat_lo_next = sat_lo_reg;
    ramp_st_next = ramp_st_reg;
    integ_next = integ_reg;
    tc_eff_next = tc_eff_reg;

    raw_l_next = load ? ev_raw : raw_l_reg;
    fresh_l_next = load ? ev_fresh : fresh_l_reg;
    tcw_l_next = load ? ev_tcw : tcw_l_reg;
    irst_l_next = load ? ev_irst : irst_l_reg;
    fclr_l_next = load ? ev_fclr : fclr_l_reg;
    grp_l_next = load ? ev_grp : grp_l_reg;
    en_s_next = load ? enable : en_s_reg;
    slew_en_s_next = load ? slew_en : slew_en_s_reg;
    tc_s_next = load ? tc : tc_s_reg;
    tcmin_s_next = load ? tc_min : tcmin_s_reg;
    kff_s_next = load ? kff : kff_s_reg;
    uff_s_next = load ? uff : uff_s_reg;
    kp_s_next = load ? kp : kp_s_reg;
    ki_s_next = load ? ki_ts : ki_s_reg;
    lim_s_next = load ? i_limit : lim_s_reg;
    slew_s_next = load ? slew : slew_s_reg;
    wdt_to_s_next = load ? wdt_timeout : wdt_to_s_reg;
    offset_s_next = load ? adc_offset : offset_s_reg;
    gain_s_next = load ? adc_gain : gain_s_reg;
    min_s_next = load ? adc_min : min_s_reg;
    max_s_next = load ? adc_max : max_s_reg;
    stale_to_s_next = load ? adc_stale : stale_to_s_reg;
    oc_to_s_next = load ? oc_timeout : oc_to_s_reg;

    raw_s_next = raw_s_reg;
    lo_bad_next = lo_bad_reg;
    hi_bad_next = hi_bad_reg;
    fbase_s_next = fbase_s_reg;
    diff_next = diff_reg;
    hi_s_next = hi_s_reg;
    lo_s_next = lo_s_reg;
    nlim_next = nlim_reg;
    iprev_next = iprev_reg;
    iphi_next = iphi_reg;
    iplo_next = iplo_reg;
    det_next = det_reg;
    cmp_hi_next = cmp_hi_reg;
    cmp_lo_next = cmp_lo_reg;
    run_next = run_reg;
    ramp_next = ramp_reg;
    tce_s_next = tce_s_reg;
    tcf_next = tcf_reg;
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

    m1_a = 16'd0;
    m1_b = 16'd0;
    m2_a = 16'd0;
    m2_b = 16'd0;

    // Clock 0: counters, raw - offset (25 bits: exact for 24-bit codes), slew bounds.
    if (start) begin
        stale_cnt_next = stale_now;
        wdt_cnt_next = wdt_now;
        oc_cnt_next = fclr_c ? 17'd0 : oc_cnt_reg;
        raw_s_next = raw_c;
        fbase_s_next = fclr_c ? 4'd0 : fault_reg;
        diff_next = $signed({raw_c[23], raw_c}) - $signed({offset_0[23], offset_0});
        hi_s_next = $signed({tc_eff_reg[15], tc_eff_reg}) + $signed({2'b00, slew_0});
        lo_s_next = $signed({tc_eff_reg[15], tc_eff_reg}) - $signed({2'b00, slew_0});
        iprev_next = irst_c ? 32'd0 : integ_reg;
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

    // Clock 2: detection, T_c' before the floor (slew limit), the held integrator's clamp
    // comparisons; low 9 bits of the difference (non-negative) times the gain.
    if (seq_reg[1]) begin
        det_next = en_cfg ? detect : 4'd0;
        iphi_next = ip_above[33];  // I > +I_LIMIT
        iplo_next = ip_below[33];  // I < -I_LIMIT
        tce_s_next = slew_en_cfg ? tce_slew[15:0] : tc_cfg;
        m1_a = {7'd0, diff_reg[8:0]};
        m1_b = gain_cfg;
    end

    // Clock 3: faults latch and the mode (a group stop runs the sample as a watchdog-only fault
    // does); the floor on T_c'; high partial product arrives (+ 2^19: round at >> 20).
    if (seq_reg[2]) begin
        fault_next = faults_now;
        run_next = en_cfg && (faults_now == 4'd0) && !grp_c;
        ramp_next = en_cfg && ((faults_now == F_WDT) || (faults_now == 4'd0 && grp_c));
        tcf_next = tce_flr[16] ? tcmin_cfg : tce_s_reg;  // T_s < TC_MIN: the floor
        cal_acc_next = {m1_p, 9'd0} + 41'd524288;
    end

    // Clock 4: calibration sum, (hi*g << 9) + lo*g + 2^19, 41 bits exact (|diff*g| < 2^40);
    // feedforward product of the floored T_c'.
    if (seq_reg[3]) begin
        cal_sum_next = cal_acc_reg + {{9{m1_p[31]}}, m1_p};
        m2_a = tcf_reg;
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
        inew_next = windup ? ihold : i_clamped[31:0];
    end

    // Clock 12: rounded output before saturation; the ramp's comparisons.
    if (seq_reg[11]) begin
        r_next = v_sum[33:9];
        ugt_next = gt_s16(u_reg, step);    // u > step
        ult_next = gt_s16(-step, u_reg);   // u < -step
    end

    // Clock 13: saturation comparisons.
    if (seq_reg[12]) begin
        rhi_next = r_gt_lim;
        rlo_next = r_lt_nlim;
        u_ramp_next = u_ramp;
        ramp_nz_next = ugt_reg || ult_reg;
    end

    // Clock 14: saturate, apply the mode.
    if (seq_reg[13]) begin
        if (run_reg) begin
            u_next = u_sat;
            integ_next = inew_reg;
            sat_hi_next = rhi_reg;
            sat_lo_next = rlo_reg;
            out_en_next = 1'b1;
            ramp_st_next = 1'b0;
            tc_eff_next = tcf_reg;
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
    st_q_reg <= state_d;
    raw_l_reg <= raw_l_next;
    fresh_l_reg <= fresh_l_next;
    tcw_l_reg <= tcw_l_next;
    irst_l_reg <= irst_l_next;
    fclr_l_reg <= fclr_l_next;
    grp_l_reg <= grp_l_next;
    en_s_reg <= en_s_next;
    slew_en_s_reg <= slew_en_s_next;
    tc_s_reg <= tc_s_next;
    tcmin_s_reg <= tcmin_s_next;
    kff_s_reg <= kff_s_next;
    uff_s_reg <= uff_s_next;
    kp_s_reg <= kp_s_next;
    ki_s_reg <= ki_s_next;
    lim_s_reg <= lim_s_next;
    slew_s_reg <= slew_s_next;
    wdt_to_s_reg <= wdt_to_s_next;
    offset_s_reg <= offset_s_next;
    gain_s_reg <= gain_s_next;
    min_s_reg <= min_s_next;
    max_s_reg <= max_s_next;
    stale_to_s_reg <= stale_to_s_next;
    oc_to_s_reg <= oc_to_s_next;
    raw_s_reg <= raw_s_next;
    lo_bad_reg <= lo_bad_next;
    hi_bad_reg <= hi_bad_next;
    fbase_s_reg <= fbase_s_next;
    diff_reg <= diff_next;
    hi_s_reg <= hi_s_next;
    lo_s_reg <= lo_s_next;
    nlim_reg <= nlim_next;
    iprev_reg <= iprev_next;
    iphi_reg <= iphi_next;
    iplo_reg <= iplo_next;
    det_reg <= det_next;
    cmp_hi_reg <= cmp_hi_next;
    cmp_lo_reg <= cmp_lo_next;
    run_reg <= run_next;
    ramp_reg <= ramp_next;
    tce_s_reg <= tce_s_next;
    tcf_reg <= tcf_next;
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

    if (rst) begin
        seq_reg <= {(LATENCY-1){1'b0}};
        grp_l_reg <= 1'b0;
        run_reg <= 1'b0;
        ramp_reg <= 1'b0;
    end
    // The state is the loop's (PRELOAD 0), or loaded before any sample reads it (PRELOAD 1: the
    // caller's registers are reset, these need not be, which keeps their logic shallow; LIVE:
    // the register has no reader and synthesis removes it).
    if (rst && PRELOAD == 0) begin
        st_q_reg <= 139'd0;
    end
end

assign seq = seq_reg;
assign state = {tc_eff_reg, integ_reg, ramp_st_reg, sat_lo_reg, sat_hi_reg, out_en_reg, u_reg,
                t_in_reg, fault_reg, oc_cnt_reg, wdt_cnt_reg, stale_cnt_reg};

`ifdef FORMAL
assign f_cfg = {en_cfg, lim_cfg, tc_cfg};
assign f_iprev = iprev_reg;
assign f_fbase = fbase_s_reg;
assign f_nlim = nlim_reg;
assign f_pi_sign = {pi_pos_reg, pi_neg_reg};
assign f_prod = {m1_p, m2_p};
assign f_mode = {run_reg, rhi_reg, rlo_reg, grp_c};
assign f_pipe = {
    {9'd0, raw_s, fbase_s_reg, diff_reg, hi_s_reg, lo_s_reg, iprev_reg},
    {108'd0, lo_bad_reg, hi_bad_reg, cmp_hi_reg, cmp_lo_reg, nlim_reg},
    {106'd0, det_reg, iphi_reg, iplo_reg, tce_s_reg},
    {37'd0, run_reg, ramp_reg, cal_acc_reg, ihold, tcf_reg},
    {87'd0, cal_sum_reg},
    {62'd0, t_in_reg, e_reg, ff_reg},
    {59'd0, fp_reg, isum_reg, pi_pos_reg, pi_neg_reg},
    {126'd0, ihi_reg, ilo_reg},
    {96'd0, inew_reg},
    {69'd0, r_reg, ugt_reg, ult_reg, u_reg - step, u_reg + step},
    {109'd0, rhi_reg, rlo_reg, u_ramp_reg, ramp_nz_reg}};
// With LIVE, what the sample reads from the caller in the place of the loaded events.
wire [28:0] f_ev = LIVE_ST ? {ev_raw, ev_fresh, ev_tcw, ev_irst, ev_fclr, ev_grp} :
                             {raw_l_reg, fresh_l_reg, tcw_l_reg, irst_l_reg, fclr_l_reg, grp_l_reg};
assign f_load = {f_ev,
                 en_cfg, slew_en_cfg, tc_cfg, tcmin_cfg, kff_cfg, uff_cfg, kp_cfg,
                 ki_cfg, lim_cfg, slew_0, wdt_to_cfg, offset_0, gain_cfg,
                 min_cfg, max_cfg, stale_to_cfg, oc_to_cfg, state & LD_MASK};
`endif

endmodule

`resetall
