`resetall
`timescale 1ns / 1ps
`default_nettype none

/*
 * ESCON-style PWM set value for the current command.
 *
 * Maxon ESCON drives read a PWM set value where 10 % duty is -I_max, 90 % is +I_max and 50 % is
 * 0 A (ESCON "PWM set value" with 10..90 % mapping, configured in ESCON Studio). Here:
 *     duty_clks = PERIOD_CLKS/2 + floor(clamp(u, +-IMAX_Q12) * K / 2^SHIFT)
 * with K = round(SPAN * 2^SHIFT / IMAX_Q12), SPAN = 2*PERIOD_CLKS/5 (40 % of the period), and
 * SHIFT the largest that keeps K below 2^15 so the product fits one 16 x 16 DSP multiply. The
 * duty value changes only at the end of a period, so no pulse is ever cut short. While
 * `enable` is low the output stays at 50 % (0 A), which is also the state after reset.
 */
module pwm_escon #(
    parameter PERIOD_CLKS = 9600,     // PWM period in clocks (48 MHz / 5 kHz)
    parameter IMAX_Q12 = 16384        // current at 90 % duty, Q3.12 A, 1..32767 (ESCON: 4 A)
) (
    input  wire        clk,
    input  wire        rst,

    input  wire [15:0] u,         // Q3.12 A current command
    input  wire        enable,    // 0: 50 % duty (0 A)
    output wire        pwm,       // PWM set value
    output wire [31:0] duty_clks  // high time of the current period in clocks (for test)
);

localparam HALF = PERIOD_CLKS / 2;
localparam SPAN = (2 * PERIOD_CLKS) / 5;

// Largest shift s with round(SPAN * 2^s / IMAX) < 2^15 (32-bit integer arithmetic: SPAN * 2^s
// stays below 2^31 for any SPAN < 2^15 and IMAX_Q12 >= 1).
function integer calc_shift;
    input integer span;
    input integer imax;
    integer s;
    begin
        s = 0;
        while ((((span << (s + 1)) + imax / 2) / imax) < 32768 && s < 24)
            s = s + 1;
        calc_shift = s;
    end
endfunction

localparam integer IMAX = IMAX_Q12;
localparam [15:0] IMAX16 = IMAX[15:0];  // fits: 1..32767
localparam SHIFT = calc_shift(SPAN, IMAX);
localparam integer K_INT = ((SPAN << SHIFT) + IMAX / 2) / IMAX;
localparam [15:0] K = K_INT[15:0];  // < 2^15 by the choice of SHIFT

localparam CNT_W = $clog2(PERIOD_CLKS);
localparam integer LAST_INT = PERIOD_CLKS - 1;
localparam [CNT_W-1:0] LAST = LAST_INT[CNT_W-1:0];  // fits: < 2^CNT_W

reg  [CNT_W-1:0] cnt_reg, cnt_next;
reg  [31:0]      duty_reg, duty_next;
reg  [15:0]      u_c;
reg  [15:0]      u_c_reg;  // clamped command, registered so the DSP keeps its own input register
reg  [15:0]      u_reg;    // command, and its comparisons with +-IMAX, one clock earlier
reg              en_reg;
reg              gt_reg;
reg              lt_reg;

// u > IMAX and u < -IMAX as the sign of a 17-bit subtraction (one carry chain each).
wire [16:0] above = {1'b0, IMAX16} - {u[15], u};
wire [16:0] below = {u[15], u} + {1'b0, IMAX16};

wire signed [31:0] prod;
mul_s16 mul (.clk(clk), .a(u_c_reg), .b(K), .p(prod));

// floor(prod / 2^SHIFT), |.| <= SPAN: the 90 % / 10 % ends of the range.
wire signed [31:0] offset = prod >>> SHIFT;

always @* begin
    // Clamp to +-IMAX so the duty never leaves 10..90 %.
    if (!en_reg) begin
        u_c = 16'd0;
    end else if (gt_reg) begin
        u_c = IMAX16;
    end else if (lt_reg) begin
        u_c = -IMAX16;
    end else begin
        u_c = u_reg;
    end

    cnt_next = (cnt_reg == LAST) ? {CNT_W{1'b0}} : cnt_reg + 1'b1;
    duty_next = duty_reg;
    if (cnt_reg == LAST) begin
        duty_next = HALF + offset;
    end
end

always @(posedge clk) begin
    cnt_reg <= cnt_next;
    duty_reg <= duty_next;
    u_c_reg <= u_c;
    u_reg <= u;
    en_reg <= enable;
    gt_reg <= above[16];
    lt_reg <= below[16];
    if (rst) begin
        cnt_reg <= {CNT_W{1'b0}};
        duty_reg <= HALF;
    end
end

assign pwm = {{(32 - CNT_W){1'b0}}, cnt_reg} < duty_reg;

// Only the signs of the comparisons are needed.
wire unused_cmp = &{1'b0, above[15:0], below[15:0]};
assign duty_clks = duty_reg;

`ifdef FORMAL
// --- formal properties (hdl/formal/pwm_escon.sby; hdl/README.md says what is proven) -------
//
// The PWM properties pwm_*: the duty stays within 10 %..90 % of the period, changes only at the
// end of a period, and is 50 % (0 A) after a period that began with the drive disabled (the
// core's enable is the loop's out_en, which every fault drops).

reg f_past_valid = 1'b0;
always @(posedge clk) f_past_valid <= 1'b1;
always @* if (!f_past_valid) assume(rst);

localparam integer F_PERIOD = PERIOD_CLKS;

// property pwm_duty_bounds: the duty stays within 10 %..90 % of the period (and the counter within the period)
always @* if (f_past_valid && !rst) begin
    pwm_duty_bounds: assert(10 * duty_reg >= F_PERIOD && 10 * duty_reg <= 9 * F_PERIOD);
    pwm_duty_bounds_2: assert(duty_reg >= HALF - SPAN && duty_reg <= HALF + SPAN);
    pwm_duty_bounds_3: assert(cnt_reg <= LAST);
end

// Helpers for the induction: the pipeline registers without reset hold consistent values
// two clocks after reset (the first period boundary is PERIOD_CLKS clocks later).
reg [1:0] f_age = 2'd0;
always @(posedge clk) if (rst) f_age <= 2'd0; else if (f_age != 2'd3) f_age <= f_age + 2'd1;
// property pwm_pipeline: the clip flags and the clipped command agree with u two clocks after reset (induction helper)
always @* if (f_past_valid && !rst && f_age >= 2'd1) begin
    pwm_pipeline: assert(gt_reg == ($signed(u_reg) > $signed(IMAX16)));
    pwm_pipeline_2: assert(lt_reg == ($signed(u_reg) < -$signed(IMAX16)));
end
always @* if (f_past_valid && !rst && f_age >= 2'd2)
    pwm_pipeline_3: assert($signed(u_c_reg) <= $signed(IMAX16) && $signed(u_c_reg) >= -$signed(IMAX16));
always @* if (f_past_valid && !rst) pwm_pipeline_4: assert(f_age == 2'd3 || cnt_reg == {{(CNT_W-2){1'b0}}, f_age});

// property pwm_period_boundary: the duty changes only at the end of a period
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(cnt_reg) != LAST)
    pwm_period_boundary: assert($stable(duty_reg));

// property pwm_half_when_disabled: a period that begins with the drive disabled (every fault disables it) is 50 %, 0 A
// Disabled (or faulted) four clocks before the end of a period: the next period is 50 %.
always @(posedge clk) if (f_past_valid && !$past(rst) && $past(cnt_reg) == LAST &&
                          !$past(enable, 5))
    pwm_half_when_disabled: assert(duty_reg == HALF);

// property pwm_reset_half: after reset the duty is 50 % and the period restarts
always @(posedge clk) if (f_past_valid && $past(rst)) pwm_reset_half: assert(duty_reg == HALF && cnt_reg == 0);

always @(posedge clk) if (f_past_valid && !rst && !$past(rst)) begin
    cover(duty_reg == HALF + SPAN);                     // 90 %: +I_max
    cover(duty_reg == HALF - SPAN);                     // 10 %: -I_max
    cover($past(duty_reg) == HALF + SPAN && duty_reg == HALF && !$past(enable, 6));  // off
end
`endif

endmodule

`resetall
