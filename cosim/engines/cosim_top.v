`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Co-simulation top: bowden_core as the board tops use it, plus a one-clock ADC strobe made
 * from a toggle bit, so that the Python harness hands over one ADC sample per FPGA sample with a
 * single signal write (no second wake-up per sample to drop adc_valid again).
 *
 * The harness writes adc_word = {toggle, code} with the toggle flipped, between two clock edges;
 * adc_valid is high from then until the next rising edge, which captures the sample: exactly one
 * clock edge sees it.
 * The PWM output is left unobserved: the co-simulation takes the command word (the PWM has its
 * own testbench).
 */
module cosim_top #(
    parameter CLKS_PER_SAMPLE = 10  // clocks per sample tick (>= 9, bowden_core)
) (
    input  wire        clk,
    input  wire        rst,

    /*
     * AXI4-Lite slave (passed to bowden_core)
     */
    input  wire [7:0]  s_axil_awaddr,
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
    input  wire [7:0]  s_axil_araddr,
    input  wire [2:0]  s_axil_arprot,
    input  wire        s_axil_arvalid,
    output wire        s_axil_arready,
    output wire [31:0] s_axil_rdata,
    output wire [1:0]  s_axil_rresp,
    output wire        s_axil_rvalid,
    input  wire        s_axil_rready,

    /*
     * ADC samples from the harness
     */
    input  wire [24:0] adc_word,     // {toggle (flips once per new sample), signed 24-bit code}

    /*
     * Drive command and status
     */
    output wire [15:0] cmd_current,  // Q3.12 A
    output wire        cmd_enable,
    output wire        cmd_valid,
    output wire        fault,
    output wire        sample_tick
);

reg adc_toggle_reg;

always @(posedge clk) begin
    adc_toggle_reg <= adc_word[24];
    if (rst) begin
        adc_toggle_reg <= 1'b0;
    end
end

wire adc_valid = adc_word[24] ^ adc_toggle_reg;
wire pwm_unused;

bowden_core #(.CLKS_PER_SAMPLE(CLKS_PER_SAMPLE)) core (
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
    .adc_valid(adc_valid), .adc_data(adc_word[23:0]),
    // The harness hands over T_in only (T_out is recorded from the plant directly).
    .adc_aux_data(24'd0), .adc_drdy_lost(1'b0), .adc_crc_err(1'b0),
    .cmd_current(cmd_current), .cmd_enable(cmd_enable), .cmd_valid(cmd_valid),
    .fault(fault), .pwm(pwm_unused), .sample_tick(sample_tick)
);

endmodule

`resetall
