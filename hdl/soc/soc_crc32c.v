`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * CRC-32C (Castagnoli; reflected polynomial 0x82F63B78, the bench protocol's frame check:
 * firmware/include/crc32c.h) for the firmware's frame encoder and receiver, a bit a clock.
 *
 * The firmware loads the register (load: the CRC so far, or 0xFFFFFFFF to begin), writes the
 * frame's bytes one by one (push), and reads the register back (state). A byte is taken least
 * significant bit first in the 8 clocks after its push, each clock
 *     crc = (crc >> 1) ^ (POLY if (crc ^ bit) & 1 else 0)
 * which is the table-driven step crc = (crc >> 8) ^ T[(crc ^ byte) & 0xFF] taken a bit at a time
 * (Ross N. Williams, "A Painless Guide to CRC Error Detection Algorithms", 1993, section 9: the
 * reflected shift register). 32 flip-flops with one look-up table each instead of the ~6 each a
 * byte-wide step needs, which the UP5K has no room for; the CPU's loops write a byte no faster
 * than every ~20 clocks.
 *
 * busy is high while a byte is being taken (at most 8 clocks after its push). The bus holds any
 * access to the unit while busy (bowden_soc.v), so a read always sees the whole byte and a push
 * or load never lands in the middle of one: a caller needs no polling and cannot lose a byte.
 */
module soc_crc32c (
    input  wire        clk,
    input  wire        rst,
    input  wire        load,       // set the register to load_value (ignored while busy)
    input  wire [31:0] load_value,
    input  wire        push,       // take byte_in over the next 8 clocks (ignored while busy)
    input  wire [7:0]  byte_in,
    output wire        busy,
    output wire [31:0] state       // the register (before the final XOR)
);

localparam [31:0] POLY = 32'h82F6_3B78;

reg [31:0] crc_reg;
reg [7:0]  bits_reg;  // the byte's bits still to take, next one in bit 0
reg [3:0]  left_reg;  // how many: 8 after a push, 0 when idle

wire feedback = crc_reg[0] ^ bits_reg[0];

assign busy = (left_reg != 4'd0);
assign state = crc_reg;

always @(posedge clk) begin
    if (busy) begin
        crc_reg <= {1'b0, crc_reg[31:1]} ^ (feedback ? POLY : 32'd0);
        bits_reg <= {1'b0, bits_reg[7:1]};
        left_reg <= left_reg - 4'd1;
    end else if (push) begin
        bits_reg <= byte_in;
        left_reg <= 4'd8;
    end else if (load) begin
        crc_reg <= load_value;
    end
    if (rst) begin
        crc_reg <= 32'hFFFF_FFFF;
        bits_reg <= 8'd0;
        left_reg <= 4'd0;
    end
end

endmodule

`resetall
