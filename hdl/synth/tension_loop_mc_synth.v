`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Synthesis harness of tension_loop_mc (hdl/synth/synth_mc.py): the loop's N channels with their
 * configuration and ADC inputs fed from a shift register (one pin; it stands for the register
 * file, which the boards' tops have), a tick every CLKS_PER_SAMPLE clocks as bowden_core makes
 * it, and every output folded into OUT_W pins through two register stages, so that synthesis
 * keeps all of the loop and the I/O fits any package. SINGLE 1 puts the single-channel
 * tension_loop (SNAPSHOT 0, the live configuration as here) in the same harness, as a baseline.
 */
module tension_loop_mc_synth #(
    parameter N = 2,                  // channels (SINGLE 0)
    parameter SINGLE = 0,             // 1: tension_loop instead of tension_loop_mc (N must be 1)
    parameter CLKS_PER_SAMPLE = 4800, // clocks per sample: 10 kHz at 48 MHz
    parameter OUT_W = 8               // output pins
) (
    input  wire             clk,
    input  wire             rst,
    input  wire             din,   // the configuration and ADC shift chain's input
    output wire [OUT_W-1:0] q      // every output of the loop, folded
);

// Inputs per channel: ADC valid and 5 flags and pulses, 10 16-bit fields, 2 15-bit fields, ADC
// data and 3 24-bit fields.
localparam IN_W = N * (6 + 10*16 + 2*15 + 4*24);
// Outputs per channel: u, t_in, tc_eff (16 each), integ (32), faults (4), 4 flags; out_valid,
// cfg_busy and the sample count.
localparam OUTS_W = N * (3*16 + 32 + 4 + 4) + 2 + 32;
localparam FOLD = (OUTS_W + OUT_W - 1) / OUT_W;  // output bits per pin

reg [IN_W-1:0] in_reg;
reg [12:0] tick_cnt_reg;
reg tick_reg;

always @(posedge clk) begin
    in_reg <= {in_reg[IN_W-2:0], din};
    tick_reg <= tick_cnt_reg == CLKS_PER_SAMPLE - 1;
    tick_cnt_reg <= (tick_cnt_reg == CLKS_PER_SAMPLE - 1) ? 13'd0 : tick_cnt_reg + 13'd1;
    if (rst) begin
        tick_cnt_reg <= 13'd0;
        tick_reg <= 1'b0;
    end
end

// The inputs, sliced off the chain.
wire [N-1:0]    adc_valid = in_reg[0*N +: N];
wire [N-1:0]    enable = in_reg[1*N +: N];
wire [N-1:0]    slew_en = in_reg[2*N +: N];
wire [N-1:0]    integ_reset = in_reg[3*N +: N];
wire [N-1:0]    fault_clear = in_reg[4*N +: N];
wire [N-1:0]    tc_wr = in_reg[5*N +: N];
localparam B16 = 6*N;
wire [N*16-1:0] tc = in_reg[B16 + 0*N*16 +: N*16];
wire [N*16-1:0] tc_min = in_reg[B16 + 1*N*16 +: N*16];
wire [N*16-1:0] kff = in_reg[B16 + 2*N*16 +: N*16];
wire [N*16-1:0] uff = in_reg[B16 + 3*N*16 +: N*16];
wire [N*16-1:0] kp = in_reg[B16 + 4*N*16 +: N*16];
wire [N*16-1:0] ki_ts = in_reg[B16 + 5*N*16 +: N*16];
wire [N*16-1:0] wdt_timeout = in_reg[B16 + 6*N*16 +: N*16];
wire [N*16-1:0] adc_gain = in_reg[B16 + 7*N*16 +: N*16];
wire [N*16-1:0] adc_stale = in_reg[B16 + 8*N*16 +: N*16];
wire [N*16-1:0] oc_timeout = in_reg[B16 + 9*N*16 +: N*16];
localparam B15 = B16 + 10*N*16;
wire [N*15-1:0] i_limit = in_reg[B15 +: N*15];
wire [N*15-1:0] slew = in_reg[B15 + N*15 +: N*15];
localparam B24 = B15 + 2*N*15;
wire [N*24-1:0] adc_data = in_reg[B24 +: N*24];
wire [N*24-1:0] adc_offset = in_reg[B24 + 1*N*24 +: N*24];
wire [N*24-1:0] adc_min = in_reg[B24 + 2*N*24 +: N*24];
wire [N*24-1:0] adc_max = in_reg[B24 + 3*N*24 +: N*24];

wire [N*16-1:0] u, t_in, tc_eff;
wire [N*32-1:0] integ;
wire [N*4-1:0]  faults;
wire [N-1:0]    out_en, saturated, wdt_ramp, grp_stop;
wire            out_valid, cfg_busy;
wire [31:0]     sample_count;

generate
    if (SINGLE != 0) begin : g_single
        tension_loop #(.SNAPSHOT(0)) loop (
            .clk(clk), .rst(rst), .tick(tick_reg),
            .adc_valid(adc_valid[0]), .adc_data(adc_data[23:0]),
            .enable(enable[0]), .slew_en(slew_en[0]), .integ_reset(integ_reset[0]),
            .fault_clear(fault_clear[0]), .tc_wr(tc_wr[0]), .tc(tc[15:0]), .tc_min(tc_min[15:0]),
            .kff(kff[15:0]), .uff(uff[15:0]), .kp(kp[15:0]), .ki_ts(ki_ts[15:0]),
            .i_limit(i_limit[14:0]), .slew(slew[14:0]), .wdt_timeout(wdt_timeout[15:0]),
            .adc_offset(adc_offset[23:0]), .adc_gain(adc_gain[15:0]), .adc_min(adc_min[23:0]),
            .adc_max(adc_max[23:0]), .adc_stale(adc_stale[15:0]), .oc_timeout(oc_timeout[15:0]),
            .cfg_busy(cfg_busy),
            .u(u[15:0]), .out_en(out_en[0]), .out_valid(out_valid), .saturated(saturated[0]),
            .wdt_ramp(wdt_ramp[0]), .faults(faults[3:0]), .t_in(t_in[15:0]),
            .integ(integ[31:0]), .tc_eff(tc_eff[15:0]), .sample_count(sample_count)
        );
        assign grp_stop = {N{1'b0}};
    end else begin : g_mc
        tension_loop_mc #(.N(N)) loop (
            .clk(clk), .rst(rst), .tick(tick_reg),
            .adc_valid(adc_valid), .adc_data(adc_data),
            .enable(enable), .slew_en(slew_en), .integ_reset(integ_reset),
            .fault_clear(fault_clear), .tc_wr(tc_wr), .tc(tc), .tc_min(tc_min),
            .kff(kff), .uff(uff), .kp(kp), .ki_ts(ki_ts), .i_limit(i_limit), .slew(slew),
            .wdt_timeout(wdt_timeout), .adc_offset(adc_offset), .adc_gain(adc_gain),
            .adc_min(adc_min), .adc_max(adc_max), .adc_stale(adc_stale),
            .oc_timeout(oc_timeout), .cfg_busy(cfg_busy),
            .u(u), .out_en(out_en), .out_valid(out_valid), .saturated(saturated),
            .wdt_ramp(wdt_ramp), .grp_stop(grp_stop), .faults(faults), .t_in(t_in),
            .integ(integ), .tc_eff(tc_eff), .sample_count(sample_count)
        );
    end
endgenerate

// Every output bit reaches a pin: registered, then XOR-folded into OUT_W pins, registered.
wire [FOLD*OUT_W-1:0] outs = {{(FOLD*OUT_W-OUTS_W){1'b0}}, u, t_in, tc_eff, integ, faults,
                              out_en, saturated, wdt_ramp, grp_stop, out_valid,
                              cfg_busy, sample_count};
reg [FOLD*OUT_W-1:0] outs_reg;
reg [OUT_W-1:0] q_reg;
integer k;
always @(posedge clk) begin
    outs_reg <= outs;
    for (k = 0; k < OUT_W; k = k + 1) q_reg[k] <= ^outs_reg[k*FOLD +: FOLD];
end

assign q = q_reg;

endmodule

`resetall
