`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * Bowden-cable tension controller core for N cables: one bank of registers per channel, the N
 * tension loops on one time-multiplexed datapath with their safety groups (tension_loop_mc),
 * and one ESCON PWM output per channel.
 *
 * Register banks: channel k's registers are the single core's map (hdl/regmap/bowden_regs.json,
 * the generated bowden_regs) at byte address k * 2^ADDR_W + the register's address, so bank 0
 * is bowden_core's map and a host that drives one cable reads and writes it as before.
 * Registers that are not a channel's own read the same in every bank: ID, SAMPLE_COUNT and
 * ADC_FLAGS (the front-end's, shared by all channels). T_OUT of bank k is cable k's far-end
 * code.
 *
 * The ADC front-end gives every channel of one conversion together (ads131m02_reader with NCH
 * = 2N, an ADS131M04 for 2 cables, an ADS131M08 for 4; adc_valid has a bit per cable, so a
 * converter per cable works too): cable k's T_in is ADC channel 2k and its T_out channel 2k + 1.
 *
 * Timing: a sample tick every CLKS_PER_SAMPLE clocks (>= tension_loop_mc's LATENCY, 1 + 15 N)
 * starts one period of every channel; cmd_valid pulses when every channel's command is new.
 * The register bus holds writes while the loops read their configuration (cfg_busy), so every
 * channel of a period uses the configuration of the tick edge, as bowden_core does.
 *
 * CFG_RAM 1 (the UP5K SoC): the banks' configuration words (every register whose one field is
 * read-write: TC to OC_TIMEOUT, TC_MIN, UFF; 262 bits a bank) are one block RAM word a channel
 * instead of flip-flops, and the memory's output register is the datapath's loaded
 * configuration (tension_loop_mc's CFG_RAM). A write of one of them writes its bits of the
 * bank's word (the byte strobes as bit enables). A read reads the bank's word the clock it is
 * taken and the bank's read multiplexer takes it a clock later (RD_STAGES 1: reg_rd_valid two
 * clocks after the read, one more; RD_STAGES 3 takes it there anyway), and the bus takes no read while the loops read the
 * memory (the tick clock and every slot, 1 + 15 N clocks) nor in a write's clock; the loops'
 * reads fall in cfg_busy, when no write is taken: the memory is never read and written in one
 * clock. The memory holds the registers' reset values from the start (its initial contents, in
 * the bitstream) and after a reset (its N clocks after rst write them; the bus waits). Read-back
 * and write semantics are the registers'.
 *
 * SEQ 1 (with CFG_RAM 1, N <= 3: the UP5K SoC from two cables on): the loops run on
 * tension_loop_seq, a microcoded engine (one adder, one DSP, a scratchpad in block RAM), instead
 * of tension_loop_mc's pipeline, with the same outputs at cmd_valid; the configuration memory
 * then holds a 24-bit word a field (bank k's field f at 16 k + f), which the engine copies at the
 * start of a period and the banks read a field at a time. CLKS_PER_SAMPLE must exceed the
 * program's clocks (hdl/seq/program.py prints them); writes wait from the
 * tick to the end of the copies, reads while the engine reads the memory and while a channel's
 * outputs are written. Not formally proven (the FORMAL block below covers SEQ 0).
 */
module bowden_core_mc #(
    parameter N = 2,                              // cables (channels): 1, 2, 4 or 8
    parameter GROUP_W = 4,                        // bits of a channel's safety group id
    parameter [N*GROUP_W-1:0] GROUP = {N*GROUP_W{1'b0}},  // channel k's group in bits
                                                  // [k*GROUP_W +: GROUP_W]; default: one group
    parameter CLK_HZ = 48000000,                  // system clock, Hz
    parameter SAMPLE_HZ = 10000,                  // loop rate, Hz
    parameter CLKS_PER_SAMPLE = CLK_HZ / SAMPLE_HZ,  // clocks per sample tick (>= 1 + 15 N;
                                                     // CFG_RAM 1: > 1 + 15 N)
    parameter PWM_HZ = 5000,                      // PWM set value frequency, Hz (ESCON <= 5 kHz)
    parameter PWM_IMAX_Q12 = 16384,               // current at 90 % duty, Q3.12 A (4 A)
    parameter [15:0] WDT_RAMP_STEP = 16'd41,      // watchdog and group ramp, Q3.12 A per sample
    parameter ADDR_W = 8,                         // byte address width of one channel's bank
    parameter RD_STAGES = 3,                      // register read-back clocks: 3 or 1
    parameter CFG_RAM = 0,                        // 1: configuration words in a block RAM
    parameter SEQ = 0,                            // CFG_RAM 1: 1 the loops on the sequenced
                                                  // datapath (tension_loop_seq), not the pipeline
    parameter CH_W = (N > 1) ? $clog2(N) : 1,     // bank select bits (derived: do not set)
    parameter BUS_W = ADDR_W + ((N > 1) ? CH_W : 0)  // bus address width (derived: do not set)
) (
    input  wire              clk,
    input  wire              rst,

    /*
     * AXI4-Lite slave: N banks of the register map, channel k's at k << ADDR_W
     */
    input  wire [BUS_W-1:0]  s_axil_awaddr,
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
    input  wire [BUS_W-1:0]  s_axil_araddr,
    input  wire [2:0]        s_axil_arprot,
    input  wire              s_axil_arvalid,
    output wire              s_axil_arready,
    output wire [31:0]       s_axil_rdata,
    output wire [1:0]        s_axil_rresp,
    output wire              s_axil_rvalid,
    input  wire              s_axil_rready,

    /*
     * Raw load-cell ADC samples: one conversion of every ADC channel, cable k's T_in in ADC
     * channel 2k and its T_out in 2k + 1 (ADC channel j in bits [j*24 +: 24], signed codes)
     */
    input  wire [N-1:0]      adc_valid,       // cable k's channels (2k, 2k + 1) are new: all
                                              // together from one converter, each on its own
                                              // from a converter per cable
    input  wire [2*N*24-1:0] adc_ch_data,
    input  wire              adc_drdy_lost,   // front-end flags, read back in ADC_FLAGS
    input  wire              adc_crc_err,

    /*
     * Drive, channel k in bits [k*W +: W]
     */
    output wire [N*16-1:0]   cmd_current,  // Q3.12 A
    output wire [N-1:0]      cmd_enable,
    output wire              cmd_valid,    // one clock when every channel's command is new
    output wire [N-1:0]      fault,        // channel k has a latched fault
    output wire [N-1:0]      pwm,          // ESCON PWM set values
    output wire              sample_tick   // one clock at the start of each period
);

localparam LATENCY = 1 + 15 * N;  // tension_loop_mc's LATENCY
localparam CNT_W = $clog2(CLKS_PER_SAMPLE);
localparam integer TICK_LAST_INT = CLKS_PER_SAMPLE - 1;
localparam [CNT_W-1:0] TICK_LAST = TICK_LAST_INT[CNT_W-1:0];

generate
    if (CLKS_PER_SAMPLE < LATENCY) begin : g_check
        bowden_core_mc_CLKS_PER_SAMPLE_must_be_at_least_1_plus_15_N error_CLKS_PER_SAMPLE ();
    end
    if (CFG_RAM != 0 && CLKS_PER_SAMPLE <= LATENCY) begin : g_check_rd
        // the bus's reads wait out the loops' (1 + 15 N clocks): they need a clock of the sample
        bowden_core_mc_CFG_RAM_needs_CLKS_PER_SAMPLE_above_1_plus_15_N error_CFG_RAM ();
    end
    if (N != 1 && N != 2 && N != 4 && N != 8) begin : g_check_n
        bowden_core_mc_N_must_be_1_2_4_or_8 error_N ();  // every bank address is a channel
    end
endgenerate

// --- sample tick (as bowden_core) ------------------------------------------------------------

reg [CNT_W-1:0] tick_cnt_reg;
reg             tick_reg;

always @(posedge clk) begin
    tick_reg <= (tick_cnt_reg == TICK_LAST);
    tick_cnt_reg <= (tick_cnt_reg == TICK_LAST) ? {CNT_W{1'b0}} : tick_cnt_reg + 1'b1;
    if (rst) begin
        tick_cnt_reg <= {CNT_W{1'b0}};
        tick_reg <= 1'b0;
    end
end

// --- register bus and the banks --------------------------------------------------------------

wire             reg_wr_en, reg_rd_en;
wire [BUS_W-1:0] reg_wr_addr, reg_rd_addr;
wire [31:0]      reg_wr_data;
wire [3:0]       reg_wr_strb;
wire             cfg_busy;
wire             cfg_rd_busy;  // CFG_RAM 1: the loops read the configuration memory
// CFG_RAM 1: the bus takes no read while the loops read the memory, nor in the clock of a write,
// so the memory is never read and written in one clock (bowden_regs_cfg_ram's no_rw_check).
wire             cfg_init;     // CFG_RAM 1: the memory takes the reset values after a reset
wire             rd_hold = (CFG_RAM != 0) && (cfg_rd_busy || reg_wr_en || cfg_init);

wire [N-1:0]     bank_wr_err, bank_rd_err, bank_rd_valid;
wire [N*32-1:0]  bank_rd_data;
reg  [CH_W-1:0]  rd_bank_reg;  // the bank of the read in flight (one at a time)

wire [CH_W-1:0] wr_bank, rd_bank;
generate
    if (N > 1) begin : g_bank_sel
        assign wr_bank = reg_wr_addr[ADDR_W +: CH_W];
        assign rd_bank = reg_rd_addr[ADDR_W +: CH_W];
    end else begin : g_bank_one
        assign wr_bank = 1'b0;
        assign rd_bank = 1'b0;
    end
endgenerate

always @(posedge clk) begin
    if (reg_rd_en) rd_bank_reg <= rd_bank;
    if (rst) rd_bank_reg <= {CH_W{1'b0}};
end

// The banks' read: the bus's, or with CFG_RAM 1 and RD_STAGES 1 a clock later, when the memory
// holds the bank's configuration word (RD_STAGES 3 takes the registers' values in its second
// clock anyway).
localparam RD_DELAY = (CFG_RAM != 0) && (RD_STAGES == 1);
reg              rd_en_d_reg;
reg  [ADDR_W-1:0] rd_addr_d_reg;
always @(posedge clk) begin
    rd_en_d_reg <= reg_rd_en;
    rd_addr_d_reg <= reg_rd_addr[ADDR_W-1:0];
    if (rst) rd_en_d_reg <= 1'b0;
end
wire              bank_rd_en_any = RD_DELAY ? rd_en_d_reg : reg_rd_en;
wire [ADDR_W-1:0] bank_rd_addr = RD_DELAY ? rd_addr_d_reg : reg_rd_addr[ADDR_W-1:0];
wire [CH_W-1:0]   bank_rd_sel = RD_DELAY ? rd_bank_reg : rd_bank;

axil_regbus #(.ADDR_W(BUS_W)) axil (
    .clk(clk), .rst(rst), .wr_hold(cfg_busy || cfg_init),
    .s_axil_awaddr(s_axil_awaddr), .s_axil_awprot(s_axil_awprot),
    .s_axil_awvalid(s_axil_awvalid), .s_axil_awready(s_axil_awready),
    .s_axil_wdata(s_axil_wdata), .s_axil_wstrb(s_axil_wstrb),
    .s_axil_wvalid(s_axil_wvalid), .s_axil_wready(s_axil_wready),
    .s_axil_bresp(s_axil_bresp), .s_axil_bvalid(s_axil_bvalid), .s_axil_bready(s_axil_bready),
    .s_axil_araddr(s_axil_araddr), .s_axil_arprot(s_axil_arprot),
    .s_axil_arvalid(s_axil_arvalid && !rd_hold), .s_axil_arready(s_axil_arready),
    .s_axil_rdata(s_axil_rdata), .s_axil_rresp(s_axil_rresp),
    .s_axil_rvalid(s_axil_rvalid), .s_axil_rready(s_axil_rready),
    .reg_wr_en(reg_wr_en), .reg_wr_addr(reg_wr_addr), .reg_wr_data(reg_wr_data),
    .reg_wr_strb(reg_wr_strb), .reg_wr_err(|bank_wr_err),
    .reg_rd_en(reg_rd_en), .reg_rd_addr(reg_rd_addr),
    .reg_rd_data(bank_rd_data[rd_bank_reg*32 +: 32]),
    .reg_rd_err(bank_rd_err[rd_bank_reg]), .reg_rd_valid(|bank_rd_valid)
);

// Channel configuration and read-back, channel k in bits [k*W +: W].
wire [N-1:0]    ctrl_enable, ctrl_integ_reset, ctrl_fault_clear, ctrl_slew_en, tc_wr;
wire [N*16-1:0] tc, tc_min, kff, kp, ki_ts, wdt_timeout, adc_gain, adc_stale, oc_timeout, uff;
wire [N*15-1:0] i_limit, slew;
wire [N*24-1:0] adc_offset, adc_min, adc_max;

// The configuration memory (CFG_RAM 1, bowden_regs_cfg_ram): channel k's word at address k.
localparam CFG_W = 262;
wire [N*CFG_W-1:0] cfg_wr_en, cfg_wr_data;
wire [CFG_W-1:0]   cfg_q;    // the memory's output register
wire               cfg_rd;   // the loops' read
wire [CH_W-1:0]    cfg_rd_ch;

wire [N*16-1:0] u, t_in, tc_eff;
wire [N*32-1:0] integ;
wire [31:0]     sample_count;
wire [N*4-1:0]  faults;
wire [N-1:0]    out_en, saturated, wdt_ramp, grp_stop;
wire            out_valid;
`ifdef FORMAL
wire [56:0]     f_loop_ctl;  // the loop's schedule (its proofs' f_ctl_state)
`endif

genvar k;
generate
    for (k = 0; k < N; k = k + 1) begin : g_bank
        wire [3:0] f = faults[k*4 +: 4];
        bowden_regs #(.ADDR_W(ADDR_W), .RD_STAGES(RD_STAGES), .CFG_RAM(CFG_RAM)) regs (
            .clk(clk), .rst(rst),
            .reg_wr_en(reg_wr_en && wr_bank == k), .reg_wr_addr(reg_wr_addr[ADDR_W-1:0]),
            .reg_wr_data(reg_wr_data), .reg_wr_strb(reg_wr_strb), .reg_wr_err(bank_wr_err[k]),
            .reg_rd_en(bank_rd_en_any && bank_rd_sel == k), .reg_rd_addr(bank_rd_addr),
            .reg_rd_data(bank_rd_data[k*32 +: 32]), .reg_rd_err(bank_rd_err[k]),
            .reg_rd_valid(bank_rd_valid[k]),
            .ctrl_enable(ctrl_enable[k]), .ctrl_integ_reset(ctrl_integ_reset[k]),
            .ctrl_fault_clear(ctrl_fault_clear[k]), .ctrl_slew_en(ctrl_slew_en[k]),
            .hw_status_out_en(out_en[k]), .hw_status_saturated(saturated[k]),
            .hw_status_fault_active(|f), .hw_status_wdt_ramp(wdt_ramp[k]),
            .hw_fault_adc_stale(f[0]), .hw_fault_adc_range(f[1]),
            .hw_fault_watchdog(f[2]), .hw_fault_overcurrent(f[3]),
            .tc(tc[k*16 +: 16]), .tc_wr(tc_wr[k]), .kff(kff[k*16 +: 16]), .kp(kp[k*16 +: 16]),
            .ki_ts(ki_ts[k*16 +: 16]), .i_limit(i_limit[k*15 +: 15]), .slew(slew[k*15 +: 15]),
            .wdt_timeout(wdt_timeout[k*16 +: 16]), .adc_offset(adc_offset[k*24 +: 24]),
            .adc_gain(adc_gain[k*16 +: 16]), .adc_min(adc_min[k*24 +: 24]),
            .adc_max(adc_max[k*24 +: 24]), .adc_stale(adc_stale[k*16 +: 16]),
            .oc_timeout(oc_timeout[k*16 +: 16]),
            .hw_sample_count(sample_count), .hw_t_in(t_in[k*16 +: 16]), .hw_u(u[k*16 +: 16]),
            .hw_integ(integ[k*32 +: 32]), .hw_tc_eff(tc_eff[k*16 +: 16]),
            .hw_t_out(adc_ch_data[(2*k+1)*24 +: 24]),
            .hw_adc_flags_drdy_lost(adc_drdy_lost), .hw_adc_flags_crc_err(adc_crc_err),
            .tc_min(tc_min[k*16 +: 16]), .uff(uff[k*16 +: 16]),
            .cfg_wr_en(cfg_wr_en[k*CFG_W +: CFG_W]), .cfg_wr_data(cfg_wr_data[k*CFG_W +: CFG_W]),
            .cfg_rd_data(cfg_q)
        );
    end
endgenerate

// --- the configuration memory (CFG_RAM 1) ---------------------------------------------------

// The loop's configuration ports: the banks' registers (CFG_RAM 0), or the memory's output in
// channel 0's bits (CFG_RAM 1: tension_loop_mc reads no other).
wire [N*16-1:0] l_tc, l_tc_min, l_kff, l_kp, l_ki_ts, l_wdt_timeout, l_adc_gain, l_adc_stale;
wire [N*16-1:0] l_oc_timeout, l_uff;
wire [N*15-1:0] l_i_limit, l_slew;
wire [N*24-1:0] l_adc_offset, l_adc_min, l_adc_max;

// SEQ 1: a word of 32 bits a field (bank k's field f at 16 k + f; tension_loop_seq reads a
// field at a time), 2 block RAMs for up to 8 banks. The banks' read-back takes the read field's
// word in every field's place of their configuration word (a read addresses one field).
wire [3:0]  cfg_rd_field;
wire [31:0] cfg_word;
function [4:0] cfg_index;  // {is a configuration word, its field}: TC 0 .. OC_TIMEOUT 12, TC_MIN 13, UFF 14
    input [5:0] a;  // the word's address (bits 7:2: a byte write's low bits are its lane)
    begin
        case ({a, 2'b00})
            8'h10: cfg_index = 5'h10; 8'h14: cfg_index = 5'h11; 8'h18: cfg_index = 5'h12;
            8'h1c: cfg_index = 5'h13; 8'h20: cfg_index = 5'h14; 8'h24: cfg_index = 5'h15;
            8'h28: cfg_index = 5'h16; 8'h2c: cfg_index = 5'h17; 8'h30: cfg_index = 5'h18;
            8'h34: cfg_index = 5'h19; 8'h38: cfg_index = 5'h1a; 8'h3c: cfg_index = 5'h1b;
            8'h40: cfg_index = 5'h1c; 8'h58: cfg_index = 5'h1d; 8'h88: cfg_index = 5'h1e;
            default: cfg_index = 5'h00;
        endcase
    end
endfunction
// Reset values and widths by field (the register map's).
function [23:0] cfg_reset;
    input [3:0] f;
    begin
        case (f)
            4'd1: cfg_reset = 24'd721;      4'd2: cfg_reset = 24'd819;
            4'd3: cfg_reset = 24'd262;      4'd4: cfg_reset = 24'd16384;
            4'd5: cfg_reset = 24'd128;      4'd6: cfg_reset = 24'd1000;
            4'd8: cfg_reset = 24'd2048;     4'd9: cfg_reset = 24'h800001;
            4'd10: cfg_reset = 24'h7FFFFE; 4'd11: cfg_reset = 24'd10;
            4'd12: cfg_reset = 24'd5000;
            default: cfg_reset = 24'd0;
        endcase
    end
endfunction
function [23:0] cfg_mask;
    input [3:0] f;
    begin
        case (f)
            4'd4, 4'd5: cfg_mask = 24'h007FFF;
            4'd7, 4'd9, 4'd10: cfg_mask = 24'hFFFFFF;
            default: cfg_mask = 24'h00FFFF;
        endcase
    end
endfunction

generate
    if (CFG_RAM != 0 && SEQ != 0) begin : g_cfg_seq
        localparam FA_W = CH_W + 4;
        (* ram_style = "block", no_rw_check *)
        reg [23:0] mem [0:(1 << FA_W) - 1];  // no field is wider than 24 bits
        reg [23:0] q_reg;
        reg            init_reg;
        reg [FA_W-1:0] init_addr_reg;
        integer ii;
        initial begin
            for (ii = 0; ii < (1 << FA_W); ii = ii + 1) mem[ii] = cfg_reset(ii[3:0]);
        end
        always @(posedge clk) begin
            if (init_reg) begin
                init_addr_reg <= init_addr_reg + 1'b1;
                if (&init_addr_reg) init_reg <= 1'b0;
            end
            if (rst) begin
                init_reg <= 1'b1;
                init_addr_reg <= {FA_W{1'b0}};
            end
        end
        assign cfg_init = init_reg || rst;
        wire [4:0]      wi = cfg_index(reg_wr_addr[7:2]);
        wire [4:0]      ri = cfg_index(reg_rd_addr[7:2]);
        wire [23:0]     wm = cfg_mask(wi[3:0]) & {{8{reg_wr_strb[2]}}, {8{reg_wr_strb[1]}},
                                                  {8{reg_wr_strb[0]}}};
        wire            w_en = init_reg || (reg_wr_en && wi[4]);
        wire [FA_W-1:0] w_addr = init_reg ? init_addr_reg : {wr_bank, wi[3:0]};
        wire [23:0]     w_mask = init_reg ? 24'hFFFFFF : wm;
        wire [23:0]     w_data = init_reg ? cfg_reset(init_addr_reg[3:0]) : reg_wr_data[23:0];
        wire [FA_W-1:0] r_addr = cfg_rd ? {cfg_rd_ch, cfg_rd_field} : {rd_bank, ri[3:0]};
        integer bi;
        always @(posedge clk) begin
            for (bi = 0; bi < 24; bi = bi + 1)
                if (w_en && w_mask[bi]) mem[w_addr][bi] <= w_data[bi];
            if (cfg_rd || reg_rd_en) q_reg <= mem[r_addr];
        end
        assign cfg_word = {8'd0, q_reg};
        assign cfg_q = {q_reg[15:0], q_reg[15:0], q_reg[15:0], q_reg[15:0], q_reg[23:0],
                        q_reg[23:0], q_reg[15:0], q_reg[23:0], q_reg[15:0], q_reg[14:0],
                        q_reg[14:0], q_reg[15:0], q_reg[15:0], q_reg[15:0], q_reg[15:0]};
        wire unused_seq_cfg = &{1'b0, cfg_wr_en, cfg_wr_data, ri[4], reg_wr_strb[3]};
    end else if (CFG_RAM != 0) begin : g_cfg_ram
        // Bit enables of the write: the written bank's (the others' are 0); the data is the
        // bus's, the same in every bank.
        reg [CFG_W-1:0] we;
        integer b;
        always @* begin
            we = {CFG_W{1'b0}};
            for (b = 0; b < N; b = b + 1) we = we | cfg_wr_en[b*CFG_W +: CFG_W];
        end
        wire [CFG_W-1:0] wd = cfg_wr_data[0 +: CFG_W];
        wire unused_wd = &{1'b0, cfg_wr_data};
        assign cfg_word = 32'd0;
        wire unused_seq_rd = &{1'b0, cfg_rd_field};
        bowden_regs_cfg_ram #(.WORDS(N), .AW(CH_W)) cfg_mem (
            .clk(clk), .rst(rst), .init_busy(cfg_init), .wr_en(we), .wr_addr(wr_bank), .wr_data(wd),
            .rd_en(cfg_rd || reg_rd_en), .rd_addr(cfg_rd ? cfg_rd_ch : rd_bank), .rd_data(cfg_q)
        );
    end else begin : g_cfg_regs
        assign cfg_q = {CFG_W{1'b0}};
        assign cfg_word = 32'd0;
        assign cfg_init = 1'b0;
        wire unused_cfg = &{1'b0, cfg_wr_en, cfg_wr_data, cfg_rd, cfg_rd_ch, cfg_rd_field};
    end
endgenerate

// The memory word's fields, packed as bowden_regs packs them (its *_q read-back wires).
genvar c;
generate
    for (c = 0; c < N; c = c + 1) begin : g_l_cfg
        if (CFG_RAM == 0) begin : g_regs
            assign l_tc[c*16 +: 16] = tc[c*16 +: 16];
            assign l_kff[c*16 +: 16] = kff[c*16 +: 16];
            assign l_kp[c*16 +: 16] = kp[c*16 +: 16];
            assign l_ki_ts[c*16 +: 16] = ki_ts[c*16 +: 16];
            assign l_i_limit[c*15 +: 15] = i_limit[c*15 +: 15];
            assign l_slew[c*15 +: 15] = slew[c*15 +: 15];
            assign l_wdt_timeout[c*16 +: 16] = wdt_timeout[c*16 +: 16];
            assign l_adc_offset[c*24 +: 24] = adc_offset[c*24 +: 24];
            assign l_adc_gain[c*16 +: 16] = adc_gain[c*16 +: 16];
            assign l_adc_min[c*24 +: 24] = adc_min[c*24 +: 24];
            assign l_adc_max[c*24 +: 24] = adc_max[c*24 +: 24];
            assign l_adc_stale[c*16 +: 16] = adc_stale[c*16 +: 16];
            assign l_oc_timeout[c*16 +: 16] = oc_timeout[c*16 +: 16];
            assign l_tc_min[c*16 +: 16] = tc_min[c*16 +: 16];
            assign l_uff[c*16 +: 16] = uff[c*16 +: 16];
        end else if (c == 0) begin : g_ram
            assign l_tc[15:0] = cfg_q[15:0];
            assign l_kff[15:0] = cfg_q[31:16];
            assign l_kp[15:0] = cfg_q[47:32];
            assign l_ki_ts[15:0] = cfg_q[63:48];
            assign l_i_limit[14:0] = cfg_q[78:64];
            assign l_slew[14:0] = cfg_q[93:79];
            assign l_wdt_timeout[15:0] = cfg_q[109:94];
            assign l_adc_offset[23:0] = cfg_q[133:110];
            assign l_adc_gain[15:0] = cfg_q[149:134];
            assign l_adc_min[23:0] = cfg_q[173:150];
            assign l_adc_max[23:0] = cfg_q[197:174];
            assign l_adc_stale[15:0] = cfg_q[213:198];
            assign l_oc_timeout[15:0] = cfg_q[229:214];
            assign l_tc_min[15:0] = cfg_q[245:230];
            assign l_uff[15:0] = cfg_q[261:246];
        end else begin : g_unread  // tension_loop_mc reads channel 0's bits only
            assign {l_tc[c*16 +: 16], l_kff[c*16 +: 16], l_kp[c*16 +: 16], l_ki_ts[c*16 +: 16],
                    l_i_limit[c*15 +: 15], l_slew[c*15 +: 15], l_wdt_timeout[c*16 +: 16],
                    l_adc_offset[c*24 +: 24], l_adc_gain[c*16 +: 16], l_adc_min[c*24 +: 24],
                    l_adc_max[c*24 +: 24], l_adc_stale[c*16 +: 16], l_oc_timeout[c*16 +: 16],
                    l_tc_min[c*16 +: 16], l_uff[c*16 +: 16]} = {CFG_W{1'b0}};
        end
    end
endgenerate
wire unused_cfg_regs = &{1'b0, tc, kff, kp, ki_ts, i_limit, slew, wdt_timeout, adc_offset,
                         adc_gain, adc_min, adc_max, adc_stale, oc_timeout, tc_min, uff};

// --- the loops -------------------------------------------------------------------------------

wire [N*24-1:0] t_in_codes;  // ADC channel 2k of every cable k
generate
    for (k = 0; k < N; k = k + 1) begin : g_t_in
        assign t_in_codes[k*24 +: 24] = adc_ch_data[2*k*24 +: 24];
    end
endgenerate

// CFG_RAM 1 (the UP5K): the datapath also keeps no copy of a channel's state word and events
// (LIVE_STATE); a channel's T_in and FAULT then change inside its slot, when the bus takes no
// read (cfg_rd_busy).
generate
    if (SEQ != 0) begin : g_seq
        tension_loop_seq #(.N(N), .GROUP_W(GROUP_W), .GROUP(GROUP),
                           .WDT_RAMP_STEP(WDT_RAMP_STEP)) loop (
    .clk(clk), .rst(rst),
    .tick(tick_reg),
    .adc_valid(adc_valid), .adc_data(t_in_codes),
    .enable(ctrl_enable), .slew_en(ctrl_slew_en), .integ_reset(ctrl_integ_reset),
    .fault_clear(ctrl_fault_clear), .tc_wr(tc_wr),
    .tc(l_tc), .tc_min(l_tc_min), .kff(l_kff), .uff(l_uff), .kp(l_kp), .ki_ts(l_ki_ts),
    .i_limit(l_i_limit), .slew(l_slew), .wdt_timeout(l_wdt_timeout),
    .adc_offset(l_adc_offset), .adc_gain(l_adc_gain), .adc_min(l_adc_min),
    .adc_max(l_adc_max), .adc_stale(l_adc_stale), .oc_timeout(l_oc_timeout),
    .cfg_busy(cfg_busy), .cfg_rd(cfg_rd), .cfg_rd_ch(cfg_rd_ch), .cfg_rd_busy(cfg_rd_busy),
    .cfg_rd_field(cfg_rd_field), .cfg_word(cfg_word),
    .u(u), .out_en(out_en), .out_valid(out_valid),
    .saturated(saturated), .wdt_ramp(wdt_ramp), .grp_stop(grp_stop), .faults(faults),
    .t_in(t_in), .integ(integ), .tc_eff(tc_eff), .sample_count(sample_count)
);

`ifdef FORMAL
        assign f_loop_ctl = 57'd0;
`endif
    end else begin : g_pipe
        assign cfg_rd_field = 4'd0;
        wire unused_word = &{1'b0, cfg_word};
        tension_loop_mc #(.N(N), .GROUP_W(GROUP_W), .GROUP(GROUP), .WDT_RAMP_STEP(WDT_RAMP_STEP),
                          .CFG_RAM(CFG_RAM), .LIVE_STATE(CFG_RAM)) loop (
    .clk(clk), .rst(rst),
    .tick(tick_reg),
    .adc_valid(adc_valid), .adc_data(t_in_codes),
    .enable(ctrl_enable), .slew_en(ctrl_slew_en), .integ_reset(ctrl_integ_reset),
    .fault_clear(ctrl_fault_clear), .tc_wr(tc_wr),
    .tc(l_tc), .tc_min(l_tc_min), .kff(l_kff), .uff(l_uff), .kp(l_kp), .ki_ts(l_ki_ts),
    .i_limit(l_i_limit), .slew(l_slew), .wdt_timeout(l_wdt_timeout),
    .adc_offset(l_adc_offset), .adc_gain(l_adc_gain), .adc_min(l_adc_min),
    .adc_max(l_adc_max), .adc_stale(l_adc_stale), .oc_timeout(l_oc_timeout),
    .cfg_busy(cfg_busy), .cfg_rd(cfg_rd), .cfg_rd_ch(cfg_rd_ch), .cfg_rd_busy(cfg_rd_busy),
    .u(u), .out_en(out_en), .out_valid(out_valid),
    .saturated(saturated), .wdt_ramp(wdt_ramp), .grp_stop(grp_stop), .faults(faults),
    .t_in(t_in), .integ(integ), .tc_eff(tc_eff), .sample_count(sample_count)
`ifdef FORMAL
    ,
    .f_chan_state(), .f_chan_tick(), .f_ctl_state(f_loop_ctl), .f_pipe_state()
`endif
);

    end
endgenerate

wire unused_grp_stop = &{1'b0, grp_stop};

// --- drive outputs ---------------------------------------------------------------------------

generate
    for (k = 0; k < N; k = k + 1) begin : g_pwm
        wire [31:0] duty;
        pwm_escon #(.PERIOD_CLKS(CLK_HZ / PWM_HZ), .IMAX_Q12(PWM_IMAX_Q12)) pwm_out (
            .clk(clk), .rst(rst),
            .u(u[k*16 +: 16]), .enable(out_en[k]), .pwm(pwm[k]), .duty_clks(duty)
        );
        wire unused_duty = &{1'b0, duty};
        assign fault[k] = |faults[k*4 +: 4];
    end
endgenerate

assign cmd_current = u;
assign cmd_enable = out_en;
assign cmd_valid = out_valid;
assign sample_tick = tick_reg;

`ifdef FORMAL
// --- formal properties (hdl/formal/bowden_core_mc.sby; hdl/README.md says what is proven) --
//
// The sub-modules carry their own properties (axil_*, regs_* in each bank, the loop's mc_*, the
// PWMs' pwm_*); here tension_loop_mc's environment (ticks at least LATENCY clocks apart,
// mc_tick_spacing) is asserted, not assumed, so the composition is proven. The core adds what
// keeps the channels apart around the loop: a write reaches the bank its address selects and no
// other, a read is answered by the bank its address selects, and each channel's drive outputs
// are its own loop's. The bank of an address is decoded here (bits ADDR_W and up), not taken
// from the core's own select.

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;
always @* if (!f_past_valid) assume(rst);

function [CH_W-1:0] f_bank_of;
    input [BUS_W-1:0] addr;
    begin
        f_bank_of = (N > 1) ? addr[BUS_W-1 -: CH_W] : {CH_W{1'b0}};
    end
endfunction

// A tick every CLKS_PER_SAMPLE clocks, the first CLKS_PER_SAMPLE clocks after reset.
reg f_ticked = 1'b0;  // a tick since reset (set with the first)
always @(posedge clk) begin
    if (tick_cnt_reg == TICK_LAST) f_ticked <= 1'b1;
    if (rst) f_ticked <= 1'b0;
end
always @* if (f_past_valid && !rst) begin
    // property core_mc_tick_period: a tick every CLKS_PER_SAMPLE clocks, the first CLKS_PER_SAMPLE clocks after reset
    core_mc_tick_period: assert(tick_cnt_reg <= TICK_LAST);
    core_mc_tick_period_2: assert(tick_reg == (tick_cnt_reg == {CNT_W{1'b0}} && f_ticked));
end

// The loop's schedule against the tick counter: its period runs from the clock after the tick,
// channel c's slot at clocks 1 + 15 c to 15 + 15 c of the sample (f_ctl_state: {ch, start,
// seq, ...}).
localparam integer F_SLOT = 15;
wire [31:0] f_pos = {{(32-CNT_W){1'b0}}, tick_cnt_reg} - 32'd1;  // clock in the period
wire        f_in_period = f_ticked && tick_cnt_reg != {CNT_W{1'b0}} && f_pos < F_SLOT * N;
wire [31:0] f_ch_exp = f_pos / F_SLOT;
wire [31:0] f_lc_exp = f_pos % F_SLOT;
wire [13:0] f_seq_exp = (f_in_period && f_lc_exp != 32'd0) ? 14'd1 << (f_lc_exp - 32'd1) : 14'd0;
always @* if (f_past_valid && !rst) begin
    // property core_mc_tick_phase: the loop's schedule (slot, its clock) follows the tick counter (induction helper)
    core_mc_tick_phase: assert(f_loop_ctl[48] == (f_in_period && f_lc_exp == 32'd0) &&
                               f_loop_ctl[47:34] == f_seq_exp &&
                               f_loop_ctl[56:49] == (f_in_period ? f_ch_exp[7:0] : 8'd0));
end

// The banks' configuration (the read-write fields) and the bank a write selects, a clock later.
localparam F_CFG_W = 2 + 262;
wire [N*F_CFG_W-1:0] f_cfg;
reg  [N*F_CFG_W-1:0] f_cfg_d;
reg  [N-1:0]         f_wr_hit_d;   // the last clock's write selected bank k
reg                  f_wr_kp_d;    // ... and was a write of all of KP's word
reg  [CH_W-1:0]      f_wr_bank_d;
reg  [15:0]          f_wr_data_d;
genvar fk;
generate
    for (fk = 0; fk < N; fk = fk + 1) begin : g_f_cfg
        assign f_cfg[fk*F_CFG_W +: F_CFG_W] = {
            ctrl_enable[fk], ctrl_slew_en[fk], tc[fk*16 +: 16], tc_min[fk*16 +: 16],
            kff[fk*16 +: 16], uff[fk*16 +: 16], kp[fk*16 +: 16], ki_ts[fk*16 +: 16],
            i_limit[fk*15 +: 15], slew[fk*15 +: 15], wdt_timeout[fk*16 +: 16],
            adc_offset[fk*24 +: 24], adc_gain[fk*16 +: 16], adc_min[fk*24 +: 24],
            adc_max[fk*24 +: 24], adc_stale[fk*16 +: 16], oc_timeout[fk*16 +: 16]};
        always @(posedge clk) f_wr_hit_d[fk] <= reg_wr_en && f_bank_of(reg_wr_addr) == fk;
    end
endgenerate
always @(posedge clk) begin
    f_cfg_d <= f_cfg;
    // KP: word 6 of the map (bowden_regs.json), byte address 0x18 in each bank
    f_wr_kp_d <= reg_wr_en && reg_wr_addr[ADDR_W-1:0] == 8'h18 && reg_wr_strb[1:0] == 2'b11;
    f_wr_bank_d <= f_bank_of(reg_wr_addr);
    f_wr_data_d <= reg_wr_data[15:0];
end

// Per bank: kept (no write selected it), the KP write landed, no memory bit enables.
reg         f_rst_d = 1'b1;
reg [N-1:0] f_kept, f_kp_ok, f_no_ram_we;
integer     fb;
always @(posedge clk) f_rst_d <= rst;
always @* begin
    for (fb = 0; fb < N; fb = fb + 1) begin
        f_kept[fb] = f_wr_hit_d[fb] ||
                     ((CFG_RAM != 0 || f_cfg[fb*F_CFG_W +: F_CFG_W] == f_cfg_d[fb*F_CFG_W +: F_CFG_W]) &&
                      !ctrl_integ_reset[fb] && !ctrl_fault_clear[fb] && !tc_wr[fb]);
        f_kp_ok[fb] = CFG_RAM != 0 || !f_wr_kp_d || f_wr_bank_d != fb ||
                      kp[fb*16 +: 16] == f_wr_data_d;
        f_no_ram_we[fb] = (reg_wr_en && f_bank_of(reg_wr_addr) == fb) ||
                          cfg_wr_en[fb*CFG_W +: CFG_W] == {CFG_W{1'b0}};
    end
end
always @* if (f_past_valid && !rst && !f_rst_d) begin
    // property core_mc_bank_write: a bus write reaches the bank its address selects and no other: another bank's registers keep their values and give no write pulses (with CFG_RAM 1 no memory bit enables), and a write of KP lands in the addressed bank
    core_mc_bank_write: assert(&f_kept);
    core_mc_bank_write_2: assert(&f_kp_ok);
end
always @* if (f_past_valid && !rst) core_mc_bank_write_3: assert(&f_no_ram_we);

// Channel k's loop inputs: bank k's configuration (CFG_RAM 0; with CFG_RAM 1 the configuration is
// the memory's word, and only T_in is checked) and cable k's T_in, ADC channel 2k.
reg [N-1:0] f_in_ok;
always @* for (fb = 0; fb < N; fb = fb + 1)
    f_in_ok[fb] = t_in_codes[fb*24 +: 24] == adc_ch_data[2*fb*24 +: 24] &&
                  (CFG_RAM != 0 || f_cfg[fb*F_CFG_W +: F_CFG_W] == {
                      ctrl_enable[fb], ctrl_slew_en[fb], l_tc[fb*16 +: 16], l_tc_min[fb*16 +: 16],
                      l_kff[fb*16 +: 16], l_uff[fb*16 +: 16], l_kp[fb*16 +: 16],
                      l_ki_ts[fb*16 +: 16], l_i_limit[fb*15 +: 15], l_slew[fb*15 +: 15],
                      l_wdt_timeout[fb*16 +: 16], l_adc_offset[fb*24 +: 24],
                      l_adc_gain[fb*16 +: 16], l_adc_min[fb*24 +: 24], l_adc_max[fb*24 +: 24],
                      l_adc_stale[fb*16 +: 16], l_oc_timeout[fb*16 +: 16]});
// property core_mc_loop_inputs: channel k's loop reads bank k's configuration (CFG_RAM 0) and cable k's T_in (ADC channel 2k)
always @* if (f_past_valid && !rst) core_mc_loop_inputs: assert(&f_in_ok);

// The bank of the read in flight, decoded from its address.
reg [CH_W-1:0] f_rd_bank = {CH_W{1'b0}};
always @(posedge clk) if (reg_rd_en) f_rd_bank <= f_bank_of(reg_rd_addr);
wire [N-1:0] f_rd_onehot = {{(N-1){1'b0}}, 1'b1} << f_rd_bank;
// property core_mc_read_bank: a read is answered by the bank its address selects: only that bank answers and the read-back multiplexer selects it
always @* if (f_past_valid && !rst && (|bank_rd_valid))
    core_mc_read_bank: assert(bank_rd_valid == f_rd_onehot && rd_bank_reg == f_rd_bank);

reg [N-1:0] f_drive_ok;
always @* for (fb = 0; fb < N; fb = fb + 1)
    f_drive_ok[fb] = cmd_enable[fb] || cmd_current[fb*16 +: 16] == 16'd0;
// property core_mc_drive_zero_when_disabled: each channel's drive command is 0 A whenever its enable is low, and every drive is off with no fault the clock after reset
always @* if (f_past_valid && !rst) core_mc_drive_zero_when_disabled: assert(&f_drive_ok);
always @(posedge clk) if (f_past_valid && $past(rst))
    core_mc_drive_zero_when_disabled_2: assert(cmd_enable == {N{1'b0}} && fault == {N{1'b0}});

// Each channel's PWM (pwm_escon takes u and the enable 5 clocks before the clock its new duty
// shows, pwm_half_when_disabled): a new duty other than 50 % only from the channel's own drive
// on with a command not 0.
localparam [31:0] F_PWM_HALF = (CLK_HZ / PWM_HZ) / 2;
wire [N*32-1:0]   f_duty;
reg  [N*32-1:0]   f_duty_d;
reg  [5*N-1:0]    f_en_hist;   // cmd_enable of the last 5 clocks, the oldest in the top bits
reg  [5*N*16-1:0] f_u_hist;
generate
    for (fk = 0; fk < N; fk = fk + 1) begin : g_f_duty
        assign f_duty[fk*32 +: 32] = g_pwm[fk].duty;
    end
endgenerate
always @(posedge clk) begin
    f_duty_d <= f_duty;
    f_en_hist <= {f_en_hist[4*N-1:0], cmd_enable};
    f_u_hist <= {f_u_hist[4*N*16-1:0], cmd_current};
end
reg [N-1:0] f_pwm_ok;
always @* for (fb = 0; fb < N; fb = fb + 1)
    f_pwm_ok[fb] = f_duty[fb*32 +: 32] == f_duty_d[fb*32 +: 32] ||
                   f_duty[fb*32 +: 32] == F_PWM_HALF ||
                   (f_en_hist[4*N + fb] && f_u_hist[(4*N + fb)*16 +: 16] != 16'd0);
// property core_mc_pwm_own_channel: channel k's PWM takes a duty other than 50 % only from channel k's drive on with a command not 0
always @* if (f_past_valid && !rst && !f_rst_d) core_mc_pwm_own_channel: assert(&f_pwm_ok);

localparam integer F_LAST_BANK_INT = N - 1;
localparam [CH_W-1:0] F_LAST_BANK = F_LAST_BANK_INT[CH_W-1:0];
always @(posedge clk) if (f_past_valid && !rst && !$past(rst)) begin
    cover(sample_tick);                                   // the first tick: the loop's period
    cover(f_wr_kp_d && f_wr_bank_d == F_LAST_BANK);      // KP written in the last bank
    cover((|bank_rd_valid) && f_rd_bank == F_LAST_BANK);  // a read answered by the last bank
end

wire f_unused = &{1'b0, f_loop_ctl};
`endif

endmodule

`resetall
