`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * UART, 8N1, for the bench protocol: BAUD from CLK_HZ by an integer divider (the nearest; at
 * 24 MHz and 921600 baud 26 clocks a bit, 0.16 % fast, well inside 8N1's +-2 % budget), a
 * receive and a transmit FIFO of 2^FIFO_AW bytes each. The receiver samples each bit at its
 * middle, after a two-flop synchroniser; a start bit that is not low at its middle is a glitch
 * and is ignored; a stop bit that is low is a framing error (the byte is dropped and counted in
 * the sticky flag). A byte that finds the receive FIFO full is dropped: sticky overrun flag.
 */
module soc_uart #(
    parameter CLK_HZ = 24000000,
    parameter BAUD = 921600,
    parameter FIFO_AW = 9
) (
    input  wire       clk,
    input  wire       rst,
    input  wire       rx,
    output reg        tx,
    // transmit: queue a byte
    input  wire       tx_push,
    input  wire [7:0] tx_data,
    output wire       tx_full,
    output wire [FIFO_AW:0] tx_level,  // bytes waiting in the transmit FIFO
    // receive: the oldest byte and its removal
    input  wire       rx_pop,
    output wire [7:0] rx_data,
    output wire       rx_avail,
    // sticky flags, cleared by the clear inputs
    output reg        rx_overrun,
    output reg        rx_frame_err,
    input  wire       clear_overrun,
    input  wire       clear_frame_err
);

localparam integer DIV = (CLK_HZ + BAUD / 2) / BAUD;
localparam integer DW = $clog2(DIV + 1);
localparam integer DIV_LAST_INT = DIV - 1;
localparam integer DIV_HALF_INT = DIV / 2 - 1;
localparam [DW-1:0] DIV_LAST = DIV_LAST_INT[DW-1:0];
localparam [DW-1:0] DIV_HALF = DIV_HALF_INT[DW-1:0];

generate
    if (DIV < 8) begin : g_check
        soc_uart_needs_at_least_8_clocks_per_bit error_DIV ();
    end
endgenerate

// --- transmit ------------------------------------------------------------------------------

wire [7:0]       txf_q;
wire [FIFO_AW:0] txf_count;
reg              tx_busy_reg;
reg [8:0]        tx_shift_reg;  // data bits then the stop bit
reg [3:0]        tx_bits_reg;
reg [DW-1:0]     tx_cnt_reg;
wire             tx_take = !tx_busy_reg && (txf_count != {(FIFO_AW + 1){1'b0}});

soc_fifo #(.AW(FIFO_AW)) txf (
    .clk(clk), .rst(rst), .push(tx_push), .din(tx_data), .pop(tx_take), .q(txf_q),
    .count(txf_count), .full(tx_full)
);

assign tx_level = txf_count;

always @(posedge clk) begin
    if (tx_take) begin
        tx_busy_reg <= 1'b1;
        tx <= 1'b0;  // start bit
        tx_shift_reg <= {1'b1, txf_q};
        tx_bits_reg <= 4'd9;
        tx_cnt_reg <= DIV_LAST;
    end else if (tx_busy_reg) begin
        if (tx_cnt_reg == {DW{1'b0}}) begin
            if (tx_bits_reg == 4'd0) begin
                tx_busy_reg <= 1'b0;  // the stop bit has lasted a whole bit
            end else begin
                tx <= tx_shift_reg[0];
                tx_shift_reg <= {1'b1, tx_shift_reg[8:1]};
                tx_bits_reg <= tx_bits_reg - 4'd1;
                tx_cnt_reg <= DIV_LAST;
            end
        end else begin
            tx_cnt_reg <= tx_cnt_reg - 1'b1;
        end
    end
    if (rst) begin
        tx <= 1'b1;
        tx_busy_reg <= 1'b0;
        tx_bits_reg <= 4'd0;
        tx_cnt_reg <= {DW{1'b0}};
        tx_shift_reg <= 9'h1FF;
    end
end

// --- receive -------------------------------------------------------------------------------

reg [2:0]    rx_sync_reg;  // synchroniser; [2] is the sampled line
reg          rx_busy_reg;
reg [3:0]    rx_bits_reg;
reg [DW-1:0] rx_cnt_reg;
reg [7:0]    rx_shift_reg;
reg          rx_push_reg;
wire         rx_line = rx_sync_reg[2];
wire [FIFO_AW:0] rxf_count;
wire         rxf_full;

soc_fifo #(.AW(FIFO_AW)) rxf (
    .clk(clk), .rst(rst), .push(rx_push_reg), .din(rx_shift_reg), .pop(rx_pop), .q(rx_data),
    .count(rxf_count), .full(rxf_full)
);

assign rx_avail = (rxf_count != {(FIFO_AW + 1){1'b0}});

always @(posedge clk) begin
    rx_sync_reg <= {rx_sync_reg[1:0], rx};
    rx_push_reg <= 1'b0;
    if (!rx_busy_reg) begin
        if (!rx_line) begin  // start bit edge: its middle half a bit later
            rx_busy_reg <= 1'b1;
            rx_bits_reg <= 4'd0;
            rx_cnt_reg <= DIV_HALF;
        end
    end else if (rx_cnt_reg == {DW{1'b0}}) begin
        rx_cnt_reg <= DIV_LAST;
        if (rx_bits_reg == 4'd0) begin
            if (rx_line) begin
                rx_busy_reg <= 1'b0;  // glitch, not a start bit
            end
            rx_bits_reg <= 4'd1;
        end else if (rx_bits_reg == 4'd9) begin
            rx_busy_reg <= 1'b0;
            if (!rx_line) begin
                rx_frame_err <= 1'b1;
            end else if (rxf_full) begin
                rx_overrun <= 1'b1;
            end else begin
                rx_push_reg <= 1'b1;
            end
        end else begin
            rx_shift_reg <= {rx_line, rx_shift_reg[7:1]};
            rx_bits_reg <= rx_bits_reg + 4'd1;
        end
    end else begin
        rx_cnt_reg <= rx_cnt_reg - 1'b1;
    end
    if (clear_overrun) begin
        rx_overrun <= 1'b0;
    end
    if (clear_frame_err) begin
        rx_frame_err <= 1'b0;
    end
    if (rst) begin
        rx_sync_reg <= 3'b111;
        rx_busy_reg <= 1'b0;
        rx_bits_reg <= 4'd0;
        rx_cnt_reg <= {DW{1'b0}};
        rx_shift_reg <= 8'd0;
        rx_push_reg <= 1'b0;
        rx_overrun <= 1'b0;
        rx_frame_err <= 1'b0;
    end
end

endmodule

`resetall
