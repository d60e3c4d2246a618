`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Formal stand-in for mul_s16 (the .sby files put it in place of the loop's two multipliers with
 * chtype): the product is a free value in the range of a 16 x 16 signed product (|p| <= 2^30),
 * new every clock. The loop's safety properties (clamps, faults,
 * watchdog) must hold for any product, so the proofs do not pay for the multipliers; the
 * exact products are checked by the simulations against the bit-exact model.
 */
module mul_s16_free (
    input  wire               clk,

    input  wire signed [15:0] a,
    input  wire signed [15:0] b,
    output wire signed [31:0] p
);

(* anyseq *) reg signed [31:0] p_any;

always @* assume(p_any >= -32'sd1073741824 && p_any <= 32'sd1073741824);

assign p = p_any;

wire unused = &{1'b0, clk, a, b};

endmodule

`resetall
