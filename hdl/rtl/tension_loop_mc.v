`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * N tension loops (one per cable) on one time-multiplexed datapath, with safety groups.
 *
 * Each channel is the loop of tension_loop.v (calibration, slew limit, floor, PI + feedforward,
 * conditional integration, faults, watchdog ramp), computed by the same datapath module,
 * tension_loop_dp, in its 15-clock schedule; the channels take turns on one instance, one slot of
 * LATENCY_CH clocks each, in channel order. A channel whose group is not stopped is bit-exact to a
 * tension_loop fed the same inputs and ticked by the same tick (the model is
 * cosim/parts/rtl_model.py, TensionLoopModel; TensionLoopMcModel for the whole module).
 *
 * Timing: `tick` (one clock) starts a control period. In the tick clock every channel's events
 * since the last tick (its latest ADC sample, a TC write, the INTEG_RESET and FAULT_CLEAR pulses)
 * and its group's stop are captured; channel k's slot then runs from clock 1 + LATENCY_CH*k.
 * `out_valid` comes LATENCY (1 + LATENCY_CH*N) clocks after the tick, when every channel's
 * outputs are new; ticks must be at least LATENCY clocks apart.
 *
 * Loads: the datapath (PRELOAD 1) takes a channel's events, configuration and state word into
 * its own registers at the clock before the channel's slot (channel 0 in the tick clock, channel
 * k + 1 in slot k's last clock), and the slot's last clock writes the new state word back, so
 * the channel's outputs change at the end of its slot. The configuration is read only at the
 * loads: `cfg_busy` (N > 1: the tick clock up to slot N - 2's clock 13, the clock before the
 * last load) tells the register bus to hold writes, so every channel uses the configuration of
 * the tick edge, as a tension_loop does.
 *
 * CFG_RAM 1 (bowden_core_mc on the UP5K): the configuration words (all but ENABLE and SLEW_EN)
 * are the caller's block RAM, one word a channel. The loads read it: `cfg_rd` (= the load)
 * with the channel `cfg_rd_ch`, and the memory's output register, which the caller gives in
 * the configuration ports' channel-0 bits (the other channels' bits are not read), is the
 * datapath's loaded configuration through the slot. `cfg_busy` then also covers the last load
 * (N = 1: the tick), so no write meets a load, and `cfg_rd_busy` (the tick and every slot)
 * tells the caller when the memory's output is in use and its own reads must wait.
 *
 * LIVE_STATE 1 (bowden_core_mc with CFG_RAM 1): the datapath keeps no copy of a channel's state
 * word and events (its LIVE): it reads the slot's channel's through this module's multiplexer in
 * every clock of the slot and writes the word back in every clock of it, so a channel's T_in,
 * FAULT and counters change in the slot's clocks 1, 4 and 6 rather than at its end (its u, drive
 * enable, integrator, T_c' and status at the end, as before).
 *
 * Safety groups: channel k belongs to group GROUP[k*GROUP_W +: GROUP_W]. When, at a tick, any
 * other channel of k's group has a latched fault (FAULT != 0), channel k runs that period as a
 * tension_loop under a watchdog-only fault: u one WDT_RAMP_STEP towards zero, the drive off once
 * u is 0, the integrator 0 (its own hard faults still give u = 0 at once). So a fault latched on
 * one channel brings every channel of its group to zero within 1 + ceil(I_LIMIT / WDT_RAMP_STEP)
 * periods; channels of other groups run on. The partners resume, from a zero integrator, with the
 * first tick after the faulted channel's FAULT is cleared.
 */
module tension_loop_mc #(
    parameter N = 2,                         // channels (cables), >= 1
    parameter GROUP_W = 4,                   // bits of a channel's group id
    parameter [N*GROUP_W-1:0] GROUP = {N*GROUP_W{1'b0}},  // group id of channel k in bits
                                             // [k*GROUP_W +: GROUP_W]; default: one group
    parameter [15:0] WDT_RAMP_STEP = 16'd41, // watchdog and group ramp-down of u, Q3.12 A per
                                             // sample (41/4096 A: 4 A reach zero in 40 ms at 10 kHz)
    parameter CFG_RAM = 0,                   // 1: the configuration words in the caller's block
                                             // RAM, read at the loads (cfg_rd)
    parameter LIVE_STATE = 0,                // 1: the state words and events read and written
                                             // by the datapath in the slot, not loaded
    parameter CH_W = (N > 1) ? $clog2(N) : 1 // channel index bits (derived: do not set)
) (
    input  wire            clk,
    input  wire            rst,

    /*
     * Sample timing
     */
    input  wire            tick,        // start of a period, one clock, >= LATENCY clocks apart

    /*
     * Raw load-cell ADC streams, channel k in bits [k*W +: W]
     */
    input  wire [N-1:0]    adc_valid,   // a new sample on channel k's adc_data
    input  wire [N*24-1:0] adc_data,    // signed 24-bit two's complement codes

    /*
     * Configuration (register fields), channel k in bits [k*W +: W]
     */
    input  wire [N-1:0]    enable,       // CTRL.ENABLE
    input  wire [N-1:0]    slew_en,      // CTRL.SLEW_EN
    input  wire [N-1:0]    integ_reset,  // CTRL.INTEG_RESET write pulse
    input  wire [N-1:0]    fault_clear,  // CTRL.FAULT_CLEAR write pulse
    input  wire [N-1:0]    tc_wr,        // TC written (watchdog refresh)
    input  wire [N*16-1:0] tc,           // Q7.8 N
    input  wire [N*16-1:0] tc_min,       // Q7.8 N, floor of T_c' (a cable cannot push)
    input  wire [N*16-1:0] kff,          // Q2.13 A/N
    input  wire [N*16-1:0] uff,          // Q3.12 A, added to u outside the PI
    input  wire [N*16-1:0] kp,           // Q2.13 A/N
    input  wire [N*16-1:0] ki_ts,        // 2^-20 A/N per sample
    input  wire [N*15-1:0] i_limit,      // UQ3.12 A
    input  wire [N*15-1:0] slew,         // UQ7.8 N per sample
    input  wire [N*16-1:0] wdt_timeout,  // samples, 0 = off
    input  wire [N*24-1:0] adc_offset,   // code
    input  wire [N*16-1:0] adc_gain,     // 2^-20 Q7.8-LSB per code
    input  wire [N*24-1:0] adc_min,      // code
    input  wire [N*24-1:0] adc_max,      // code
    input  wire [N*16-1:0] adc_stale,    // samples, 0 = off
    input  wire [N*16-1:0] oc_timeout,   // samples, 0 = off
    output wire            cfg_busy,     // the configuration is in use: hold writes
    output wire            cfg_rd,       // CFG_RAM 1: read channel cfg_rd_ch's configuration
    output wire [CH_W-1:0] cfg_rd_ch,    //   words into the memory's output register
    output wire            cfg_rd_busy,  // CFG_RAM 1: the memory's output is in use

    /*
     * Drive commands, channel k in bits [k*W +: W]
     */
    output wire [N*16-1:0] u,            // Q3.12 A current command
    output wire [N-1:0]    out_en,       // drive enable
    output wire            out_valid,    // one clock: every channel's outputs are new

    /*
     * Status and read-back, channel k in bits [k*W +: W]
     */
    output wire [N-1:0]    saturated,
    output wire [N-1:0]    wdt_ramp,     // ramping down (own watchdog fault or group stop)
    output wire [N-1:0]    grp_stop,     // this period, another channel of the group had a fault
    output wire [N*4-1:0]  faults,       // {overcurrent, watchdog, adc_range, adc_stale}
    output wire [N*16-1:0] t_in,         // Q7.8 N
    output wire [N*32-1:0] integ,        // Q3.28 A
    output wire [N*16-1:0] tc_eff,       // Q7.8 N
    output wire [31:0]     sample_count
`ifdef FORMAL
    ,
    /*
     * Formal only: the state between samples, for the isolation proof's two copies
     * (hdl/formal/tension_loop_mc_iso.v), which compares them; channel k in [k*W +: W]
     */
    output wire [N*168-1:0] f_chan_state,  // kept from sample to sample
    output wire [N*28-1:0]  f_chan_tick,   // the events taken at the tick (read in the period)
    output wire [56:0]      f_ctl_state,   // the schedule and the sample count
    output wire [13*128+431:0] f_pipe_state  // the slot's pipeline, each register from the clock
                                           // after its slot writes it (0 before), and what
                                           // the datapath loaded for the slot
`endif
);

localparam LATENCY_CH = 15;             // clocks of one channel's slot (tension_loop's LATENCY)
localparam [31:0] N_LAST = N - 1;
localparam [CH_W-1:0] CH_LAST = N_LAST[CH_W-1:0];  // the last channel's index
localparam [31:0] N_LD_LAST = (N > 1) ? N - 2 : 0;
localparam [CH_W-1:0] CH_LD_LAST = N_LD_LAST[CH_W-1:0];  // the slot that loads the last channel
localparam ST_W = 139;                  // tension_loop_dp's state word (its layout)

// Period sequencer: the channel in its slot, the slot's first clock, the hold of the
// configuration; the schedule within the slot is the datapath's (seq_reg[k] high in clock k+1).
reg  [CH_W-1:0]         ch_reg, ch_next;
reg                     start_reg, start_next;
reg                     busy_reg, busy_next;
reg  [31:0]             sample_cnt_reg, sample_cnt_next;
reg                     out_valid_reg, out_valid_next;
wire [LATENCY_CH-2:0]   seq_reg;

// Per channel: events between ticks, and the events and group stop captured at the tick.
reg  [N*24-1:0] raw_reg, raw_next;
reg  [N-1:0]    fresh_reg, fresh_next;
reg  [N-1:0]    tcw_pend_reg, tcw_pend_next;
reg  [N-1:0]    irst_pend_reg, irst_pend_next;
reg  [N-1:0]    fclr_pend_reg, fclr_pend_next;
reg  [N*24-1:0] raw_t_reg, raw_t_next;
reg  [N-1:0]    fresh_t_reg, fresh_t_next;
reg  [N-1:0]    tcw_t_reg, tcw_t_next;
reg  [N-1:0]    irst_t_reg, irst_t_next;
reg  [N-1:0]    fclr_t_reg, fclr_t_next;
reg  [N-1:0]    grp_t_reg, grp_t_next;

// Per channel: the state between samples (tension_loop_dp's state word: counters, faults, u, the
// integrator, T_c', the read-backs), written back at the end of the channel's slot.
reg  [N*ST_W-1:0] st_reg, st_next;

// Each channel's fields of its state word.
wire [N*4-1:0]  fault_ch;
wire [N*16-1:0] t_in_ch, u_ch, tc_eff_ch;
wire [N*32-1:0] integ_ch;
wire [N-1:0]    out_en_ch, sat_hi_ch, sat_lo_ch, ramp_st_ch;
genvar sk;
generate
    for (sk = 0; sk < N; sk = sk + 1) begin : g_st
        wire [ST_W-1:0] w = st_reg[sk*ST_W +: ST_W];
        assign fault_ch[sk*4 +: 4] = w[54:51];
        assign t_in_ch[sk*16 +: 16] = w[70:55];      // Q7.8 N
        assign u_ch[sk*16 +: 16] = w[86:71];         // Q3.12 A
        assign out_en_ch[sk] = w[87];
        assign sat_hi_ch[sk] = w[88];
        assign sat_lo_ch[sk] = w[89];
        assign ramp_st_ch[sk] = w[90];
        assign integ_ch[sk*32 +: 32] = w[122:91];    // Q3.28 A
        assign tc_eff_ch[sk*16 +: 16] = w[138:123];  // Q7.8 N
        wire unused_cnt = &{1'b0, w[50:0]};          // the counters: read by the datapath only
    end
endgenerate

// Group stop at the tick: another channel of the group has a latched fault. The membership is
// fixed by GROUP, so it is wiring.
wire [N-1:0] grp_now;
group_or #(.N(N), .GROUP_W(GROUP_W), .GROUP(GROUP), .W(4), .SELF(0)) grp (
    .x(fault_ch), .y(grp_now)
);

// The datapath takes a channel's events, configuration and state into its own registers the
// clock before the channel's slot (PRELOAD): channel 0 at the tick, with the events of the tick
// clock; channel k + 1 in the last clock of slot k, with the events taken at the tick. Nothing
// but those loads reads a channel's registers, so the N-way multiplexers end in flip-flops.
wire            ld = tick || (seq_reg[LATENCY_CH-2] && ch_reg != CH_LAST);
wire [CH_W-1:0] ch_ld = tick ? {CH_W{1'b0}} : ch_reg + 1'b1;
wire            ev_now = tick && (LIVE_STATE == 0);  // channel 0's load takes the tick's
wire [N*24-1:0] raw_ev = ev_now ? raw_t_next : raw_t_reg;
wire [N-1:0]    fresh_ev = ev_now ? fresh_t_next : fresh_t_reg;
wire [N-1:0]    tcw_ev = ev_now ? tcw_t_next : tcw_t_reg;
wire [N-1:0]    irst_ev = ev_now ? irst_t_next : irst_t_reg;
wire [N-1:0]    fclr_ev = ev_now ? fclr_t_next : fclr_t_reg;
wire [N-1:0]    grp_ev = ev_now ? grp_t_next : grp_t_reg;
wire [ST_W-1:0] dp_state;  // the slot's channel's state (read by the proofs)
// The channel whose events and state word the datapath reads: the load's, or with LIVE_STATE the
// slot's (the events taken at the tick, held through the period).
wire [CH_W-1:0] ch_ev = (LIVE_STATE != 0) ? ch_reg : ch_ld;
wire [ST_W-1:0] dp_res;    // its state after the slot (in the slot's last clock)

`ifdef FORMAL
wire [31:0]  f_dp_cfg;
wire [31:0]  f_dp_iprev;
wire [3:0]   f_dp_fbase;
wire [15:0]  f_dp_nlim;
wire [1:0]   f_dp_pi_sign;
wire [63:0]  f_dp_prod;
wire [3:0]   f_dp_mode;
wire [11*128-1:0] f_dp_pipe;
wire [431:0] f_dp_load;
`endif

// The configuration words the datapath reads: the load's channel's (CFG_RAM 0), or the caller's
// memory output, channel 0's bits of the ports (CFG_RAM 1).
wire [CH_W-1:0] ch_cfg = (CFG_RAM != 0) ? {CH_W{1'b0}} : ch_ld;

tension_loop_dp #(.WDT_RAMP_STEP(WDT_RAMP_STEP), .SNAPSHOT(1),
                  .PRELOAD((CFG_RAM != 0) ? 2 : 1), .LIVE(LIVE_STATE)) dp (
    .clk(clk), .rst(rst),
    .start(start_reg), .ld(ld), .seq(seq_reg),
    .ev_raw(raw_ev[ch_ev*24 +: 24]), .ev_fresh(fresh_ev[ch_ev]), .ev_tcw(tcw_ev[ch_ev]),
    .ev_irst(irst_ev[ch_ev]), .ev_fclr(fclr_ev[ch_ev]), .ev_grp(grp_ev[ch_ev]),
    .enable(enable[ch_ld]), .slew_en(slew_en[ch_ld]), .tc(tc[ch_cfg*16 +: 16]),
    .tc_min(tc_min[ch_cfg*16 +: 16]), .kff(kff[ch_cfg*16 +: 16]), .uff(uff[ch_cfg*16 +: 16]),
    .kp(kp[ch_cfg*16 +: 16]), .ki_ts(ki_ts[ch_cfg*16 +: 16]), .i_limit(i_limit[ch_cfg*15 +: 15]),
    .slew(slew[ch_cfg*15 +: 15]), .wdt_timeout(wdt_timeout[ch_cfg*16 +: 16]),
    .adc_offset(adc_offset[ch_cfg*24 +: 24]), .adc_gain(adc_gain[ch_cfg*16 +: 16]),
    .adc_min(adc_min[ch_cfg*24 +: 24]), .adc_max(adc_max[ch_cfg*24 +: 24]),
    .adc_stale(adc_stale[ch_cfg*16 +: 16]), .oc_timeout(oc_timeout[ch_cfg*16 +: 16]),
    .ld_state(st_reg[ch_ev*ST_W +: ST_W]), .state(dp_state), .state_res(dp_res)
`ifdef FORMAL
    ,
    .f_cfg(f_dp_cfg), .f_iprev(f_dp_iprev), .f_fbase(f_dp_fbase), .f_nlim(f_dp_nlim),
    .f_pi_sign(f_dp_pi_sign), .f_prod(f_dp_prod), .f_mode(f_dp_mode), .f_pipe(f_dp_pipe),
    .f_load(f_dp_load)
`endif
);

// The slot's state itself is read only by the proofs: the outputs are the written-back words.
wire unused_dp = &{1'b0, dp_state};

integer k;

always @* begin
    // Sequencer: the tick starts channel 0's slot a clock later, each slot's last clock the
    // next channel's, the last slot's out_valid. The configuration is read at the loads: held
    // from the tick clock (a write there would land before channel 1's load) up to the clock
    // before the last load.
    ch_next = ch_reg;
    start_next = tick;
    busy_next = ((N > 1) && tick) ||
                (busy_reg && !(seq_reg[(CFG_RAM != 0) ? LATENCY_CH-2 : LATENCY_CH-3] &&
                               ch_reg == CH_LD_LAST));
    sample_cnt_next = tick ? sample_cnt_reg + 32'd1 : sample_cnt_reg;
    out_valid_next = 1'b0;
    if (seq_reg[LATENCY_CH-2]) begin
        if (ch_reg == CH_LAST) begin
            ch_next = {CH_W{1'b0}};
            out_valid_next = 1'b1;
        end else begin
            ch_next = ch_reg + 1'b1;
            start_next = 1'b1;
        end
    end

    // Events of every channel, all the time; at the tick they become the period's.
    for (k = 0; k < N; k = k + 1) begin
        raw_next[k*24 +: 24] = adc_valid[k] ? adc_data[k*24 +: 24] : raw_reg[k*24 +: 24];
    end
    fresh_next = tick ? {N{1'b0}} : (fresh_reg | adc_valid);
    tcw_pend_next = tick ? {N{1'b0}} : (tcw_pend_reg | tc_wr);
    irst_pend_next = tick ? {N{1'b0}} : (irst_pend_reg | integ_reset);
    fclr_pend_next = tick ? {N{1'b0}} : (fclr_pend_reg | fault_clear);
    raw_t_next = tick ? raw_next : raw_t_reg;
    fresh_t_next = tick ? (fresh_reg | adc_valid) : fresh_t_reg;
    tcw_t_next = tick ? (tcw_pend_reg | tc_wr) : tcw_t_reg;
    irst_t_next = tick ? (irst_pend_reg | integ_reset) : irst_t_reg;
    fclr_t_next = tick ? (fclr_pend_reg | fault_clear) : fclr_t_reg;
    grp_t_next = tick ? grp_now : grp_t_reg;

    // The slot's last clock: its channel's new state (LIVE_STATE: every clock of the slot).
    st_next = st_reg;
    if (seq_reg[LATENCY_CH-2] || (LIVE_STATE != 0 && (start_reg || (|seq_reg)))) begin
        st_next[ch_reg*ST_W +: ST_W] = dp_res;
    end
end

always @(posedge clk) begin
    ch_reg <= ch_next;
    start_reg <= start_next;
    busy_reg <= busy_next;
    sample_cnt_reg <= sample_cnt_next;
    out_valid_reg <= out_valid_next;
    raw_reg <= raw_next;
    fresh_reg <= fresh_next;
    tcw_pend_reg <= tcw_pend_next;
    irst_pend_reg <= irst_pend_next;
    fclr_pend_reg <= fclr_pend_next;
    raw_t_reg <= raw_t_next;
    fresh_t_reg <= fresh_t_next;
    tcw_t_reg <= tcw_t_next;
    irst_t_reg <= irst_t_next;
    fclr_t_reg <= fclr_t_next;
    grp_t_reg <= grp_t_next;
    st_reg <= st_next;

    if (rst) begin
        ch_reg <= {CH_W{1'b0}};
        start_reg <= 1'b0;
        busy_reg <= 1'b0;
        sample_cnt_reg <= 32'd0;
        out_valid_reg <= 1'b0;
        raw_reg <= {(N*24){1'b0}};
        fresh_reg <= {N{1'b0}};
        tcw_pend_reg <= {N{1'b0}};
        irst_pend_reg <= {N{1'b0}};
        fclr_pend_reg <= {N{1'b0}};
        grp_t_reg <= {N{1'b0}};
        st_reg <= {(N*ST_W){1'b0}};
    end
end

assign cfg_busy = ((N > 1 || CFG_RAM != 0) && tick) || busy_reg;
assign cfg_rd = ld;
assign cfg_rd_ch = ch_ld;
assign cfg_rd_busy = tick || start_reg || (|seq_reg);

assign u = u_ch;
assign out_en = out_en_ch;
assign out_valid = out_valid_reg;
assign saturated = sat_hi_ch | sat_lo_ch;
assign wdt_ramp = ramp_st_ch;
assign grp_stop = grp_t_reg;
assign faults = fault_ch;
assign t_in = t_in_ch;
assign integ = integ_ch;
assign tc_eff = tc_eff_ch;
assign sample_count = sample_cnt_reg;

`ifdef FORMAL
// --- formal properties (hdl/formal/tension_loop_mc.sby; hdl/README.md says what is proven) -
//
// The safety groups' properties mc_* against shadows of the period and of the faults at the
// tick (f_* registers). The environment (reset at start, ticks at least LATENCY clocks apart) is
// assumed when this module is the top of a proof. The arithmetic of each channel is
// tension_loop's, simulated bit-exact against the model; its single-loop properties are
// tension_loop.sby's.
`ifdef FORMAL_TENSION_LOOP_MC_TOP
`define TL_ENV assume
`else
`define TL_ENV assert
`endif

localparam [3:0] F_LC_LAST = LATENCY_CH - 1;  // the slot's last clock (tension_loop's 14)
localparam integer F_UMAX = 32767;            // the largest |u| (I_LIMIT is 15 bits)
localparam integer F_STEP = WDT_RAMP_STEP;
localparam integer F_RAMP_N = (F_UMAX + F_STEP - 1) / F_STEP;  // ramp samples from any u to 0
localparam F_AGE_W = $clog2(F_RAMP_N + 1);
localparam [F_AGE_W-1:0] F_AGE_MAX = F_RAMP_N;

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;

always @* if (!f_past_valid) assume(rst);

// Shadow of the period: running, the channel in its slot, the clock within the slot.
reg            f_run = 1'b0;
reg [CH_W-1:0] f_ch = {CH_W{1'b0}};
reg [3:0]      f_lc = 4'd0;
always @(posedge clk) begin
    if (rst) begin
        f_run <= 1'b0;
        f_ch <= {CH_W{1'b0}};
        f_lc <= 4'd0;
    end else if (tick) begin
        f_run <= 1'b1;
        f_ch <= {CH_W{1'b0}};
        f_lc <= 4'd0;
    end else if (f_run) begin
        if (f_lc == F_LC_LAST) begin
            f_lc <= 4'd0;
            if (f_ch == CH_LAST) f_run <= 1'b0;
            else f_ch <= f_ch + 1'b1;
        end else begin
            f_lc <= f_lc + 4'd1;
        end
    end
end

// property mc_tick_spacing: a tick comes only when no period is running, at least LATENCY clocks after the last (assumed when tension_loop_mc is the top)
always @* if (f_past_valid && !rst && tick) mc_tick_spacing: `TL_ENV(!f_run);

// CFG_RAM 1: the configuration words' ports (channel 0's bits) are the caller's memory output
// register, which changes only at an edge where it is read, and in the period only at the loads.
wire [261:0] f_cfg_words = {tc[15:0], tc_min[15:0], kff[15:0], uff[15:0], kp[15:0], ki_ts[15:0],
                            i_limit[14:0], slew[14:0], wdt_timeout[15:0], adc_offset[23:0],
                            adc_gain[15:0], adc_min[23:0], adc_max[23:0], adc_stale[15:0],
                            oc_timeout[15:0]};
reg [261:0] f_cfg_words_d;
reg         f_cfg_held_d = 1'b0;  // the last clock was in the period and no load
always @(posedge clk) begin
    f_cfg_words_d <= f_cfg_words;
    f_cfg_held_d <= cfg_rd_busy && !cfg_rd;
end
// property mc_cfg_ram_held: with CFG_RAM 1 the configuration words change only at a load while a period runs (the caller's memory is read only then; assumed when tension_loop_mc is the top)
always @* if (CFG_RAM != 0 && f_past_valid && !rst && f_cfg_held_d)
    mc_cfg_ram_held: `TL_ENV(f_cfg_words == f_cfg_words_d);

wire [LATENCY_CH-2:0] f_seq_exp = (f_run && f_lc != 4'd0) ?
                                  {{(LATENCY_CH-2){1'b0}}, 1'b1} << (f_lc - 4'd1) :
                                  {(LATENCY_CH-1){1'b0}};
always @* if (f_past_valid && !rst) begin
    // property mc_schedule: the sequencer is the shadow's position in the period: one slot at a time, in channel order (induction helper)
    mc_schedule: assert(start_reg == (f_run && f_lc == 4'd0));
    mc_schedule_2: assert(seq_reg == f_seq_exp);
    mc_schedule_3: assert(ch_reg == (f_run ? f_ch : {CH_W{1'b0}}));
    mc_schedule_4: assert(busy_reg == (f_run && f_ch + 1 < N &&
                                       (CFG_RAM != 0 || !(f_ch + 2 == N && f_lc == F_LC_LAST))));
    mc_schedule_5: assert(f_ch <= CH_LAST && f_lc <= F_LC_LAST);
end

// The group stop each channel should see: another channel of its group has a latched fault.
reg [N-1:0] f_partner_fault;
reg [N-1:0] f_pf;  // at the last tick
integer fi, fj;
always @* begin
    for (fi = 0; fi < N; fi = fi + 1) begin
        f_partner_fault[fi] = 1'b0;
        for (fj = 0; fj < N; fj = fj + 1)
            if (fj != fi && GROUP[fj*GROUP_W +: GROUP_W] == GROUP[fi*GROUP_W +: GROUP_W] &&
                faults[fj*4 +: 4] != 4'd0)
                f_partner_fault[fi] = 1'b1;
    end
end
always @(posedge clk) begin
    if (rst) f_pf <= {N{1'b0}};
    else if (tick) f_pf <= f_partner_fault;
end
// property mc_group_stop_set: a channel's group stop for a period is set exactly when, at its tick, another channel of its group had a latched fault
always @* if (f_past_valid && !rst) mc_group_stop_set: assert(grp_t_reg == f_pf);

// The watchdog ramp of a command: towards zero by WDT_RAMP_STEP, never past it.
function [15:0] f_ramp;
    input [15:0] x;
    begin
        if ($signed(x) > $signed(WDT_RAMP_STEP)) f_ramp = x - WDT_RAMP_STEP;
        else if ($signed(x) < -$signed(WDT_RAMP_STEP)) f_ramp = x + WDT_RAMP_STEP;
        else f_ramp = 16'd0;
    end
endfunction

// The ramp bound: |u| after `age` stopped samples in a row (F_UMAX - age * WDT_RAMP_STEP, 0 from
// F_RAMP_N on).
function signed [31:0] f_bound;
    input [F_AGE_W-1:0] age;
    begin
        if (age >= F_AGE_MAX) f_bound = 32'sd0;
        else f_bound = F_UMAX - $signed({{(32-F_AGE_W){1'b0}}, age}) * F_STEP;
    end
endfunction

// The slot's last clock, and whether its channel is stopped this sample: the group stop of the
// period or a fault of its own.
wire f_end = f_run && f_lc == F_LC_LAST;
wire        grp_c = f_dp_mode[0];      // the slot's group stop
wire [3:0]  fault_c = dp_state[54:51];  // the slot's FAULT
wire [15:0] u_c = dp_state[86:71];      // the slot's u before its last clock, Q3.12 A
wire f_stop = grp_c || fault_c != 4'd0;
reg            f_end_d = 1'b0;  // the clock after a slot's last: its channel's outputs are new
reg [CH_W-1:0] f_ch_d;
reg            f_stop_d;
reg            f_grp_only_d;    // stopped by the group alone (no fault of its own)
reg [15:0]     f_uprev_d;       // u before the sample
reg [N*F_AGE_W-1:0] f_age = {(N*F_AGE_W){1'b0}};  // per channel: stopped samples in a row
integer fa;
always @(posedge clk) begin
    f_end_d <= f_end && !rst;
    f_ch_d <= f_ch;
    f_stop_d <= f_stop;
    f_grp_only_d <= grp_c && fault_c == 4'd0;
    f_uprev_d <= u_c;
    for (fa = 0; fa < N; fa = fa + 1)
        if (rst) f_age[fa*F_AGE_W +: F_AGE_W] <= {F_AGE_W{1'b0}};
        else if (f_end && f_ch == fa)
            f_age[fa*F_AGE_W +: F_AGE_W] <= !f_stop ? {F_AGE_W{1'b0}} :
                (f_age[fa*F_AGE_W +: F_AGE_W] == F_AGE_MAX) ? F_AGE_MAX :
                f_age[fa*F_AGE_W +: F_AGE_W] + 1'b1;
end

wire [15:0] f_u_d = u_ch[f_ch_d*16 +: 16];  // the finished channel's new u
// property mc_stop_ramp: a stopped sample (group stop or own fault) moves u one WDT_RAMP_STEP towards zero or to zero, the drive on only while u is not 0, the integrator 0
always @* if (f_past_valid && !rst && f_end_d && f_stop_d) begin
    mc_stop_ramp: assert(f_u_d == f_ramp(f_uprev_d) || f_u_d == 16'd0);
    mc_stop_ramp_2: assert(out_en_ch[f_ch_d] == (f_u_d != 16'd0));
    mc_stop_ramp_3: assert(integ_ch[f_ch_d*32 +: 32] == 32'd0 && !sat_hi_ch[f_ch_d] && !sat_lo_ch[f_ch_d]);
end

// Every channel against its ramp bound.
reg [N-1:0] f_in_bound, f_en_follows, f_zero;
integer fb;
always @* begin
    for (fb = 0; fb < N; fb = fb + 1) begin
        f_in_bound[fb] = $signed(u_ch[fb*16 +: 16]) <= f_bound(f_age[fb*F_AGE_W +: F_AGE_W]) &&
                         -$signed(u_ch[fb*16 +: 16]) <= f_bound(f_age[fb*F_AGE_W +: F_AGE_W]);
        f_en_follows[fb] = f_age[fb*F_AGE_W +: F_AGE_W] == {F_AGE_W{1'b0}} ||
                           out_en_ch[fb] == (u_ch[fb*16 +: 16] != 16'd0);
        f_zero[fb] = f_age[fb*F_AGE_W +: F_AGE_W] != F_AGE_MAX ||
                     (u_ch[fb*16 +: 16] == 16'd0 && !out_en_ch[fb]);
    end
end
always @* if (f_past_valid && !rst) begin
    // property mc_ramp_bound: every channel, after `age` stopped samples in a row: abs(u) <= 32767 - age * WDT_RAMP_STEP (never -32768), the drive on only while u is not 0
    mc_ramp_bound: assert(&f_in_bound);
    mc_ramp_bound_2: assert(&f_en_follows);
    // property mc_group_zero: a fault latched on a channel of a group (its own or another's) brings every channel of the group to u = 0, drive off, within ceil(32767 / WDT_RAMP_STEP) stopped samples, and keeps it there while the fault stays latched
    mc_group_zero: assert(&f_zero);
end

// The slot's datapath against its channel's state word and its loaded configuration, each
// register from the clock after the datapath writes it to the slot's end (induction helpers:
// without them the induction needs a window of a whole slot, 16 clocks, to see the datapath's
// registers recomputed from a load; with them the last clock of a slot follows from the two
// before it). The layout of f_dp_pipe and f_dp_mode is tension_loop_dp's f_pipe and f_mode.
wire [15:0] f_dp_u = dp_state[86:71];             // u entering the sample (written in clock 14)
wire        f_dp_en = f_dp_cfg[31];               // ENABLE, loaded
wire [14:0] f_dp_lim = f_dp_cfg[30:16];           // I_LIMIT, loaded
wire        f_dp_run = f_dp_mode[3];              // clock 3: the sample runs the loop
wire        f_dp_ramp = f_dp_pipe[7*128 + 89];    // clock 3: the sample ramps
wire [15:0] f_dp_u_up = f_dp_pipe[1*128 +: 16];   // clock 12: u + step
wire [15:0] f_dp_u_dn = f_dp_pipe[1*128 + 16 +: 16];  // clock 12: u - step
wire        f_dp_ult = f_dp_pipe[1*128 + 32];     // clock 12: u < -step
wire        f_dp_ugt = f_dp_pipe[1*128 + 33];     // clock 12: u > step
wire [24:0] f_dp_r = f_dp_pipe[1*128 + 34 +: 25]; // clock 12: the rounded output
wire        f_dp_ramp_nz = f_dp_pipe[0];          // clock 13: the ramp's u is not 0
wire [15:0] f_dp_u_ramp = f_dp_pipe[1 +: 16];     // clock 13: the ramp's u
wire        f_dp_rhi = f_dp_mode[2];              // clock 13: r > I_LIMIT
wire        f_dp_rlo = f_dp_mode[1];              // clock 13: r < -I_LIMIT
wire signed [15:0] f_step = WDT_RAMP_STEP;
always @* if (f_past_valid && !rst && f_run) begin
    // property mc_slot_pipeline: in a channel's slot the datapath holds that channel's u, and from the clock after it writes them, -I_LIMIT, the mode of the FAULT it latched, the ramp's steps and comparisons and the saturation flags of that u, the loaded configuration and the rounded output (induction helper)
    mc_slot_pipeline: assert(f_dp_u == u_ch[f_ch*16 +: 16]);
    if (f_lc >= 4'd2) mc_slot_pipeline_2: assert(f_dp_nlim == -{1'b0, f_dp_lim});
    if (f_lc >= 4'd4) mc_slot_pipeline_3: assert(
        f_dp_run == (f_dp_en && fault_c == 4'd0 && !grp_c) &&
        f_dp_ramp == (f_dp_en && (fault_c == 4'b0100 || (fault_c == 4'd0 && grp_c))));
    if (f_lc >= 4'd13) mc_slot_pipeline_4: assert(
        f_dp_ugt == ($signed(f_dp_u) > f_step) && f_dp_ult == ($signed(f_dp_u) < -f_step) &&
        f_dp_u_dn == f_dp_u - WDT_RAMP_STEP && f_dp_u_up == f_dp_u + WDT_RAMP_STEP);
    if (f_lc == F_LC_LAST) mc_slot_pipeline_5: assert(
        f_dp_u_ramp == (f_dp_ugt ? f_dp_u_dn : f_dp_ult ? f_dp_u_up : 16'd0) &&
        f_dp_ramp_nz == (f_dp_ugt || f_dp_ult) &&
        f_dp_rhi == ($signed(f_dp_r) > $signed({10'd0, f_dp_lim})) &&
        f_dp_rlo == ($signed(f_dp_r) < $signed({{9{f_dp_nlim[15]}}, f_dp_nlim})));
end

// Covers: a partner ramps under a group stop, and reaches zero.
always @* if (f_past_valid && !rst && f_end_d && f_grp_only_d) begin
    cover(f_u_d != 16'd0 && f_u_d == f_ramp(f_uprev_d) && f_u_d != f_uprev_d);
    cover(f_u_d == 16'd0 && f_uprev_d != 16'd0);
end

// The state between samples, for the isolation proof (tension_loop_mc_iso.v).
genvar fk;
generate
    for (fk = 0; fk < N; fk = fk + 1) begin : g_f_state
        assign f_chan_tick[fk*28 +: 28] = {raw_t_reg[fk*24 +: 24], fresh_t_reg[fk], tcw_t_reg[fk],
                                           irst_t_reg[fk], fclr_t_reg[fk]};
        assign f_chan_state[fk*168 +: 168] = {
            raw_reg[fk*24 +: 24], fresh_reg[fk], tcw_pend_reg[fk], irst_pend_reg[fk],
            fclr_pend_reg[fk], grp_t_reg[fk], st_reg[fk*ST_W +: ST_W]};
    end
endgenerate
// The slot's pipeline registers, grouped by the slot clock that writes them, each group shown
// from the clock after that one to the slot's end (0 before: it still holds the last slot's);
// the products on the clocks the slot reads them.
function [127:0] f_after;
    input [3:0] w;
    input [127:0] x;
    begin
        f_after = (f_run && f_lc > w) ? x : 128'd0;
    end
endfunction
wire f_m1_read = f_run && (f_lc == 4'd3 || f_lc == 4'd4 || f_lc == 4'd9);
wire f_m2_read = f_run && (f_lc == 4'd6 || f_lc == 4'd9);
assign f_pipe_state = {
    f_after(4'd0, f_dp_pipe[10*128 +: 128]),
    f_after(4'd1, f_dp_pipe[9*128 +: 128]),
    f_after(4'd2, f_dp_pipe[8*128 +: 128]),
    f_after(4'd3, f_dp_pipe[7*128 +: 128]),
    f_after(4'd4, f_dp_pipe[6*128 +: 128]),
    f_after(4'd6, f_dp_pipe[5*128 +: 128]),
    f_after(4'd9, f_dp_pipe[4*128 +: 128]),
    f_after(4'd10, f_dp_pipe[3*128 +: 128]),
    f_after(4'd11, f_dp_pipe[2*128 +: 128]),
    f_after(4'd12, f_dp_pipe[1*128 +: 128]),
    f_after(4'd13, f_dp_pipe[0*128 +: 128]),
    {96'd0, f_m1_read ? f_dp_prod[63:32] : 32'd0},
    {96'd0, f_m2_read ? f_dp_prod[31:0] : 32'd0},
    f_dp_load};
wire f_dp_unused = &{1'b0, f_dp_cfg, f_dp_iprev, f_dp_fbase, f_dp_nlim, f_dp_pi_sign};
assign f_ctl_state = {{(8-CH_W){1'b0}}, ch_reg, start_reg, seq_reg, busy_reg, out_valid_reg,
                      sample_cnt_reg};

`undef TL_ENV
`endif

endmodule

`resetall
