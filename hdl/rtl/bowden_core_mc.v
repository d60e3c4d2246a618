`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Bowden-cable tension controller core for N cables: one bank of registers per channel, the N
 * tension loops on one time-multiplexed datapath with their safety groups (tension_loop_mc),
 * and one ESCON PWM output per channel.
 *
 * Register banks: channel k's registers are the single core's map (hdl/regmap/bowden_regs.json,
 * the generated bowden_regs) at byte address k * 2^ADDR_W + the register's address, so bank 0
 * is bowden_core's map and a host that drives one cable reads and writes it as before.
 * Registers that are not a channel's own read the same in every bank: ID, SAMPLE_COUNT and
 * ADC_FLAGS (the front-end's, shared by all channels). T_OUT of bank k is cable k's far-end
 * code.
 *
 * The ADC front-end gives every channel of one conversion together (ads131m02_reader with NCH
 * = 2N, an ADS131M04 for 2 cables, an ADS131M08 for 4; adc_valid has a bit per cable, so a
 * converter per cable works too): cable k's T_in is ADC channel 2k and its T_out channel 2k + 1.
 *
 * Timing: a sample tick every CLKS_PER_SAMPLE clocks (>= tension_loop_mc's LATENCY, 1 + 15 N)
 * starts one period of every channel; cmd_valid pulses when every channel's command is new.
 * The register bus holds writes while the loops read their configuration (cfg_busy), so every
 * channel of a period uses the configuration of the tick edge, as bowden_core does.
 */
module bowden_core_mc #(
    parameter N = 2,                              // cables (channels): 1, 2, 4 or 8
    parameter GROUP_W = 4,                        // bits of a channel's safety group id
    parameter [N*GROUP_W-1:0] GROUP = {N*GROUP_W{1'b0}},  // channel k's group in bits
                                                  // [k*GROUP_W +: GROUP_W]; default: one group
    parameter CLK_HZ = 48000000,                  // system clock, Hz
    parameter SAMPLE_HZ = 10000,                  // loop rate, Hz
    parameter CLKS_PER_SAMPLE = CLK_HZ / SAMPLE_HZ,  // clocks per sample tick (>= 1 + 15 N)
    parameter PWM_HZ = 5000,                      // PWM set value frequency, Hz (ESCON <= 5 kHz)
    parameter PWM_IMAX_Q12 = 16384,               // current at 90 % duty, Q3.12 A (4 A)
    parameter [15:0] WDT_RAMP_STEP = 16'd41,      // watchdog and group ramp, Q3.12 A per sample
    parameter ADDR_W = 8,                         // byte address width of one channel's bank
    parameter RD_STAGES = 3,                      // register read-back clocks: 3 or 1
    parameter CH_W = (N > 1) ? $clog2(N) : 1,     // bank select bits (derived: do not set)
    parameter BUS_W = ADDR_W + ((N > 1) ? CH_W : 0)  // bus address width (derived: do not set)
) (
    input  wire              clk,
    input  wire              rst,

    /*
     * AXI4-Lite slave: N banks of the register map, channel k's at k << ADDR_W
     */
    input  wire [BUS_W-1:0]  s_axil_awaddr,
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
    input  wire [BUS_W-1:0]  s_axil_araddr,
    input  wire [2:0]        s_axil_arprot,
    input  wire              s_axil_arvalid,
    output wire              s_axil_arready,
    output wire [31:0]       s_axil_rdata,
    output wire [1:0]        s_axil_rresp,
    output wire              s_axil_rvalid,
    input  wire              s_axil_rready,

    /*
     * Raw load-cell ADC samples: one conversion of every ADC channel, cable k's T_in in ADC
     * channel 2k and its T_out in 2k + 1 (ADC channel j in bits [j*24 +: 24], signed codes)
     */
    input  wire [N-1:0]      adc_valid,       // cable k's channels (2k, 2k + 1) are new: all
                                              // together from one converter, each on its own
                                              // from a converter per cable
    input  wire [2*N*24-1:0] adc_ch_data,
    input  wire              adc_drdy_lost,   // front-end flags, read back in ADC_FLAGS
    input  wire              adc_crc_err,

    /*
     * Drive, channel k in bits [k*W +: W]
     */
    output wire [N*16-1:0]   cmd_current,  // Q3.12 A
    output wire [N-1:0]      cmd_enable,
    output wire              cmd_valid,    // one clock when every channel's command is new
    output wire [N-1:0]      fault,        // channel k has a latched fault
    output wire [N-1:0]      pwm,          // ESCON PWM set values
    output wire              sample_tick   // one clock at the start of each period
);

localparam LATENCY = 1 + 15 * N;  // tension_loop_mc's LATENCY
localparam CNT_W = $clog2(CLKS_PER_SAMPLE);
localparam integer TICK_LAST_INT = CLKS_PER_SAMPLE - 1;
localparam [CNT_W-1:0] TICK_LAST = TICK_LAST_INT[CNT_W-1:0];

generate
    if (CLKS_PER_SAMPLE < LATENCY) begin : g_check
        bowden_core_mc_CLKS_PER_SAMPLE_must_be_at_least_1_plus_15_N error_CLKS_PER_SAMPLE ();
    end
    if (N != 1 && N != 2 && N != 4 && N != 8) begin : g_check_n
        bowden_core_mc_N_must_be_1_2_4_or_8 error_N ();  // every bank address is a channel
    end
endgenerate

// --- sample tick (as bowden_core) ------------------------------------------------------------

reg [CNT_W-1:0] tick_cnt_reg;
reg             tick_reg;

always @(posedge clk) begin
    tick_reg <= (tick_cnt_reg == TICK_LAST);
    tick_cnt_reg <= (tick_cnt_reg == TICK_LAST) ? {CNT_W{1'b0}} : tick_cnt_reg + 1'b1;
    if (rst) begin
        tick_cnt_reg <= {CNT_W{1'b0}};
        tick_reg <= 1'b0;
    end
end

// --- register bus and the banks --------------------------------------------------------------

wire             reg_wr_en, reg_rd_en;
wire [BUS_W-1:0] reg_wr_addr, reg_rd_addr;
wire [31:0]      reg_wr_data;
wire [3:0]       reg_wr_strb;
wire             cfg_busy;

wire [N-1:0]     bank_wr_err, bank_rd_err, bank_rd_valid;
wire [N*32-1:0]  bank_rd_data;
reg  [CH_W-1:0]  rd_bank_reg;  // the bank of the read in flight (one at a time)

wire [CH_W-1:0] wr_bank, rd_bank;
generate
    if (N > 1) begin : g_bank_sel
        assign wr_bank = reg_wr_addr[ADDR_W +: CH_W];
        assign rd_bank = reg_rd_addr[ADDR_W +: CH_W];
    end else begin : g_bank_one
        assign wr_bank = 1'b0;
        assign rd_bank = 1'b0;
    end
endgenerate

always @(posedge clk) begin
    if (reg_rd_en) rd_bank_reg <= rd_bank;
    if (rst) rd_bank_reg <= {CH_W{1'b0}};
end

axil_regbus #(.ADDR_W(BUS_W)) axil (
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
    .reg_wr_strb(reg_wr_strb), .reg_wr_err(|bank_wr_err),
    .reg_rd_en(reg_rd_en), .reg_rd_addr(reg_rd_addr),
    .reg_rd_data(bank_rd_data[rd_bank_reg*32 +: 32]),
    .reg_rd_err(bank_rd_err[rd_bank_reg]), .reg_rd_valid(|bank_rd_valid)
);

// Channel configuration and read-back, channel k in bits [k*W +: W].
wire [N-1:0]    ctrl_enable, ctrl_integ_reset, ctrl_fault_clear, ctrl_slew_en, tc_wr;
wire [N*16-1:0] tc, tc_min, kff, kp, ki_ts, wdt_timeout, adc_gain, adc_stale, oc_timeout, uff;
wire [N*15-1:0] i_limit, slew;
wire [N*24-1:0] adc_offset, adc_min, adc_max;

wire [N*16-1:0] u, t_in, tc_eff;
wire [N*32-1:0] integ;
wire [31:0]     sample_count;
wire [N*4-1:0]  faults;
wire [N-1:0]    out_en, saturated, wdt_ramp, grp_stop;
wire            out_valid;

genvar k;
generate
    for (k = 0; k < N; k = k + 1) begin : g_bank
        wire [3:0] f = faults[k*4 +: 4];
        bowden_regs #(.ADDR_W(ADDR_W), .RD_STAGES(RD_STAGES)) regs (
            .clk(clk), .rst(rst),
            .reg_wr_en(reg_wr_en && wr_bank == k), .reg_wr_addr(reg_wr_addr[ADDR_W-1:0]),
            .reg_wr_data(reg_wr_data), .reg_wr_strb(reg_wr_strb), .reg_wr_err(bank_wr_err[k]),
            .reg_rd_en(reg_rd_en && rd_bank == k), .reg_rd_addr(reg_rd_addr[ADDR_W-1:0]),
            .reg_rd_data(bank_rd_data[k*32 +: 32]), .reg_rd_err(bank_rd_err[k]),
            .reg_rd_valid(bank_rd_valid[k]),
            .ctrl_enable(ctrl_enable[k]), .ctrl_integ_reset(ctrl_integ_reset[k]),
            .ctrl_fault_clear(ctrl_fault_clear[k]), .ctrl_slew_en(ctrl_slew_en[k]),
            .hw_status_out_en(out_en[k]), .hw_status_saturated(saturated[k]),
            .hw_status_fault_active(|f), .hw_status_wdt_ramp(wdt_ramp[k]),
            .hw_fault_adc_stale(f[0]), .hw_fault_adc_range(f[1]),
            .hw_fault_watchdog(f[2]), .hw_fault_overcurrent(f[3]),
            .tc(tc[k*16 +: 16]), .tc_wr(tc_wr[k]), .kff(kff[k*16 +: 16]), .kp(kp[k*16 +: 16]),
            .ki_ts(ki_ts[k*16 +: 16]), .i_limit(i_limit[k*15 +: 15]), .slew(slew[k*15 +: 15]),
            .wdt_timeout(wdt_timeout[k*16 +: 16]), .adc_offset(adc_offset[k*24 +: 24]),
            .adc_gain(adc_gain[k*16 +: 16]), .adc_min(adc_min[k*24 +: 24]),
            .adc_max(adc_max[k*24 +: 24]), .adc_stale(adc_stale[k*16 +: 16]),
            .oc_timeout(oc_timeout[k*16 +: 16]),
            .hw_sample_count(sample_count), .hw_t_in(t_in[k*16 +: 16]), .hw_u(u[k*16 +: 16]),
            .hw_integ(integ[k*32 +: 32]), .hw_tc_eff(tc_eff[k*16 +: 16]),
            .hw_t_out(adc_ch_data[(2*k+1)*24 +: 24]),
            .hw_adc_flags_drdy_lost(adc_drdy_lost), .hw_adc_flags_crc_err(adc_crc_err),
            .tc_min(tc_min[k*16 +: 16]), .uff(uff[k*16 +: 16])
        );
    end
endgenerate

// --- the loops -------------------------------------------------------------------------------

wire [N*24-1:0] t_in_codes;  // ADC channel 2k of every cable k
generate
    for (k = 0; k < N; k = k + 1) begin : g_t_in
        assign t_in_codes[k*24 +: 24] = adc_ch_data[2*k*24 +: 24];
    end
endgenerate

tension_loop_mc #(.N(N), .GROUP_W(GROUP_W), .GROUP(GROUP), .WDT_RAMP_STEP(WDT_RAMP_STEP)) loop (
    .clk(clk), .rst(rst),
    .tick(tick_reg),
    .adc_valid(adc_valid), .adc_data(t_in_codes),
    .enable(ctrl_enable), .slew_en(ctrl_slew_en), .integ_reset(ctrl_integ_reset),
    .fault_clear(ctrl_fault_clear), .tc_wr(tc_wr),
    .tc(tc), .tc_min(tc_min), .kff(kff), .uff(uff), .kp(kp), .ki_ts(ki_ts), .i_limit(i_limit),
    .slew(slew), .wdt_timeout(wdt_timeout), .adc_offset(adc_offset), .adc_gain(adc_gain),
    .adc_min(adc_min), .adc_max(adc_max), .adc_stale(adc_stale), .oc_timeout(oc_timeout),
    .cfg_busy(cfg_busy),
    .u(u), .out_en(out_en), .out_valid(out_valid),
    .saturated(saturated), .wdt_ramp(wdt_ramp), .grp_stop(grp_stop), .faults(faults),
    .t_in(t_in), .integ(integ), .tc_eff(tc_eff), .sample_count(sample_count)
);

wire unused_grp_stop = &{1'b0, grp_stop};

// --- drive outputs ---------------------------------------------------------------------------

generate
    for (k = 0; k < N; k = k + 1) begin : g_pwm
        wire [31:0] duty;
        pwm_escon #(.PERIOD_CLKS(CLK_HZ / PWM_HZ), .IMAX_Q12(PWM_IMAX_Q12)) pwm_out (
            .clk(clk), .rst(rst),
            .u(u[k*16 +: 16]), .enable(out_en[k]), .pwm(pwm[k]), .duty_clks(duty)
        );
        wire unused_duty = &{1'b0, duty};
        assign fault[k] = |faults[k*4 +: 4];
    end
endgenerate

assign cmd_current = u;
assign cmd_enable = out_en;
assign cmd_valid = out_valid;
assign sample_tick = tick_reg;

endmodule

`resetall
