`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Formal stand-in for mul_s16 in the isolation proof (tension_loop_mc_iso.sby puts it in place
 * of the loop's two multipliers with chtype): the "product" is the pair of operands itself, with
 * mul_s16's two clocks of registers. It is a function of the operands that loses nothing, so
 * any path by which one channel's data could reach another's through the shared multipliers
 * (their operand or product registers included) shows in it, without the solver paying for a
 * real 16 x 16 product in two copies of the design.
 */
module mul_s16_tag (
    input  wire               clk,

    input  wire signed [15:0] a,
    input  wire signed [15:0] b,
    output wire signed [31:0] p
);

reg [15:0] a_reg;
reg [15:0] b_reg;
reg [31:0] p_reg;

always @(posedge clk) begin
    a_reg <= a;
    b_reg <= b;
    p_reg <= {a_reg, b_reg};
end

assign p = p_reg;

endmodule

`resetall
