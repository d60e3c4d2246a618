`timescale 1ns / 1ps
`default_nettype none
// Port-only stand-in of the ECP5 user access to the configuration clock pin, so that Verilator can
// lint the ECP5 SoC top (synthesis uses the real primitive).
module USRMCLK (
    input wire USRMCLKI,
    input wire USRMCLKTS
);
wire unused = &{1'b0, USRMCLKI, USRMCLKTS};
endmodule
