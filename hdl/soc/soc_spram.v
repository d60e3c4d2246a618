`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * 16384 x 32-bit memory of the iCE40 UP5K's single-port RAM: two SB_SPRAM256KA (16K x 16 each,
 * Lattice TN1314 / FPGA-TN-02022 "iCE40 SPRAM Usage Guide"), byte write enables mapped onto their
 * nibble masks, read data in the clock after the address, as soc_ram. The SPRAM has no
 * initial contents: the boot loader (firmware/soc/boot.S) copies the image into it from the flash.
 */
module soc_spram (
    input  wire        clk,
    input  wire        en,
    input  wire [3:0]  we,
    input  wire [13:0] addr,
    input  wire [31:0] wdata,
    output wire [31:0] rdata
);

SB_SPRAM256KA lo (
    .ADDRESS(addr), .DATAIN(wdata[15:0]), .MASKWREN({we[1], we[1], we[0], we[0]}),
    .WREN(|we[1:0]), .CHIPSELECT(en), .CLOCK(clk), .STANDBY(1'b0), .SLEEP(1'b0),
    .POWEROFF(1'b1), .DATAOUT(rdata[15:0])
);

SB_SPRAM256KA hi (
    .ADDRESS(addr), .DATAIN(wdata[31:16]), .MASKWREN({we[3], we[3], we[2], we[2]}),
    .WREN(|we[3:2]), .CHIPSELECT(en), .CLOCK(clk), .STANDBY(1'b0), .SLEEP(1'b0),
    .POWEROFF(1'b1), .DATAOUT(rdata[31:16])
);

endmodule

`resetall
