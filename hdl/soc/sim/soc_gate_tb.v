`timescale 1ns / 1ps
`default_nettype none

/*
 * Gate-level simulation top: yosys's synthesized netlist of the iCEBreaker top
 * (ice40_up5k_soc_top, with its cells from yosys's ice40 cells_sim.v and the PLL stand-in
 * sb_pll40_pad_standin.v) and the board's SPI flash (spi_flash_model, holding the image). clk
 * is the PLL's output clock (the stand-in passes the pin through). The UART, the ADC pins and
 * the drives of both cables (the board's pins; cable k's in bit k) are the testbench's. Not part
 * of the RTL.
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
    output wire [1:0] drive_pwm,     // ice40_up5k_soc_top's DRIVES: the pins of both cables
    output wire [1:0] drive_enable,
    output wire led_fault,
    output wire led_run,
    output wire flash_cs_n
);

wire flash_sck, flash_mosi, flash_miso;

ice40_up5k_soc_top board (
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
