`timescale 1ns / 1ps
`default_nettype none
// Port-only stand-in of the iCE40 UP5K SPRAM primitive, so that Verilator can lint soc_spram and
// the UP5K SoC top (synthesis uses the real primitive; simulations use yosys's cell model).
module SB_SPRAM256KA (
    input  wire [13:0] ADDRESS,
    input  wire [15:0] DATAIN,
    input  wire [3:0]  MASKWREN,
    input  wire        WREN,
    input  wire        CHIPSELECT,
    input  wire        CLOCK,
    input  wire        STANDBY,
    input  wire        SLEEP,
    input  wire        POWEROFF,
    output wire [15:0] DATAOUT
);
assign DATAOUT = 16'd0;
wire unused = &{1'b0, ADDRESS, DATAIN, MASKWREN, WREN, CHIPSELECT, CLOCK, STANDBY, SLEEP, POWEROFF};
endmodule
