`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Isolation proof of tension_loop_mc (tension_loop_mc_iso.sby): two copies of the module, A and
 * B, get the same clock, reset, tick and the same inputs for channel J; every other channel's
 * inputs are free in each copy, separately. When the other channels of J's group have latched
 * faults in A exactly when they do in B at each tick (J's group stop is the same), channel J's
 * outputs and state are the same in both copies at every clock: channel J depends on the other
 * channels only through the group stop, and on channels of other groups not at all.
 */
module tension_loop_mc_iso #(
    parameter N = 2,                        // channels
    parameter GROUP_W = 4,                  // bits of a group id
    parameter [N*GROUP_W-1:0] GROUP = {N*GROUP_W{1'b0}},  // the groups, as tension_loop_mc
    parameter J = 0,                        // the observed channel
    parameter LIVE_STATE = 0                // as tension_loop_mc (the UP5K's datapath: 1)
) (
    input  wire clk
);

`ifdef FORMAL
localparam [N-1:0]    M1 = {{(N-1){1'b0}}, 1'b1} << J;  // channel J's bits of a 1-bit vector
localparam [N*15-1:0] M15 = {{(N*15-15){1'b0}}, 15'h7FFF} << (J*15);
localparam [N*16-1:0] M16 = {{(N*16-16){1'b0}}, 16'hFFFF} << (J*16);
localparam [N*24-1:0] M24 = {{(N*24-24){1'b0}}, 24'hFFFFFF} << (J*24);

// The shared inputs, copy A's inputs and copy B's own for the channels other than J.
(* anyseq *) reg rst, tick;
(* anyseq *) reg [N-1:0] a_adc_valid, b_adc_valid, a_enable, b_enable, a_slew_en, b_slew_en;
(* anyseq *) reg [N-1:0] a_integ_reset, b_integ_reset, a_fault_clear, b_fault_clear;
(* anyseq *) reg [N-1:0] a_tc_wr, b_tc_wr;
(* anyseq *) reg [N*24-1:0] a_adc_data, b_adc_data, a_adc_offset, b_adc_offset;
(* anyseq *) reg [N*24-1:0] a_adc_min, b_adc_min, a_adc_max, b_adc_max;
(* anyseq *) reg [N*16-1:0] a_tc, b_tc, a_tc_min, b_tc_min, a_kff, b_kff, a_uff, b_uff;
(* anyseq *) reg [N*16-1:0] a_kp, b_kp, a_ki_ts, b_ki_ts, a_wdt_timeout, b_wdt_timeout;
(* anyseq *) reg [N*16-1:0] a_adc_gain, b_adc_gain, a_adc_stale, b_adc_stale;
(* anyseq *) reg [N*16-1:0] a_oc_timeout, b_oc_timeout;
(* anyseq *) reg [N*15-1:0] a_i_limit, b_i_limit, a_slew, b_slew;

// Copy B: channel J's inputs are A's.
`define TLMC_ISO_B(x, m) ((a_``x & m) | (b_``x & ~m))

wire [N*16-1:0] a_u, b_u, a_t_in, b_t_in, a_tc_eff, b_tc_eff;
wire [N*32-1:0] a_integ, b_integ;
wire [N*4-1:0]  a_faults, b_faults;
wire [N-1:0]    a_out_en, b_out_en, a_saturated, b_saturated, a_wdt_ramp, b_wdt_ramp;
wire [N-1:0]    a_grp_stop, b_grp_stop;
wire [N*168-1:0] a_chan, b_chan;
wire [N*28-1:0]  a_tick, b_tick;
wire [56:0]      a_ctl, b_ctl;
wire [13*128+431:0] a_pipe, b_pipe;
wire a_busy, b_busy, a_valid, b_valid;
wire [31:0] a_count, b_count;

tension_loop_mc #(.N(N), .GROUP_W(GROUP_W), .GROUP(GROUP), .LIVE_STATE(LIVE_STATE)) a (
    .clk(clk), .rst(rst), .tick(tick),
    .adc_valid(a_adc_valid), .adc_data(a_adc_data),
    .enable(a_enable), .slew_en(a_slew_en), .integ_reset(a_integ_reset),
    .fault_clear(a_fault_clear), .tc_wr(a_tc_wr), .tc(a_tc), .tc_min(a_tc_min), .kff(a_kff),
    .uff(a_uff), .kp(a_kp), .ki_ts(a_ki_ts), .i_limit(a_i_limit), .slew(a_slew),
    .wdt_timeout(a_wdt_timeout), .adc_offset(a_adc_offset), .adc_gain(a_adc_gain),
    .adc_min(a_adc_min), .adc_max(a_adc_max), .adc_stale(a_adc_stale),
    .oc_timeout(a_oc_timeout), .cfg_busy(a_busy),
    .u(a_u), .out_en(a_out_en), .out_valid(a_valid), .saturated(a_saturated),
    .wdt_ramp(a_wdt_ramp), .grp_stop(a_grp_stop), .faults(a_faults), .t_in(a_t_in),
    .integ(a_integ), .tc_eff(a_tc_eff), .sample_count(a_count),
    .f_chan_state(a_chan), .f_chan_tick(a_tick), .f_ctl_state(a_ctl),
    .f_pipe_state(a_pipe)
);

tension_loop_mc #(.N(N), .GROUP_W(GROUP_W), .GROUP(GROUP), .LIVE_STATE(LIVE_STATE)) b (
    .clk(clk), .rst(rst), .tick(tick),
    .adc_valid(`TLMC_ISO_B(adc_valid, M1)), .adc_data(`TLMC_ISO_B(adc_data, M24)),
    .enable(`TLMC_ISO_B(enable, M1)), .slew_en(`TLMC_ISO_B(slew_en, M1)),
    .integ_reset(`TLMC_ISO_B(integ_reset, M1)), .fault_clear(`TLMC_ISO_B(fault_clear, M1)),
    .tc_wr(`TLMC_ISO_B(tc_wr, M1)), .tc(`TLMC_ISO_B(tc, M16)),
    .tc_min(`TLMC_ISO_B(tc_min, M16)), .kff(`TLMC_ISO_B(kff, M16)),
    .uff(`TLMC_ISO_B(uff, M16)), .kp(`TLMC_ISO_B(kp, M16)), .ki_ts(`TLMC_ISO_B(ki_ts, M16)),
    .i_limit(`TLMC_ISO_B(i_limit, M15)), .slew(`TLMC_ISO_B(slew, M15)),
    .wdt_timeout(`TLMC_ISO_B(wdt_timeout, M16)), .adc_offset(`TLMC_ISO_B(adc_offset, M24)),
    .adc_gain(`TLMC_ISO_B(adc_gain, M16)), .adc_min(`TLMC_ISO_B(adc_min, M24)),
    .adc_max(`TLMC_ISO_B(adc_max, M24)), .adc_stale(`TLMC_ISO_B(adc_stale, M16)),
    .oc_timeout(`TLMC_ISO_B(oc_timeout, M16)), .cfg_busy(b_busy),
    .u(b_u), .out_en(b_out_en), .out_valid(b_valid), .saturated(b_saturated),
    .wdt_ramp(b_wdt_ramp), .grp_stop(b_grp_stop), .faults(b_faults), .t_in(b_t_in),
    .integ(b_integ), .tc_eff(b_tc_eff), .sample_count(b_count),
    .f_chan_state(b_chan), .f_chan_tick(b_tick), .f_ctl_state(b_ctl),
    .f_pipe_state(b_pipe)
);

`undef TLMC_ISO_B

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;

// J's group stop as each copy will take it at a tick: another channel of J's group has a fault.
reg a_pf, b_pf;
integer fi;
always @* begin
    a_pf = 1'b0;
    b_pf = 1'b0;
    for (fi = 0; fi < N; fi = fi + 1)
        if (fi != J && GROUP[fi*GROUP_W +: GROUP_W] == GROUP[J*GROUP_W +: GROUP_W]) begin
            a_pf = a_pf || a_faults[fi*4 +: 4] != 4'd0;
            b_pf = b_pf || b_faults[fi*4 +: 4] != 4'd0;
        end
end
// The only channel-to-channel path allowed: the group stop is the same in both copies.
always @* if (tick) assume(a_pf == b_pf);

// A period is running: its slot's first clock or a schedule bit (f_ctl_state {ch, start, seq, ...}).
wire f_running = |a_ctl[48:34];
wire f_slot_j = f_running && a_ctl[56:49] == J;
wire [N-1:0] f_ne_1 = (a_out_en ^ b_out_en) | (a_saturated ^ b_saturated) |
                      (a_wdt_ramp ^ b_wdt_ramp) | (a_grp_stop ^ b_grp_stop);
always @* if (f_past_valid && !rst) begin
    // property mc_isolation: channel J's outputs (u, drive enable, faults, read-backs, status) are the same in two copies that differ only in the other channels' inputs, as long as J's group stop is the same (J's other state and the schedule: induction helper)
    mc_isolation: assert(a_u[J*16 +: 16] == b_u[J*16 +: 16] && !f_ne_1[J]);
    mc_isolation_2: assert(a_faults[J*4 +: 4] == b_faults[J*4 +: 4] &&
                           a_t_in[J*16 +: 16] == b_t_in[J*16 +: 16] &&
                           a_integ[J*32 +: 32] == b_integ[J*32 +: 32] &&
                           a_tc_eff[J*16 +: 16] == b_tc_eff[J*16 +: 16]);
    mc_isolation_3: assert(a_chan[J*168 +: 168] == b_chan[J*168 +: 168]);
    // The events taken at the tick (not reset) while a period reads them.
    if (f_running) mc_isolation_4: assert(a_tick[J*28 +: 28] == b_tick[J*28 +: 28]);
    mc_isolation_5: assert(a_ctl == b_ctl && a_valid == b_valid && a_busy == b_busy);
    // In J's slot, the pipeline once the slot has written it.
    if (f_slot_j) mc_isolation_6: assert(a_pipe == b_pipe);
end

// Not vacuous: the copies differ in another channel while J runs.
always @* if (f_past_valid && !rst)
    cover(a_chan != b_chan && a_out_en[J] && a_u[J*16 +: 16] != 16'd0);

wire unused = &{1'b0, a_count, b_count};
`else
wire unused = &{1'b0, clk};
`endif

endmodule

`resetall
