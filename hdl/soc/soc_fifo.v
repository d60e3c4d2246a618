`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Byte FIFO for the UART: 2^AW entries in an inferred synchronous RAM (one iCE40 EBR / ECP5
 * DP16KD at AW 9), first word fall-through: `q` is the oldest byte whenever `count` is nonzero.
 * The RAM is read every clock at the head the clock's pop leaves; a byte written into that very
 * entry on the same clock is passed around the RAM (the RAM returns the old contents then).
 * A push into a full FIFO is dropped (the caller counts it).
 */
module soc_fifo #(
    parameter AW = 9
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          push,
    input  wire [7:0]    din,
    input  wire          pop,
    output wire [7:0]    q,
    output reg  [AW:0]   count,
    output wire          full
);

localparam [AW:0] DEPTH = {1'b1, {AW{1'b0}}};

reg [7:0]    mem [0:(1 << AW) - 1];
// Head and tail with one bit above the address: equal when empty, apart by 2^AW when full; the
// count is their difference (no counter of its own).
reg [AW:0]   head_reg, tail_reg;
reg [7:0]    mem_q_reg, bypass_reg;
reg          bypass_sel_reg;

always @* count = tail_reg - head_reg;
assign full = (tail_reg == (head_reg ^ DEPTH));
wire empty = (tail_reg == head_reg);
wire do_push = push && !full;
wire do_pop = pop && !empty;
wire [AW:0] head_next = head_reg + {{AW{1'b0}}, do_pop};

always @(posedge clk) begin
    if (do_push) begin
        mem[tail_reg[AW-1:0]] <= din;
    end
    mem_q_reg <= mem[head_next[AW-1:0]];
    bypass_reg <= din;
    bypass_sel_reg <= do_push && (tail_reg[AW-1:0] == head_next[AW-1:0]);
end

assign q = bypass_sel_reg ? bypass_reg : mem_q_reg;

always @(posedge clk) begin
    head_reg <= head_next;
    if (do_push) begin
        tail_reg <= tail_reg + 1'b1;
    end
    if (rst) begin
        head_reg <= {(AW + 1){1'b0}};
        tail_reg <= {(AW + 1){1'b0}};
    end
end

endmodule

`resetall
