`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * The safety groups' wiring of the multi-channel loops (tension_loop_mc, tension_loop_seq): for
 * each channel k, the OR of a W-bit word of every channel of k's group (GROUP: a group id of
 * GROUP_W bits a channel, fixed, so this is wiring), k's own word included when SELF is 1.
 * tension_loop_mc and tension_loop_seq take their group stop from the other channels' FAULT
 * words (W 4, SELF 0); tension_loop_seq's guard, a fault the tick does not clear on any channel
 * of the group (W 1, SELF 1).
 */
module group_or #(
    parameter N = 2,
    parameter GROUP_W = 4,
    parameter [N*GROUP_W-1:0] GROUP = {N*GROUP_W{1'b0}},
    parameter W = 4,
    parameter SELF = 0
) (
    input  wire [N*W-1:0] x,
    output wire [N-1:0]   y
);

genvar gk, gj;
generate
    for (gk = 0; gk < N; gk = gk + 1) begin : g_grp
        wire [N-1:0] member_x;
        for (gj = 0; gj < N; gj = gj + 1) begin : g_member
            if ((SELF != 0 || gj != gk) &&
                GROUP[gj*GROUP_W +: GROUP_W] == GROUP[gk*GROUP_W +: GROUP_W]) begin : g_same
                assign member_x[gj] = |x[gj*W +: W];
            end else begin : g_other
                assign member_x[gj] = 1'b0;
            end
        end
        assign y[gk] = |member_x;
    end
endgenerate

endmodule

`resetall
