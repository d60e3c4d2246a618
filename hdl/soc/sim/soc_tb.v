`timescale 1ns / 1ps
`default_nettype none

/*
 * Simulation top of bowden_soc: the SoC with its SPI flash (spi_flash_model); the UART, the ADC
 * pins, the drive and a reset are the testbench's. Not part of the RTL.
 */
module soc_tb #(
    parameter CHANNELS = 1,
    parameter CLK_HZ = 24000000,
    parameter ROM_INIT = "",
    parameter FLASH_INIT = "",
    parameter CPU_FAST = 1,
    parameter CPU_MUL = 2,
    parameter MEM_SPRAM = 0,
    parameter CFG_RAM = 0,
    parameter SEQ = 0,
    parameter BOOT_FLASH = 0,
    parameter BOOT_INIT = "",
    parameter ROM_WORDS = 16384,
    parameter RAM_WORDS = 4096,
    parameter ADC_WAIT_CLKS = 8192
) (
    input  wire clk,
    input  wire rst,
    input  wire uart_rx,
    output wire uart_tx,
    output wire adc_sclk,
    output wire adc_cs_n,
    output wire adc_din,
    input  wire adc_dout,
    input  wire adc_drdy_n,
    output wire drive_pwm,
    output wire drive_enable,
    output wire [CHANNELS-1:0] drive_pwm_all,    // every cable's (the co-simulation's)
    output wire [CHANNELS-1:0] drive_enable_all,
    output wire fault,
    output wire cpu_trap,
    output wire sample_tick,
    output wire flash_cs_n,
    output wire boot_done
);

wire flash_sck, flash_mosi, flash_miso;
// Cable 0's drive (bank 0) on drive_pwm and drive_enable, as the one-cable tests observe it;
// every cable's on the _all ports.
wire [CHANNELS-1:0] pwm_all, enable_all;
assign drive_pwm = pwm_all[0];
assign drive_enable = enable_all[0];
assign drive_pwm_all = pwm_all;
assign drive_enable_all = enable_all;

bowden_soc #(
    .CHANNELS(CHANNELS), .CLK_HZ(CLK_HZ), .ROM_INIT(ROM_INIT), .CPU_FAST(CPU_FAST), .CPU_MUL(CPU_MUL), .ADC_WAIT_CLKS(ADC_WAIT_CLKS),
    .MEM_SPRAM(MEM_SPRAM), .BOOT_FLASH(BOOT_FLASH), .ROM_WORDS(ROM_WORDS), .RAM_WORDS(RAM_WORDS),
    .BOOT_INIT(BOOT_INIT), .CFG_RAM(CFG_RAM), .SEQ(SEQ)
) soc (
    .clk(clk), .rst(rst), .uart_rx(uart_rx), .uart_tx(uart_tx),
    .flash_sck(flash_sck), .flash_cs_n(flash_cs_n), .flash_mosi(flash_mosi),
    .flash_miso(flash_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n), .drive_pwm(pwm_all), .drive_enable(enable_all),
    .fault(fault), .cpu_trap(cpu_trap), .boot_done(boot_done),
    .sample_tick(sample_tick)
);

spi_flash_model #(.INIT_FILE(FLASH_INIT)) flash (
    .sck(flash_sck), .cs_n(flash_cs_n), .mosi(flash_mosi), .miso(flash_miso)
);

endmodule
