`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * AXI4-Lite slave to the simple register bus of bowden_regs.
 *
 * One transaction of each kind at a time: a write is taken when address and data are both
 * valid (and the previous response has been accepted) and wr_hold is low, a read when the
 * address is valid and no read is in flight. wr_hold stalls writes while the loop reads its
 * live configuration (bowden_soc: tension_loop's cfg_busy, at most 14 clocks; 0 elsewhere).
 * The register file answers a read with reg_rd_valid, however many clocks later. Decode errors
 * give SLVERR; everything else OKAY.
 */
module axil_regbus #(
    parameter ADDR_W = 8  // byte address width
) (
    input  wire              clk,
    input  wire              rst,

    input  wire              wr_hold,  // hold writes (not taken) while high

    /*
     * AXI4-Lite slave
     */
    input  wire [ADDR_W-1:0] s_axil_awaddr,
    input  wire [2:0]        s_axil_awprot,
    input  wire              s_axil_awvalid,
    output wire              s_axil_awready,
    input  wire [31:0]       s_axil_wdata,
    input  wire [3:0]        s_axil_wstrb,
    input  wire              s_axil_wvalid,
    output wire              s_axil_wready,
    output wire [1:0]        s_axil_bresp,
    output wire              s_axil_bvalid,
    input  wire              s_axil_bready,
    input  wire [ADDR_W-1:0] s_axil_araddr,
    input  wire [2:0]        s_axil_arprot,
    input  wire              s_axil_arvalid,
    output wire              s_axil_arready,
    output wire [31:0]       s_axil_rdata,
    output wire [1:0]        s_axil_rresp,
    output wire              s_axil_rvalid,
    input  wire              s_axil_rready,

    /*
     * Register bus master
     */
    output wire              reg_wr_en,
    output wire [ADDR_W-1:0] reg_wr_addr,
    output wire [31:0]       reg_wr_data,
    output wire [3:0]        reg_wr_strb,
    input  wire              reg_wr_err,
    output wire              reg_rd_en,
    output wire [ADDR_W-1:0] reg_rd_addr,
    input  wire [31:0]       reg_rd_data,
    input  wire              reg_rd_err,
    input  wire              reg_rd_valid
);

localparam [1:0] RESP_OKAY = 2'b00;
localparam [1:0] RESP_SLVERR = 2'b10;

reg       bvalid_reg, bvalid_next;
reg [1:0] bresp_reg, bresp_next;
reg       rvalid_reg, rvalid_next;
reg       rwait_reg, rwait_next;  // read issued, waiting for reg_rd_valid

wire wr_go = s_axil_awvalid && s_axil_wvalid && !bvalid_reg && !wr_hold;
wire rd_go = s_axil_arvalid && !rvalid_reg && !rwait_reg;

always @* begin
    bvalid_next = bvalid_reg && !s_axil_bready;
    bresp_next = bresp_reg;
    rvalid_next = (rvalid_reg && !s_axil_rready) || reg_rd_valid;
    rwait_next = (rwait_reg && !reg_rd_valid) || rd_go;
    if (wr_go) begin
        bvalid_next = 1'b1;
        bresp_next = reg_wr_err ? RESP_SLVERR : RESP_OKAY;
    end
end

always @(posedge clk) begin
    bvalid_reg <= bvalid_next;
    bresp_reg <= bresp_next;
    rvalid_reg <= rvalid_next;
    rwait_reg <= rwait_next;
    if (rst) begin
        bvalid_reg <= 1'b0;
        bresp_reg <= RESP_OKAY;
        rvalid_reg <= 1'b0;
        rwait_reg <= 1'b0;
    end
end

assign s_axil_awready = wr_go;
assign s_axil_wready = wr_go;
assign s_axil_bvalid = bvalid_reg;
assign s_axil_bresp = bresp_reg;
assign s_axil_arready = rd_go;
// The register file holds its read data until the next read, so R needs no buffer.
assign s_axil_rvalid = rvalid_reg;
assign s_axil_rdata = reg_rd_data;
assign s_axil_rresp = reg_rd_err ? RESP_SLVERR : RESP_OKAY;

assign reg_wr_en = wr_go;
assign reg_wr_addr = s_axil_awaddr;
assign reg_wr_data = s_axil_wdata;
assign reg_wr_strb = s_axil_wstrb;
assign reg_rd_en = rd_go;
assign reg_rd_addr = s_axil_araddr;

// Protection attributes carry no meaning for these registers.
wire unused_prot = &{1'b0, s_axil_awprot, s_axil_arprot};

`ifdef FORMAL
// --- formal properties (hdl/formal/bowden_core.sby; hdl/README.md says what is proven) -----
//
// The bus properties axil_*, slave side: under the AXI4-Lite rules for the master (assumed), every
// request gets exactly one response, in order, within a bounded time, never a response without
// a request, and the response code is the register file's error flag for that address.

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;
always @* if (!f_past_valid) assume(rst);

// The master: no valid during reset; a valid stays, with its payload, until it is taken.
always @* if (rst) assume(!s_axil_awvalid && !s_axil_wvalid && !s_axil_arvalid);
always @(posedge clk) if (f_past_valid && !$past(rst)) begin
    if ($past(s_axil_awvalid && !s_axil_awready))
        assume(s_axil_awvalid && $stable(s_axil_awaddr) && $stable(s_axil_awprot));
    if ($past(s_axil_wvalid && !s_axil_wready))
        assume(s_axil_wvalid && $stable(s_axil_wdata) && $stable(s_axil_wstrb));
    if ($past(s_axil_arvalid && !s_axil_arready))
        assume(s_axil_arvalid && $stable(s_axil_araddr) && $stable(s_axil_arprot));
end

// Outstanding requests (accepted, not yet answered) per channel.
reg [1:0] f_wr_out, f_rd_out;
reg [2:0] f_rd_age;  // clocks the outstanding read has waited
reg       f_wr_err;  // the register file refused the outstanding write
wire f_aw_hs = s_axil_awvalid && s_axil_awready;
wire f_w_hs = s_axil_wvalid && s_axil_wready;
wire f_ar_hs = s_axil_arvalid && s_axil_arready;
wire f_b_hs = s_axil_bvalid && s_axil_bready;
wire f_r_hs = s_axil_rvalid && s_axil_rready;
always @(posedge clk) begin
    f_wr_out <= f_wr_out + {1'b0, f_aw_hs} - {1'b0, f_b_hs};
    f_rd_out <= f_rd_out + {1'b0, f_ar_hs} - {1'b0, f_r_hs};
    f_rd_age <= (f_rd_out != 2'd0 && !s_axil_rvalid) ? f_rd_age + 3'd1 : 3'd0;
    if (f_aw_hs) f_wr_err <= reg_wr_err;
    if (rst) begin
        f_wr_out <= 2'd0;
        f_rd_out <= 2'd0;
        f_rd_age <= 3'd0;
    end
end

always @* if (f_past_valid && !rst) begin
    // property axil_one_at_a_time: address and data are taken together, at most one write and one read outstanding
    // Address and data are taken together, one write and one read at a time.
    axil_one_at_a_time: assert(s_axil_awready == s_axil_wready);
    axil_one_at_a_time_2: assert(f_wr_out <= 2'd1 && f_rd_out <= 2'd1);
    // property axil_one_response: a response exactly for an outstanding request: none without one, none twice
    // A response exactly for an outstanding request (none without one, none twice).
    axil_one_response: assert(s_axil_bvalid == (f_wr_out == 2'd1));
    if (s_axil_rvalid) axil_one_response_2: assert(f_rd_out == 2'd1);
    if (s_axil_awready) axil_one_response_3: assert(f_wr_out == 2'd0 || f_b_hs);
    if (s_axil_arready) axil_one_response_4: assert(f_rd_out == 2'd0);
    // property axil_no_deadlock: a read is answered within 4 clocks, a write on the next clock, and a request finding nothing outstanding is taken at once (a write unless wr_hold)
    // No deadlock: a read is answered within 4 clocks, a write on the next clock (above), and
    // a request finding nothing outstanding is taken at once (a write unless held: how long
    // bowden_core holds it is core_write_hold).
    axil_no_deadlock: assert(f_rd_age <= 3'd3);
    if (s_axil_awvalid && s_axil_wvalid && f_wr_out == 2'd0 && !wr_hold) axil_no_deadlock_2: assert(s_axil_awready);
    if (s_axil_arvalid && f_rd_out == 2'd0) axil_no_deadlock_3: assert(s_axil_arready);
    // property axil_resp_code: BRESP and RRESP are SLVERR exactly for unmapped addresses, else OKAY
    // The write response is the register file's verdict (SLVERR for unmapped, else OKAY).
    if (s_axil_bvalid) axil_resp_code: assert(s_axil_bresp == (f_wr_err ? RESP_SLVERR : RESP_OKAY));
    if (s_axil_rvalid) axil_resp_code_2: assert(s_axil_rresp == (reg_rd_err ? RESP_SLVERR : RESP_OKAY));
    // property axil_read_in_flight: the read wait flag is the outstanding read not yet answered (induction helper)
    // Helpers for the induction: the read in flight.
    axil_read_in_flight: assert(rwait_reg == (f_rd_out == 2'd1 && !s_axil_rvalid));
end

// property axil_resp_held: a response waits, unchanged, until it is taken
always @(posedge clk) if (f_past_valid && !$past(rst)) begin
    if ($past(s_axil_bvalid && !s_axil_bready)) axil_resp_held: assert(s_axil_bvalid && $stable(s_axil_bresp));
    if ($past(s_axil_rvalid && !s_axil_rready))
        axil_resp_held_2: assert(s_axil_rvalid && $stable(s_axil_rdata) && $stable(s_axil_rresp));
end

always @(posedge clk) if (f_past_valid && !rst && !$past(rst)) begin
    cover(f_b_hs && s_axil_bresp == RESP_SLVERR);
    cover(f_r_hs && s_axil_rresp == RESP_SLVERR);
    cover($past(f_r_hs) && f_ar_hs);  // a read right after the last one's response
    cover($past(s_axil_bvalid && !s_axil_bready) && f_b_hs);  // a stalled response
end
`endif

endmodule

`resetall
