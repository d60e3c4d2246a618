`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Co-simulation top of the antagonistic pair: bowden_core_mc with two cables in one safety
 * group, plus the one-clock ADC strobes of cosim_top.v (a toggle bit per cable), so that the
 * harness hands over a conversion with a single signal write. Both toggles flip together for
 * one conversion of both cables (one ADS131M04, the board's part); one alone when only that
 * cable's samples are new (its samples stopped on the other: a stale fault on one cable).
 *
 * The harness's bus master reaches cable k's registers at bank k (byte address k * 0x100 +
 * the single core's address, regmap.bank_addr / BOWDEN_REG_AT). The ADC word carries both
 * cables' T_in codes; the far-end channels (T_OUT) are not driven: the harness hands the far-end codes to the
 * firmware directly, as the single-cable engines do.
 * The PWM outputs are left unobserved; grp_stop is the loop's group stop, which no register
 * shows, taken out for the record (a hierarchical reference: simulation only).
 */
module cosim_pair_top #(
    parameter CLKS_PER_SAMPLE = 128  // clocks per sample tick (>= 1 + 15 N = 31, bowden_core_mc)
) (
    input  wire        clk,
    input  wire        rst,

    /*
     * AXI4-Lite slave (passed to bowden_core_mc): bank k at k << 8
     */
    input  wire [8:0]  s_axil_awaddr,
    input  wire [2:0]  s_axil_awprot,
    input  wire        s_axil_awvalid,
    output wire        s_axil_awready,
    input  wire [31:0] s_axil_wdata,
    input  wire [3:0]  s_axil_wstrb,
    input  wire        s_axil_wvalid,
    output wire        s_axil_wready,
    output wire [1:0]  s_axil_bresp,
    output wire        s_axil_bvalid,
    input  wire        s_axil_bready,
    input  wire [8:0]  s_axil_araddr,
    input  wire [2:0]  s_axil_arprot,
    input  wire        s_axil_arvalid,
    output wire        s_axil_arready,
    output wire [31:0] s_axil_rdata,
    output wire [1:0]  s_axil_rresp,
    output wire        s_axil_rvalid,
    input  wire        s_axil_rready,

    /*
     * ADC conversions from the harness
     */
    input  wire [49:0] adc_word,     // {cable 1's toggle, cable 0's toggle (each flips once per
                                     //  new sample of that cable), cable 1's T_in code,
                                     //  cable 0's T_in code}, signed 24-bit codes

    /*
     * Drive commands and status, cable k in bits [k*W +: W]
     */
    output wire [31:0] cmd_current,  // Q3.12 A
    output wire [1:0]  cmd_enable,
    output wire        cmd_valid,
    output wire [1:0]  fault,
    output wire [1:0]  grp_stop,
    output wire        sample_tick
);

localparam N = 2;

reg [N-1:0] adc_toggle_reg;

always @(posedge clk) begin
    adc_toggle_reg <= adc_word[49:48];
    if (rst) begin
        adc_toggle_reg <= {N{1'b0}};
    end
end

wire [N-1:0] adc_valid = adc_word[49:48] ^ adc_toggle_reg;
// ADC channel 2k is cable k's T_in, 2k + 1 its T_out (not driven here).
wire [2*N*24-1:0] adc_ch_data = {24'd0, adc_word[47:24], 24'd0, adc_word[23:0]};
wire [N-1:0] pwm_unused;

bowden_core_mc #(.N(N), .CLKS_PER_SAMPLE(CLKS_PER_SAMPLE)) core (
    .clk(clk), .rst(rst),
    .s_axil_awaddr(s_axil_awaddr), .s_axil_awprot(s_axil_awprot),
    .s_axil_awvalid(s_axil_awvalid), .s_axil_awready(s_axil_awready),
    .s_axil_wdata(s_axil_wdata), .s_axil_wstrb(s_axil_wstrb),
    .s_axil_wvalid(s_axil_wvalid), .s_axil_wready(s_axil_wready),
    .s_axil_bresp(s_axil_bresp), .s_axil_bvalid(s_axil_bvalid), .s_axil_bready(s_axil_bready),
    .s_axil_araddr(s_axil_araddr), .s_axil_arprot(s_axil_arprot),
    .s_axil_arvalid(s_axil_arvalid), .s_axil_arready(s_axil_arready),
    .s_axil_rdata(s_axil_rdata), .s_axil_rresp(s_axil_rresp),
    .s_axil_rvalid(s_axil_rvalid), .s_axil_rready(s_axil_rready),
    .adc_valid(adc_valid), .adc_ch_data(adc_ch_data),
    .adc_drdy_lost(1'b0), .adc_crc_err(1'b0),
    .cmd_current(cmd_current), .cmd_enable(cmd_enable), .cmd_valid(cmd_valid),
    .fault(fault), .pwm(pwm_unused), .sample_tick(sample_tick)
);

assign grp_stop = core.grp_stop;  // the loop's, whichever form (bowden_core_mc's SEQ)

endmodule

`resetall
