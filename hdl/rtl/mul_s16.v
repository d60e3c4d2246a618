`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Registered signed 16 x 16 -> 32 multiplier, two clocks from operands to product.
 *
 * Operands are registered on the way in and the product on the way out, with no reset and no
 * enable, so that yosys packs both register stages into one DSP (iCE40 SB_MAC16 with its input
 * and output pipeline registers, ECP5 MULT18X18D with REG_INPUT and REG_OUTPUT). nextpnr only
 * times register-to-register paths through the iCE40 DSP when those registers are inside it.
 */
module mul_s16 (
    input  wire               clk,

    input  wire signed [15:0] a,  // operand, captured every clock
    input  wire signed [15:0] b,  // operand, captured every clock
    output wire signed [31:0] p   // a * b of the operands two clocks earlier (exact)
);

reg signed [15:0] a_reg;
reg signed [15:0] b_reg;
reg signed [31:0] p_reg;

always @(posedge clk) begin
    a_reg <= a;
    b_reg <= b;
    // 16 x 16 signed fits 32 bits exactly: |a*b| <= 2^30.
    p_reg <= a_reg * b_reg;
end

assign p = p_reg;

endmodule

`resetall
