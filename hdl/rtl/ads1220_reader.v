`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Front-end for a TI ADS1220 24-bit load-cell ADC: configures it for continuous conversion and
 * streams each conversion result as a signed 24-bit code (adc_valid / adc_data).
 *
 * ADS1220 datasheet (TI SBAS501): SPI mode 1 (both sides drive on SCLK rising and sample on
 * falling),
 * commands RESET 0x06, WREG 0x43 (registers 0..3), START/SYNC 0x08; in continuous conversion
 * mode a result is read by 24 SCLKs once DRDY goes low, no command needed. CS is held low.
 * Default configuration: AIN0/AIN1, PGA gain 128 (reg 0 = 0x0E); 2000 SPS turbo, continuous
 * (reg 1 = 0xD4); external ratiometric reference on REFP0/REFN0 (reg 2 = 0x40); reg 3 = 0x00.
 */
module ads1220_reader #(
    parameter SCLK_HALF_CLKS = 8,            // SCLK half period in clocks (48 MHz -> 3 MHz)
    parameter WAIT_CLKS = 16384,             // wait after power-up and after RESET, clocks
    parameter [31:0] CONFIG = 32'h0ED44000   // registers 0..3, register 0 in the top byte
) (
    input  wire        clk,
    input  wire        rst,

    /*
     * ADS1220 pins
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
    output wire [23:0] adc_data
);

localparam [2:0] S_WAIT = 3'd0, S_RESET = 3'd1, S_WAIT2 = 3'd2, S_CONFIG = 3'd3,
                 S_START = 3'd4, S_IDLE = 3'd5, S_READ = 3'd6;
localparam WAIT_W = $clog2(WAIT_CLKS + 1);
localparam integer WAIT_LAST_INT = WAIT_CLKS - 1;
localparam [WAIT_W-1:0] WAIT_LAST = WAIT_LAST_INT[WAIT_W-1:0];

reg  [2:0]        state_reg, state_next;
reg  [WAIT_W-1:0] wait_reg, wait_next;
reg  [SCLK_HALF_CLKS-1:0] ring_reg, ring_next;  // one-hot: a half SCLK period ends at bit 0
reg               wait_hit_reg, wait_hit_next;
reg               sclk_reg, sclk_next;
reg  [5:0]        bits_reg, bits_next;    // bits left in the transfer
reg  [39:0]       tx_reg, tx_next;        // MSB goes out first
reg  [23:0]       rx_reg, rx_next;
reg               din_reg, din_next;
reg               valid_reg, valid_next;
reg  [1:0]        drdy_sync_reg;
reg  [1:0]        dout_sync_reg;

localparam [SCLK_HALF_CLKS-1:0] RING_START = {1'b1, {(SCLK_HALF_CLKS-1){1'b0}}};
wire half_done = ring_reg[0];
wire drdy = !drdy_sync_reg[1];

always @* begin
    state_next = state_reg;
    wait_next = wait_reg;
    // Held at its start value outside transfers, so each transfer starts with a full half period.
    ring_next = {ring_reg[0], ring_reg[SCLK_HALF_CLKS-1:1]};
    wait_hit_next = (wait_reg == WAIT_LAST);  // registered: the wait may run one clock longer
    sclk_next = sclk_reg;
    bits_next = bits_reg;
    tx_next = tx_reg;
    rx_next = rx_reg;
    din_next = din_reg;
    valid_next = 1'b0;

    case (state_reg)
        S_WAIT, S_WAIT2: begin
            ring_next = RING_START;
            wait_next = wait_reg + 1'b1;
            if (wait_hit_reg) begin
                wait_next = {WAIT_W{1'b0}};
                state_next = (state_reg == S_WAIT) ? S_RESET : S_CONFIG;
                bits_next = (state_reg == S_WAIT) ? 6'd8 : 6'd40;
                tx_next = (state_reg == S_WAIT) ? {8'h06, 32'd0} : {8'h43, CONFIG};
            end
        end
        S_IDLE: begin
            ring_next = RING_START;
            if (drdy) begin
                state_next = S_READ;
                bits_next = 6'd24;
                tx_next = 40'd0;
            end
        end
        default: begin
            // Shift engine: rising edge drives DIN, falling edge samples DOUT.
            if (half_done) begin
                sclk_next = !sclk_reg;
                if (!sclk_reg) begin
                    // Rising edge: the next bit goes out on DIN (the ADC samples it falling).
                    din_next = tx_reg[39];
                    tx_next = {tx_reg[38:0], 1'b0};
                end else begin
                    // Falling edge: DOUT (driven by the ADC after the rising edge) is sampled.
                    rx_next = {rx_reg[22:0], dout_sync_reg[1]};
                    bits_next = bits_reg - 1'b1;
                    if (bits_reg == 6'd1) begin
                        case (state_reg)
                            S_RESET: state_next = S_WAIT2;
                            S_CONFIG: begin
                                state_next = S_START;
                                bits_next = 6'd8;
                                tx_next = {8'h08, 32'd0};
                            end
                            S_START: state_next = S_IDLE;
                            default: begin
                                state_next = S_IDLE;
                                valid_next = 1'b1;
                            end
                        endcase
                    end
                end
            end
        end
    endcase
end

always @(posedge clk) begin
    state_reg <= state_next;
    wait_reg <= wait_next;
    ring_reg <= ring_next;
    wait_hit_reg <= wait_hit_next;
    sclk_reg <= sclk_next;
    bits_reg <= bits_next;
    tx_reg <= tx_next;
    rx_reg <= rx_next;
    din_reg <= din_next;
    valid_reg <= valid_next;
    drdy_sync_reg <= {drdy_sync_reg[0], adc_drdy_n};
    dout_sync_reg <= {dout_sync_reg[0], adc_dout};
    if (rst) begin
        state_reg <= S_WAIT;
        wait_reg <= {WAIT_W{1'b0}};
        ring_reg <= RING_START;
        wait_hit_reg <= 1'b0;
        sclk_reg <= 1'b0;
        din_reg <= 1'b0;
        bits_reg <= 6'd0;
        valid_reg <= 1'b0;
        drdy_sync_reg <= 2'b11;
    end
end

assign adc_sclk = sclk_reg;
assign adc_cs_n = (state_reg == S_WAIT);
assign adc_din = din_reg;
assign adc_valid = valid_reg;
assign adc_data = rx_reg;

endmodule

`resetall
