`timescale 1ns / 1ps
`default_nettype none

/*
 * Gate-level simulation top: yosys's synthesized netlist of the iCEBreaker top
 * (ice40_up5k_soc_top, with its cells from yosys's ice40 cells_sim.v and the PLL stand-in
 * sb_pll40_pad_standin.v) and the board's SPI flash (spi_flash_model, holding the image). clk
 * is the PLL's output clock (the stand-in passes the pin through). The UART, the ADC pins and
 * the drive of cable 0 are the testbench's (the netlist's second cable is left alone, as the
 * firmware drives bank 0). Not part of the RTL.
 */
module soc_gate_tb #(
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
wire [1:0] pwm_all, enable_all;  // the board's two cables (ice40_up5k_soc_top's CHANNELS)
assign drive_pwm = pwm_all[0];
assign drive_enable = enable_all[0];

ice40_up5k_soc_top board (
    .clk_12mhz(clk), .uart_rx(uart_rx), .uart_tx(uart_tx),
    .flash_sck(flash_sck), .flash_cs_n(flash_cs_n), .flash_mosi(flash_mosi),
    .flash_miso(flash_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n), .drive_pwm(pwm_all), .drive_enable(enable_all),
    .led_fault(led_fault), .led_run(led_run)
);

spi_flash_model #(.INIT_FILE(FLASH_INIT)) flash (
    .sck(flash_sck), .cs_n(flash_cs_n), .mosi(flash_mosi), .miso(flash_miso)
);

endmodule
