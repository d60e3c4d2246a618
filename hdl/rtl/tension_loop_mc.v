`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * N tension loops (one per cable) on one time-multiplexed datapath, with safety groups.
 *
 * Each channel is the loop of tension_loop.v (calibration, slew limit, floor, PI + feedforward,
 * conditional integration, faults, watchdog ramp), computed with the same arithmetic in the same
 * 15-clock schedule; the channels take turns on the two multipliers, one slot of LATENCY_CH
 * clocks each, in channel order. A channel whose group is not stopped is bit-exact to a
 * tension_loop fed the same inputs and ticked by the same tick (the model is
 * cosim/parts/rtl_model.py, TensionLoopModel; TensionLoopMcModel for the whole module).
 *
 * Timing: `tick` (one clock) starts a control period. In the tick clock every channel's events
 * since the last tick (its latest ADC sample, a TC write, the INTEG_RESET and FAULT_CLEAR pulses)
 * and its group's stop are captured; channel k's slot then runs from clock 1 + LATENCY_CH*k.
 * `out_valid` comes LATENCY (1 + LATENCY_CH*N) clocks after the tick, when every channel's
 * outputs are new; ticks must be at least LATENCY clocks apart.
 *
 * Configuration: the slots read the live per-channel configuration ports (as tension_loop with
 * SNAPSHOT 0), and `cfg_busy` (the tick clock up to the last slot's clock 13) tells the register
 * bus to hold writes, so every channel uses the configuration of the tick edge, as a
 * tension_loop does.
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
    parameter [15:0] WDT_RAMP_STEP = 16'd41  // watchdog and group ramp-down of u, Q3.12 A per
                                             // sample (41/4096 A: 4 A reach zero in 40 ms at 10 kHz)
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
    output wire [13*128-1:0] f_pipe_state  // the slot's pipeline, each register from the clock
                                           // after its slot writes it (0 before)
`endif
);

localparam LATENCY_CH = 15;             // clocks of one channel's slot (tension_loop's LATENCY)
localparam CH_W = (N > 1) ? $clog2(N) : 1;
localparam [31:0] N_LAST = N - 1;
localparam [CH_W-1:0] CH_LAST = N_LAST[CH_W-1:0];  // the last channel's index

localparam [3:0] F_WDT = 4'b0100;  // fault bits: {overcurrent, watchdog, adc_range, adc_stale}

// Period sequencer: the channel in its slot, the slot's first clock, the schedule within it
// (seq_reg[k] high in clock k+1 of the slot), the hold of the configuration.
reg  [CH_W-1:0]         ch_reg, ch_next;
reg                     start_reg, start_next;
reg  [LATENCY_CH-2:0]   seq_reg, seq_next;
reg                     busy_reg, busy_next;
reg  [31:0]             sample_cnt_reg, sample_cnt_next;

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

// Per channel: counters, latched faults and the results (tension_loop's state between samples).
reg  [N*17-1:0] stale_cnt_reg, stale_cnt_next;
reg  [N*17-1:0] wdt_cnt_reg, wdt_cnt_next;
reg  [N*17-1:0] oc_cnt_reg, oc_cnt_next;
reg  [N*4-1:0]  fault_reg, fault_next;
reg  [N*16-1:0] t_in_reg, t_in_next;
reg  [N*16-1:0] u_reg, u_next;
reg  [N-1:0]    out_en_reg, out_en_next;
reg  [N-1:0]    sat_hi_reg, sat_hi_next;
reg  [N-1:0]    sat_lo_reg, sat_lo_next;
reg  [N-1:0]    ramp_st_reg, ramp_st_next;
reg  [N*32-1:0] integ_reg, integ_next;
reg  [N*16-1:0] tc_eff_reg, tc_eff_next;
reg             out_valid_reg, out_valid_next;

// The channel in its slot: its configuration and state.
wire        en_cfg = enable[ch_reg];
wire        slew_en_cfg = slew_en[ch_reg];
wire [15:0] tc_cfg = tc[ch_reg*16 +: 16];                   // Q7.8 N
wire [15:0] tcmin_cfg = tc_min[ch_reg*16 +: 16];            // Q7.8 N
wire [15:0] kff_cfg = kff[ch_reg*16 +: 16];                 // Q2.13 A/N
wire [15:0] uff_cfg = uff[ch_reg*16 +: 16];                 // Q3.12 A
wire [15:0] kp_cfg = kp[ch_reg*16 +: 16];                   // Q2.13 A/N
wire [15:0] ki_cfg = ki_ts[ch_reg*16 +: 16];                // 2^-20 A/N per sample
wire [14:0] lim_cfg = i_limit[ch_reg*15 +: 15];             // UQ3.12 A
wire [14:0] slew_cfg = slew[ch_reg*15 +: 15];               // UQ7.8 N
wire [15:0] wdt_to_cfg = wdt_timeout[ch_reg*16 +: 16];
wire [23:0] offset_cfg = adc_offset[ch_reg*24 +: 24];       // Q23.0 code
wire [15:0] gain_cfg = adc_gain[ch_reg*16 +: 16];           // 2^-20 Q7.8-LSB per code
wire [23:0] min_cfg = adc_min[ch_reg*24 +: 24];             // Q23.0 code
wire [23:0] max_cfg = adc_max[ch_reg*24 +: 24];             // Q23.0 code
wire [15:0] stale_to_cfg = adc_stale[ch_reg*16 +: 16];
wire [15:0] oc_to_cfg = oc_timeout[ch_reg*16 +: 16];

wire [23:0] raw_c = raw_t_reg[ch_reg*24 +: 24];
wire        fresh_c = fresh_t_reg[ch_reg];
wire        tcw_c = tcw_t_reg[ch_reg];
wire        irst_c = irst_t_reg[ch_reg];
wire        fclr_c = fclr_t_reg[ch_reg];
wire        grp_c = grp_t_reg[ch_reg];
wire [16:0] stale_cnt_c = stale_cnt_reg[ch_reg*17 +: 17];
wire [16:0] wdt_cnt_c = wdt_cnt_reg[ch_reg*17 +: 17];
wire [16:0] oc_cnt_c = oc_cnt_reg[ch_reg*17 +: 17];
wire [3:0]  fault_c = fault_reg[ch_reg*4 +: 4];
wire [15:0] u_c = u_reg[ch_reg*16 +: 16];                    // Q3.12 A
wire        sat_hi_c = sat_hi_reg[ch_reg];
wire        sat_lo_c = sat_lo_reg[ch_reg];
wire [31:0] integ_c = integ_reg[ch_reg*32 +: 32];            // Q3.28 A
wire [15:0] tc_eff_c = tc_eff_reg[ch_reg*16 +: 16];          // Q7.8 N

// Group stop at the tick: another channel of the group has a latched fault. The membership is
// fixed by GROUP, so it is wiring.
wire [N-1:0] grp_now;
genvar gk, gj;
generate
    for (gk = 0; gk < N; gk = gk + 1) begin : g_grp
        wire [N-1:0] partner_fault;
        for (gj = 0; gj < N; gj = gj + 1) begin : g_partner
            if (gj != gk && GROUP[gj*GROUP_W +: GROUP_W] == GROUP[gk*GROUP_W +: GROUP_W]) begin : g_same
                assign partner_fault[gj] = |fault_reg[gj*4 +: 4];
            end else begin : g_other
                assign partner_fault[gj] = 1'b0;
            end
        end
        assign grp_now[gk] = |partner_fault;
    end
endgenerate

// Slot pipeline (tension_loop's, shared by the channels; every register here is written in a
// slot before that slot reads it, so nothing passes from one channel's slot to the next).
reg  [23:0] raw_s_reg, raw_s_next;
reg         lo_bad_reg, lo_bad_next;
reg         hi_bad_reg, hi_bad_next;
reg  [3:0]  fbase_s_reg, fbase_s_next;
reg  [24:0] diff_reg, diff_next;
reg  [16:0] hi_s_reg, hi_s_next;
reg  [16:0] lo_s_reg, lo_s_next;
reg  [15:0] nlim_reg, nlim_next;  // -I_LIMIT, computed once per slot off the critical paths
reg  [31:0] iprev_reg, iprev_next;
reg         iphi_reg, iphi_next;  // I entering the sample > +I_LIMIT (I_LIMIT lowered)
reg         iplo_reg, iplo_next;  // I entering the sample < -I_LIMIT
reg  [31:0] ihold_reg, ihold_next;  // clamp(I, +-I_LIMIT): the integrator when it holds
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

// Multiplier operands.
reg  [15:0] m1_a, m1_b, m2_a, m2_b;
wire signed [31:0] m1_p, m2_p;

mul_s16 mul1 (.clk(clk), .a(m1_a), .b(m1_b), .p(m1_p));
mul_s16 mul2 (.clk(clk), .a(m2_a), .b(m2_b), .p(m2_p));

// --- the slot's clock 0 (start_reg) ---------------------------------------------------------

// The counters as tension_loop.v computes them at its tick, from the events of the tick.
wire [16:0] stale_inc = stale_cnt_c + {16'd0, !stale_cnt_c[16]};
wire [16:0] wdt_inc = wdt_cnt_c + {16'd0, !wdt_cnt_c[16]};
wire [16:0] stale_now = fresh_c ? 17'd0 : fclr_c ? 17'd1 : stale_inc;
wire [16:0] wdt_now = (!en_cfg || tcw_c) ? 17'd0 : fclr_c ? 17'd1 : wdt_inc;

// --- later clocks of the slot (tension_loop.v says why each is exact) -----------------------

wire [24:0] below_min = {raw_s_reg[23], raw_s_reg} - {min_cfg[23], min_cfg};
wire [24:0] above_max = {max_cfg[23], max_cfg} - {raw_s_reg[23], raw_s_reg};
wire [3:0] detect = {(oc_to_cfg != 16'd0) && (oc_cnt_c >= {1'b0, oc_to_cfg}),
                     (wdt_to_cfg != 16'd0) && (wdt_cnt_c >= {1'b0, wdt_to_cfg}),
                     lo_bad_reg || hi_bad_reg,
                     (stale_to_cfg != 16'd0) && (stale_cnt_c >= {1'b0, stale_to_cfg})};
wire [3:0] faults_now = fbase_s_reg | det_reg;

wire [17:0] tc_above = {hi_s_reg[16], hi_s_reg} - {{2{tc_cfg[15]}}, tc_cfg};
wire [17:0] tc_below = {{2{tc_cfg[15]}}, tc_cfg} - {lo_s_reg[16], lo_s_reg};
wire [16:0] tce_slew = cmp_hi_reg ? hi_s_reg : cmp_lo_reg ? lo_s_reg : {tc_cfg[15], tc_cfg};
wire [16:0] tce_flr = {tce_s_reg[15], tce_s_reg} - {tcmin_cfg[15], tcmin_cfg};

// round(x / 2^20) fits Q7.8 unless bits 40..35 differ: saturate to the Q7.8 range.
wire cal_ovf = !((&cal_sum_reg[40:35]) || !(|cal_sum_reg[40:35]));
wire [15:0] t_in_now = cal_ovf ? {cal_sum_reg[40], {15{~cal_sum_reg[40]}}} : cal_sum_reg[35:20];

// Error in 17 bits, saturated to Q7.8; t_in of the slot's channel was written in clock 5.
wire [15:0] t_in_c = t_in_reg[ch_reg*16 +: 16];
wire signed [16:0] e_full = $signed({tce_s_reg[15], tce_s_reg}) -
                            $signed({t_in_c[15], t_in_c});
wire e_ovf = e_full[16] != e_full[15];
wire [15:0] e_now = e_ovf ? {e_full[16], {15{~e_full[16]}}} : e_full[15:0];

wire signed [32:0] lim28 = $signed({2'b00, lim_cfg, 16'd0});
wire signed [32:0] nlim28 = $signed({nlim_reg[15], nlim_reg, 16'd0});
wire [33:0] i_above = {lim28[32], lim28} - {isum_reg[32], isum_reg};
wire [33:0] i_below = {isum_reg[32], isum_reg} - {nlim28[32], nlim28};
wire [32:0] i_clamped = ihi_reg ? lim28 : ilo_reg ? nlim28 : isum_reg;
wire windup = (sat_hi_c && pi_pos_reg) || (sat_lo_c && pi_neg_reg);
wire [33:0] ip_above = {lim28[32], lim28} - {{2{iprev_reg[31]}}, iprev_reg};
wire [33:0] ip_below = {{2{iprev_reg[31]}}, iprev_reg} - {nlim28[32], nlim28};

wire signed [33:0] v_sum = $signed(fp_reg) + $signed({{9{inew_reg[31]}}, inew_reg[31:7]});

wire signed [24:0] lim12 = $signed({10'd0, lim_cfg});
wire signed [24:0] nlim12 = $signed({{9{nlim_reg[15]}}, nlim_reg});
wire [25:0] r_above = {lim12[24], lim12} - {r_reg[24], r_reg};
wire [25:0] r_below = {r_reg[24], r_reg} - {nlim12[24], nlim12};
wire [15:0] u_sat = rhi_reg ? {1'b0, lim_cfg} : rlo_reg ? nlim_reg : r_reg[15:0];

wire signed [15:0] step = $signed(WDT_RAMP_STEP);
wire [15:0] u_ramp = ugt_reg ? u_dn_reg : ult_reg ? u_up_reg : 16'd0;

// Bits dropped on purpose: as in tension_loop.v.
wire unused_bits = &{1'b0, tce_slew[16], below_min[23:0], above_max[23:0], cal_sum_reg[19:0], i_clamped[32], v_sum[8:0],
                     r_above[24:0], r_below[24:0], i_above[32:0], i_below[32:0],
                     ip_above[32:0], ip_below[32:0],
                     tc_above[16:0], tc_below[16:0], tce_flr[15:0]};

integer k;

always @* begin
    // Sequencer: the tick starts channel 0's slot a clock later, each slot's last clock the
    // next channel's, the last slot's out_valid.
    ch_next = ch_reg;
    start_next = tick;
    seq_next = {seq_reg[LATENCY_CH-3:0], start_reg};
    busy_next = tick || (busy_reg && !(seq_reg[LATENCY_CH-3] && ch_reg == CH_LAST));
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

    m1_a = 16'd0;
    m1_b = 16'd0;
    m2_a = 16'd0;
    m2_b = 16'd0;

    // Clock 0 of the slot (tension_loop's tick clock): counters, raw - offset, slew bounds.
    if (start_reg) begin
        stale_cnt_next[ch_reg*17 +: 17] = stale_now;
        wdt_cnt_next[ch_reg*17 +: 17] = wdt_now;
        oc_cnt_next[ch_reg*17 +: 17] = fclr_c ? 17'd0 : oc_cnt_c;
        raw_s_next = raw_c;
        fbase_s_next = fclr_c ? 4'd0 : fault_c;
        diff_next = $signed({raw_c[23], raw_c}) - $signed({offset_cfg[23], offset_cfg});
        hi_s_next = $signed({tc_eff_c[15], tc_eff_c}) + $signed({2'b00, slew_cfg});
        lo_s_next = $signed({tc_eff_c[15], tc_eff_c}) - $signed({2'b00, slew_cfg});
        iprev_next = irst_c ? 32'd0 : integ_c;
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

    // Clock 2: detection, the slew limit, the held integrator's clamp comparisons; low 9 bits
    // of the difference (non-negative) times the gain.
    if (seq_reg[1]) begin
        det_next = en_cfg ? detect : 4'd0;
        iphi_next = ip_above[33];  // I > +I_LIMIT
        iplo_next = ip_below[33];  // I < -I_LIMIT
        tce_s_next = slew_en_cfg ? tce_slew[15:0] : tc_cfg;
        m1_a = {7'd0, diff_reg[8:0]};
        m1_b = gain_cfg;
    end

    // Clock 3: faults latch and the mode (a group stop runs the channel as a watchdog-only
    // fault does); the floor; high partial product (+ 2^19: round at >> 20); the held integrator.
    if (seq_reg[2]) begin
        fault_next[ch_reg*4 +: 4] = faults_now;
        run_next = en_cfg && (faults_now == 4'd0) && !grp_c;
        ramp_next = en_cfg && ((faults_now == F_WDT) || (faults_now == 4'd0 && grp_c));
        tce_s_next = tce_flr[16] ? tcmin_cfg : tce_s_reg;  // T_s < TC_MIN: the floor
        cal_acc_next = {m1_p, 9'd0} + 41'd524288;
        ihold_next = iphi_reg ? lim28[31:0] : iplo_reg ? nlim28[31:0] : iprev_reg;
    end

    // Clock 4: calibration sum, 41 bits exact (|diff*g| < 2^40); feedforward product.
    if (seq_reg[3]) begin
        cal_sum_next = cal_acc_reg + {{9{m1_p[31]}}, m1_p};
        m2_a = tce_s_reg;
        m2_b = kff_cfg;
    end

    // Clock 5: T_in.
    if (seq_reg[4]) begin
        t_in_next[ch_reg*16 +: 16] = t_in_now;
    end

    // Clock 6: error; feedforward plus {UFF, 9'h100} (exact: |ff| < 2^31 + 2^24 + 2^8).
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

    // Clock 12: rounded output before saturation; the ramp's comparisons and steps.
    if (seq_reg[11]) begin
        r_next = v_sum[33:9];
        ugt_next = $signed(u_c) > step;
        ult_next = $signed(u_c) < -step;
        u_dn_next = u_c - step;
        u_up_next = u_c + step;
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
        if (run_reg) begin
            u_next[ch_reg*16 +: 16] = u_sat;
            integ_next[ch_reg*32 +: 32] = inew_reg;
            sat_hi_next[ch_reg] = rhi_reg;
            sat_lo_next[ch_reg] = rlo_reg;
            out_en_next[ch_reg] = 1'b1;
            ramp_st_next[ch_reg] = 1'b0;
            tc_eff_next[ch_reg*16 +: 16] = tce_s_reg;
            // Consecutive saturated samples, stopping at 2^16.
            oc_cnt_next[ch_reg*17 +: 17] = !(rhi_reg || rlo_reg) ? 17'd0 :
                                          oc_cnt_c + {16'd0, !oc_cnt_c[16]};
        end else begin
            u_next[ch_reg*16 +: 16] = ramp_reg ? u_ramp_reg : 16'd0;
            out_en_next[ch_reg] = ramp_reg && ramp_nz_reg;
            ramp_st_next[ch_reg] = ramp_reg && ramp_nz_reg;
            integ_next[ch_reg*32 +: 32] = 32'd0;
            sat_hi_next[ch_reg] = 1'b0;
            sat_lo_next[ch_reg] = 1'b0;
            tc_eff_next[ch_reg*16 +: 16] = 16'd0;
            oc_cnt_next[ch_reg*17 +: 17] = 17'd0;
        end
    end
end

always @(posedge clk) begin
    ch_reg <= ch_next;
    start_reg <= start_next;
    seq_reg <= seq_next;
    busy_reg <= busy_next;
    sample_cnt_reg <= sample_cnt_next;
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
    stale_cnt_reg <= stale_cnt_next;
    wdt_cnt_reg <= wdt_cnt_next;
    oc_cnt_reg <= oc_cnt_next;
    fault_reg <= fault_next;
    t_in_reg <= t_in_next;
    u_reg <= u_next;
    out_en_reg <= out_en_next;
    sat_hi_reg <= sat_hi_next;
    sat_lo_reg <= sat_lo_next;
    ramp_st_reg <= ramp_st_next;
    integ_reg <= integ_next;
    tc_eff_reg <= tc_eff_next;
    out_valid_reg <= out_valid_next;
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

    if (rst) begin
        ch_reg <= {CH_W{1'b0}};
        start_reg <= 1'b0;
        seq_reg <= {(LATENCY_CH-1){1'b0}};
        busy_reg <= 1'b0;
        sample_cnt_reg <= 32'd0;
        raw_reg <= {(N*24){1'b0}};
        fresh_reg <= {N{1'b0}};
        tcw_pend_reg <= {N{1'b0}};
        irst_pend_reg <= {N{1'b0}};
        fclr_pend_reg <= {N{1'b0}};
        grp_t_reg <= {N{1'b0}};
        stale_cnt_reg <= {(N*17){1'b0}};
        wdt_cnt_reg <= {(N*17){1'b0}};
        oc_cnt_reg <= {(N*17){1'b0}};
        fault_reg <= {(N*4){1'b0}};
        t_in_reg <= {(N*16){1'b0}};
        u_reg <= {(N*16){1'b0}};
        out_en_reg <= {N{1'b0}};
        sat_hi_reg <= {N{1'b0}};
        sat_lo_reg <= {N{1'b0}};
        ramp_st_reg <= {N{1'b0}};
        integ_reg <= {(N*32){1'b0}};
        tc_eff_reg <= {(N*16){1'b0}};
        out_valid_reg <= 1'b0;
        run_reg <= 1'b0;
        ramp_reg <= 1'b0;
    end
end

// The tick clock up to the last slot's clock 13 read the configuration (clock 14 still reads
// I_LIMIT, so a write presented in it lands after it).
assign cfg_busy = tick || busy_reg;

assign u = u_reg;
assign out_en = out_en_reg;
assign out_valid = out_valid_reg;
assign saturated = sat_hi_reg | sat_lo_reg;
assign wdt_ramp = ramp_st_reg;
assign grp_stop = grp_t_reg;
assign faults = fault_reg;
assign t_in = t_in_reg;
assign integ = integ_reg;
assign tc_eff = tc_eff_reg;
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

wire [LATENCY_CH-2:0] f_seq_exp = (f_run && f_lc != 4'd0) ?
                                  {{(LATENCY_CH-2){1'b0}}, 1'b1} << (f_lc - 4'd1) :
                                  {(LATENCY_CH-1){1'b0}};
always @* if (f_past_valid && !rst) begin
    // property mc_schedule: the sequencer is the shadow's position in the period: one slot at a time, in channel order (induction helper)
    mc_schedule: assert(start_reg == (f_run && f_lc == 4'd0));
    mc_schedule_2: assert(seq_reg == f_seq_exp);
    mc_schedule_3: assert(ch_reg == (f_run ? f_ch : {CH_W{1'b0}}));
    mc_schedule_4: assert(busy_reg == (f_run && !(f_ch == CH_LAST && f_lc == F_LC_LAST)));
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

wire [15:0] f_u_d = u_reg[f_ch_d*16 +: 16];  // the finished channel's new u
// property mc_stop_ramp: a stopped sample (group stop or own fault) moves u one WDT_RAMP_STEP towards zero or to zero, the drive on only while u is not 0, the integrator 0
always @* if (f_past_valid && !rst && f_end_d && f_stop_d) begin
    mc_stop_ramp: assert(f_u_d == f_ramp(f_uprev_d) || f_u_d == 16'd0);
    mc_stop_ramp_2: assert(out_en_reg[f_ch_d] == (f_u_d != 16'd0));
    mc_stop_ramp_3: assert(integ_reg[f_ch_d*32 +: 32] == 32'd0 && !sat_hi_reg[f_ch_d] && !sat_lo_reg[f_ch_d]);
end

// Every channel against its ramp bound.
reg [N-1:0] f_in_bound, f_en_follows, f_zero;
integer fb;
always @* begin
    for (fb = 0; fb < N; fb = fb + 1) begin
        f_in_bound[fb] = $signed(u_reg[fb*16 +: 16]) <= f_bound(f_age[fb*F_AGE_W +: F_AGE_W]) &&
                         -$signed(u_reg[fb*16 +: 16]) <= f_bound(f_age[fb*F_AGE_W +: F_AGE_W]);
        f_en_follows[fb] = f_age[fb*F_AGE_W +: F_AGE_W] == {F_AGE_W{1'b0}} ||
                           out_en_reg[fb] == (u_reg[fb*16 +: 16] != 16'd0);
        f_zero[fb] = f_age[fb*F_AGE_W +: F_AGE_W] != F_AGE_MAX ||
                     (u_reg[fb*16 +: 16] == 16'd0 && !out_en_reg[fb]);
    end
end
always @* if (f_past_valid && !rst) begin
    // property mc_ramp_bound: every channel, after `age` stopped samples in a row: abs(u) <= 32767 - age * WDT_RAMP_STEP (never -32768), the drive on only while u is not 0
    mc_ramp_bound: assert(&f_in_bound);
    mc_ramp_bound_2: assert(&f_en_follows);
    // property mc_group_zero: a fault latched on a channel of a group (its own or another's) brings every channel of the group to u = 0, drive off, within ceil(32767 / WDT_RAMP_STEP) stopped samples, and keeps it there while the fault stays latched
    mc_group_zero: assert(&f_zero);
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
            fclr_pend_reg[fk], grp_t_reg[fk], stale_cnt_reg[fk*17 +: 17],
            wdt_cnt_reg[fk*17 +: 17], oc_cnt_reg[fk*17 +: 17], fault_reg[fk*4 +: 4],
            t_in_reg[fk*16 +: 16], u_reg[fk*16 +: 16], out_en_reg[fk], sat_hi_reg[fk],
            sat_lo_reg[fk], ramp_st_reg[fk], integ_reg[fk*32 +: 32], tc_eff_reg[fk*16 +: 16]};
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
    f_after(4'd0, {raw_s_reg, fbase_s_reg, diff_reg, hi_s_reg, lo_s_reg, iprev_reg}),
    f_after(4'd1, {lo_bad_reg, hi_bad_reg, cmp_hi_reg, cmp_lo_reg, nlim_reg}),
    f_after(4'd2, {det_reg, iphi_reg, iplo_reg, tce_s_reg}),
    f_after(4'd3, {run_reg, ramp_reg, cal_acc_reg, ihold_reg}),
    f_after(4'd4, {cal_sum_reg}),
    f_after(4'd6, {e_reg, ff_reg}),
    f_after(4'd9, {fp_reg, isum_reg, pi_pos_reg, pi_neg_reg}),
    f_after(4'd10, {ihi_reg, ilo_reg}),
    f_after(4'd11, {inew_reg}),
    f_after(4'd12, {r_reg, ugt_reg, ult_reg, u_dn_reg, u_up_reg}),
    f_after(4'd13, {rhi_reg, rlo_reg, u_ramp_reg, ramp_nz_reg}),
    {96'd0, f_m1_read ? m1_p : 32'd0},
    {96'd0, f_m2_read ? m2_p : 32'd0}};
assign f_ctl_state = {{(8-CH_W){1'b0}}, ch_reg, start_reg, seq_reg, busy_reg, out_valid_reg,
                      sample_cnt_reg};

`undef TL_ENV
`endif

endmodule

`resetall
