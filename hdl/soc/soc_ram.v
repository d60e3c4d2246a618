`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Word memory of the SoC, one port, byte write enables, read in the clock after the address:
 * inferred block RAM (iCE40 EBR, ECP5 DP16KD), initialised from INIT_FILE ($readmemh, one 32-bit
 * word per line) when one is given. The UP5K's memories are its SPRAMs instead (soc_spram.v):
 * its 15 KiB of EBR hold neither the image nor the data.
 */
module soc_ram #(
    parameter WORDS = 8192,
    parameter INIT_FILE = ""
) (
    input  wire                     clk,
    input  wire                     en,
    input  wire [3:0]               we,
    input  wire [$clog2(WORDS)-1:0] addr,
    input  wire [31:0]              wdata,
    output reg  [31:0]              rdata
);

// Block RAM even when small and never written (the UP5K's boot loader): left to itself yosys
// makes a read-only memory of a few words out of LUTs, which the UP5K has none to spare for.
(* ram_style = "block" *) reg [31:0] mem [0:WORDS-1];

generate
    if (INIT_FILE != "") begin : g_init
        initial $readmemh(INIT_FILE, mem);
    end
endgenerate

always @(posedge clk) begin
    if (en) begin
        if (we[0]) mem[addr][7:0] <= wdata[7:0];
        if (we[1]) mem[addr][15:8] <= wdata[15:8];
        if (we[2]) mem[addr][23:16] <= wdata[23:16];
        if (we[3]) mem[addr][31:24] <= wdata[31:24];
        rdata <= mem[addr];
    end
end

endmodule

`resetall
