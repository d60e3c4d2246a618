`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * The whole controller on one FPGA: a picorv32 (RV32I with Zmmul: the multiplier soc_mul on its
 * co-processor port, in one DSP; no divider, no compressed instructions, no interrupt, no traps,
 * which the UP5K has no room for; from the pythondata-cpu-picorv32 package, not copied here)
 * runs the bench firmware (firmware/soc) next to the tension loop.
 *
 *   picorv32 --+-- 0x0000_0000 ROM: the image ($readmemh of ROM_INIT, or written by the boot loader)
 *              +-- 0x1000_0000 RAM: data and stack
 *              +-- 0x2000_0000 the core's register map, a bank a cable (AXI4-Lite via
 *                              picorv32_axi_adapter)
 *              +-- 0x3000_0000 UART (bench protocol), timer (the 1 kHz tick's count), SPI flash
 *                              master (settings), system words, CRC-32C unit (firmware/soc/soc.h)
 *   bowden_core(_mc) <- ads131m02_reader <- ADS131M0x;  bowden_core(_mc) -> ESCON per cable (PWM
 *                                                       set value, enable)
 *
 * CHANNELS cables (1, 2 or 4): one ADS131M0x with two channels a cable (the ADS131M02 for one,
 * the M04 for two, the M08 for four; cable k's T_in on ADC channel 2k, its T_out on 2k + 1),
 * channel k's register bank at 0x2000_0000 + k * 0x100 (bank 0 is the one-cable map, which the
 * firmware drives), one PWM and one enable output a cable. Channels 2j and 2j + 1 are one safety
 * group (an antagonistic pair: a fault on one ramps both to zero). One cable is bowden_core,
 * more are bowden_core_mc. The firmware reads the count from SOC_SYS_CHANNELS.
 *
 * Every rate is an exact number of clocks at CLK_HZ (checked at elaboration): the loop's sample
 * (CLK_HZ / SAMPLE_HZ), the PWM period (CLK_HZ / PWM_HZ) and the firmware's tick (the timer's
 * period, CLK_HZ / tick rate, set by the firmware from SOC_SYS_CLK_HZ). The UART's bit is the
 * nearest whole number of clocks (soc_uart.v).
 *
 * CPU_FAST selects picorv32's single-cycle barrel shifter over its two-stage shifter (four bits
 * a clock); hdl/README.md, "bowden_soc", compares the two.
 */
module bowden_soc #(
    parameter CHANNELS = 1,           // cables: 1, 2 or 4 (one ADS131M0x, two ADC channels a cable)
    parameter CLK_HZ = 24000000,      // system clock, Hz
    parameter SAMPLE_HZ = 10000,      // loop rate, Hz (CLK_HZ a multiple of it)
    parameter PWM_HZ = 5000,          // ESCON PWM frequency, Hz (CLK_HZ a multiple of it)
    parameter BAUD = 921600,          // UART, 8N1
    parameter UART_FIFO_AW = 9,       // UART FIFOs of 512 bytes each
    parameter ROM_WORDS = 16384,      // 64 KiB image (mk/soc.mk SOC_ROM_BYTES)
    parameter RAM_WORDS = 4096,       // 16 KiB data and stack (mk/soc.mk SOC_RAM_BYTES)
    parameter ROM_INIT = "",          // $readmemh file of the image
    parameter CPU_FAST = 1,           // 1: barrel shifter; 0: the two-stage shifter (fewer LUTs)
    parameter CPU_MUL = 1,            // RV32I + Zmmul: 1 soc_mul on the co-processor port (one DSP,
                                      // 6..9 clocks), 2 picorv32's own (4 DSPs, 3 clocks); 0: none
    parameter MEM_SPRAM = 0,          // 1: ROM and RAM in the UP5K's SPRAMs (16384 words each)
    parameter CFG_RAM = 0,            // CHANNELS > 1: 1 the banks' configuration words in a
                                      // block RAM (bowden_core_mc's CFG_RAM; the UP5K's top)
    parameter SEQ = 0,                // CFG_RAM 1: 1 the loops on the sequenced datapath
                                      // (bowden_core_mc's SEQ)
    parameter BOOT_FLASH = 0,         // 1: the CPU starts in the boot loader (BOOT_INIT), which copies
                                      // the image from the flash into the (writable) ROM
    parameter BOOT_INIT = "",         // $readmemh file of the boot loader (firmware/soc/boot.S)
    parameter BOOT_WORDS = 64,        // its block RAM at 0x4000_0000
    parameter FLASH_HALF_CLKS = 1,    // flash SCK half period, clocks
    parameter ADC_SCLK_HALF_CLKS = 3, // ADC SCLK half period, clocks (24 MHz -> 4 MHz, >= 3)
    parameter ADC_WAIT_CLKS = 8192    // ADC wait after power-up, clocks
) (
    input  wire clk,
    input  wire rst,

    // bench protocol
    input  wire uart_rx,
    output wire uart_tx,

    // SPI NOR flash (settings; the bitstream's flash)
    output wire flash_sck,
    output wire flash_cs_n,
    output wire flash_mosi,
    input  wire flash_miso,

    // ADS131M02 (SPI mode 1)
    output wire adc_sclk,
    output wire adc_cs_n,
    output wire adc_din,
    input  wire adc_dout,
    input  wire adc_drdy_n,

    // ESCON drives, cable k in bit k
    output wire [CHANNELS-1:0] drive_pwm,
    output wire [CHANNELS-1:0] drive_enable,

    // status
    output wire fault,       // a loop fault is latched on some cable
    output wire cpu_trap,    // the CPU stopped on an illegal instruction or misaligned access
    output wire boot_done,   // the image is in place and the CPU runs
    output wire sample_tick  // one clock at the start of each loop sample
);

// --- elaboration checks: exact rates --------------------------------------------------------

generate
    if (CLK_HZ % SAMPLE_HZ != 0) begin : g_check_sample
        bowden_soc_CLK_HZ_must_be_a_multiple_of_SAMPLE_HZ error_SAMPLE_HZ ();
    end
    if (CHANNELS != 1 && CHANNELS != 2 && CHANNELS != 4) begin : g_check_channels
        // two ADC channels a cable on one ADS131M0x, whose largest part has eight
        bowden_soc_CHANNELS_must_be_1_2_or_4 error_CHANNELS ();
    end
    if (CLK_HZ % PWM_HZ != 0) begin : g_check_pwm
        bowden_soc_CLK_HZ_must_be_a_multiple_of_PWM_HZ error_PWM_HZ ();
    end
endgenerate

localparam ROM_AW = $clog2(ROM_WORDS);
localparam RAM_AW = $clog2(RAM_WORDS);

// --- CPU -------------------------------------------------------------------------------------

wire        mem_valid, mem_instr, mem_ready;
wire [31:0] mem_addr, mem_wdata, mem_rdata;
wire [3:0]  mem_wstrb;

wire        unused_cpu;
wire [31:0] eoi, la_addr, la_wdata, pcpi_insn, pcpi_rs1, pcpi_rs2;
wire [3:0]  la_wstrb;
wire        la_read, la_write, pcpi_valid, trace_valid;
wire [35:0] trace_data;
wire        pcpi_wr, pcpi_wait, pcpi_ready;
wire [31:0] pcpi_rd;

// No interrupt (the firmware polls the timer's tick count: its interrupt only counted ticks),
// no trap on a misaligned access or an illegal instruction (the code is the compiler's), the
// multiplier outside (soc_mul): the UP5K has no room for more (hdl/README.md, "The CPU,
// measured"). EBREAK / ECALL still stop the CPU (cpu_trap). LATCHED_MEM_RDATA: every source of
// mem_rdata holds its word after the transfer (block RAMs, SPRAMs, the registered I/O word, the
// register map's read register), and without compressed instructions picorv32 reads mem_rdata
// only in the transfer's clock, so its own copy's multiplexer is not needed. No reset value of
// the stack pointer (STACKADDR at its default): start.S and boot.S set or never use sp, and the
// reset's write of x2 cost 10 logic cells of the UP5K's two cables (hdl/README.md, "Room for two
// cables on the UP5K").
picorv32 #(
    .ENABLE_COUNTERS(0), .ENABLE_COUNTERS64(0), .ENABLE_REGS_16_31(1),
    .ENABLE_REGS_DUALPORT(1), .LATCHED_MEM_RDATA(1), .TWO_STAGE_SHIFT(1),
    .BARREL_SHIFTER(CPU_FAST), .TWO_CYCLE_COMPARE(0), .TWO_CYCLE_ALU(0),
    .COMPRESSED_ISA(0), .CATCH_MISALIGN(0), .CATCH_ILLINSN(0),
    .ENABLE_MUL(0), .ENABLE_FAST_MUL(CPU_MUL == 2), .ENABLE_DIV(0), .ENABLE_PCPI(CPU_MUL == 1),
    .ENABLE_IRQ(0), .ENABLE_IRQ_QREGS(0), .ENABLE_IRQ_TIMER(0), .ENABLE_TRACE(0),
    .REGS_INIT_ZERO(0), .PROGADDR_RESET((BOOT_FLASH != 0) ? 32'h4000_0000 : 32'h0000_0000),
    .STACKADDR(32'hffff_ffff)  // none: the firmware's start.S sets sp first
) cpu (
    .clk(clk), .resetn(!rst), .trap(cpu_trap),
    .mem_valid(mem_valid), .mem_instr(mem_instr), .mem_ready(mem_ready),
    .mem_addr(mem_addr), .mem_wdata(mem_wdata), .mem_wstrb(mem_wstrb), .mem_rdata(mem_rdata),
    .mem_la_read(la_read), .mem_la_write(la_write), .mem_la_addr(la_addr),
    .mem_la_wdata(la_wdata), .mem_la_wstrb(la_wstrb),
    .pcpi_valid(pcpi_valid), .pcpi_insn(pcpi_insn), .pcpi_rs1(pcpi_rs1), .pcpi_rs2(pcpi_rs2),
    .pcpi_wr(pcpi_wr), .pcpi_rd(pcpi_rd),
    .pcpi_wait(pcpi_wait), .pcpi_ready(pcpi_ready),
    .irq(32'd0), .eoi(eoi),
    .trace_valid(trace_valid), .trace_data(trace_data)
);

// The multiplier (RV32I + Zmmul) on the co-processor port: one DSP, 6 to 9 clocks a multiply.
generate
    if (CPU_MUL == 1) begin : g_mul
        soc_mul mul (
            .clk(clk), .rst(rst), .pcpi_valid(pcpi_valid), .pcpi_insn(pcpi_insn),
            .pcpi_rs1(pcpi_rs1), .pcpi_rs2(pcpi_rs2), .pcpi_wr(pcpi_wr), .pcpi_rd(pcpi_rd),
            .pcpi_wait(pcpi_wait), .pcpi_ready(pcpi_ready)
        );
    end else begin : g_no_mul
        assign pcpi_wr = 1'b0;
        assign pcpi_rd = 32'd0;
        assign pcpi_wait = 1'b0;
        assign pcpi_ready = 1'b0;
    end
endgenerate

// The trace is not used.
assign unused_cpu = &{1'b0, eoi, trace_valid, trace_data,
                      (CPU_MUL == 1) ? 1'b0 : &{pcpi_valid, pcpi_insn, pcpi_rs1, pcpi_rs2}};

// --- bus decode ------------------------------------------------------------------------------

wire sel_rom = (mem_addr[31:28] == 4'h0);
wire sel_ram = (mem_addr[31:28] == 4'h1);
wire sel_regs = (mem_addr[31:28] == 4'h2);
wire sel_io = (mem_addr[31:28] == 4'h3);
wire sel_boot = (BOOT_FLASH != 0) && (mem_addr[31:28] == 4'h4);
wire sel_none = !(sel_rom || sel_ram || sel_regs || sel_io || sel_boot);

// ROM and RAM are accessed through picorv32's look-ahead interface: the address, data and
// strobes of the next transfer come a clock before mem_valid (picorv32 README, "Look-Ahead
// Interface"), so the block RAM's registered read is ready in the clock mem_valid rises, and
// the transfer ends there (a CPI of about 4.1 instead of 5.2 on Dhrystone, same README). I/O and
// unmapped addresses answer in the clock after the request (an unmapped access reads 0 and
// writes nothing); the register map answers through AXI4-Lite.
wire la_rom = (la_addr[31:28] == 4'h0);
wire la_ram = (la_addr[31:28] == 4'h1);
wire la_go = la_read || la_write;

reg  ready_reg;
wire crc_wait;  // an access to the CRC unit while it takes a byte waits for it (soc_crc32c.v)
wire access = mem_valid && !ready_reg && (sel_io || sel_none) && !crc_wait;
wire io_access = access && sel_io;

always @(posedge clk) begin
    ready_reg <= access;
    if (rst) begin
        ready_reg <= 1'b0;
    end
end

wire [31:0] rom_rdata, ram_rdata;
reg  [31:0] io_rdata_reg;

// Boot loader (BOOT_FLASH): a block RAM the bitstream initialises, where the CPU starts; it
// writes the image into the ROM (writable then) and jumps to it. boot_done: the CPU has fetched
// from the ROM (the image runs).
wire [31:0] boot_rdata;
wire        la_boot = (la_addr[31:28] == 4'h4);
wire        spi_busy;
wire [7:0]  spi_dout;

generate
    if (BOOT_FLASH != 0) begin : g_boot
        soc_ram #(.WORDS(BOOT_WORDS), .INIT_FILE(BOOT_INIT)) boot (
            .clk(clk), .en(la_read && la_boot), .we(4'd0),
            .addr(la_addr[$clog2(BOOT_WORDS)+1:2]), .wdata(32'd0), .rdata(boot_rdata)
        );
        reg boot_done_reg;
        always @(posedge clk) begin
            if (mem_valid && mem_instr && sel_rom) begin
                boot_done_reg <= 1'b1;
            end
            if (rst) begin
                boot_done_reg <= 1'b0;
            end
        end
        assign boot_done = boot_done_reg;
    end else begin : g_no_boot
        assign boot_rdata = 32'd0;
        assign boot_done = 1'b1;
    end
endgenerate

wire              rom_en = ((BOOT_FLASH != 0) ? la_go : la_read) && la_rom;
wire [3:0]        rom_we = (BOOT_FLASH != 0 && la_write) ? la_wstrb : 4'd0;
wire [ROM_AW-1:0] rom_addr = la_addr[ROM_AW+1:2];
wire              ram_en = la_go && la_ram;
wire [3:0]        ram_we = la_write ? la_wstrb : 4'd0;
wire [RAM_AW-1:0] ram_addr = la_addr[RAM_AW+1:2];

generate
    if (MEM_SPRAM != 0) begin : g_spram
        soc_spram rom (
            .clk(clk), .en(rom_en), .we(rom_we), .addr(rom_addr), .wdata(la_wdata),
            .rdata(rom_rdata)
        );
        soc_spram ram (
            .clk(clk), .en(ram_en), .we(ram_we), .addr(ram_addr), .wdata(la_wdata),
            .rdata(ram_rdata)
        );
    end else begin : g_bram
        soc_ram #(.WORDS(ROM_WORDS), .INIT_FILE(ROM_INIT)) rom (
            .clk(clk), .en(rom_en), .we(rom_we), .addr(rom_addr), .wdata(la_wdata),
            .rdata(rom_rdata)
        );
        soc_ram #(.WORDS(RAM_WORDS)) ram (
            .clk(clk), .en(ram_en), .we(ram_we), .addr(ram_addr), .wdata(la_wdata),
            .rdata(ram_rdata)
        );
    end
endgenerate

// --- register map: the core over AXI4-Lite ---------------------------------------------------

localparam ADDR_W = 8;                                     // a bank's byte address width
localparam CH_W = (CHANNELS > 1) ? $clog2(CHANNELS) : 0;   // bank select bits
localparam BUS_W = ADDR_W + CH_W;                          // the banks' byte address width

wire        axi_awvalid, axi_awready, axi_wvalid, axi_wready, axi_bvalid, axi_bready;
wire        axi_arvalid, axi_arready, axi_rvalid, axi_rready;
wire [31:0] axi_awaddr, axi_araddr, axi_wdata, axi_rdata;
wire [2:0]  axi_awprot, axi_arprot;
wire [3:0]  axi_wstrb;
wire [1:0]  axi_bresp, axi_rresp;
wire        regs_ready;
wire [31:0] regs_rdata;

picorv32_axi_adapter axi_adapter (
    .clk(clk), .resetn(!rst),
    .mem_axi_awvalid(axi_awvalid), .mem_axi_awready(axi_awready), .mem_axi_awaddr(axi_awaddr),
    .mem_axi_awprot(axi_awprot), .mem_axi_wvalid(axi_wvalid), .mem_axi_wready(axi_wready),
    .mem_axi_wdata(axi_wdata), .mem_axi_wstrb(axi_wstrb), .mem_axi_bvalid(axi_bvalid),
    .mem_axi_bready(axi_bready), .mem_axi_arvalid(axi_arvalid), .mem_axi_arready(axi_arready),
    .mem_axi_araddr(axi_araddr), .mem_axi_arprot(axi_arprot), .mem_axi_rvalid(axi_rvalid),
    .mem_axi_rready(axi_rready), .mem_axi_rdata(axi_rdata),
    .mem_valid(mem_valid && sel_regs), .mem_instr(mem_instr), .mem_ready(regs_ready),
    .mem_addr(mem_addr), .mem_wdata(mem_wdata), .mem_wstrb(mem_wstrb), .mem_rdata(regs_rdata)
);

// An SLVERR (unmapped register word) reads 0, as on the SPI bridge; the response codes are for
// the bus, the firmware knows its map.
wire unused_axi = &{1'b0, axi_awaddr[31:BUS_W], axi_araddr[31:BUS_W], axi_bresp, axi_rresp};

// --- load-cell ADC (as bowden_system wires it) -----------------------------------------------

// One cable: the ADS131M02 at OSR 128 (32 kSPS), its 96-bit frame in 24 us of the 31.25 us
// period at SCLK clk / 6. More cables: the 4- and 8-channel parts' frames (144 and 240 bits,
// 36 and 58 us at 24 and 25 MHz) do not fit that period, so OSR 256 (16 kSPS, 62.5 us: a fresh
// conversion at every 10 kHz sample still; CLOCK's OSR field bits 4:2 = 001, the ADS131M04 and
// ADS131M08 datasheets, "Register Map").
localparam ADC_NCH = 2 * CHANNELS;
localparam integer ADC_CLOCK_INT = (CHANNELS == 1) ? 32'h0302 :
                                   ((((1 << ADC_NCH) - 1) << 8) | 32'h06);  // CHn_EN, OSR, PWR
localparam [15:0] ADC_CLOCK_REG = ADC_CLOCK_INT[15:0];
localparam integer ADC_PERIOD_DIV = (CHANNELS == 1) ? 32000 : 16000;  // conversions a second
localparam integer ADC_FRAME_BITS = 24 * (ADC_NCH + 2);
// drdy_lost after four conversion periods without DRDY, or four frames' time if longer.
localparam integer DRDY_TIMEOUT_PERIODS = (4 * CLK_HZ) / ADC_PERIOD_DIV;
localparam integer DRDY_TIMEOUT_FRAMES = 4 * 2 * ADC_FRAME_BITS * ADC_SCLK_HALF_CLKS;
localparam integer ADC_DRDY_TIMEOUT_CLKS = (DRDY_TIMEOUT_PERIODS > DRDY_TIMEOUT_FRAMES) ?
                                           DRDY_TIMEOUT_PERIODS : DRDY_TIMEOUT_FRAMES;

wire                  rdr_valid;
wire [ADC_NCH*24-1:0] rdr_ch_data;
wire                  adc_drdy_lost, adc_crc_err;
wire [15:0]           adc_status;

ads131m02_reader #(
    .NCH(ADC_NCH), .CLOCK_REG(ADC_CLOCK_REG),
    .SCLK_HALF_CLKS(ADC_SCLK_HALF_CLKS), .WAIT_CLKS(ADC_WAIT_CLKS),
    .DRDY_TIMEOUT_CLKS(ADC_DRDY_TIMEOUT_CLKS)
) adc (
    .clk(clk), .rst(rst),
    .adc_sclk(adc_sclk), .adc_cs_n(adc_cs_n), .adc_din(adc_din), .adc_dout(adc_dout),
    .adc_drdy_n(adc_drdy_n), .adc_valid(rdr_valid),
    .adc_ch_data(rdr_ch_data),  // cable k: CH 2k (T_in), CH 2k + 1 (T_out)
    .adc_status(adc_status), .crc_error(adc_crc_err),
    .drdy_lost(adc_drdy_lost)
);

wire unused_adc_status = &{1'b0, adc_status};

// The same two clocks of latency as bowden_system (cosim.parts.interface.CORE_PIPE_CLKS) on the
// valid bit; the data needs no pipeline of its own: the reader holds a code from its valid clock
// until the next frame's (some 750 clocks later), so the code at the delayed valid is the same.
reg [1:0]  adc_valid_pipe_reg;

always @(posedge clk) begin
    adc_valid_pipe_reg <= {adc_valid_pipe_reg[0], rdr_valid};
    if (rst) begin
        adc_valid_pipe_reg <= 2'b00;
    end
end

// Channels 2j and 2j + 1 in group j (an antagonistic pair; one cable alone in group 0).
localparam GROUP_W = 4;

function [CHANNELS*GROUP_W-1:0] pair_groups;
    input integer n;
    integer c;
    begin
        pair_groups = {CHANNELS*GROUP_W{1'b0}};
        for (c = 0; c < n; c = c + 1) begin
            pair_groups[c*GROUP_W +: GROUP_W] = c[GROUP_W:1];
        end
    end
endfunction

wire [CHANNELS*16-1:0] cmd_current;
wire                   cmd_valid;
wire [CHANNELS-1:0]    ch_fault;
wire unused_cmd = &{1'b0, cmd_current, cmd_valid};

// One cable: bowden_core (the one-cable SoC bit for bit). Its loop reads
// the live registers (SNAPSHOT 0) and the read-back takes one clock (RD_STAGES 1): the 48 MHz
// boards' read pipeline and configuration snapshot (355 flip-flops, most of them a logic cell
// each) do not fit the UP5K and 24/25 MHz does not need them (hdl/README.md, "Bitstreams").
// bowden_core_mc with N = 1 computes the same samples but loads each channel's configuration and
// state into the datapath the clock before its slot: 643 logic cells more on the UP5K (5647, over
// its 5280), which only pays for itself from two channels on.
// More cables: bowden_core_mc, a bank and a PWM a cable, the loops on one time-multiplexed
// datapath, with the one-clock read-back; on the UP5K (CFG_RAM 1) the banks' configuration
// words in a block RAM whose output register is the datapath's loaded configuration.
generate
    if (CHANNELS == 1) begin : g_core
        bowden_core #(
            .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .PWM_HZ(PWM_HZ), .ADDR_W(ADDR_W),
            .RD_STAGES(1), .SNAPSHOT(0)
        ) core (
            .clk(clk), .rst(rst),
            .s_axil_awaddr(axi_awaddr[BUS_W-1:0]), .s_axil_awprot(axi_awprot),
            .s_axil_awvalid(axi_awvalid), .s_axil_awready(axi_awready), .s_axil_wdata(axi_wdata),
            .s_axil_wstrb(axi_wstrb), .s_axil_wvalid(axi_wvalid), .s_axil_wready(axi_wready),
            .s_axil_bresp(axi_bresp), .s_axil_bvalid(axi_bvalid), .s_axil_bready(axi_bready),
            .s_axil_araddr(axi_araddr[BUS_W-1:0]), .s_axil_arprot(axi_arprot),
            .s_axil_arvalid(axi_arvalid), .s_axil_arready(axi_arready), .s_axil_rdata(axi_rdata),
            .s_axil_rresp(axi_rresp), .s_axil_rvalid(axi_rvalid), .s_axil_rready(axi_rready),
            .adc_valid(adc_valid_pipe_reg[1]), .adc_data(rdr_ch_data[23:0]),
            .adc_aux_data(rdr_ch_data[47:24]), .adc_drdy_lost(adc_drdy_lost),
            .adc_crc_err(adc_crc_err),
            .cmd_current(cmd_current), .cmd_enable(drive_enable), .cmd_valid(cmd_valid),
            .fault(ch_fault), .pwm(drive_pwm), .sample_tick(sample_tick)
        );
    end else begin : g_core_mc
        bowden_core_mc #(
            .N(CHANNELS), .GROUP_W(GROUP_W), .GROUP(pair_groups(CHANNELS)),
            .CLK_HZ(CLK_HZ), .SAMPLE_HZ(SAMPLE_HZ), .PWM_HZ(PWM_HZ), .ADDR_W(ADDR_W),
            .RD_STAGES(1), .CFG_RAM(CFG_RAM), .SEQ(SEQ)
        ) core (
            .clk(clk), .rst(rst),
            .s_axil_awaddr(axi_awaddr[BUS_W-1:0]), .s_axil_awprot(axi_awprot),
            .s_axil_awvalid(axi_awvalid), .s_axil_awready(axi_awready), .s_axil_wdata(axi_wdata),
            .s_axil_wstrb(axi_wstrb), .s_axil_wvalid(axi_wvalid), .s_axil_wready(axi_wready),
            .s_axil_bresp(axi_bresp), .s_axil_bvalid(axi_bvalid), .s_axil_bready(axi_bready),
            .s_axil_araddr(axi_araddr[BUS_W-1:0]), .s_axil_arprot(axi_arprot),
            .s_axil_arvalid(axi_arvalid), .s_axil_arready(axi_arready), .s_axil_rdata(axi_rdata),
            .s_axil_rresp(axi_rresp), .s_axil_rvalid(axi_rvalid), .s_axil_rready(axi_rready),
            .adc_valid({CHANNELS{adc_valid_pipe_reg[1]}}), .adc_ch_data(rdr_ch_data),
            .adc_drdy_lost(adc_drdy_lost), .adc_crc_err(adc_crc_err),
            .cmd_current(cmd_current), .cmd_enable(drive_enable), .cmd_valid(cmd_valid),
            .fault(ch_fault), .pwm(drive_pwm), .sample_tick(sample_tick)
        );
    end
endgenerate

assign fault = |ch_fault;

// --- I/O: UART, timer, SPI flash, system -----------------------------------------------------

// firmware/soc/soc.h offsets (word index = offset / 4)
localparam [5:0] IO_UART_DATA = 6'h00, IO_UART_STATUS = 6'h01, IO_TIMER_COUNT = 6'h04,
                 IO_TIMER_PERIOD = 6'h05, IO_TIMER_TICKS = 6'h06, IO_SPI_CS = 6'h08,
                 IO_SPI_DATA = 6'h09, IO_SYS_CLK_HZ = 6'h0C, IO_SYS_MARK = 6'h0D,
                 IO_SYS_CHANNELS = 6'h0E,
                 IO_CRC_STATE = 6'h10, IO_CRC_DATA = 6'h11;

wire [5:0] io_word = mem_addr[7:2];
wire       io_wr = io_access && (mem_wstrb != 4'd0);
wire       io_rd = io_access && (mem_wstrb == 4'd0);
wire       unused_io_addr = &{1'b0, mem_addr[27:8], mem_addr[1:0], sel_none, la_addr[27:15],
                              la_addr[1:0], la_boot};

wire [7:0] uart_rx_data;
wire       uart_rx_avail, uart_tx_full, uart_overrun, uart_frame_err;
wire [UART_FIFO_AW:0] uart_tx_level;

soc_uart #(.CLK_HZ(CLK_HZ), .BAUD(BAUD), .FIFO_AW(UART_FIFO_AW)) uart (
    .clk(clk), .rst(rst), .rx(uart_rx), .tx(uart_tx),
    .tx_push(io_wr && io_word == IO_UART_DATA), .tx_data(mem_wdata[7:0]), .tx_full(uart_tx_full),
    .tx_level(uart_tx_level),
    .rx_pop(io_rd && io_word == IO_UART_DATA), .rx_data(uart_rx_data),
    .rx_avail(uart_rx_avail), .rx_overrun(uart_overrun), .rx_frame_err(uart_frame_err),
    .clear_overrun(io_wr && io_word == IO_UART_STATUS && mem_wdata[2]),
    .clear_frame_err(io_wr && io_word == IO_UART_STATUS && mem_wdata[3])
);

wire        crc_busy;
wire [31:0] crc_state;
wire        crc_sel = sel_io && (io_word == IO_CRC_STATE || io_word == IO_CRC_DATA);
assign crc_wait = crc_sel && crc_busy;

soc_crc32c crc (
    .clk(clk), .rst(rst),
    .load(io_wr && io_word == IO_CRC_STATE), .load_value(mem_wdata),
    .push(io_wr && io_word == IO_CRC_DATA), .byte_in(mem_wdata[7:0]),
    .busy(crc_busy), .state(crc_state)
);

reg        spi_cs_reg;

soc_spi_master #(.HALF_CLKS(FLASH_HALF_CLKS)) spi (
    .clk(clk), .rst(rst), .cs(spi_cs_reg), .start(io_wr && io_word == IO_SPI_DATA),
    .din(mem_wdata[7:0]),
    .busy(spi_busy), .dout(spi_dout),
    .sck(flash_sck), .cs_n(flash_cs_n), .mosi(flash_mosi), .miso(flash_miso)
);

// The period is at most CLK_HZ (a tick rate of 1 Hz, the firmware's lowest): TIMER_W bits.
localparam TIMER_W = $clog2(CLK_HZ + 1);

reg [31:0]        timer_count_reg;
reg [TIMER_W-1:0] timer_period_reg, timer_phase_reg;
reg [15:0]        timer_ticks_reg;
// The firmware's phase, for the simulation's probes only (public: cosim/bench/emulate/soc/ reads
// it).
reg [7:0]                 mark_reg /*verilator public_flat_rd*/;
wire                      unused_mark = &{1'b0, mark_reg};

always @(posedge clk) begin
    // Timer: the tick count goes up every timer_period_reg clocks (0: stopped); a new period
    // restarts it. The phase counts down from the period to 1 (no comparison with period - 1).
    timer_count_reg <= timer_count_reg + 32'd1;
    if (timer_period_reg == {TIMER_W{1'b0}}) begin
        timer_phase_reg <= {TIMER_W{1'b0}};
    end else if (timer_phase_reg[TIMER_W-1:1] == {(TIMER_W - 1){1'b0}}) begin
        timer_phase_reg <= timer_period_reg;
        timer_ticks_reg <= timer_ticks_reg + 16'd1;
    end else begin
        timer_phase_reg <= timer_phase_reg - {{(TIMER_W - 1){1'b0}}, 1'b1};
    end
    if (io_wr) begin
        case (io_word)
            IO_TIMER_PERIOD: begin
                timer_period_reg <= mem_wdata[TIMER_W-1:0];
                timer_phase_reg <= mem_wdata[TIMER_W-1:0];
            end
            IO_SPI_CS: spi_cs_reg <= mem_wdata[0];
            IO_SYS_MARK: mark_reg <= mem_wdata[7:0];
            default: ;
        endcase
    end
    if (io_rd) begin
        case (io_word)
            IO_UART_DATA: io_rdata_reg <= {23'd0, uart_rx_avail, uart_rx_data};
            IO_UART_STATUS: io_rdata_reg <= {{(15 - UART_FIFO_AW){1'b0}}, uart_tx_level,
                                             12'd0, uart_frame_err, uart_overrun,
                                             uart_rx_avail, uart_tx_full};
            IO_TIMER_COUNT: io_rdata_reg <= timer_count_reg;
            IO_TIMER_TICKS: io_rdata_reg <= {16'd0, timer_ticks_reg};
            IO_SPI_DATA: io_rdata_reg <= {23'd0, spi_busy, spi_dout};
            IO_SYS_CLK_HZ: io_rdata_reg <= CLK_HZ;
            IO_SYS_CHANNELS: io_rdata_reg <= CHANNELS;
            IO_CRC_STATE: io_rdata_reg <= crc_state;
            default: io_rdata_reg <= 32'd0;
        endcase
    end
    if (rst) begin
        timer_count_reg <= 32'd0;
        timer_period_reg <= {TIMER_W{1'b0}};
        timer_phase_reg <= {TIMER_W{1'b0}};
        timer_ticks_reg <= 16'd0;
        spi_cs_reg <= 1'b0;
        mark_reg <= 8'd0;
        io_rdata_reg <= 32'd0;
    end
end

// --- read data -------------------------------------------------------------------------------

assign mem_ready = ready_reg || regs_ready || (mem_valid && (sel_rom || sel_ram || sel_boot));
assign mem_rdata = sel_regs ? regs_rdata :
                   sel_rom ? rom_rdata :
                   sel_ram ? ram_rdata :
                   sel_io ? io_rdata_reg :
                   sel_boot ? boot_rdata : 32'd0;

endmodule

`resetall
