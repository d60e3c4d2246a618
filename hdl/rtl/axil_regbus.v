`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * AXI4-Lite slave to the simple register bus of bowden_regs.
 *
 * One transaction of each kind at a time: a write is taken when address and data are both
 * valid (and the previous response has been accepted), a read when the address is valid and no
 * read is in flight. The register file answers a read with reg_rd_valid. Decode errors give
 * SLVERR; everything else OKAY.
 */
module axil_regbus #(
    parameter ADDR_W = 8  // byte address width
) (
    input  wire              clk,
    input  wire              rst,

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

wire wr_go = s_axil_awvalid && s_axil_wvalid && !bvalid_reg;
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

endmodule

`resetall
