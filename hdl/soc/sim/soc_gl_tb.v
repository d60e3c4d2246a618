`timescale 1ns / 1ps
`default_nettype none

/*
 * Gate-level simulation top: the UP5K board top as yosys synthesized it (netlist.v of
 * make bitstream, cells from yosys's ice40/cells_sim.v) with the SPI flash model holding the
 * image at 0x080000. The PLL is an analog block that yosys's cell library leaves as a black box:
 * pll_ideal.v stands in for it (its output is the pad's clock, locked), so the testbench drives
 * the pad with the PLL's 24 MHz. Not part of the RTL.
 */
module soc_gl_tb #(
    parameter FLASH_INIT = ""
) (
    input  wire clk,
    input  wire uart_rx,
    output wire uart_tx,
    output wire adc_sclk,
    output wire adc_cs_n,
    output wire adc_din,
    input  wire adc_dout,
    input  wire adc_drdy_n,
    output wire drive_pwm,
    output wire drive_enable,
    output wire led_fault,
    output wire led_run,
    output wire flash_cs_n
);

wire flash_sck, flash_mosi, flash_miso;

ice40_up5k_soc_top top (
    .clk_12mhz(clk), .uart_rx(uart_rx), .uart_tx(uart_tx),
    .flash_sck(flash_sck), .flash_cs_n(flash_cs_n), .flash_mosi(flash_mosi),
    .flash_miso(flash_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n), .drive_pwm(drive_pwm), .drive_enable(drive_enable),
    .led_fault(led_fault), .led_run(led_run)
);

spi_flash_model #(.INIT_FILE(FLASH_INIT)) flash (
    .sck(flash_sck), .cs_n(flash_cs_n), .mosi(flash_mosi), .miso(flash_miso)
);

endmodule
