`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Front-end for a TI ADS131M0x simultaneous-sampling 24-bit ADC: the ADS131M02 (two channels:
 * the load cells on T_in and T_out of one cable) by default, or with NCH the family's parts of
 * 3, 4, 6 or 8 channels, whose frames have the same format with one word per channel
 * (the ADS131M04 and ADS131M08 datasheets, sections "SPI Communication Frames" and
 * "Register Map"; CLOCK's CHn_EN is bit 8 + n, GAIN1 holds CH0-CH3 and GAIN2 CH4-CH7, 4 bits a
 * channel). It configures the ADC once, then reads one frame per data-ready and streams every
 * channel as signed 24-bit codes (adc_valid; adc_ch_data, channel k in bits [k*24 +: 24]).
 *
 * ADS131M02 datasheet (TI SBAS853A):
 * - 8.5.1 SPI, mode 1: the host drives DIN and the device DOUT on SCLK rising edges, both sample
 *   on falling edges; frames are delimited by CS (low for a whole frame).
 * - 8.5.1.7/8.5.1.8 frames of 24-bit words (MODE.WLENGTH = 01, the reset value); a frame on DOUT
 *   is the response word (STATUS for a NULL command), CH0, CH1 (... CH[NCH-1]) and the output CRC
 *   word (the 16-bit CRC in its top bits, zero padding): FRAME_BITS = 24 * (NCH + 2), 96 for
 *   the ADS131M02. Commands are 16 bits in the top of a word: NULL 0x0000, WREG
 *   011a_aaaa_annn_nnnn (8.5.1.10).
 * - 8.5.1.11 CRC: CCITT x^16 + x^12 + x^5 + 1, seed 0xFFFF (MODE.CRC_TYPE = 0, the reset value),
 *   over every bit of the frame's words before the CRC word. Run over the whole frame, the
 *   remainder is zero when the CRC matches (its zero padding keeps a non-zero remainder
 *   non-zero), so the check needs no buffer for the CRC word.
 * - 8.5.1.5 DRDY: falls when a new conversion of both channels is ready; the reader starts a
 *   frame on each falling edge (a result that was not read makes DRDY pulse high before the
 *   next one, so every conversion gives an edge).
 * - 8.6 registers: CLOCK (0x03) = 0x0302: CH0 and CH1 on, OSR 128, high-resolution mode:
 *   f_DATA = 8.192 MHz / 2 / 128 = 32 kSPS (8.4.1: f_MOD = CLKIN / 2); GAIN1 (0x04) = 0x0077:
 *   PGA gain 128 on both channels. Named assumption: an 8.192 MHz oscillator on CLKIN. With NCH
 *   channels the defaults turn every channel on (CLOCK 0x0F02 for 4, 0xFF02 for 8) at gain 128
 *   (GAIN1 0x7777; GAIN2 0x7777 with more than 4), and the configuration frame writes CLOCK,
 *   GAIN1 and, with more than 4 channels, GAIN2.
 *
 * Faults: a frame whose CRC does not match gives no sample (crc_error until a good frame); no
 * DRDY edge for DRDY_TIMEOUT_CLKS raises drdy_lost until the next edge. Either way the core
 * gets no adc_valid, and its ADC_STALE limit latches the fault (bowden_core), as with the
 * ADS1220 front-end.
 */
module ads131m02_reader #(
    parameter NCH = 2,                       // channels of the part: 2 (M02), 3, 4 (M04), 6, 8 (M08)
    parameter SCLK_HALF_CLKS = 4,            // SCLK half period in clocks (48 MHz -> 6 MHz), >= 3
    parameter WAIT_CLKS = 16384,             // wait after power-up before configuring, clocks
    // CLOCK register: every channel on, OSR 128, high resolution
    parameter [15:0] CLOCK_REG = {{(8-NCH){1'b0}}, {NCH{1'b1}}, 8'h02},
    // GAIN1 / GAIN2 registers: PGA 128 on CH0-CH3 / CH4-CH7 (GAIN2 written only for NCH > 4)
    parameter [15:0] GAIN_REG = {{(4-(NCH < 4 ? NCH : 4)){4'h0}}, {(NCH < 4 ? NCH : 4){4'h7}}},
    parameter [15:0] GAIN2_REG = 16'h7777,
    parameter CRC_CHECK = 1,                 // 1: drop frames whose output CRC does not match
    parameter DRDY_TIMEOUT_CLKS = 6000       // clocks without DRDY before drdy_lost (4 x 31.25 us)
) (
    input  wire        clk,
    input  wire        rst,

    /*
     * ADS131M02 pins
     */
    output wire        adc_sclk,
    output wire        adc_cs_n,
    output wire        adc_din,     // to the ADC's DIN
    input  wire        adc_dout,    // from the ADC's DOUT
    input  wire        adc_drdy_n,

    /*
     * Sample stream
     */
    output wire        adc_valid,
    output wire [NCH*24-1:0] adc_ch_data,  // channel k in bits [k*24 +: 24], signed codes
                                           // (one cable: CH0 T_in, CH1 T_out)
    output wire [15:0] adc_status,    // STATUS word of the last good frame

    /*
     * Faults
     */
    output wire        crc_error,     // the last frame's CRC did not match (it was dropped)
    output wire        drdy_lost      // no DRDY falling edge for DRDY_TIMEOUT_CLKS
);

// Parameter check: DOUT passes two synchronizer flops and is sampled SCLK_HALF_CLKS clocks after
// the rising edge that launched it, so a half period must span them and the ADC's output delay.
generate
    if (SCLK_HALF_CLKS < 3) begin : g_check
        ads131m02_reader_SCLK_HALF_CLKS_must_be_at_least_3 error_SCLK_HALF_CLKS ();
    end
    if (NCH < 2 || NCH > 8) begin : g_check_nch
        ads131m02_reader_NCH_must_be_2_to_8 error_NCH ();
    end
endgenerate

localparam FRAME_BITS = 24 * (NCH + 2);  // words of 24 bits: response, CH0 .. CH[NCH-1], CRC
localparam RX_BITS = 24 * (NCH + 1);     // the words before the CRC word
localparam BITS_W = $clog2(FRAME_BITS + 1);
localparam [15:0] CRC_POLY = 16'h1021;  // CCITT
// WREG from CLOCK (0x03): CLOCK and GAIN1 (n = 1), and GAIN2 (n = 2) with more than 4 channels.
localparam [15:0] WREG_CLOCK_GAIN = (NCH > 4) ? 16'h6182 : 16'h6181;
// The configuration frame, bit i sent when i + 1 bits are left (MSB first): the command, the
// registers it writes, then zeros (and the CRC word's slot). Read frames send NULL (all zeros):
// DIN needs no shift register.
localparam [95:0] CONFIG_HEAD = {WREG_CLOCK_GAIN, 8'd0, CLOCK_REG, 8'd0, GAIN_REG, 8'd0,
                                 (NCH > 4) ? {GAIN2_REG, 8'd0} : 24'd0};
wire [FRAME_BITS-1:0] config_frame;
generate
    if (FRAME_BITS == 96) begin : g_frame_4
        assign config_frame = CONFIG_HEAD;
    end else begin : g_frame_n
        assign config_frame = {CONFIG_HEAD, {(FRAME_BITS - 96){1'b0}}};
    end
endgenerate
localparam [BITS_W-1:0] FRAME_BITS_W = FRAME_BITS[BITS_W-1:0];

localparam [1:0] S_WAIT = 2'd0, S_CONFIG = 2'd1, S_IDLE = 2'd2, S_READ = 2'd3;
localparam WAIT_W = $clog2(WAIT_CLKS + 1);
localparam integer WAIT_LAST_INT = WAIT_CLKS - 1;
localparam [WAIT_W-1:0] WAIT_LAST = WAIT_LAST_INT[WAIT_W-1:0];
localparam TO_W = $clog2(DRDY_TIMEOUT_CLKS + 1);
localparam [TO_W-1:0] TO_LIMIT = DRDY_TIMEOUT_CLKS[TO_W-1:0];

reg  [1:0]        state_reg, state_next;
reg  [WAIT_W-1:0] wait_reg, wait_next;
reg               wait_hit_reg, wait_hit_next;
reg  [SCLK_HALF_CLKS-1:0] ring_reg, ring_next;  // one-hot: a half SCLK period ends at bit 0
reg               sclk_reg, sclk_next;
reg  [BITS_W-1:0] bits_reg, bits_next;  // bits left in the frame
reg  [RX_BITS-1:0] rx_reg, rx_next;       // the frame's words before the CRC word
reg  [15:0]       crc_reg, crc_next;      // remainder over the bits received so far
reg               din_reg, din_next;
reg               valid_reg, valid_next;
reg               crc_err_reg, crc_err_next;
reg  [NCH*24-1:0] ch_reg, ch_next;       // channel k in bits [k*24 +: 24]
reg  [15:0]       status_reg, status_next;
reg  [TO_W-1:0]   to_reg, to_next;        // clocks since the last DRDY edge (saturates)
reg  [2:0]        drdy_sync_reg;          // two synchronizer flops and the previous level
reg  [1:0]        dout_sync_reg;
reg               cs_n_reg;               // one clock behind the state: SCLK idles around CS
// Decodes of the bit count, registered: the count changes only on SCLK falling edges, at least
// SCLK_HALF_CLKS (>= 3) clocks apart, so the flags have settled when the next edge uses them,
// and the receive flops' enable is one LUT.
reg               rx_keep_reg;            // bits_reg > 24: the bit is not the CRC word's
reg               last_reg;               // bits_reg == 1: this falling edge ends the frame

localparam [SCLK_HALF_CLKS-1:0] RING_START = {1'b1, {(SCLK_HALF_CLKS-1){1'b0}}};
wire half_done = ring_reg[0];
wire drdy_fall = drdy_sync_reg[2] && !drdy_sync_reg[1];
wire rx_bit = dout_sync_reg[1];
wire crc_fb = crc_reg[15] ^ rx_bit;

// The channel words of the frame received (CH0 first on the line), channel k in [k*24 +: 24].
wire [NCH*24-1:0] rx_channels;
genvar g;
generate
    for (g = 0; g < NCH; g = g + 1) begin : g_rx_channel
        assign rx_channels[g*24 +: 24] = rx_reg[(NCH-1-g)*24 +: 24];
    end
endgenerate

always @* begin
    state_next = state_reg;
    wait_next = wait_reg;
    wait_hit_next = (wait_reg == WAIT_LAST);  // registered: the wait may run one clock longer
    // Held at its start value outside frames, so each frame starts with a full half period.
    ring_next = {ring_reg[0], ring_reg[SCLK_HALF_CLKS-1:1]};
    sclk_next = sclk_reg;
    bits_next = bits_reg;
    rx_next = rx_reg;
    crc_next = crc_reg;
    din_next = din_reg;
    valid_next = 1'b0;
    crc_err_next = crc_err_reg;
    ch_next = ch_reg;
    status_next = status_reg;
    // Saturating: only "at least DRDY_TIMEOUT_CLKS" matters.
    to_next = (to_reg == TO_LIMIT) ? to_reg : to_reg + 1'b1;
    if (drdy_fall) begin
        to_next = {TO_W{1'b0}};
    end

    case (state_reg)
        S_WAIT: begin
            ring_next = RING_START;
            wait_next = wait_reg + 1'b1;
            to_next = {TO_W{1'b0}};  // DRDY is not watched before the ADC is configured
            if (wait_hit_reg) begin
                state_next = S_CONFIG;
                bits_next = FRAME_BITS_W;
            end
        end
        S_IDLE: begin
            ring_next = RING_START;
            if (drdy_fall) begin
                state_next = S_READ;
                bits_next = FRAME_BITS_W;  // NULL command: the response word is STATUS
                crc_next = 16'hFFFF;
            end
        end
        default: begin
            // Shift engine: rising edge drives DIN, falling edge samples DOUT.
            if (half_done) begin
                sclk_next = !sclk_reg;
                if (!sclk_reg) begin
                    // bits_reg - 1 is in 0..FRAME_BITS - 1 here (a frame starts with FRAME_BITS
                    // bits left).
                    din_next = (state_reg == S_CONFIG) && config_frame[bits_reg - 1'b1];
                end else begin
                    crc_next = {crc_reg[14:0], 1'b0} ^ (crc_fb ? CRC_POLY : 16'h0000);
                    bits_next = bits_reg - 1'b1;
                    if (rx_keep_reg) begin
                        // The CRC word only enters the remainder.
                        rx_next = {rx_reg[RX_BITS-2:0], rx_bit};
                    end
                    if (last_reg) begin
                        state_next = S_IDLE;
                        if (state_reg == S_READ) begin
                            // crc_next is the remainder over the whole frame: zero if it
                            // matches. A dropped frame leaves the last good sample in place.
                            if (CRC_CHECK == 0 || crc_next == 16'h0000) begin
                                valid_next = 1'b1;
                                crc_err_next = 1'b0;
                                status_next = rx_reg[RX_BITS-1 -: 16];
                                ch_next = rx_channels;
                            end else begin
                                crc_err_next = 1'b1;
                            end
                        end
                    end
                end
            end
        end
    endcase
end

always @(posedge clk) begin
    state_reg <= state_next;
    wait_reg <= wait_next;
    wait_hit_reg <= wait_hit_next;
    ring_reg <= ring_next;
    sclk_reg <= sclk_next;
    bits_reg <= bits_next;
    rx_reg <= rx_next;
    crc_reg <= crc_next;
    din_reg <= din_next;
    valid_reg <= valid_next;
    crc_err_reg <= crc_err_next;
    ch_reg <= ch_next;
    status_reg <= status_next;
    to_reg <= to_next;
    drdy_sync_reg <= {drdy_sync_reg[1:0], adc_drdy_n};
    dout_sync_reg <= {dout_sync_reg[0], adc_dout};
    cs_n_reg <= !(state_reg == S_CONFIG || state_reg == S_READ);
    rx_keep_reg <= bits_reg > 24;
    last_reg <= bits_reg == 1;
    if (rst) begin
        state_reg <= S_WAIT;
        wait_reg <= {WAIT_W{1'b0}};
        wait_hit_reg <= 1'b0;
        ring_reg <= RING_START;
        sclk_reg <= 1'b0;
        bits_reg <= {BITS_W{1'b0}};
        din_reg <= 1'b0;
        valid_reg <= 1'b0;
        crc_err_reg <= 1'b0;
        to_reg <= {TO_W{1'b0}};
        drdy_sync_reg <= 3'b111;
        cs_n_reg <= 1'b1;
    end
end

assign adc_sclk = sclk_reg;
assign adc_cs_n = cs_n_reg;
assign adc_din = din_reg;
assign adc_valid = valid_reg;
assign adc_ch_data = ch_reg;
assign adc_status = status_reg;
assign crc_error = crc_err_reg;
assign drdy_lost = (to_reg == TO_LIMIT);

`ifdef FORMAL
// --- formal properties (hdl/formal/ads131m02_reader.sby; hdl/README.md says what is proven) --
//
// A stuck or absent DRDY raises drdy_lost: once the reader is past its power-up wait, a DRDY
// pin that holds its level (high: absent; low: stuck) for DRDY_TIMEOUT_CLKS + 2 clocks, for
// any DOUT and any reset history, has drdy_lost set. No DRDY edge means no frame, so the core
// gets no sample and latches FAULT.ADC_STALE (bowden_core's fault path).

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;
always @* if (!f_past_valid) assume(rst);

localparam integer F_MAX_INT = DRDY_TIMEOUT_CLKS + 2;
localparam [TO_W+1:0] F_MAX = F_MAX_INT[TO_W+1:0];

reg            f_drdy_past;                 // the pin at the last edge
reg [TO_W+1:0] f_quiet;                     // edges since the pin last changed, past S_WAIT

always @(posedge clk) begin
    f_drdy_past <= adc_drdy_n;
    if (adc_drdy_n != f_drdy_past || state_reg == S_WAIT) begin
        f_quiet <= {(TO_W+2){1'b0}};
    end else if (f_quiet != F_MAX) begin
        f_quiet <= f_quiet + 1'b1;
    end
    if (rst) begin
        f_drdy_past <= 1'b1;
        f_quiet <= {(TO_W+2){1'b0}};
    end
end

always @* if (f_past_valid && !rst) begin
    // property ads_drdy_lost: past the power-up wait, a DRDY pin that holds its level for the DRDY timeout + 2 clocks has drdy_lost set
    if (f_quiet == F_MAX) ads_drdy_lost: assert(drdy_lost);
    // property ads_drdy_tracking: the synchronizer holds the pin's recent levels and the timeout counter has run at least as long as the pin has been quiet (induction helper)
    // Induction helpers: the synchronizer holds the pin's recent levels, and the timeout
    // counter has run at least as long as the pin has been quiet.
    ads_drdy_tracking: assert(f_drdy_past == drdy_sync_reg[0]);
    if (f_quiet >= 1) ads_drdy_tracking_2: assert(drdy_sync_reg[1] == drdy_sync_reg[0] && state_reg != S_WAIT);
    if (f_quiet >= 2) ads_drdy_tracking_3: assert(drdy_sync_reg[2] == drdy_sync_reg[1]);
    if (f_quiet >= 2) ads_drdy_tracking_4: assert(to_reg == TO_LIMIT || {2'b00, to_reg} + 2 >= f_quiet);
    ads_drdy_tracking_5: assert(to_reg <= TO_LIMIT);
    ads_drdy_tracking_6: assert(f_quiet <= F_MAX);
end
`endif

endmodule

`resetall
