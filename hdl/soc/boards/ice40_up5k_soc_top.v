`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * iCEBreaker (iCE40UP5K-SG48) top of bowden_soc: the board's 12 MHz oscillator (pin 35) through
 * the PLL to 24 MHz, not the internal SB_HFOSC (its 48 MHz is specified within +-10 % only,
 * iCE40 UltraPlus data sheet FPGA-DS-02008, "sysCLOCK": too loose for a 921600-baud UART,
 * and the loop's sample period and Ki*Ts would be off by as much). The image is booted from
 * the SPI flash at 0x080000 into the SPRAM (firmware/soc/boot.S, in a block RAM the bitstream
 * initialises); the settings live at 0x100000.
 * UART on the FTDI's second channel (RX pin 6, TX pin 9), the ADS131M0x on PMOD1B (an ADS131M04
 * for the two cables of an antagonistic pair), the ESCONs on PMOD2 (cable 0 on its pins 1-2,
 * cable 1 on 3-4). From two cables on, the banks' configuration in block RAM (CFG_RAM) and the
 * loops on the sequenced datapath (SEQ: tension_loop_seq), which fit two cables in the UP5K.
 */
module ice40_up5k_soc_top #(
    parameter DRIVES = 2,             // the cables ice40_up5k_soc.pcf has pins for (do not set)
    parameter CHANNELS = 1,           // cables driven (the board table's), 1 .. DRIVES
    parameter BOOT_INIT = "boot.hex"  // the boot loader (make bitstream copies it beside the netlist)
) (
    input  wire clk_12mhz,
    input  wire uart_rx,
    output wire uart_tx,
    output wire flash_sck,
    output wire flash_cs_n,
    output wire flash_mosi,
    input  wire flash_miso,
    output wire adc_sclk,
    output wire adc_cs_n,
    output wire adc_din,
    input  wire adc_dout,
    input  wire adc_drdy_n,
    output wire [DRIVES-1:0] drive_pwm,     // cable k's ESCON in bit k
    output wire [DRIVES-1:0] drive_enable,
    output wire led_fault,   // red LED, active low: a loop fault is latched, the CPU stopped, or
                             // no image booted (yet)
    output wire led_run      // green LED, active low: a drive is enabled
);

localparam CLK_HZ = 24000000;

wire clk, pll_lock, pll_core;

// 12 MHz * (DIVF + 1) / (DIVR + 1) = 768 MHz VCO (533..1066 MHz), / 2^DIVQ = 24 MHz; the PFD
// at 12 MHz (10..133 MHz), FILTER_RANGE 1 for that PFD (iCE40 sysCLOCK PLL guide, TN1251).
SB_PLL40_PAD #(
    .FEEDBACK_PATH("SIMPLE"), .DIVR(4'd0), .DIVF(7'd63), .DIVQ(3'd5), .FILTER_RANGE(3'd1)
) pll (
    .PACKAGEPIN(clk_12mhz), .PLLOUTCORE(pll_core), .PLLOUTGLOBAL(clk), .LOCK(pll_lock),
    .RESETB(1'b1), .BYPASS(1'b0)
);

// Reset until the PLL has locked and 256 clocks after (flip-flops start at zero on the iCE40).
reg [7:0] por_reg;
reg       rst_reg;

always @(posedge clk) begin
    if (!pll_lock) begin
        por_reg <= 8'd0;
    end else if (!(&por_reg)) begin
        por_reg <= por_reg + 8'd1;
    end
    rst_reg <= !(&por_reg);
end

wire fault, cpu_trap, boot_done, sample_tick;
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

bowden_soc #(
    .CHANNELS(CHANNELS), .CLK_HZ(CLK_HZ), .ROM_WORDS(16384), .RAM_WORDS(16384), .MEM_SPRAM(1),
    .CFG_RAM(1), .SEQ(1),
    .BOOT_FLASH(1), .BOOT_INIT(BOOT_INIT), .CPU_FAST(0), .CPU_MUL(1), .FLASH_HALF_CLKS(1), .ADC_SCLK_HALF_CLKS(3),
    .ADC_WAIT_CLKS(8192)
) soc (
    .clk(clk), .rst(rst_reg), .uart_rx(uart_rx), .uart_tx(uart_tx),
    .flash_sck(flash_sck), .flash_cs_n(flash_cs_n), .flash_mosi(flash_mosi),
    .flash_miso(flash_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n), .drive_pwm(pwm), .drive_enable(enable),
    .fault(fault), .cpu_trap(cpu_trap), .boot_done(boot_done), .sample_tick(sample_tick)
);

// Red also while the image is copied from the flash (some 60 ms), and for good when the flash
// holds no image (firmware/soc/boot.S).
assign led_fault = !(fault || cpu_trap || !boot_done);
assign led_run = !(|enable);

wire unused = &{1'b0, sample_tick, pll_core};

endmodule

`resetall
