`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * iCE40 UP5K board top (pinout of the 1BitSquared iCEBreaker, UP5K-SG48; see
 * ice40_up5k.pcf): bowden_system (bowden_core) at 48 MHz from the internal oscillator, an
 * external MCU on PMOD1A through the SPI bridge, an ADS131M02 load-cell ADC on PMOD1B, and the
 * ESCON drive (PWM set value, enable) on PMOD2.
 */
module ice40_up5k_top (
    /*
     * MCU (SPI slave, mode 0)
     */
    input  wire mcu_sck,
    input  wire mcu_cs_n,
    input  wire mcu_mosi,
    output wire mcu_miso,

    /*
     * ADS131M02 (SPI mode 1; CLKIN from an 8.192 MHz oscillator on the board)
     */
    output wire adc_sclk,
    output wire adc_cs_n,
    output wire adc_din,
    input  wire adc_dout,
    input  wire adc_drdy_n,

    /*
     * ESCON drive and indicators
     */
    output wire drive_pwm,
    output wire drive_enable,
    output wire led_fault,    // red LED, active low on the iCEBreaker
    output wire led_run       // green LED, active low
);

localparam CLK_HZ = 48000000;  // SB_HFOSC with CLKHF_DIV 0b00

wire clk;

SB_HFOSC #(
    .CLKHF_DIV("0b00")
) hfosc (
    .CLKHFPU(1'b1),
    .CLKHFEN(1'b1),
    .CLKHF(clk)
);

// Power-on reset: iCE40 flip-flops start at zero, so this counter holds reset for 2^8 clocks.
// The reset itself comes from a flip-flop: it fans out to most of the design.
reg [7:0] por_reg;
reg       rst_reg;
wire rst = rst_reg;

always @(posedge clk) begin
    if (!(&por_reg)) begin
        por_reg <= por_reg + 8'd1;
    end
    rst_reg <= !(&por_reg);
end

wire [15:0] cmd_current;
wire        cmd_valid, fault, sample_tick;

// ADS131M02: SCLK = 48 MHz / 2 / 4 = 6 MHz (up to 25 MHz), a 96-bit frame in 16 us of its
// 31.25 us conversion period.
bowden_system #(
    .CLK_HZ(CLK_HZ), .ADC_ADS131M02(1), .ADC_SCLK_HALF_CLKS(4), .ADC_WAIT_CLKS(16384)
) system (
    .clk(clk), .rst(rst),
    .mcu_sck(mcu_sck), .mcu_cs_n(mcu_cs_n), .mcu_mosi(mcu_mosi), .mcu_miso(mcu_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n),
    .drive_pwm(drive_pwm), .drive_enable(drive_enable),
    .cmd_current(cmd_current), .cmd_valid(cmd_valid), .fault(fault),
    .sample_tick(sample_tick)
);

assign led_fault = !fault;
assign led_run = !drive_enable;

// The drive takes the PWM set value; the command word is for boards with a DAC.
wire unused_cmd = &{1'b0, cmd_current, cmd_valid, sample_tick};

endmodule

`resetall
