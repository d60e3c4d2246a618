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
 * The sample is tension_loop_dp (PRELOAD 0), the datapath tension_loop_mc shares among its
 * channels: two registered multipliers (mul_s16) compute the five products in a fixed schedule;
 * the results appear LATENCY (15) clocks after the tick, marked by `out_valid`. Ticks must be at least
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
`ifdef FORMAL
    ,
    output wire [3:0]  f_clk_in_sample  // formal only: clocks since the last tick (LATENCY:
                                        // idle), for bowden_core's induction helper
`endif
);

localparam LATENCY = 15;  // clocks from tick to out_valid; documented minimum tick spacing

// Events between ticks, consumed at the tick.
reg  [23:0] raw_reg, raw_next;
reg         fresh_reg, fresh_next;
reg         tcw_pend_reg, tcw_pend_next;
reg         irst_pend_reg, irst_pend_next;
reg         fclr_pend_reg, fclr_pend_next;
reg  [31:0] sample_cnt_reg, sample_cnt_next;
reg         out_valid_reg, out_valid_next;

// Sample at or before the tick edge; events of the tick clock itself count.
wire [23:0] raw_now = adc_valid ? adc_data : raw_reg;
wire        fresh_now = fresh_reg | adc_valid;
wire        fclr_now = fclr_pend_reg | fault_clear;
wire        tcw_now = tcw_pend_reg | tc_wr;
wire        irst_now = irst_pend_reg | integ_reset;

// The sample itself: tension_loop_dp, started by the tick, on this loop's state.
wire [13:0]  seq_reg;
wire [138:0] state;
wire [138:0] state_res;

// The state word's fields (tension_loop_dp's layout; the counters, below 51, for the proofs).
wire [3:0]  fault_reg = state[54:51];
wire [15:0] t_in_reg = state[70:55];      // Q7.8 N
wire [15:0] u_reg = state[86:71];         // Q3.12 A
wire        out_en_reg = state[87];
wire        sat_hi_reg = state[88];
wire        sat_lo_reg = state[89];
wire        ramp_st_reg = state[90];
wire [31:0] integ_reg = state[122:91];    // Q3.28 A
wire [15:0] tc_eff_reg = state[138:123];  // Q7.8 N

`ifdef FORMAL
localparam [3:0] F_WDT = 4'b0100;  // fault bits: {overcurrent, watchdog, adc_range, adc_stale}
wire [16:0]  stale_cnt_reg = state[16:0];
wire [16:0]  wdt_cnt_reg = state[33:17];
wire [16:0]  oc_cnt_reg = state[50:34];
wire [31:0]  f_dp_cfg;
wire [31:0]  iprev_reg;
wire [3:0]   fbase_s_reg;
wire [15:0]  nlim_reg;
wire [1:0]   f_pi_sign;
wire [63:0]  f_prod;
wire [3:0]   f_mode;
wire [11*128-1:0] f_pipe;
wire [431:0] f_load;
wire         en_cfg = f_dp_cfg[31];
wire [14:0]  lim_cfg = f_dp_cfg[30:16];       // UQ3.12 A
wire [15:0]  tc_cfg = f_dp_cfg[15:0];         // Q7.8 N
wire         pi_pos_reg = f_pi_sign[1];
wire         pi_neg_reg = f_pi_sign[0];
wire signed [31:0] m2_p = f_prod[31:0];
wire         run_reg = f_mode[3];
wire         rhi_reg = f_mode[2];
wire         rlo_reg = f_mode[1];
`endif

tension_loop_dp #(.WDT_RAMP_STEP(WDT_RAMP_STEP), .SNAPSHOT(SNAPSHOT), .PRELOAD(0)) dp (
    .clk(clk), .rst(rst),
    .start(tick), .ld(1'b0), .seq(seq_reg),
    .ev_raw(raw_now), .ev_fresh(fresh_now), .ev_tcw(tcw_now), .ev_irst(irst_now),
    .ev_fclr(fclr_now), .ev_grp(1'b0),
    .enable(enable), .slew_en(slew_en), .tc(tc), .tc_min(tc_min), .kff(kff), .uff(uff),
    .kp(kp), .ki_ts(ki_ts), .i_limit(i_limit), .slew(slew), .wdt_timeout(wdt_timeout),
    .adc_offset(adc_offset), .adc_gain(adc_gain), .adc_min(adc_min), .adc_max(adc_max),
    .adc_stale(adc_stale), .oc_timeout(oc_timeout),
    .ld_state(139'd0), .state(state), .state_res(state_res)
`ifdef FORMAL
    ,
    .f_cfg(f_dp_cfg), .f_iprev(iprev_reg), .f_fbase(fbase_s_reg), .f_nlim(nlim_reg),
    .f_pi_sign(f_pi_sign), .f_prod(f_prod), .f_mode(f_mode), .f_pipe(f_pipe),
    .f_load(f_load)
`endif
);

// The state a sample leaves is the state (no load here); the counters are the proofs'.
wire unused_state = &{1'b0, state_res, state[50:0]};

always @* begin
    raw_next = raw_now;
    fresh_next = tick ? 1'b0 : fresh_now;
    tcw_pend_next = tick ? 1'b0 : tcw_now;
    irst_pend_next = tick ? 1'b0 : irst_now;
    fclr_pend_next = tick ? 1'b0 : fclr_now;
    sample_cnt_next = tick ? sample_cnt_reg + 32'd1 : sample_cnt_reg;
    out_valid_next = seq_reg[LATENCY-2];
end

always @(posedge clk) begin
    raw_reg <= raw_next;
    fresh_reg <= fresh_next;
    tcw_pend_reg <= tcw_pend_next;
    irst_pend_reg <= irst_pend_next;
    fclr_pend_reg <= fclr_pend_next;
    sample_cnt_reg <= sample_cnt_next;
    out_valid_reg <= out_valid_next;

    if (rst) begin
        raw_reg <= 24'd0;
        fresh_reg <= 1'b0;
        tcw_pend_reg <= 1'b0;
        irst_pend_reg <= 1'b0;
        fclr_pend_reg <= 1'b0;
        sample_cnt_reg <= 32'd0;
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
assign f_clk_in_sample = f_since_tick;
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

// The sample's datapath registers as functions of its snapshot and shadows, each from the clock
// after the datapath writes it to the sample's end (induction helpers: without them the
// induction needs a window of a whole sample, 16 clocks, to see them recomputed from a tick).
// The layout of f_pipe and f_mode is tension_loop_dp's.
wire        f_dp_grp = f_mode[0];                 // the group stop (none here: ev_grp is 0)
wire        f_dp_ramp = f_pipe[7*128 + 89];       // clock 3: the sample ramps
wire [31:0] f_dp_ihold = f_pipe[7*128 + 16 +: 32];  // clock 3: the held integrator, clamped
wire [15:0] f_dp_tcf = f_pipe[7*128 +: 16];       // clock 3: T_c' after the floor
wire        f_dp_iphi = f_pipe[8*128 + 17];       // clock 2: I entering > +I_LIMIT
wire        f_dp_iplo = f_pipe[8*128 + 16];       // clock 2: I entering < -I_LIMIT
wire [32:0] f_dp_isum = f_pipe[4*128 + 2 +: 33];  // clock 9: I + KI_TS*e
wire        f_dp_ihi = f_pipe[3*128 + 1];         // clock 10: that sum > +I_LIMIT
wire        f_dp_ilo = f_pipe[3*128];             // clock 10: that sum < -I_LIMIT
wire [31:0] f_dp_inew = f_pipe[2*128 +: 32];      // clock 11: the new integrator
wire [15:0] f_dp_u_up = f_pipe[1*128 +: 16];      // clock 12: u + step
wire [15:0] f_dp_u_dn = f_pipe[1*128 + 16 +: 16]; // clock 12: u - step
wire        f_dp_ult = f_pipe[1*128 + 32];        // clock 12: u < -step
wire        f_dp_ugt = f_pipe[1*128 + 33];        // clock 12: u > step
wire [24:0] f_dp_r = f_pipe[1*128 + 34 +: 25];    // clock 12: the rounded output
wire        f_dp_ramp_nz = f_pipe[0];             // clock 13: the ramp's u is not 0
wire [15:0] f_dp_u_ramp = f_pipe[1 +: 16];        // clock 13: the ramp's u
wire [23:0] f_dp_raw_s = f_pipe[10*128 + 95 +: 24];  // clock 0: the sample's ADC code
wire        f_dp_lo_bad = f_pipe[9*128 + 19];     // clock 1: code < ADC_MIN
wire        f_dp_hi_bad = f_pipe[9*128 + 18];     // clock 1: code > ADC_MAX
wire [3:0]  f_dp_det = f_pipe[8*128 + 18 +: 4];   // clock 2: the faults detected
// The configuration the later clocks read: the snapshot (SNAPSHOT 1) or the held ports.
wire        f_snap = SNAPSHOT != 0;
wire [23:0] f_min_cfg = f_snap ? f_load[218:195] : adc_min;
wire [23:0] f_max_cfg = f_snap ? f_load[194:171] : adc_max;
wire [15:0] f_stale_to_cfg = f_snap ? f_load[170:155] : adc_stale;
wire [15:0] f_wdt_to_cfg = f_snap ? f_load[274:259] : wdt_timeout;
wire [15:0] f_oc_to_cfg = f_snap ? f_load[154:139] : oc_timeout;
wire [15:0] f_tcmin_cfg = f_snap ? f_load[384:369] : tc_min;
wire signed [15:0] f_step = WDT_RAMP_STEP;
wire signed [32:0] f_lim28 = $signed({2'b00, lim_cfg, 16'd0});
wire signed [32:0] f_isum = $signed(f_dp_isum);
wire [31:0] f_inew_exp = f_hold ? f_iprev_c[31:0] : f_dp_ihi ? f_lim28[31:0] :
                         f_dp_ilo ? -f_lim28[31:0] : f_dp_isum[31:0];
always @* if (f_past_valid && !rst && f_busy) begin
    // property tl_sample_pipeline: while a sample is in flight its datapath registers are, from the clock after it writes each, the mode of the FAULT it latched, the integrator's sums, clamps and hold, the floor, the ramp's steps and the saturation flags, as functions of the snapshot and the shadows (induction helper)
    tl_sample_pipeline: assert(!f_dp_grp);
    if (f_since_tick >= 4'd3) tl_sample_pipeline_2: assert(
        f_dp_iphi == ($signed(f_iprev) > f_lim28) && f_dp_iplo == ($signed(f_iprev) < -f_lim28));
    if (f_since_tick >= 4'd4) tl_sample_pipeline_3: assert(
        run_reg == (en_cfg && fault_reg == 4'd0) && f_dp_ramp == (en_cfg && fault_reg == F_WDT) &&
        f_dp_ihold == f_iprev_c[31:0] && $signed(f_dp_tcf) >= $signed(f_tcmin_s));
    if (f_since_tick >= 4'd10) tl_sample_pipeline_4: assert(
        f_isum == $signed({f_iprev[31], f_iprev}) + $signed({f_pi[31], f_pi}));
    if (f_since_tick >= 4'd11) tl_sample_pipeline_5: assert(
        f_dp_ihi == (f_isum > f_lim28) && f_dp_ilo == (f_isum < -f_lim28));
    if (f_since_tick >= 4'd12) tl_sample_pipeline_6: assert(f_dp_inew == f_inew_exp);
    if (f_since_tick >= 4'd13) tl_sample_pipeline_7: assert(
        f_dp_ugt == ($signed(u_reg) > f_step) && f_dp_ult == ($signed(u_reg) < -f_step) &&
        f_dp_u_dn == u_reg - WDT_RAMP_STEP && f_dp_u_up == u_reg + WDT_RAMP_STEP);
    if (f_since_tick == 4'd14) tl_sample_pipeline_8: assert(
        f_dp_u_ramp == (f_dp_ugt ? f_dp_u_dn : f_dp_ult ? f_dp_u_up : 16'd0) &&
        f_dp_ramp_nz == (f_dp_ugt || f_dp_ult) &&
        rhi_reg == ($signed(f_dp_r) > $signed({10'd0, lim_cfg})) &&
        rlo_reg == ($signed(f_dp_r) < $signed({{9{nlim_reg[15]}}, nlim_reg})));
    tl_sample_pipeline_9: assert(f_min_cfg == f_min_s && f_max_cfg == f_max_s &&
        f_stale_to_cfg == f_stale_to_s && f_wdt_to_cfg == f_wdt_to_s &&
        f_oc_to_cfg == f_oc_to_s && f_tcmin_cfg == f_tcmin_s);
    if (f_since_tick >= 4'd1) tl_sample_pipeline_10: assert(f_dp_raw_s == f_raw_s);
    if (f_since_tick >= 4'd2) tl_sample_pipeline_11: assert(
        f_dp_lo_bad == ($signed(f_raw_s) < $signed(f_min_s)) &&
        f_dp_hi_bad == ($signed(f_raw_s) > $signed(f_max_s)));
    if (f_since_tick >= 4'd3) tl_sample_pipeline_12: assert(f_dp_det == (f_en_s ? f_detect : 4'd0));
end

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

// property tl_hard_fault_age: a hard fault younger than 11 clocks was latched in the sample in flight, in its third clock (induction helper)
always @* if (f_past_valid && !rst && (fault_reg & ~F_WDT) != 4'd0 && f_hard_age < F_SAFE_CLKS)
    tl_hard_fault_age: assert(f_busy && f_since_tick >= 4'd4 && f_hard_age == f_since_tick - 4'd4);

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
