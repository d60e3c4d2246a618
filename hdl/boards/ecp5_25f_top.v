`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * ECP5 LFE5U-25F board top (pinout of the Radiona ULX3S, CABGA381; see ecp5_25f.lpf):
 * bowden_system (bowden_core) at 100 MHz from the 25 MHz oscillator through a PLL, an external
 * MCU on the GPIO header through the SPI bridge, an ADS131M02 load-cell ADC (T_in, T_out) and the ESCON drive.
 */
module ecp5_25f_top (
    input  wire clk_25mhz,

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
    output wire led_fault,
    output wire led_run
);

localparam CLK_HZ = 100000000;  // PLL: 25 MHz * CLKFB_DIV 4 / CLKI_DIV 1, VCO 600 MHz / 6

wire clk;
wire pll_locked;
wire pll_intfb;  // internal feedback output, not used (feedback from CLKOP)

// VCO = 25 MHz * 4 * 6 = 600 MHz (400..800 MHz allowed), CLKOP = 600 / 6 = 100 MHz.
EHXPLLL #(
    .PLLRST_ENA("DISABLED"),
    .INTFB_WAKE("DISABLED"),
    .STDBY_ENABLE("DISABLED"),
    .DPHASE_SOURCE("DISABLED"),
    .OUTDIVIDER_MUXA("DIVA"),
    .OUTDIVIDER_MUXB("DIVB"),
    .OUTDIVIDER_MUXC("DIVC"),
    .OUTDIVIDER_MUXD("DIVD"),
    .CLKI_DIV(1),
    .CLKOP_ENABLE("ENABLED"),
    .CLKOP_DIV(6),
    .CLKOP_CPHASE(2),
    .CLKOP_FPHASE(0),
    .FEEDBK_PATH("CLKOP"),
    .CLKFB_DIV(4)
) pll (
    .RST(1'b0),
    .STDBY(1'b0),
    .CLKI(clk_25mhz),
    .CLKOP(clk),
    .CLKFB(clk),
    .CLKINTFB(pll_intfb),
    .PHASESEL0(1'b0),
    .PHASESEL1(1'b0),
    .PHASEDIR(1'b1),
    .PHASESTEP(1'b1),
    .PHASELOADREG(1'b1),
    .PLLWAKESYNC(1'b0),
    .ENCLKOP(1'b0),
    .LOCK(pll_locked)
);

// Reset until the PLL has locked and for 2^8 clocks after (ECP5 flip-flops start at zero).
// The reset itself comes from a flip-flop: it fans out to most of the design.
reg [7:0] por_reg;
reg       lock_sync_reg, lock_reg;
reg       rst_reg;
wire rst = rst_reg;

always @(posedge clk) begin
    lock_sync_reg <= pll_locked;
    lock_reg <= lock_sync_reg;
    if (!lock_reg) begin
        por_reg <= 8'd0;
    end else if (!(&por_reg)) begin
        por_reg <= por_reg + 8'd1;
    end
    rst_reg <= !(&por_reg);
end

wire [15:0] cmd_current;
wire        cmd_valid, fault, sample_tick;

// ADS131M02: SCLK = 100 MHz / 2 / 8 = 6.25 MHz (up to 25 MHz), a 96-bit frame in 15.4 us of
// its 31.25 us conversion period.
bowden_system #(
    .CLK_HZ(CLK_HZ), .ADC_ADS131M02(1), .ADC_SCLK_HALF_CLKS(8), .ADC_WAIT_CLKS(32768)
) system (
    .clk(clk), .rst(rst),
    .mcu_sck(mcu_sck), .mcu_cs_n(mcu_cs_n), .mcu_mosi(mcu_mosi), .mcu_miso(mcu_miso),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n),
    .drive_pwm(drive_pwm), .drive_enable(drive_enable),
    .cmd_current(cmd_current), .cmd_valid(cmd_valid), .fault(fault),
    .sample_tick(sample_tick)
);

assign led_fault = fault;
assign led_run = drive_enable;

// The drive takes the PWM set value; the command word is for boards with a DAC.
wire unused_cmd = &{1'b0, cmd_current, cmd_valid, sample_tick, pll_intfb};

endmodule

`resetall
