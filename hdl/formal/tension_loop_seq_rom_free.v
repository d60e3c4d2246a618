`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Formal stand-in for tension_loop_seq_rom (tension_loop_seq.sby puts it in place of the
 * program's ROM with chtype): a free 40-bit word every clock and a free phase-1 entry, so the
 * properties proven with it hold for any program the ROM could hold (and for any sequence of
 * words, which no ROM can exceed).
 */
module tension_loop_seq_rom_free (
    input  wire        clk,
    input  wire [8:0]  addr,
    output wire [39:0] data,
    output wire [8:0]  entry1
);

(* anyseq *) reg [39:0] data_any;
(* anyconst *) reg [8:0] entry1_any;

assign data = data_any;
assign entry1 = entry1_any;

wire unused = &{1'b0, clk, addr};

endmodule

`resetall
