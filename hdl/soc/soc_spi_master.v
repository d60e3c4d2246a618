`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * SPI master for the board's NOR flash, mode 0, MSB first: `start` sends `din` and receives a
 * byte in 8 SCK periods of 2 * HALF_CLKS clocks; `busy` until `dout` holds the received byte.
 * Chip select is the firmware's (cs_n follows `cs`). SCLK = CLK / (2 * HALF_CLKS): 12 MHz at
 * 24 MHz with HALF_CLKS 1 (the flash takes 50 MHz for its plain read, W25Q128JV sec. 9.6).
 */
module soc_spi_master #(
    parameter HALF_CLKS = 1
) (
    input  wire       clk,
    input  wire       rst,
    input  wire       cs,
    input  wire       start,
    input  wire [7:0] din,
    output reg        busy,
    output reg  [7:0] dout,
    output reg        sck,
    output reg        cs_n,
    output wire       mosi,
    input  wire       miso
);

localparam integer HW = (HALF_CLKS > 1) ? $clog2(HALF_CLKS) : 1;
localparam integer HALF_LAST_INT = HALF_CLKS - 1;
localparam [HW-1:0] HALF_LAST = HALF_LAST_INT[HW-1:0];

reg [7:0]    shift_reg;
reg [3:0]    edges_reg;  // SCK edges left (16 per byte)
reg [HW-1:0] half_reg;

assign mosi = shift_reg[7];

always @(posedge clk) begin
    cs_n <= !cs;
    if (!busy) begin
        if (start) begin
            busy <= 1'b1;
            shift_reg <= din;
            edges_reg <= 4'd15;
            half_reg <= HALF_LAST;
        end
    end else if (half_reg != {HW{1'b0}}) begin
        half_reg <= half_reg - 1'b1;
    end else begin
        half_reg <= HALF_LAST;
        sck <= !sck;
        if (!sck) begin
            dout <= {dout[6:0], miso};  // rising edge: sample
        end else begin
            shift_reg <= {shift_reg[6:0], 1'b0};  // falling edge: next bit out
        end
        if (edges_reg == 4'd0) begin
            busy <= 1'b0;
        end else begin
            edges_reg <= edges_reg - 4'd1;
        end
    end
    if (rst) begin
        busy <= 1'b0;
        sck <= 1'b0;
        cs_n <= 1'b1;
        shift_reg <= 8'd0;
        edges_reg <= 4'd0;
        half_reg <= {HW{1'b0}};
        dout <= 8'd0;
    end
end

endmodule

`resetall
