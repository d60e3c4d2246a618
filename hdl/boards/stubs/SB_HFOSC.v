`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Port-only stand-in for the iCE40 SB_HFOSC primitive, so that Verilator can lint the board
 * top. Synthesis uses yosys's own cell library and never reads this file.
 */
// The parameter configures the real oscillator; the stand-in only has to accept it.
/* verilator lint_off UNUSEDPARAM */
module SB_HFOSC #(
    parameter CLKHF_DIV = "0b00"  // 48 MHz / 2^n
) (
/* verilator lint_on UNUSEDPARAM */
    input  wire CLKHFPU,
    input  wire CLKHFEN,
    output wire CLKHF
);

assign CLKHF = CLKHFPU & CLKHFEN;

endmodule

`resetall
