`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Boot copier of the UP5K SoC: the image is too large for the UP5K's 15 KiB of EBR and its
 * SPRAM cannot be initialised by the bitstream, so after reset this copies the image from the
 * SPI flash into the program memory while the CPU is held in reset, then lets it go (`done`).
 *
 * Flash layout at BOOT_ADDR (firmware/soc/tools/mkimage.py --flash): a 32-bit little-endian
 * byte count, then the image. Sequence: release from power-down (0xAB) and wait tRES1 (3 us,
 * W25Q128JV sec. 9.6: WAKE_CLKS), then one read (0x03) of the count and the words. A count above
 * the memory (a blank flash reads 0xFFFFFFFF) is clipped to it: the CPU then finds no valid code
 * and traps (cpu_trap), which the board shows rather than hanging silently.
 */
module soc_boot #(
    parameter [23:0] BOOT_ADDR = 24'h080000,
    parameter WORDS = 16384,
    parameter WAKE_CLKS = 100
) (
    input  wire                     clk,
    input  wire                     rst,
    output reg                      done,
    // the SPI master (soc_spi_master), owned until done
    output reg                      spi_cs,
    output reg                      spi_start,
    output reg  [7:0]               spi_din,
    input  wire                     spi_busy,
    input  wire [7:0]               spi_dout,
    // program memory write port
    output reg                      mem_we,
    output reg  [$clog2(WORDS)-1:0] mem_addr,
    output reg  [31:0]              mem_wdata
);

localparam AW = $clog2(WORDS);
localparam [2:0] S_WAKE = 3'd0, S_WAKE_WAIT = 3'd1, S_CMD = 3'd2, S_LEN = 3'd3, S_DATA = 3'd4,
                 S_DONE = 3'd5;

reg [2:0]  state_reg;
reg [1:0]  byte_reg;      // byte within the word (or command byte index)
reg        wait_reg;      // a byte is on its way
reg [15:0] wake_reg;
reg [31:8] word_reg;     // the bytes so far, shifted down as the next arrives
reg [AW:0] left_reg;      // words still to copy

// Little-endian: the first byte of a word ends in bits 7..0 after the fourth.
wire [31:0] word_next = {spi_dout, word_reg[31:8]};
wire [31:0] len_words = (word_next + 32'd3) >> 2;
localparam [AW:0] WORDS_W = WORDS;

always @(posedge clk) begin
    spi_start <= 1'b0;
    mem_we <= 1'b0;
    if (wait_reg) begin
        if (!spi_busy && !spi_start) begin
            wait_reg <= 1'b0;
            case (state_reg)
                S_WAKE: begin
                    spi_cs <= 1'b0;
                    state_reg <= S_WAKE_WAIT;
                end
                S_CMD: begin
                    byte_reg <= byte_reg + 2'd1;
                    if (byte_reg == 2'd3) begin
                        state_reg <= S_LEN;
                        byte_reg <= 2'd0;
                    end
                end
                S_LEN: begin
                    word_reg <= word_next[31:8];
                    byte_reg <= byte_reg + 2'd1;
                    if (byte_reg == 2'd3) begin
                        byte_reg <= 2'd0;
                        left_reg <= (len_words > {{(31 - AW){1'b0}}, WORDS_W}) ? WORDS_W :
                                    len_words[AW:0];
                        state_reg <= (word_next == 32'd0) ? S_DONE : S_DATA;
                        mem_addr <= {AW{1'b1}};  // the first write adds one
                    end
                end
                S_DATA: begin
                    word_reg <= word_next[31:8];
                    byte_reg <= byte_reg + 2'd1;
                    if (byte_reg == 2'd3) begin
                        byte_reg <= 2'd0;
                        mem_we <= 1'b1;
                        mem_addr <= mem_addr + 1'b1;
                        mem_wdata <= word_next;
                        left_reg <= left_reg - 1'b1;
                        if (left_reg == {{AW{1'b0}}, 1'b1}) begin
                            state_reg <= S_DONE;
                        end
                    end
                end
                default: ;
            endcase
        end
    end else begin
        case (state_reg)
            S_WAKE: begin
                spi_cs <= 1'b1;
                spi_din <= 8'hAB;
                spi_start <= 1'b1;
                wait_reg <= 1'b1;
            end
            S_WAKE_WAIT: begin
                wake_reg <= wake_reg + 16'd1;
                if (wake_reg == WAKE_CLKS[15:0]) begin
                    state_reg <= S_CMD;
                end
            end
            S_CMD: begin
                spi_cs <= 1'b1;
                case (byte_reg)
                    2'd0: spi_din <= 8'h03;
                    2'd1: spi_din <= BOOT_ADDR[23:16];
                    2'd2: spi_din <= BOOT_ADDR[15:8];
                    default: spi_din <= BOOT_ADDR[7:0];
                endcase
                spi_start <= 1'b1;
                wait_reg <= 1'b1;
            end
            S_LEN, S_DATA: begin
                spi_din <= 8'h00;
                spi_start <= 1'b1;
                wait_reg <= 1'b1;
            end
            default: begin  // S_DONE
                spi_cs <= 1'b0;
                done <= 1'b1;
            end
        endcase
    end
    if (rst) begin
        state_reg <= S_WAKE;
        byte_reg <= 2'd0;
        wait_reg <= 1'b0;
        wake_reg <= 16'd0;
        word_reg <= 24'd0;
        left_reg <= {(AW + 1){1'b0}};
        done <= 1'b0;
        spi_cs <= 1'b0;
        spi_start <= 1'b0;
        spi_din <= 8'd0;
        mem_we <= 1'b0;
        mem_addr <= {AW{1'b0}};
        mem_wdata <= 32'd0;
    end
end

endmodule

`resetall
