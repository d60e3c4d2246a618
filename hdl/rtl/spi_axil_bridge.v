`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * SPI slave (mode 0) to AXI4-Lite master: lets an external MCU running firmware/ reach the
 * registers of bowden_core on boards without a processor on chip.
 *
 * Frames, MSB first, chip select low for the whole frame:
 *   write: [1 a6..a0] [d31..d24] [d23..d16] [d15..d8] [d7..d0]           (40 clocks)
 *   read:  [0 a6..a0] [dummy]    [d31..d24] [d23..d16] [d15..d8] [d7..d0] (48 clocks)
 * a6..a0 is the word address (byte address / 4). The dummy byte gives the AXI read time; MISO
 * is 0 during the first two bytes. A write is issued after its 40th bit, a read after the 8th.
 * A frame cut short by chip select is dropped. The AXI error responses are not reported.
 *
 * SCK, CS_N and MOSI are synchronized to clk, so SCK must be below clk / 8.
 */
module spi_axil_bridge #(
    parameter ADDR_W = 8  // AXI byte address width (<= 9: 7-bit word address)
) (
    input  wire              clk,
    input  wire              rst,

    /*
     * SPI slave
     */
    input  wire              spi_sck,
    input  wire              spi_cs_n,
    input  wire              spi_mosi,
    output wire              spi_miso,

    /*
     * AXI4-Lite master
     */
    output wire [ADDR_W-1:0] m_axil_awaddr,
    output wire [2:0]        m_axil_awprot,
    output wire              m_axil_awvalid,
    input  wire              m_axil_awready,
    output wire [31:0]       m_axil_wdata,
    output wire [3:0]        m_axil_wstrb,
    output wire              m_axil_wvalid,
    input  wire              m_axil_wready,
    input  wire [1:0]        m_axil_bresp,
    input  wire              m_axil_bvalid,
    output wire              m_axil_bready,
    output wire [ADDR_W-1:0] m_axil_araddr,
    output wire [2:0]        m_axil_arprot,
    output wire              m_axil_arvalid,
    input  wire              m_axil_arready,
    input  wire [31:0]       m_axil_rdata,
    input  wire [1:0]        m_axil_rresp,
    input  wire              m_axil_rvalid,
    output wire              m_axil_rready
);

// Two-flop synchronizers plus one stage for edge detection.
reg [2:0] sck_sync_reg;
reg [1:0] cs_sync_reg;
reg [1:0] mosi_sync_reg;

wire sck_rise = sck_sync_reg[1] && !sck_sync_reg[2];
wire sck_fall = !sck_sync_reg[1] && sck_sync_reg[2];
wire cs_active = !cs_sync_reg[1];
wire mosi = mosi_sync_reg[1];

reg  [5:0]  bit_cnt_reg, bit_cnt_next;     // bits received in this frame (saturates at 48)
reg  [7:0]  cmd_reg, cmd_next;             // {write, word address}
reg  [31:0] shift_in_reg, shift_in_next;
reg  [31:0] shift_out_reg, shift_out_next;
reg         miso_reg, miso_next;
reg         awvalid_reg, awvalid_next;
reg         wvalid_reg, wvalid_next;
reg         arvalid_reg, arvalid_next;
reg  [31:0] wdata_reg, wdata_next;

// Decodes of the bit count, registered: SCK edges are at least 8 clocks apart, so the flags
// have settled long before the next edge uses them, and no edge sees a long decode path.
reg        in_cmd_reg;    // bit_cnt < 8
reg        last_cmd_reg;  // bit_cnt == 7: this rising edge completes the command byte
reg        last_wr_reg;   // bit_cnt == 39: this rising edge completes a write frame
reg        done_reg;      // bit_cnt == 48: the frame is complete
reg        data_out_reg;  // bit_cnt >= 16: read data goes out on MISO

wire [5:0] bits_after = bit_cnt_reg + 6'd1;
wire [7:0] cmd_now = {cmd_reg[6:0], mosi};

always @* begin
    bit_cnt_next = bit_cnt_reg;
    cmd_next = cmd_reg;
    shift_in_next = shift_in_reg;
    shift_out_next = shift_out_reg;
    miso_next = miso_reg;
    awvalid_next = awvalid_reg && !m_axil_awready;
    wvalid_next = wvalid_reg && !m_axil_wready;
    arvalid_next = arvalid_reg && !m_axil_arready;
    wdata_next = wdata_reg;

    if (!cs_active) begin
        bit_cnt_next = 6'd0;
        miso_next = 1'b0;
    end else begin
        if (sck_rise && !done_reg) begin
            bit_cnt_next = bits_after;
            if (in_cmd_reg) begin
                cmd_next = cmd_now;
            end else begin
                shift_in_next = {shift_in_reg[30:0], mosi};
            end
            if (last_cmd_reg && !cmd_now[7]) begin
                arvalid_next = 1'b1;  // read: fetch during the dummy byte
            end
            if (last_wr_reg && cmd_reg[7]) begin
                awvalid_next = 1'b1;
                wvalid_next = 1'b1;
                wdata_next = {shift_in_reg[30:0], mosi};
            end
        end
        // Mode 0: MISO changes on the falling edge before the bit is sampled.
        if (sck_fall) begin
            if (data_out_reg) begin
                miso_next = shift_out_reg[31];
                shift_out_next = {shift_out_reg[30:0], 1'b0};
            end else begin
                miso_next = 1'b0;
            end
        end
    end
    if (m_axil_rvalid) begin
        shift_out_next = m_axil_rdata;
    end
end

always @(posedge clk) begin
    sck_sync_reg <= {sck_sync_reg[1:0], spi_sck};
    cs_sync_reg <= {cs_sync_reg[0], spi_cs_n};
    mosi_sync_reg <= {mosi_sync_reg[0], spi_mosi};
    bit_cnt_reg <= bit_cnt_next;
    in_cmd_reg <= bit_cnt_reg < 6'd8;
    last_cmd_reg <= bit_cnt_reg == 6'd7;
    last_wr_reg <= bit_cnt_reg == 6'd39;
    done_reg <= bit_cnt_reg == 6'd48;
    data_out_reg <= bit_cnt_reg >= 6'd16;
    cmd_reg <= cmd_next;
    shift_in_reg <= shift_in_next;
    shift_out_reg <= shift_out_next;
    miso_reg <= miso_next;
    awvalid_reg <= awvalid_next;
    wvalid_reg <= wvalid_next;
    arvalid_reg <= arvalid_next;
    wdata_reg <= wdata_next;
    if (rst) begin
        sck_sync_reg <= 3'b000;
        cs_sync_reg <= 2'b11;
        bit_cnt_reg <= 6'd0;
        shift_out_reg <= 32'd0;
        miso_reg <= 1'b0;
        awvalid_reg <= 1'b0;
        wvalid_reg <= 1'b0;
        arvalid_reg <= 1'b0;
    end
end

// Word address to byte address; upper address bits beyond ADDR_W are dropped (ADDR_W <= 9).
wire [8:0] byte_addr = {cmd_reg[6:0], 2'b00};

assign m_axil_awaddr = byte_addr[ADDR_W-1:0];
assign m_axil_awprot = 3'b000;
assign m_axil_awvalid = awvalid_reg;
assign m_axil_wdata = wdata_reg;
assign m_axil_wstrb = 4'hF;
assign m_axil_wvalid = wvalid_reg;
assign m_axil_bready = 1'b1;
assign m_axil_araddr = byte_addr[ADDR_W-1:0];
assign m_axil_arprot = 3'b000;
assign m_axil_arvalid = arvalid_reg;
assign m_axil_rready = 1'b1;
assign spi_miso = miso_reg;

// Responses are accepted and not reported over SPI.
wire unused_resp = &{1'b0, m_axil_bresp, m_axil_bvalid, m_axil_rresp, byte_addr};

endmodule

`resetall
