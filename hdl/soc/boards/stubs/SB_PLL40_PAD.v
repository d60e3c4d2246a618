`timescale 1ns / 1ps
`default_nettype none
// Port-only stand-in of the iCE40 PLL fed from its pad, so that Verilator can lint the UP5K SoC
// top (synthesis uses the real primitive).
// The parameters configure the real PLL; the stand-in only has to accept them.
/* verilator lint_off UNUSEDPARAM */
module SB_PLL40_PAD #(
    parameter FEEDBACK_PATH = "SIMPLE",
    parameter [3:0] DIVR = 4'd0,
    parameter [6:0] DIVF = 7'd0,
    parameter [2:0] DIVQ = 3'd0,
    parameter [2:0] FILTER_RANGE = 3'd0
) (
    input  wire PACKAGEPIN,
    output wire PLLOUTCORE,
    output wire PLLOUTGLOBAL,
    output wire LOCK,
    input  wire RESETB,
    input  wire BYPASS
);
assign PLLOUTCORE = PACKAGEPIN;
assign PLLOUTGLOBAL = PACKAGEPIN;
assign LOCK = RESETB;
wire unused = &{1'b0, BYPASS};
endmodule
