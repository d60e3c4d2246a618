`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * SPI slave (mode 0) to AXI4-Lite master: lets an external MCU running firmware/ reach the
 * registers of bowden_core on boards without a processor on chip.
 *
 * Frames, MSB first, chip select low for the whole frame:
 *   write: [1 a6..a0] [d31..d24] [d23..d16] [d15..d8] [d7..d0] [status]           (48 clocks)
 *   read:  [0 a6..a0] [dummy]    [d31..d24] [d23..d16] [d15..d8] [d7..d0] [status] (56 clocks)
 * a6..a0 is the word address (byte address / 4). The dummy byte gives the AXI read time; MISO
 * is 0 during the first two bytes (and during a write's data). A write is issued after its
 * 40th bit, a read after the 8th; the status byte on MISO then tells the MCU what became of
 * it (the MCU may end the frame before it, 40 or 48 clocks, and learn nothing):
 *   status = {3'b101, WRITE, DONE, BUSY, RESP[1:0]}
 *     101   fixed: a MISO line stuck at 0 or 1 never reads as a status
 *     WRITE the frame was a write
 *     DONE  the access was answered in time for this frame (a read's data is valid)
 *     BUSY  refused without a bus access: the previous access was still outstanding
 *     RESP  the AXI response: 00 OKAY, 10 SLVERR (refused by the register file), 11 DECERR
 *           (word address beyond the bus's ADDR_W: refused here, no bus access)
 *   e.g. 0xB8 write OKAY, 0xBA write refused by the register file (SLVERR), 0xBB write beyond
 *        the bus (DECERR), 0xA8 read OKAY, 0xAA read of an unmapped word (its data reads 0).
 * A frame cut short by chip select before its access point is dropped with no bus access.
 * After reset the bridge ignores the bus until chip select has been seen high, so a frame in
 * progress during reset is dropped whole rather than read from its middle.
 *
 * SCK, CS_N and MOSI are synchronized to clk, so SCK must be below clk / 8 (the bus access
 * guarantees need no such limit: hdl/formal/spi_axil_bridge.sby proves them for any pins).
 */
module spi_axil_bridge #(
    parameter ADDR_W = 8  // AXI byte address width (3..9; 9: the whole 7-bit word address)
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

localparam [1:0] RESP_OKAY = 2'b00;
localparam [1:0] RESP_DECERR = 2'b11;
localparam [2:0] STATUS_TAG = 3'b101;

// Two-flop synchronizers plus one stage for edge detection. Chip select resets to "low"
// (a frame may be in progress); `armed` waits for it to be seen high.
reg [2:0] sck_sync_reg;
reg [1:0] cs_sync_reg;
reg [1:0] mosi_sync_reg;

wire sck_rise = sck_sync_reg[1] && !sck_sync_reg[2];
wire sck_fall = !sck_sync_reg[1] && sck_sync_reg[2];
wire cs_active = !cs_sync_reg[1];
wire mosi = mosi_sync_reg[1];

reg  [5:0]  bit_cnt_reg, bit_cnt_next;     // bits received in this frame (saturates at 56)
reg         armed_reg, armed_next;         // chip select seen high since reset
reg  [7:0]  cmd_reg, cmd_next;             // {write, word address}
reg  [31:0] shift_in_reg, shift_in_next;
reg  [31:0] shift_out_reg, shift_out_next;
reg         miso_reg, miso_next;
reg         awvalid_reg, awvalid_next;
reg         wvalid_reg, wvalid_next;
reg         arvalid_reg, arvalid_next;
reg  [8:0]  addr_reg, addr_next;           // byte address of the access issued
reg  [31:0] wdata_reg, wdata_next;
reg         busy_reg, busy_next;           // an access is issued and not yet answered
reg         wait_reg, wait_next;           // this frame's access is not yet answered
reg         done_st_reg, done_st_next;     // status: DONE
reg         busy_st_reg, busy_st_next;     // status: BUSY
reg  [1:0]  resp_st_reg, resp_st_next;     // status: RESP

// Decodes of the bit count, registered: the next SCK edge comes two clocks later at the
// earliest (a rise needs a low sample first), so the flags have settled when it uses them, and
// no edge sees a long decode path. Gated by chip select, so a new frame never sees the last
// frame's count.
reg        in_cmd_reg;    // bit_cnt < 8
reg        rd_pt_reg;     // bit_cnt == 7 of a read: this rising edge is its access point
reg        pt_reg;        // this rising edge is an access point: bit_cnt == 7 of a read, 39 of a write
reg        go_reg;        // an access point whose word address fits the bus: an access is issued
                          // at this rising edge unless one is outstanding
reg        bad_reg;       // an access point whose word address is beyond the bus
reg        full_reg;      // bit_cnt == 56: the longest frame is complete
reg        data_out_reg;  // read data or status bits go out on MISO
reg        stat_ld_reg;   // this falling edge sends the status byte's first bit

wire [5:0] bits_after = bit_cnt_reg + 6'd1;
wire [7:0] cmd_now = {cmd_reg[6:0], mosi};

// The word address must fit the bus: a narrower bus would alias words onto others. A read's
// last address bit arrives with its access point, at byte address bit 2, inside any bus of
// ADDR_W >= 3, so the range check needs only the bits before it.
wire [8:0] rd_addr = {cmd_now[6:0], 2'b00};
wire [8:0] wr_addr = {cmd_reg[6:0], 2'b00};
wire [8:0] rd_addr_known = {cmd_reg[5:0], 3'b000};
wire       rd_in_range = (rd_addr_known >> ADDR_W) == 9'd0;
wire       wr_in_range = (wr_addr >> ADDR_W) == 9'd0;
wire       rd_pt_now = cs_active && armed_reg && bit_cnt_reg == 6'd7 && !cmd_reg[6];
wire       wr_pt_now = cs_active && armed_reg && bit_cnt_reg == 6'd39 && cmd_reg[7];

// The access point and the access itself, flat ANDs of registered flags and the pins' edge:
// the enables of the address, the valids and the status, through the frame's branches below,
// were the iCE40's longest paths. The flags imply the rest of the branches' conditions: they
// are registered from a count of 7 or 39 (so not full) with armed_reg set, which stays set.
wire       at_pt = sck_rise && cs_active && pt_reg;
wire       issue = sck_rise && cs_active && go_reg && !busy_reg;

wire       resp_now = m_axil_bvalid || m_axil_rvalid;
wire [1:0] resp_code = m_axil_rvalid ? m_axil_rresp : m_axil_bresp;
wire [7:0] status = {STATUS_TAG, cmd_reg[7], done_st_reg, busy_st_reg, resp_st_reg};
wire       shift_out_en = (sck_fall && (stat_ld_reg || data_out_reg)) ||
                          (wait_reg && m_axil_rvalid && !data_out_reg) || !cs_active;

always @* begin
    bit_cnt_next = bit_cnt_reg;
    armed_next = armed_reg || !cs_active;
    cmd_next = cmd_reg;
    shift_in_next = shift_in_reg;
    shift_out_next = shift_out_reg;
    miso_next = miso_reg;
    awvalid_next = awvalid_reg && !m_axil_awready;
    wvalid_next = wvalid_reg && !m_axil_wready;
    arvalid_next = arvalid_reg && !m_axil_arready;
    addr_next = addr_reg;
    wdata_next = wdata_reg;
    busy_next = busy_reg && !resp_now;
    wait_next = wait_reg && !resp_now && cs_active;
    done_st_next = done_st_reg;
    busy_st_next = busy_st_reg;
    resp_st_next = resp_st_reg;

    // The answer to this frame's access, in time for its status (and a read's data phase).
    if (wait_reg && resp_now && (cmd_reg[7] || !data_out_reg)) begin
        done_st_next = 1'b1;
        resp_st_next = resp_code;
    end

    // MISO's shift register, a flat priority (one short path): the status byte, the data
    // bits, a read's answer before its data phase, zero between frames (so a refused read's
    // data reads 0). Outside a frame MISO itself is held at 0 below.
    // Its enable is the OR of the four cases, spelled out flat (nested, it was the iCE40's
    // longest path once the write data's was shortened).
    if (shift_out_en) begin
        if (sck_fall && stat_ld_reg) begin
            shift_out_next = {status[6:0], 25'd0};
        end else if (sck_fall && data_out_reg) begin
            shift_out_next = {shift_out_reg[30:0], 1'b0};
        end else if (wait_reg && m_axil_rvalid && !data_out_reg) begin
            shift_out_next = m_axil_rdata;
        end else begin
            shift_out_next = 32'd0;
        end
    end

    if (!cs_active || !armed_reg) begin
        bit_cnt_next = 6'd0;
        miso_next = 1'b0;
    end else begin
        if (sck_rise && !full_reg) begin
            bit_cnt_next = bits_after;
            if (in_cmd_reg) begin
                cmd_next = cmd_now;
            end else begin
                shift_in_next = {shift_in_reg[30:0], mosi};
            end
        end
        // Mode 0: MISO changes on the falling edge before the bit is sampled.
        if (sck_fall) begin
            if (stat_ld_reg) begin
                miso_next = status[7];
            end else if (data_out_reg) begin
                miso_next = shift_out_reg[31];
            end else begin
                miso_next = 1'b0;
            end
        end
    end

    // The access point of a frame (the 8th bit of a read, the 40th of a write): the status
    // starts again, and the access is refused while the last one is outstanding (BUSY) or when
    // its word is beyond the bus (DECERR); else issued (a read fetches during the dummy byte).
    if (at_pt) begin
        done_st_next = busy_reg || bad_reg;
        busy_st_next = busy_reg;
        resp_st_next = (!busy_reg && bad_reg) ? RESP_DECERR : RESP_OKAY;
    end
    if (issue) begin
        busy_next = 1'b1;
        wait_next = 1'b1;
        if (rd_pt_reg) begin
            arvalid_next = 1'b1;
            addr_next = rd_addr;
        end else begin
            awvalid_next = 1'b1;
            wvalid_next = 1'b1;
            addr_next = wr_addr;
            wdata_next = {shift_in_reg[30:0], mosi};
        end
    end
end

always @(posedge clk) begin
    sck_sync_reg <= {sck_sync_reg[1:0], spi_sck};
    cs_sync_reg <= {cs_sync_reg[0], spi_cs_n};
    mosi_sync_reg <= {mosi_sync_reg[0], spi_mosi};
    bit_cnt_reg <= bit_cnt_next;
    armed_reg <= armed_next;
    in_cmd_reg <= !cs_active || bit_cnt_reg < 6'd8;
    rd_pt_reg <= rd_pt_now;
    pt_reg <= rd_pt_now || wr_pt_now;
    go_reg <= (rd_pt_now && rd_in_range) || (wr_pt_now && wr_in_range);
    bad_reg <= (rd_pt_now && !rd_in_range) || (wr_pt_now && !wr_in_range);
    full_reg <= cs_active && bit_cnt_reg == 6'd56;
    data_out_reg <= cs_active && armed_reg &&
                    (cmd_reg[7] ? bit_cnt_reg > 6'd40 : bit_cnt_reg >= 6'd16);
    stat_ld_reg <= cs_active && armed_reg &&
                   (cmd_reg[7] ? bit_cnt_reg == 6'd40 : bit_cnt_reg == 6'd48);
    cmd_reg <= cmd_next;
    shift_in_reg <= shift_in_next;
    shift_out_reg <= shift_out_next;
    miso_reg <= miso_next;
    awvalid_reg <= awvalid_next;
    wvalid_reg <= wvalid_next;
    arvalid_reg <= arvalid_next;
    addr_reg <= addr_next;
    wdata_reg <= wdata_next;
    busy_reg <= busy_next;
    wait_reg <= wait_next;
    done_st_reg <= done_st_next;
    busy_st_reg <= busy_st_next;
    resp_st_reg <= resp_st_next;
    if (rst) begin
        sck_sync_reg <= 3'b000;
        cs_sync_reg <= 2'b00;
        bit_cnt_reg <= 6'd0;
        armed_reg <= 1'b0;
        in_cmd_reg <= 1'b1;
        rd_pt_reg <= 1'b0;
        pt_reg <= 1'b0;
        go_reg <= 1'b0;
        bad_reg <= 1'b0;
        full_reg <= 1'b0;
        data_out_reg <= 1'b0;
        stat_ld_reg <= 1'b0;
        shift_out_reg <= 32'd0;
        miso_reg <= 1'b0;
        awvalid_reg <= 1'b0;
        wvalid_reg <= 1'b0;
        arvalid_reg <= 1'b0;
        busy_reg <= 1'b0;
        wait_reg <= 1'b0;
        done_st_reg <= 1'b0;
        busy_st_reg <= 1'b0;
        resp_st_reg <= RESP_OKAY;
    end
end

assign m_axil_awaddr = addr_reg[ADDR_W-1:0];
assign m_axil_awprot = 3'b000;
assign m_axil_awvalid = awvalid_reg;
assign m_axil_wdata = wdata_reg;
assign m_axil_wstrb = 4'hF;
assign m_axil_wvalid = wvalid_reg;
assign m_axil_bready = 1'b1;
assign m_axil_araddr = addr_reg[ADDR_W-1:0];
assign m_axil_arprot = 3'b000;
assign m_axil_arvalid = arvalid_reg;
assign m_axil_rready = 1'b1;
assign spi_miso = miso_reg;

// The upper address bits are zero whenever an access is issued (checked above).
wire unused_addr = &{1'b0, addr_reg};

`ifdef FORMAL
// --- formal properties (hdl/formal/spi_axil_bridge.sby; hdl/README.md says what is proven) --
//
// The bus properties spi_*, bridge side, for any pin activity (no limit on SCK) and any reset:
// a bus access only from a complete frame begun with chip select seen high, at its access
// point, with the frame's address (never aliased) and data; idle after chip select high; an
// AXI4-Lite master with one access at a time. The slave is assumed to follow AXI4-Lite.

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;
always @* if (!f_past_valid) assume(rst);

// The pins two clocks late (the synchronizers' delay), modelled on their own.
reg [2:0] f_sck;
reg [1:0] f_cs_n, f_mosi;
always @(posedge clk) begin
    f_sck <= {f_sck[1:0], spi_sck};
    f_cs_n <= {f_cs_n[0], spi_cs_n};
    f_mosi <= {f_mosi[0], spi_mosi};
    if (rst) begin
        f_sck <= 3'b000;
        f_cs_n <= 2'b00;
    end
end
wire f_cs = !f_cs_n[1];
reg [1:0] f_mosi_age = 2'd0;  // MOSI's synchronizer has no reset: equal after two clocks
always @(posedge clk) if (f_mosi_age != 2'd2) f_mosi_age <= f_mosi_age + 2'd1;
wire f_mosi_ok = f_mosi_age == 2'd2;
wire f_rise = f_sck[1] && !f_sck[2];

// The frame: bits clocked since chip select fell, once it has been seen high after reset.
reg        f_armed;
reg [5:0]  f_bits;
reg [7:0]  f_cmd;
reg [31:0] f_data;
always @(posedge clk) begin
    if (!f_cs) f_armed <= 1'b1;
    if (!f_cs || !f_armed) begin
        f_bits <= 6'd0;
    end else if (f_rise && f_bits != 6'd56) begin
        f_bits <= f_bits + 6'd1;
        if (f_bits < 6'd8) f_cmd <= {f_cmd[6:0], f_mosi[1]};
        else f_data <= {f_data[30:0], f_mosi[1]};
    end
    if (rst) begin
        f_armed <= 1'b0;
        f_bits <= 6'd0;
    end
end

// The AXI4-Lite slave: no response without its request, none during or right after reset.
reg f_aw_acc, f_w_acc, f_ar_acc;  // accepted, not yet answered
always @(posedge clk) begin
    if (m_axil_awvalid && m_axil_awready) f_aw_acc <= 1'b1;
    if (m_axil_wvalid && m_axil_wready) f_w_acc <= 1'b1;
    if (m_axil_arvalid && m_axil_arready) f_ar_acc <= 1'b1;
    if (m_axil_bvalid) {f_aw_acc, f_w_acc} <= 2'b00;
    if (m_axil_rvalid) f_ar_acc <= 1'b0;
    if (rst) {f_aw_acc, f_w_acc, f_ar_acc} <= 3'b000;
end
always @* begin
    if (rst || !f_past_valid || !(f_aw_acc && f_w_acc)) assume(!m_axil_bvalid);
    if (rst || !f_past_valid || !f_ar_acc) assume(!m_axil_rvalid);
end
always @(posedge clk) if (f_past_valid && $past(rst)) assume(!m_axil_bvalid && !m_axil_rvalid);

reg f_awv, f_arv;  // the valids one clock ago
always @(posedge clk) begin
    f_awv <= awvalid_reg;
    f_arv <= arvalid_reg;
end
wire f_issue_w = awvalid_reg && !f_awv;
wire f_issue_r = arvalid_reg && !f_arv;

always @* if (f_past_valid && !rst) begin
    // property spi_frame_count: the bridge's bit count, command and data are the frame's; nothing counts before chip select was seen high after reset
    // The bridge's count is the frame's; nothing counts before chip select was seen high.
    spi_frame_count: assert(armed_reg == f_armed);
    spi_frame_count_2: assert(bit_cnt_reg == f_bits);
    if (f_bits >= 6'd40) spi_frame_count_3: assert(shift_in_reg == f_data);
    else if (f_bits > 6'd8)
        spi_frame_count_4: assert(((shift_in_reg ^ f_data) & ~(32'hFFFFFFFF << (f_bits - 6'd8))) == 32'd0);
    if (f_bits >= 6'd8) spi_frame_count_5: assert(cmd_reg == f_cmd);
    else spi_frame_count_6: assert(((cmd_reg ^ f_cmd) & ~(8'hFF << f_bits)) == 8'd0);
    // property spi_sync_delay: the synchronizers are the model's two-clock delay line (induction helper)
    // Helpers for the induction: the synchronizers are the model's delay line.
    spi_sync_delay: assert(sck_sync_reg == f_sck && cs_sync_reg == f_cs_n);
    if (f_mosi_ok) spi_sync_delay_2: assert(mosi_sync_reg == f_mosi);
    // property spi_one_access: one access at a time, never a word beyond ADDR_W, address and data valid together
    // One access at a time: a write's address and data, or a read, until it is answered.
    spi_one_access: assert(!((awvalid_reg || wvalid_reg || f_aw_acc || f_w_acc) &&
             (arvalid_reg || f_ar_acc)));
    spi_one_access_2: assert(busy_reg == (awvalid_reg || wvalid_reg || f_aw_acc || f_w_acc ||
                        arvalid_reg || f_ar_acc));
    if (awvalid_reg || wvalid_reg || arvalid_reg) spi_one_access_3: assert((addr_reg >> ADDR_W) == 9'd0);
    spi_one_access_4: assert(awvalid_reg == wvalid_reg || f_aw_acc || f_w_acc);
    spi_one_access_5: assert(!(f_aw_acc && awvalid_reg) && !(f_w_acc && wvalid_reg) && !(f_ar_acc && arvalid_reg));
    if (wait_reg) spi_one_access_6: assert(busy_reg);
end

// property spi_idle_after_cs: the clock after chip select high: no bits counted, no access from a partial frame
// The idle state after chip select high: no bits, no access from a partial frame.
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(!f_cs))
    spi_idle_after_cs: assert(bit_cnt_reg == 6'd0 && !f_issue_w && !f_issue_r);

// property spi_access_point: a write only after the 40th bit of a write frame, a read only after the 8th of a read frame, with the frame's address (never aliased) and data
// An access only at the access point of a complete frame, with the frame's address and data.
always @(posedge clk) if (f_past_valid && !rst) begin
    if (f_issue_w) begin
        spi_access_point: assert($past(f_rise) && f_bits == 6'd40 && f_cmd[7]);
        spi_access_point_2: assert(addr_reg == {f_cmd[6:0], 2'b00} && wdata_reg == f_data);
        spi_access_point_3: assert(wvalid_reg && m_axil_wstrb == 4'hF);
    end
    if (f_issue_r) begin
        spi_access_point_4: assert($past(f_rise) && f_bits == 6'd8 && !f_cmd[7]);
        spi_access_point_5: assert(addr_reg == {f_cmd[6:0], 2'b00});
    end
    if ($past(wvalid_reg) && !wvalid_reg) spi_access_point_6: assert($past(m_axil_wready) || $past(rst));
end

// property spi_axi_valid_held: AXI4-Lite master rules: a valid stays, with its payload, until it is taken
// AXI4-Lite master rules: a valid stays, with its payload, until it is taken.
always @(posedge clk) if (f_past_valid && !$past(rst) && !rst) begin
    if ($past(awvalid_reg && !m_axil_awready))
        spi_axi_valid_held: assert(awvalid_reg && $stable(m_axil_awaddr));
    if ($past(wvalid_reg && !m_axil_wready)) spi_axi_valid_held_2: assert(wvalid_reg && $stable(m_axil_wdata));
    if ($past(arvalid_reg && !m_axil_arready))
        spi_axi_valid_held_3: assert(arvalid_reg && $stable(m_axil_araddr));
end
// property spi_reset_idle: no AXI request the clock after reset
always @(posedge clk) if (f_past_valid && $past(rst))
    spi_reset_idle: assert(!awvalid_reg && !wvalid_reg && !arvalid_reg);

// Covers: each kind of frame, each refusal, and a frame after a reset in mid-frame.
reg f_rst_mid;  // a reset came while a frame was in progress
always @(posedge clk) begin
    if (rst && f_bits != 6'd0) f_rst_mid <= 1'b1;
    if (!f_past_valid) f_rst_mid <= 1'b0;
end
always @(posedge clk) if (f_past_valid && !rst && !$past(rst)) begin
    cover(f_issue_w);
    cover(f_issue_r && $past(m_axil_rvalid, 3));          // a read right after another
    cover(m_axil_bvalid && m_axil_bresp == 2'b10 && cmd_reg[7] && done_st_next);
    cover($past(pt_reg && !rd_pt_reg && sck_rise) && resp_st_reg == RESP_DECERR);
    cover($past(rd_pt_reg && sck_rise && busy_reg) && busy_st_reg);
    cover(f_rst_mid && f_issue_w);
end
`endif

endmodule

`resetall
