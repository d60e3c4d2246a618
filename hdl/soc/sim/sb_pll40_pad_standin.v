`timescale 1ns / 1ps
`default_nettype none

/*
 * Simulation stand-in for the iCE40's SB_PLL40_PAD in the gate-level simulation of the UP5K
 * netlist (yosys's cells_sim.v declares it as an empty black box). A zero-delay simulation has no
 * analog PLL, so the testbench drives PACKAGEPIN at the PLL's output frequency and the stand-in
 * passes it through to PLLOUTGLOBAL/PLLOUTCORE. What the stand-in does check is the setting the
 * netlist gives the PLL: with the board's F_IN_HZ, the output F_IN * (DIVF + 1) / (DIVR + 1) /
 * 2^DIVQ must be F_OUT_HZ, the VCO within 533..1066 MHz and the PFD within 10..133 MHz (iCE40
 * sysCLOCK PLL design guide, TN1251), else the simulation stops at elaboration. LOCK rises
 * LOCK_CLKS output clocks after RESETB is high (the part's lock time is not modelled).
 * Not synthesizable; not part of the RTL.
 */
module SB_PLL40_PAD #(
    parameter FEEDBACK_PATH = "SIMPLE",
    parameter DELAY_ADJUSTMENT_MODE_FEEDBACK = "FIXED",
    parameter DELAY_ADJUSTMENT_MODE_RELATIVE = "FIXED",
    parameter SHIFTREG_DIV_MODE = 1'b0,
    parameter FDA_FEEDBACK = 4'b0000,
    parameter FDA_RELATIVE = 4'b0000,
    parameter PLLOUT_SELECT = "GENCLK",
    parameter [3:0] DIVR = 4'b0000,
    parameter [6:0] DIVF = 7'b0000000,
    parameter [2:0] DIVQ = 3'b000,
    parameter FILTER_RANGE = 3'b000,
    parameter ENABLE_ICEGATE = 1'b0,
    parameter TEST_MODE = 1'b0,
    parameter EXTERNAL_DIVIDE_FACTOR = 1
) (
    input  wire       PACKAGEPIN,
    output wire       PLLOUTCORE,
    output wire       PLLOUTGLOBAL,
    input  wire       EXTFEEDBACK,
    input  wire [7:0] DYNAMICDELAY,
    output wire       LOCK,
    input  wire       BYPASS,
    input  wire       RESETB,
    input  wire       LATCHINPUTVALUE,
    output wire       SDO,
    input  wire       SDI,
    input  wire       SCLK
);

localparam [63:0] F_IN_HZ = 64'd12000000;   // the iCEBreaker's oscillator (pin 35)
localparam [63:0] F_OUT_HZ = 64'd24000000;  // the SoC's clock (ice40_up5k_soc_top CLK_HZ)
localparam [4:0]  LOCK_CLKS = 5'd16;

localparam [63:0] PFD_HZ = F_IN_HZ / (64'd1 + {60'd0, DIVR});
localparam [63:0] VCO_HZ = PFD_HZ * (64'd1 + {57'd0, DIVF});
localparam [63:0] OUT_HZ = VCO_HZ >> DIVQ;

initial begin
    if (FEEDBACK_PATH != "SIMPLE") $fatal(1, "SB_PLL40_PAD stand-in: only FEEDBACK_PATH SIMPLE");
    if (OUT_HZ != F_OUT_HZ) $fatal(1, "SB_PLL40_PAD: output %0d Hz, not %0d", OUT_HZ, F_OUT_HZ);
    if (VCO_HZ < 533000000 || VCO_HZ > 1066000000) $fatal(1, "SB_PLL40_PAD: VCO %0d Hz", VCO_HZ);
    if (PFD_HZ < 10000000 || PFD_HZ > 133000000) $fatal(1, "SB_PLL40_PAD: PFD %0d Hz", PFD_HZ);
end

reg [4:0] count;

initial count = 5'd0;  // flip-flops start at zero, as the netlist's do

always @(posedge PACKAGEPIN or negedge RESETB) begin
    if (!RESETB) begin
        count <= 5'd0;
    end else if (count != LOCK_CLKS) begin
        count <= count + 5'd1;
    end
end

assign PLLOUTCORE = PACKAGEPIN;  // BYPASS or not: the pin is the output clock here
assign PLLOUTGLOBAL = PLLOUTCORE;
assign LOCK = RESETB && count == LOCK_CLKS;
assign SDO = 1'b0;

endmodule
