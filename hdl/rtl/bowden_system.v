`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Board-independent Bowden tension controller: bowden_core with its register map reached by an
 * external MCU through the SPI bridge, and its load-cell samples from an ADS131M02 front-end
 * (T_in on CH0 for the loop, T_out on CH1 read back in T_OUT; hdl/README.md, "Sensing") or,
 * with ADC_ADS131M02 = 0, from the ADS1220 front-end of the first boards (T_in only).
 * A board top adds only its clock, its reset and its indicators.
 *
 * MCU -> spi_axil_bridge -> AXI4-Lite -> bowden_core <- ads131m02_reader <- ADS131M02
 *                                            |          (or ads1220_reader <- ADS1220)
 *                                            +-> ESCON drive (PWM set value, enable)
 */
module bowden_system #(
    parameter CLK_HZ = 48000000,      // system clock, Hz
    parameter ADC_ADS131M02 = 1,      // 1: ADS131M02 front-end (two channels); 0: ADS1220
    parameter ADC_SCLK_HALF_CLKS = 4, // ADC SCLK half period, clocks (48 MHz -> 6 MHz)
    parameter ADC_WAIT_CLKS = 16384   // ADC wait after power-up (and the ADS1220's RESET), clocks
) (
    input  wire        clk,
    input  wire        rst,

    /*
     * MCU (SPI slave, mode 0; SCK below clk / 8)
     */
    input  wire        mcu_sck,
    input  wire        mcu_cs_n,
    input  wire        mcu_mosi,
    output wire        mcu_miso,

    /*
     * Load-cell ADC (SPI mode 1)
     */
    output wire        adc_sclk,
    output wire        adc_cs_n,
    output wire        adc_din,
    input  wire        adc_dout,
    input  wire        adc_drdy_n,

    /*
     * ESCON drive
     */
    output wire        drive_pwm,     // PWM set value
    output wire        drive_enable,

    /*
     * Command and status
     */
    output wire [15:0] cmd_current,   // Q3.12 A, for a board with a DAC
    output wire        cmd_valid,     // one clock when cmd_current is new
    output wire        fault,         // a fault is latched
    output wire        sample_tick    // one clock at the start of each sample
);

// --- MCU register access -------------------------------------------------------------------

// Byte address width of the register bus (the map's 64 words). The bridge refuses the SPI
// frame's words 64..127 with DECERR instead of aliasing them onto 0..63.
localparam ADDR_W = 8;

wire [ADDR_W-1:0] axil_awaddr, axil_araddr;
wire [2:0]  axil_awprot, axil_arprot;
wire        axil_awvalid, axil_awready, axil_wvalid, axil_wready, axil_bvalid, axil_bready;
wire        axil_arvalid, axil_arready, axil_rvalid, axil_rready;
wire [31:0] axil_wdata, axil_rdata;
wire [3:0]  axil_wstrb;
wire [1:0]  axil_bresp, axil_rresp;

spi_axil_bridge #(.ADDR_W(ADDR_W)) spi (
    .clk(clk), .rst(rst),
    .spi_sck(mcu_sck), .spi_cs_n(mcu_cs_n), .spi_mosi(mcu_mosi), .spi_miso(mcu_miso),
    .m_axil_awaddr(axil_awaddr), .m_axil_awprot(axil_awprot), .m_axil_awvalid(axil_awvalid),
    .m_axil_awready(axil_awready), .m_axil_wdata(axil_wdata), .m_axil_wstrb(axil_wstrb),
    .m_axil_wvalid(axil_wvalid), .m_axil_wready(axil_wready), .m_axil_bresp(axil_bresp),
    .m_axil_bvalid(axil_bvalid), .m_axil_bready(axil_bready), .m_axil_araddr(axil_araddr),
    .m_axil_arprot(axil_arprot), .m_axil_arvalid(axil_arvalid), .m_axil_arready(axil_arready),
    .m_axil_rdata(axil_rdata), .m_axil_rresp(axil_rresp), .m_axil_rvalid(axil_rvalid),
    .m_axil_rready(axil_rready)
);

// --- load-cell ADC -------------------------------------------------------------------------

// ADS131M02 DRDY timeout: four conversion periods at 32 kSPS (125 us), and at least four frames
// (so that a slow test clock does not flag the reads themselves).
localparam integer DRDY_TIMEOUT_PERIODS = CLK_HZ / 8000;
localparam integer DRDY_TIMEOUT_FRAMES = 4 * 2 * 96 * ADC_SCLK_HALF_CLKS;
localparam integer ADC_DRDY_TIMEOUT_CLKS = (DRDY_TIMEOUT_PERIODS > DRDY_TIMEOUT_FRAMES) ?
                                           DRDY_TIMEOUT_PERIODS : DRDY_TIMEOUT_FRAMES;

wire        rdr_valid;
wire [23:0] rdr_data, adc_aux_data;
wire        adc_drdy_lost, adc_crc_err;

generate
    if (ADC_ADS131M02 != 0) begin : g_ads131m02
        wire [15:0] adc_status;

        ads131m02_reader #(
            .SCLK_HALF_CLKS(ADC_SCLK_HALF_CLKS), .WAIT_CLKS(ADC_WAIT_CLKS),
            .DRDY_TIMEOUT_CLKS(ADC_DRDY_TIMEOUT_CLKS)
        ) adc (
            .clk(clk), .rst(rst),
            .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
            .adc_drdy_n(adc_drdy_n), .adc_valid(rdr_valid),
            .adc_ch_data({adc_aux_data, rdr_data}),  // CH1 (T_out), CH0 (T_in)
            .adc_status(adc_status), .crc_error(adc_crc_err),
            .drdy_lost(adc_drdy_lost)
        );

        // The STATUS word is for a debugger's eye; the loop needs none of it.
        wire unused_status = &{1'b0, adc_status};
    end else begin : g_ads1220
        ads1220_reader #(.SCLK_HALF_CLKS(ADC_SCLK_HALF_CLKS), .WAIT_CLKS(ADC_WAIT_CLKS)) adc (
            .clk(clk), .rst(rst),
            .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
            .adc_drdy_n(adc_drdy_n), .adc_valid(rdr_valid), .adc_data(rdr_data)
        );

        // One channel, no frame check: T_OUT reads 0, the flags stay clear (a lost DRDY still
        // latches FAULT.ADC_STALE).
        assign adc_aux_data = 24'd0;
        assign adc_drdy_lost = 1'b0;
        assign adc_crc_err = 1'b0;
    end
endgenerate

// Two registers between the front-end and the core: the reader sits by the ADC's pins, the
// loop's sample path (valid -> sample mux -> offset subtraction) by the multipliers, and the
// route between them was the iCE40's longest path; the second stage has only the loop as its
// load, so it can sit there. Two clocks (42 ns at 48 MHz) more from DRDY to the core, which
// cosim.parts.interface.CORE_PIPE_CLKS counts.
reg [1:0]  adc_valid_pipe_reg;
reg [23:0] adc_data_pipe_reg [0:1];  // no reset: taken only with its valid bit

always @(posedge clk) begin
    adc_valid_pipe_reg <= {adc_valid_pipe_reg[0], rdr_valid};
    adc_data_pipe_reg[0] <= rdr_data;
    adc_data_pipe_reg[1] <= adc_data_pipe_reg[0];
    if (rst) begin
        adc_valid_pipe_reg <= 2'b00;
    end
end

wire        adc_valid = adc_valid_pipe_reg[1];
wire [23:0] adc_data = adc_data_pipe_reg[1];

// --- core ----------------------------------------------------------------------------------

bowden_core #(.CLK_HZ(CLK_HZ), .ADDR_W(ADDR_W)) core (
    .clk(clk), .rst(rst),
    .s_axil_awaddr(axil_awaddr), .s_axil_awprot(axil_awprot), .s_axil_awvalid(axil_awvalid),
    .s_axil_awready(axil_awready), .s_axil_wdata(axil_wdata), .s_axil_wstrb(axil_wstrb),
    .s_axil_wvalid(axil_wvalid), .s_axil_wready(axil_wready), .s_axil_bresp(axil_bresp),
    .s_axil_bvalid(axil_bvalid), .s_axil_bready(axil_bready), .s_axil_araddr(axil_araddr),
    .s_axil_arprot(axil_arprot), .s_axil_arvalid(axil_arvalid), .s_axil_arready(axil_arready),
    .s_axil_rdata(axil_rdata), .s_axil_rresp(axil_rresp), .s_axil_rvalid(axil_rvalid),
    .s_axil_rready(axil_rready),
    .adc_valid(adc_valid), .adc_data(adc_data), .adc_aux_data(adc_aux_data),
    .adc_drdy_lost(adc_drdy_lost), .adc_crc_err(adc_crc_err),
    .cmd_current(cmd_current), .cmd_enable(drive_enable), .cmd_valid(cmd_valid),
    .fault(fault), .pwm(drive_pwm), .sample_tick(sample_tick)
);

endmodule

`resetall
