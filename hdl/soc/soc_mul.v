`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * RV32 multiply (MUL, MULH, MULHSU, MULHU: the Zmmul subset) for picorv32's co-processor port
 * (PCPI, picorv32 README "Pico Co-Processor Interface"), in one DSP used four times: the UP5K
 * has no room for picorv32's own single-pass multiplier (ENABLE_FAST_MUL: a 33 x 33 product
 * whose partial products are summed in LUTs, some 400 logic cells; hdl/README.md, "The CPU,
 * measured").
 *
 * The 64-bit product of the operands as unsigned words, from the four 16 x 16 products
 * (al = rs1[15:0], ah = rs1[31:16], bl, bh likewise), then the signed corrections of the high word:
 *   P_u = al*bl + (al*bh + ah*bl) * 2^16 + ah*bh * 2^32
 *   P   = P_u - (rs1 signed and negative ? rs2 : 0) * 2^32 - (rs2 signed and negative ? rs1 : 0) * 2^32
 * (two's complement: a negative rs1 is its unsigned word minus 2^32), modulo 2^64.
 *
 * One product is started a clock (clocks 0..3) and is ready two clocks later (operand and product
 * registers inside the DSP, as in mul_s16.v); the 33-bit accumulator takes them at clocks 2..5:
 *   2: acc = al*bl                       5: acc = acc / 2^16 + ah*bh (the high word, unsigned)
 *   3: lo[15:0] = acc[15:0],             6, 7: acc -= rs2 when rs1 is signed and negative, and
 *      acc = acc / 2^16 + al*bh                acc -= rs1 when rs2 is, each only when needed
 *   4: acc += ah*bl (MUL: the low word is {acc[15:0], lo[15:0]}: done)
 * The answer is registered in lo; ready the clock after the last step (MUL: 6 clocks from the
 * request, MULHU 7, MULH / MULHSU 7 to 9). picorv32 holds the instruction and the operands (pcpi_valid, rs1,
 * rs2) until pcpi_ready, and drops pcpi_valid the clock after it.
 */
module soc_mul (
    input  wire        clk,
    input  wire        rst,

    input  wire        pcpi_valid,
    input  wire [31:0] pcpi_insn,
    input  wire [31:0] pcpi_rs1,
    input  wire [31:0] pcpi_rs2,
    output wire        pcpi_wr,
    output wire [31:0] pcpi_rd,
    output wire        pcpi_wait,
    output wire        pcpi_ready
);

// OP funct7 0000001, funct3 0xx: the multiplies (1xx are the divides, not here)
wire is_mul = pcpi_valid && (pcpi_insn[6:0] == 7'b0110011) && (pcpi_insn[31:25] == 7'b0000001) &&
              !pcpi_insn[14];
wire [1:0] op = pcpi_insn[13:12];
wire unused_insn = &{1'b0, pcpi_insn[24:15], pcpi_insn[11:7]};  // the registers: picorv32's  // 00 MUL, 01 MULH, 10 MULHSU, 11 MULHU
wire fix_a = ((op == 2'b01) || (op == 2'b10)) && pcpi_rs1[31];  // rs1 signed and negative
wire fix_b = (op == 2'b01) && pcpi_rs2[31];                      // rs2 signed and negative

reg  [2:0]  t_reg;      // clock of the operation (0..7)
reg         busy_reg;
reg         ready_reg;
reg  [32:0] acc_reg;
reg  [31:0] lo_reg;     // the low half-word so far, then the answer

// The DSP: operands and product registered inside it (no reset, no enable).
reg  [15:0] x_reg, y_reg;
reg  [31:0] p_reg;
wire [15:0] x = t_reg[1] ? pcpi_rs1[31:16] : pcpi_rs1[15:0];  // al, al, ah, ah
wire [15:0] y = t_reg[0] ? pcpi_rs2[31:16] : pcpi_rs2[15:0];  // bl, bh, bl, bh

always @(posedge clk) begin
    x_reg <= x;
    y_reg <= y;
    p_reg <= x_reg * y_reg;
end

// Clocks 6 and 7 subtract the corrections: rs2 first when rs1 needs one, then rs1.
wire        fix = (t_reg == 3'd6) ? (fix_a || fix_b) : fix_b;
wire [31:0] fix_word = (t_reg == 3'd6 && fix_a) ? pcpi_rs2 : pcpi_rs1;
wire [32:0] base = (t_reg == 3'd3 || t_reg == 3'd5) ? {16'd0, acc_reg[32:16]} : acc_reg;
wire [32:0] addend = t_reg[2] && t_reg[1] ? (fix ? {1'b1, ~fix_word} : 33'd0) : {1'b0, p_reg};
wire [32:0] acc_next = base + addend + {32'd0, t_reg[2] && t_reg[1] && fix};

// The last clock: MUL after clock 4 (the low word needs no ah*bh), the others after clock 5,
// 6 or 7 as their corrections need.
wire last = (t_reg == 3'd4 && op == 2'b00) ||
            (t_reg == 3'd5 && !fix_a && !fix_b) ||
            (t_reg == 3'd6 && !(fix_a && fix_b)) ||
            (t_reg == 3'd7);

always @(posedge clk) begin
    ready_reg <= 1'b0;
    if (busy_reg) begin
        t_reg <= t_reg + 3'd1;
        acc_reg <= acc_next;
        if (t_reg == 3'd3) begin
            lo_reg[15:0] <= acc_reg[15:0];
        end
        if (last) begin
            // MUL: the low word's upper half; MULH*: the high word
            lo_reg[31:16] <= (op == 2'b00) ? acc_next[15:0] : acc_next[31:16];
            if (op != 2'b00) begin
                lo_reg[15:0] <= acc_next[15:0];
            end
            busy_reg <= 1'b0;
            ready_reg <= 1'b1;
            t_reg <= 3'd0;  // idle at 0: the next operation's first product starts at once
        end
    end else if (is_mul && !ready_reg) begin
        busy_reg <= 1'b1;
        t_reg <= 3'd1;
    end
    if (busy_reg && t_reg == 3'd1) begin
        acc_reg <= 33'd0;  // clock 2 adds the first product to nothing
    end
    if (rst) begin
        busy_reg <= 1'b0;
        ready_reg <= 1'b0;
        t_reg <= 3'd0;
    end
end

assign pcpi_wr = ready_reg;
assign pcpi_ready = ready_reg;
assign pcpi_rd = lo_reg;
assign pcpi_wait = busy_reg;

endmodule

`resetall
