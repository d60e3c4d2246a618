`timescale 1ns / 1ps
`default_nettype none

/*
 * Simulation model of a 25-series SPI NOR flash (the commands firmware/soc/spi_flash.h uses:
 * 0x03 read, 0x06/0x04 write enable/disable, 0x05 status, 0x20 4-KiB sector erase, 0x02 page
 * program within a 256-byte page, 0xAB release from power-down), mode 0, 2^AW bytes (addresses
 * wrap). Programming clears bits only (NOR). After an erase or a program the status word's busy
 * bit stays set for BUSY_POLLS status reads; commands other than the status read are ignored
 * while busy, as on the part. The array survives a reset of the SoC (a power cycle of the
 * board keeps the flash), and INIT_FILE ($readmemh, one byte a line) preloads it.
 * Not synthesizable; not part of the RTL.
 */
module spi_flash_model #(
    parameter AW = 21,
    parameter INIT_FILE = "",
    parameter BUSY_POLLS = 3
) (
    input  wire sck,
    input  wire cs_n,
    input  wire mosi,
    output reg  miso
);

// public: the full-system co-simulation (cosim/bench/emulate/soc) loads and saves the array and
// watches the counters of erases and programs.
reg [7:0]  mem [0:(1 << AW) - 1] /*verilator public_flat_rw*/;
reg [7:0]  cmd;
reg [7:0]  shift;
reg [23:0] addr;
reg [31:0] nbits;
reg        wel;
integer    busy /*verilator public_flat_rd*/;
integer    i;
integer    erases /*verilator public_flat_rd*/;
integer    programs /*verilator public_flat_rd*/;

initial begin
    for (i = 0; i < (1 << AW); i = i + 1) mem[i] = 8'hFF;
    if (INIT_FILE != "") $readmemh(INIT_FILE, mem);
    nbits = 0;
    wel = 1'b0;
    busy = 0;
    miso = 1'b0;
    erases = 0;
    programs = 0;
end

wire [AW-1:0] a = addr[AW-1:0];
wire [31:0]   rd_off = (nbits - 32'd32) >> 3;
wire [31:0]   rd_bit = (nbits - 32'd32) & 32'd7;

always @(posedge sck or posedge cs_n) begin
    if (cs_n) begin
        if (nbits >= 8) begin
            if (cmd == 8'h05 && nbits >= 16 && busy > 0) begin
                busy = busy - 1;
            end else if (busy == 0) begin
                case (cmd)
                    8'h06: wel = 1'b1;
                    8'h04: wel = 1'b0;
                    8'h20: if (wel && nbits == 32) begin
                        for (i = 0; i < 4096; i = i + 1)
                            mem[{a[AW-1:12], i[11:0]}] = 8'hFF;
                        busy = BUSY_POLLS;
                        wel = 1'b0;
                        erases = erases + 1;
                    end
                    8'h02: if (wel && nbits >= 40) begin
                        busy = BUSY_POLLS;
                        wel = 1'b0;
                        programs = programs + 1;
                    end
                    default: ;
                endcase
            end
        end
        nbits = 0;
    end else begin
        shift = {shift[6:0], mosi};
        nbits = nbits + 1;
        if (nbits == 8) cmd = shift;
        if (nbits == 16) addr[23:16] = shift;
        if (nbits == 24) addr[15:8] = shift;
        if (nbits == 32) addr[7:0] = shift;
        // page program: each whole data byte lands (bits cleared only), wrapping in its page
        if (cmd == 8'h02 && wel && busy == 0 && nbits > 32 && nbits % 8 == 0) begin
            mem[{a[AW-1:8], a[7:0] + 8'((nbits - 40) / 8)}] =
                mem[{a[AW-1:8], a[7:0] + 8'((nbits - 40) / 8)}] & shift;
        end
    end
end

// Output: the bit for the next rising edge, on the falling edge (mode 0).
always @(negedge sck or negedge cs_n) begin
    if (nbits >= 32 && cmd == 8'h03) begin
        miso <= mem[a + rd_off[AW-1:0]][3'd7 - rd_bit[2:0]];
    end else if (nbits >= 8 && cmd == 8'h05) begin
        miso <= (busy > 0) && ((7 - (nbits - 8) % 8) == 0) ? 1'b1 :
                ((7 - (nbits - 8) % 8) == 1) ? wel : 1'b0;
    end else begin
        miso <= 1'b0;
    end
end

endmodule
