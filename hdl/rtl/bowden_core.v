`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Bowden-cable tension controller core: registers, the PI + feedforward loop and the drive
 * outputs. Used as is by the board tops and by the co-simulation.
 *
 * A sample tick every CLKS_PER_SAMPLE clocks (the first CLKS_PER_SAMPLE clocks after reset)
 * starts one loop computation on the most recent ADC sample; cmd_valid pulses LATENCY (15)
 * clocks later with the new command. CLKS_PER_SAMPLE may be as low as 15, which the
 * co-simulation uses to spend few simulated clocks per sample.
 *
 * RD_STAGES and SNAPSHOT trade flip-flops for clock speed: the defaults (3, 1) are the
 * external-MCU boards' at 48 MHz (a three-clock registered read-back, a configuration snapshot
 * at the tick); bowden_soc (24/25 MHz, the UP5K full) sets 1 and 0: a one-clock read-back, and
 * the loop reads the live registers while the bus holds a write for the 14 clocks of a sample
 * that read them (tension_loop, property tl_cfg_held).
 */
module bowden_core #(
    parameter CLK_HZ = 48000000,                  // system clock, Hz
    parameter SAMPLE_HZ = 10000,                  // loop rate, Hz
    parameter CLKS_PER_SAMPLE = CLK_HZ / SAMPLE_HZ,  // clocks per sample tick (>= 15)
    parameter PWM_HZ = 5000,                      // PWM set value frequency, Hz (ESCON <= 5 kHz)
    parameter PWM_IMAX_Q12 = 16384,               // current at 90 % duty, Q3.12 A (4 A)
    parameter [15:0] WDT_RAMP_STEP = 16'd41,      // watchdog ramp, Q3.12 A per sample
    parameter ADDR_W = 8,                         // register byte address width
    parameter RD_STAGES = 3,                      // register read-back clocks: 3 or 1
    parameter SNAPSHOT = 1                        // 1: configuration snapshot; 0: writes held
) (
    input  wire              clk,
    input  wire              rst,

    /*
     * AXI4-Lite slave: the register map (hdl/regmap/bowden_regs.json)
     */
    input  wire [ADDR_W-1:0] s_axil_awaddr,
    input  wire [2:0]        s_axil_awprot,
    input  wire              s_axil_awvalid,
    output wire              s_axil_awready,
    input  wire [31:0]       s_axil_wdata,
    input  wire [3:0]        s_axil_wstrb,
    input  wire              s_axil_wvalid,
    output wire              s_axil_wready,
    output wire [1:0]        s_axil_bresp,
    output wire              s_axil_bvalid,
    input  wire              s_axil_bready,
    input  wire [ADDR_W-1:0] s_axil_araddr,
    input  wire [2:0]        s_axil_arprot,
    input  wire              s_axil_arvalid,
    output wire              s_axil_arready,
    output wire [31:0]       s_axil_rdata,
    output wire [1:0]        s_axil_rresp,
    output wire              s_axil_rvalid,
    input  wire              s_axil_rready,

    /*
     * Raw load-cell ADC samples
     */
    input  wire              adc_valid,
    input  wire [23:0]       adc_data,     // signed 24-bit code
    input  wire [23:0]       adc_aux_data, // T_out's signed 24-bit code (read back as T_OUT)
    input  wire              adc_drdy_lost, // front-end flags, read back in ADC_FLAGS
    input  wire              adc_crc_err,

    /*
     * Drive
     */
    output wire [15:0]       cmd_current,  // Q3.12 A
    output wire              cmd_enable,
    output wire              cmd_valid,    // one clock when cmd_current is new
    output wire              fault,        // a fault is latched
    output wire              pwm,          // ESCON PWM set value
    output wire              sample_tick   // one clock at the start of each sample
);

localparam CNT_W = $clog2(CLKS_PER_SAMPLE);
localparam integer TICK_LAST_INT = CLKS_PER_SAMPLE - 1;
localparam [CNT_W-1:0] TICK_LAST = TICK_LAST_INT[CNT_W-1:0];  // fits: < 2^CNT_W

// Parameter check: a tick spacing below the loop latency would start a sample before the last
// one finished. Verilog-2005 has no elaboration-time $error, so a missing module stands in.
generate
    if (CLKS_PER_SAMPLE < 15) begin : g_check
        bowden_core_CLKS_PER_SAMPLE_must_be_at_least_15 error_CLKS_PER_SAMPLE ();
    end
endgenerate

// --- sample tick ---------------------------------------------------------------------------

reg [CNT_W-1:0] tick_cnt_reg, tick_cnt_next;
reg             tick_reg, tick_next;

always @* begin
    tick_next = (tick_cnt_reg == TICK_LAST);
    tick_cnt_next = tick_next ? {CNT_W{1'b0}} : tick_cnt_reg + 1'b1;
end

always @(posedge clk) begin
    tick_cnt_reg <= tick_cnt_next;
    tick_reg <= tick_next;
    if (rst) begin
        tick_cnt_reg <= {CNT_W{1'b0}};
        tick_reg <= 1'b0;
    end
end

// --- registers -----------------------------------------------------------------------------

wire              reg_wr_en, reg_wr_err, reg_rd_en, reg_rd_err, reg_rd_valid;
wire [ADDR_W-1:0] reg_wr_addr, reg_rd_addr;
wire [31:0]       reg_wr_data, reg_rd_data;
wire [3:0]        reg_wr_strb;

wire cfg_busy;  // the loop reads its live configuration (SNAPSHOT 0): hold writes

axil_regbus #(.ADDR_W(ADDR_W)) axil (
    .clk(clk), .rst(rst), .wr_hold(cfg_busy),
    .s_axil_awaddr(s_axil_awaddr), .s_axil_awprot(s_axil_awprot),
    .s_axil_awvalid(s_axil_awvalid), .s_axil_awready(s_axil_awready),
    .s_axil_wdata(s_axil_wdata), .s_axil_wstrb(s_axil_wstrb),
    .s_axil_wvalid(s_axil_wvalid), .s_axil_wready(s_axil_wready),
    .s_axil_bresp(s_axil_bresp), .s_axil_bvalid(s_axil_bvalid), .s_axil_bready(s_axil_bready),
    .s_axil_araddr(s_axil_araddr), .s_axil_arprot(s_axil_arprot),
    .s_axil_arvalid(s_axil_arvalid), .s_axil_arready(s_axil_arready),
    .s_axil_rdata(s_axil_rdata), .s_axil_rresp(s_axil_rresp),
    .s_axil_rvalid(s_axil_rvalid), .s_axil_rready(s_axil_rready),
    .reg_wr_en(reg_wr_en), .reg_wr_addr(reg_wr_addr), .reg_wr_data(reg_wr_data),
    .reg_wr_strb(reg_wr_strb), .reg_wr_err(reg_wr_err),
    .reg_rd_en(reg_rd_en), .reg_rd_addr(reg_rd_addr), .reg_rd_data(reg_rd_data),
    .reg_rd_err(reg_rd_err), .reg_rd_valid(reg_rd_valid)
);

wire        ctrl_enable, ctrl_integ_reset, ctrl_fault_clear, ctrl_slew_en, tc_wr;
wire [15:0] tc, tc_min, kff, kp, ki_ts, wdt_timeout, adc_gain, adc_stale, oc_timeout, uff;
wire [14:0] i_limit, slew;
wire [23:0] adc_offset, adc_min, adc_max;

wire [15:0] u, t_in, tc_eff;
wire [31:0] integ, sample_count;
wire [3:0]  faults;
wire        out_en, out_valid, saturated, wdt_ramp;
// bowden_regs' configuration word for a block RAM (its CFG_RAM 1; here 0: not used)
wire [261:0] cfg_rd_none = 262'd0;
wire [261:0] cfg_wr_en_none, cfg_wr_data_none;
wire unused_cfg = &{1'b0, cfg_wr_en_none, cfg_wr_data_none};

bowden_regs #(.ADDR_W(ADDR_W), .RD_STAGES(RD_STAGES)) regs (
    .clk(clk), .rst(rst),
    .reg_wr_en(reg_wr_en), .reg_wr_addr(reg_wr_addr), .reg_wr_data(reg_wr_data),
    .reg_wr_strb(reg_wr_strb), .reg_wr_err(reg_wr_err),
    .reg_rd_en(reg_rd_en), .reg_rd_addr(reg_rd_addr), .reg_rd_data(reg_rd_data),
    .reg_rd_err(reg_rd_err), .reg_rd_valid(reg_rd_valid),
    .ctrl_enable(ctrl_enable), .ctrl_integ_reset(ctrl_integ_reset),
    .ctrl_fault_clear(ctrl_fault_clear), .ctrl_slew_en(ctrl_slew_en),
    .hw_status_out_en(out_en), .hw_status_saturated(saturated),
    .hw_status_fault_active(|faults), .hw_status_wdt_ramp(wdt_ramp),
    .hw_fault_adc_stale(faults[0]), .hw_fault_adc_range(faults[1]),
    .hw_fault_watchdog(faults[2]), .hw_fault_overcurrent(faults[3]),
    .tc(tc), .tc_wr(tc_wr), .kff(kff), .kp(kp), .ki_ts(ki_ts), .i_limit(i_limit), .slew(slew),
    .wdt_timeout(wdt_timeout), .adc_offset(adc_offset), .adc_gain(adc_gain),
    .adc_min(adc_min), .adc_max(adc_max), .adc_stale(adc_stale), .oc_timeout(oc_timeout),
    .hw_sample_count(sample_count), .hw_t_in(t_in), .hw_u(u), .hw_integ(integ),
    .hw_tc_eff(tc_eff), .hw_t_out(adc_aux_data), .hw_adc_flags_drdy_lost(adc_drdy_lost),
    .hw_adc_flags_crc_err(adc_crc_err), .tc_min(tc_min), .uff(uff),
    .cfg_wr_en(cfg_wr_en_none), .cfg_wr_data(cfg_wr_data_none), .cfg_rd_data(cfg_rd_none)
);

// --- loop and drive ------------------------------------------------------------------------

`ifdef FORMAL
wire [3:0] f_loop_clk;  // the loop's clock within its sample (its proofs' shadow)
`endif

tension_loop #(.WDT_RAMP_STEP(WDT_RAMP_STEP), .SNAPSHOT(SNAPSHOT)) loop (
    .clk(clk), .rst(rst),
    .tick(tick_reg),
    .adc_valid(adc_valid), .adc_data(adc_data),
    .enable(ctrl_enable), .slew_en(ctrl_slew_en), .integ_reset(ctrl_integ_reset),
    .fault_clear(ctrl_fault_clear), .tc_wr(tc_wr),
    .tc(tc), .tc_min(tc_min), .kff(kff), .uff(uff), .kp(kp), .ki_ts(ki_ts), .i_limit(i_limit),
    .slew(slew), .wdt_timeout(wdt_timeout), .adc_offset(adc_offset), .adc_gain(adc_gain),
    .adc_min(adc_min), .adc_max(adc_max), .adc_stale(adc_stale), .oc_timeout(oc_timeout),
    .cfg_busy(cfg_busy),
    .u(u), .out_en(out_en), .out_valid(out_valid),
    .saturated(saturated), .wdt_ramp(wdt_ramp), .faults(faults),
    .t_in(t_in), .integ(integ), .tc_eff(tc_eff), .sample_count(sample_count)
`ifdef FORMAL
    ,
    .f_clk_in_sample(f_loop_clk)
`endif
);

wire [31:0] pwm_duty;

pwm_escon #(.PERIOD_CLKS(CLK_HZ / PWM_HZ), .IMAX_Q12(PWM_IMAX_Q12)) pwm_out (
    .clk(clk), .rst(rst),
    .u(u), .enable(out_en), .pwm(pwm), .duty_clks(pwm_duty)
);

// The duty read-back serves the PWM's own testbench only.
wire unused_duty = &{1'b0, pwm_duty};

assign cmd_current = u;
assign cmd_enable = out_en;
assign cmd_valid = out_valid;
assign fault = |faults;
assign sample_tick = tick_reg;

`ifdef FORMAL
// --- formal properties (hdl/formal/bowden_core.sby; hdl/README.md says what is proven) -----
//
// The sub-modules carry their own properties; here tension_loop's environment (ticks at least
// 15 clocks apart) is asserted, not assumed, so the composition is proven. The core adds the
// sample period and the drive outputs as the board sees them.

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;
always @* if (!f_past_valid) assume(rst);

always @* if (f_past_valid && !rst) begin
    // property core_tick_period: a tick every CLKS_PER_SAMPLE clocks, the first CLKS_PER_SAMPLE clocks after reset
    core_tick_period: assert(tick_cnt_reg <= TICK_LAST);
    core_tick_period_2: assert(tick_reg == (tick_cnt_reg == {CNT_W{1'b0}} && f_ticked));
    // property core_drive_zero_when_disabled: the board's drive command is 0 A whenever its enable is low
    // The drive: zero current whenever it is disabled.
    if (!cmd_enable) core_drive_zero_when_disabled: assert(cmd_current == 16'd0);
end

// A tick every CLKS_PER_SAMPLE clocks, the first CLKS_PER_SAMPLE clocks after reset.
reg f_ticked;
always @(posedge clk) begin
    if (tick_next) f_ticked <= 1'b1;
    if (rst) f_ticked <= 1'b0;
end

always @(posedge clk) if (f_past_valid && !rst && !$past(rst))
    cover(sample_tick && $past(f_ticked));  // the second tick

// The loop's clock within its sample is the tick counter's: LATENCY (idle) at a tick, before
// the first and from LATENCY clocks after a tick on.
wire [31:0] f_cnt = tick_cnt_reg;
wire [3:0]  f_loop_clk_exp = (f_ticked && f_cnt != 32'd0 && f_cnt < 32'd15) ? f_cnt[3:0] : 4'd15;
// property core_tick_phase: the loop's clock within its sample follows the tick counter (induction helper)
always @* if (f_past_valid && !rst) core_tick_phase: assert(f_loop_clk == f_loop_clk_exp);

// SNAPSHOT 0: a write waits at most 14 clocks (the loop's cfg_busy), so the CPU's store stalls
// that long at worst. f_hold_run: consecutive clocks of hold before this one.
reg [4:0] f_hold_run;
always @(posedge clk) begin
    f_hold_run <= cfg_busy ? f_hold_run + 5'd1 : 5'd0;
    if (rst) f_hold_run <= 5'd0;
end
// property core_write_hold: the register bus holds a write for at most 14 consecutive clocks (SNAPSHOT 0; never with the snapshot)
always @* if (f_past_valid && !rst) begin
    if (SNAPSHOT != 0) core_write_hold: assert(!cfg_busy);
    else core_write_hold_2: assert(!cfg_busy || f_hold_run < 5'd14);
end
// property core_hold_count: the count of held clocks is the loop's clock within its sample (SNAPSHOT 0; 0 with the snapshot; induction helper)
always @* if (f_past_valid && !rst)
    core_hold_count: assert(f_hold_run == ((SNAPSHOT == 0 && f_loop_clk != 4'd15) ? {1'b0, f_loop_clk} : 5'd0));

generate
    if (SNAPSHOT == 0) begin : g_f_hold
        // A write that found the bus held, taken once the sample no longer reads the registers.
        always @(posedge clk) if (f_past_valid && !rst && !$past(rst))
            cover($past(s_axil_awvalid && s_axil_wvalid && !s_axil_bvalid && cfg_busy) &&
                  s_axil_awready);
    end
endgenerate
`endif

endmodule

`resetall
