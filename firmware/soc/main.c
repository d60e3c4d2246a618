/*
 * main.c - the bench device (dev.h) on bowden_soc: the loop's registers memory-mapped (hal.h's
 * MMIO back end), the protocol on the UART, the settings in the SPI flash, the tick from the
 * timer's tick count.
 *
 * Cables: the SoC says how many it drives (SOC_SYS_CHANNELS, its CHANNELS parameter); the image
 * holds at most BOWDEN_CHANNELS_MAX (set by the build: mk/soc.mk builds one image per count, as
 * each cable costs RAM) and runs the smaller of the two, cable k's firmware on register bank k
 * (SOC_REGS_BASE + BOWDEN_REG_AT(k, 0)). The one-cable image drives bank 0, as it always did.
 *
 * The timer counts ticks in hardware; the main loop polls the count and runs them, so dev_tick
 * and the protocol's receiver never run at once and need no locking. A tick found with more than
 * one pending was late: the device's OVERRUN fault says so (dev_overrun) and the missed ticks are not
 * run twice (the loop in the FPGA holds its last T_c meanwhile, guarded by its watchdog).
 *
 * Requests use the time the tick leaves and never delay it: a received frame is served (decoded,
 * dispatched, its reply queued) only when the clocks left before the next tick hold the longest
 * request's handling, or when it is the first frame after a tick (then that tick and that one
 * request share the period; hdl/README.md gives the measured figures). A frame that has to wait
 * stays in the UART's receive FIFO (512 bytes: 5.5 ms at 921600 baud) until then. Its bytes
 * before the delimiter are gathered as they come and handed to the decoder together (at the
 * delimiter, at 64 bytes, or while the delimiter waits: a handling's fixed cost is paid once a
 * frame, not once a byte); the frame's check, its dispatch and its reply wait for the admitted
 * delimiter. During a run, a long frame whose delimiter comes after a long tick has its bytes
 * decoded at once and is served after the next tick, so that no period holds a tick and a whole
 * long frame (RX_WHOLE_CLKS below). Frames' CRCs run in the SoC's CRC unit (crc32c.h, soc.h).
 */
#include <stdint.h>

#include "bowden_regs.h"
#include "crc32c.h"
#include "dev.h"
#include "fw.h"
#include "fxp.h"
#include "hal.h"
#include "soc.h"
#include "spi_flash.h"

_Static_assert(CRC32C_UNIT_ADDR == SOC_IO_BASE + SOC_CRC_STATE, "crc32c.h uses the SoC's CRC unit");

static hal_t g_hal[BOWDEN_CHANNELS_MAX]; /* cable k's HAL on its register bank */
static fw_t g_fw[BOWDEN_CHANNELS_MAX];
static uint32_t g_channels; /* the cables this image runs: [1, BOWDEN_CHANNELS_MAX] */
static flash_hal_t g_flash;
static dev_t g_dev;

/* Cable k's T_out in Q7.8 N from its bank's T_OUT register's raw code, with the loop's own
 * calibration formula (hdl/README.md, "The loop": sat16(((raw - ADC_OFFSET) * ADC_GAIN + 2^19) >>
 * 20)) and the cable's own calibration. */
static int32_t t_out_q8(const hal_t *h, const fw_loop_config_t *l)
{
    uint32_t word = hal_read(h, BOWDEN_REG_T_OUT) & BOWDEN_T_OUT_MASK;
    int32_t raw = (int32_t)(word << 8) >> 8; /* sign-extend the 24-bit code */
    /* ((raw - offset) * gain + 2^19) >> 20 as the rounded high word of (raw - offset) *
     * (gain * 2^12) (|raw - offset| < 2^24 and |gain| <= 2^15, both 24-bit and 16-bit register
     * fields, so gain * 2^12 fits 32 bits). */
    int32_t q = fxp_mul_hi_round_i32(raw - l->adc_offset, l->adc_gain * 4096);
    if (q > 32767) {
        q = 32767;
    } else if (q < -32768) {
        q = -32768;
    }
    return (int32_t)q;
}

static uint32_t g_timer_rate_hz;
static uint32_t g_tick_period_clks; /* the timer's period: SoC clocks per tick */
/* A tick's length, 1e6 / rate microseconds, as quotient and remainder: divided once per rate,
 * not at every tick (the CPU has no divide instruction: libc.c's routine). */
static uint32_t g_tick_us;
static uint32_t g_tick_us_rem;

/* Program the timer for the configured tick rate (checked by dev_settings_check: 1..65535 Hz). */
static void timer_follow_rate(void)
{
    uint32_t rate = g_dev.settings[0].fw.tick_rate_hz;
    if (rate != g_timer_rate_hz && rate != 0U) {
        g_timer_rate_hz = rate;
        g_tick_us = 1000000U / rate;
        g_tick_us_rem = 1000000U % rate;
        g_tick_period_clks = soc_io_read(SOC_SYS_CLK_HZ) / rate;
        soc_io_write(SOC_TIMER_PERIOD, g_tick_period_clks);
    }
}

/* The longest request's handling in clocks, with its margin: 9 271 measured (make perf-soc, the
 * ECP5's configuration; START 8 473 on the UP5K's, tests/soc/tb_soc_tick.py; the UP5K's clocks
 * run some 10 % above the ECP5's) and one pass of the idle loop.
 * During a run the requests that take long are refused (BUSY), so the ticks that matter meet
 * only short ones. */
#define RX_ADMIT_CLKS 13500U
/* Bytes taken from the receive FIFO and given to the transmit FIFO in one pass of the main loop
 * at most: a pass stays short, so a tick is seen soon after the timer counts it (64 bytes a pass
 * still moves them many times faster than the UART's 92 bytes a millisecond). */
#define RX_BYTES_PER_PASS 64U
#define TX_BYTES_PER_PASS 64U

static uint32_t g_tick_clk;    /* SOC_TIMER_COUNT when the main loop found the last tick */
static uint32_t g_frame_owed;  /* 1: in this pass, the first after a tick, a frame is served
                                  whatever the time left */
static uint32_t g_delim_held;  /* 1: a frame's delimiter was read and its handling waits */
static uint32_t g_delim_next;  /* 1: it waits for the first pass after the next tick */

/* Whether a frame's handling may start now (the rule in this file's header). */
static uint32_t rx_admitted(void)
{
    if (g_frame_owed != 0U) {
        return 1U;
    }
    if (g_delim_next != 0U) {
        return 0U;
    }
    uint32_t since = soc_io_read(SOC_TIMER_COUNT) - g_tick_clk;
    return (since < g_tick_period_clks && g_tick_period_clks - since >= RX_ADMIT_CLKS) ? 1U : 0U;
}

/* Received bytes to the device: a frame's delimiter among them has it decoded, dispatched and
 * its reply queued. The phase word brackets exactly that (the simulation measures it). */
static void rx_hand_over(uint8_t *buf, uint32_t n)
{
    soc_io_write(SOC_SYS_MARK, SOC_MARK_RX);
    dev_rx_bytes(&g_dev, DEV_PORT_SERIAL, buf, n);
    soc_io_write(SOC_SYS_MARK, SOC_MARK_IDLE);
}

/* Received bytes gathered until a frame's delimiter or a full buffer: each handling has a fixed
 * cost (some 500 clocks of calls into the device and the decoder), so a frame's bytes are handed
 * over in one or two handlings, not in one for every byte or two the UART brings a pass.
 * During a run, a delimiter admitted with more than RX_DELIM_BYTES bytes gathered before it, later
 * than RX_WHOLE_CLKS after the tick's start, does not take them along: they are decoded now and
 * the frame is served in the first pass after the next tick. A whole STREAM frame decoded and
 * served in one handling took some 4 900 clocks with four cables, more than a period's half
 * leaves beside their tick (the frame's bytes and both its delimiters waiting in the FIFO at the
 * tick's end: the first delimiter admitted as the first frame after the tick, the second by the
 * clocks left); split, its decoding and its handling take some 2 400 and 2 600 in two periods.
 * After a short tick (one cable's, some 4 500 clocks) a whole frame still fits, and a short
 * request (HELLO: 8 bytes) is always served at once. */
#define RX_DELIM_BYTES 16U
#define RX_WHOLE_CLKS 6000U
static uint8_t g_rx_buf[64];
static uint32_t g_rx_n;
/* 1: bytes of the frame being received were handed over without its delimiter (a full buffer, or
 * a delimiter that waits), so the decoder holds part of a frame. */
static uint32_t g_rx_open;

static void uart_poll(void)
{
    uint8_t *const buf = g_rx_buf;
    uint32_t n = g_rx_n;
    for (uint32_t i = 0U; i < RX_BYTES_PER_PASS; ++i) {
        uint8_t byte = 0U;
        if (g_delim_held == 0U) {
            uint32_t v = soc_io_read(SOC_UART_DATA);
            if ((v & 0x100U) == 0U) {
                break;
            }
            byte = (uint8_t)v;
        }
        if (byte == 0U) {
            if (rx_admitted() == 0U) {
                g_delim_held = 1U;
                break;
            }
            if (n > RX_DELIM_BYTES && g_dev.running != 0U &&
                soc_io_read(SOC_TIMER_COUNT) - g_tick_clk >= RX_WHOLE_CLKS) {
                g_delim_held = 1U;
                g_delim_next = 1U;
                break;
            }
            g_delim_held = 0U;
            g_delim_next = 0U;
            g_frame_owed = 0U;
        }
        /* A delimiter with nothing before it (every frame on the wire starts with one) ends an
         * empty frame, which the decoder skips: it is admitted as any delimiter (the first
         * frame after a tick, as before), but not handed over alone, which cost a handling's
         * fixed cost for nothing (some 600 clocks with four cables). */
        if (byte == 0U && n == 0U && g_rx_open == 0U) {
            continue;
        }
        buf[n++] = byte;
        if (byte == 0U || n == sizeof g_rx_buf) {
            rx_hand_over(buf, n);
            g_rx_open = (byte != 0U) ? 1U : 0U;
            n = 0U;
        }
    }
    /* A delimiter that waits for its time: the bytes before it are decoded meanwhile. */
    if (g_delim_held != 0U && n > 0U) {
        rx_hand_over(buf, n);
        g_rx_open = 1U;
        n = 0U;
    }
    g_rx_n = n;
    g_frame_owed = 0U; /* owed in the first pass after a tick only */
    /* Transmit what the FIFO has room for, up to TX_BYTES_PER_PASS, in chunks (one dev_tx_bytes
     * call per chunk). */
    uint32_t room = SOC_UART_TX_DEPTH - (soc_io_read(SOC_UART_STATUS) >> 16);
    if (room > TX_BYTES_PER_PASS) {
        room = TX_BYTES_PER_PASS;
    }
    uint8_t out[32];
    while (room > 0U) {
        uint32_t got = dev_tx_bytes(&g_dev, DEV_PORT_SERIAL, out, room < sizeof out ? room : sizeof out);
        if (got == 0U) {
            break;
        }
        for (uint32_t i = 0U; i < got; ++i) {
            soc_io_write(SOC_UART_DATA, out[i]);
        }
        room -= got;
    }
}

int main(void)
{
    soc_io_write(SOC_SYS_MARK, SOC_MARK_BOOT);
    /* The SoC's cables, as many as this image holds (a SoC of more keeps the others' drives
     * disabled: their banks are never written). */
    uint32_t n = soc_io_read(SOC_SYS_CHANNELS);
    g_channels = (n < 1U) ? 1U : (n > BOWDEN_CHANNELS_MAX) ? BOWDEN_CHANNELS_MAX : n;
    for (uint32_t k = 0U; k < g_channels; ++k) {
        hal_init_mmio(&g_hal[k], (volatile uint32_t *)(SOC_REGS_BASE + BOWDEN_REG_AT(k, 0U)));
        fw_init(&g_fw[k], &g_hal[k]);
    }
    spi_flash_init(&g_flash);
    dev_init_channels(&g_dev, g_fw, g_channels, &g_flash);
    /* Bytes that arrived during start-up are dropped with their overrun flag: a request sent
     * while the board booted gets no answer, and the client retries (PROTOCOL.md). */
    while ((soc_io_read(SOC_UART_DATA) & 0x100U) != 0U) {
    }
    soc_io_write(SOC_UART_STATUS, 0xCU);
    timer_follow_rate();

    uint32_t time_us = 0U;
    uint32_t us_rem = 0U;
    uint32_t taken = soc_io_read(SOC_TIMER_TICKS);
    g_tick_clk = soc_io_read(SOC_TIMER_COUNT);
    for (;;) {
        soc_io_write(SOC_SYS_MARK, SOC_MARK_IDLE);
        uart_poll();
        /* The timer's 16-bit count only goes up; the ticks not yet run are the difference. The
         * clock count is read first: a tick whose edge falls between the two reads is dated a
         * few clocks early, never late (late would overstate the time left before the next). */
        uint32_t now_clk = soc_io_read(SOC_TIMER_COUNT);
        uint32_t seen = soc_io_read(SOC_TIMER_TICKS);
        uint32_t pending = (seen - taken) & 0xFFFFU;
        if (pending == 0U) {
            continue;
        }
        taken = seen;
        g_tick_clk = now_clk;
        if (pending > 1U) {
            dev_overrun(&g_dev);
        }
        /* Time in microseconds, exact for any rate: 1e6 / rate with its remainder carried. */
        time_us += g_tick_us;
        us_rem += g_tick_us_rem;
        if (us_rem >= g_timer_rate_hz) {
            us_rem -= g_timer_rate_hz;
            ++time_us;
        }
        soc_io_write(SOC_SYS_MARK, SOC_MARK_TICK);
        int32_t t_out[BOWDEN_CHANNELS_MAX];
        for (uint32_t k = 0U; k < g_channels; ++k) {
            t_out[k] = t_out_q8(&g_hal[k], &g_dev.settings[k].fw.loop);
        }
        dev_tick_channels(&g_dev, time_us, t_out);
        timer_follow_rate();
        g_frame_owed = 1U;
    }
}
