`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * ULX3S (LFE5U-25F) top of bowden_soc at the board's 25 MHz oscillator, no PLL: 25 MHz is an
 * exact multiple of the loop's 10 kHz, the PWM's 5 kHz and the firmware's 1 kHz, and the UART's
 * 921600 baud is 27 clocks a bit (0.5 % off). The image is in block RAM ($readmemh at synthesis);
 * the settings live in the configuration flash at 0x100000, whose clock pin is reached through
 * USRMCLK (it is the configuration clock). UART on the FT231X (FPGA TX to its RXD on L4, RX from
 * its TXD on M1); the ADS131M0x (an ADS131M08 for four cables) and the ESCONs on the GPIO header
 * J1: the converter and cable 0 as ecp5_25f_top, cables 1 to 3 on GP6/GN6 to GP8/GN8.
 */
module ecp5_25f_soc_top #(
    parameter DRIVES = 4,             // the cables ecp5_25f_soc.lpf has pins for (do not set)
    parameter CHANNELS = 4,           // cables driven (the board table's), 1 .. DRIVES
    parameter ROM_INIT = "bowden_fw.hex"
) (
    input  wire clk_25mhz,
    input  wire ftdi_txd,    // FPGA receives
    output wire ftdi_rxd,    // FPGA transmits
    output wire flash_csn,
    output wire flash_mosi,
    input  wire flash_miso,
    output wire flash_holdn,
    output wire flash_wpn,
    output wire adc_sclk,
    output wire adc_cs_n,
    output wire adc_din,
    input  wire adc_dout,
    input  wire adc_drdy_n,
    output wire [DRIVES-1:0] drive_pwm,     // cable k's ESCON in bit k
    output wire [DRIVES-1:0] drive_enable,
    output wire led_fault,
    output wire led_run
);

localparam CLK_HZ = 25000000;
// Data and stack in block RAM: 16 KiB for the one-cable image, 32 KiB for the images of two and
// four cables (each cable's firmware state, settings and stream buffer: 4.6 KB; mk/soc.mk).
localparam RAM_WORDS = (CHANNELS > 1) ? 8192 : 4096;

wire clk = clk_25mhz;

// Reset for 256 clocks after configuration (ECP5 flip-flops start at zero).
reg [7:0] por_reg;
reg       rst_reg;

always @(posedge clk) begin
    if (!(&por_reg)) begin
        por_reg <= por_reg + 8'd1;
    end
    rst_reg <= !(&por_reg);
end

wire flash_sck, fault, cpu_trap, boot_done, sample_tick;
wire [CHANNELS-1:0] pwm, enable;

// The board's pins for cables beyond CHANNELS stay low: PWM low and the ESCON disabled.
generate
    if (CHANNELS > DRIVES) begin : g_check_channels
        soc_top_CHANNELS_must_not_exceed_DRIVES error_CHANNELS ();
    end else if (CHANNELS == DRIVES) begin : g_all
        assign drive_pwm = pwm;
        assign drive_enable = enable;
    end else begin : g_some
        assign drive_pwm = {{(DRIVES - CHANNELS){1'b0}}, pwm};
        assign drive_enable = {{(DRIVES - CHANNELS){1'b0}}, enable};
    end
endgenerate

USRMCLK usrmclk (.USRMCLKI(flash_sck), .USRMCLKTS(1'b0));

assign flash_holdn = 1'b1;
assign flash_wpn = 1'b1;

bowden_soc #(
    .CHANNELS(CHANNELS), .CLK_HZ(CLK_HZ), .ROM_WORDS(16384), .RAM_WORDS(RAM_WORDS), .ROM_INIT(ROM_INIT), .CPU_FAST(1),
    .CPU_MUL(2),
    .FLASH_HALF_CLKS(1), .ADC_SCLK_HALF_CLKS(3), .ADC_WAIT_CLKS(8192)
) soc (
    .clk(clk), .rst(rst_reg), .uart_rx(ftdi_txd), .uart_tx(ftdi_rxd),
    .flash_sck(flash_sck), .flash_cs_n(flash_csn), .flash_mosi(flash_mosi),
    .flash_miso(flash_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n), .drive_pwm(pwm), .drive_enable(enable),
    .fault(fault), .cpu_trap(cpu_trap), .boot_done(boot_done), .sample_tick(sample_tick)
);

assign led_fault = fault || cpu_trap;  // ULX3S LEDs are active high
assign led_run = |enable;

wire unused = &{1'b0, boot_done, sample_tick};

endmodule

`resetall
