/* test_dev.c - the device end to end: requests in, replies and telemetry out (dev.c), on the
 * host build (shadow registers, emulated flash). */
#include <string.h>

#include "bowden_regs.h"
#include "dev_host.h"
#include "params.h"
#include "test_util.h"
#include "unit.h"

static dev_host_t host;

/* Send a request on a serial port; return the first reply with that seq (or msg 0). */
static proto_frame_t request(uint32_t port, uint8_t msg, uint8_t seq, const uint8_t *payload,
                             uint32_t len)
{
    proto_frame_t f = {PROTO_VERSION, msg, seq, (uint8_t)len, {0}};
    if (len > 0U) {
        memcpy(f.payload, payload, len);
    }
    uint8_t w[PROTO_MAX_WIRE];
    uint32_t n = proto_encode(&f, w, sizeof w);
    dev_rx_bytes(&host.dev, port, w, n);
    proto_rx_t rx;
    proto_rx_init(&rx);
    proto_frame_t g = {0, 0, 0, 0, {0}};
    uint8_t out[64];
    uint32_t k;
    while ((k = dev_tx_bytes(&host.dev, port, out, sizeof out)) > 0U) {
        for (uint32_t i = 0; i < k; ++i) {
            proto_frame_t h;
            if (proto_rx_byte(&rx, out[i], &h) && h.seq == seq && h.msg != PROTO_MSG_TELEMETRY) {
                g = h;
            }
        }
    }
    return g;
}

static proto_frame_t set_param(uint32_t id, int32_t value, uint8_t seq)
{
    proto_param_set_t m = {(uint16_t)id, value, 0U, {0U}};
    uint8_t p[8];
    uint32_t n = proto_param_set_pack(&m, p);
    return request(0U, PROTO_MSG_PARAM_SET, seq, p, n);
}

static uint32_t error_code(const proto_frame_t *g)
{
    proto_error_t e;
    return (g->msg == PROTO_MSG_ERROR && proto_error_unpack(&e, g->payload, g->len)) ? e.code
                                                                                     : 0xFFU;
}

static void test_dev_hello_and_params(void)
{
    dev_host_init(&host);
    proto_frame_t g = request(0U, PROTO_MSG_HELLO, 1U, NULL, 0U);
    proto_hello_ack_t h;
    CHECK(g.msg == PROTO_MSG_HELLO_ACK && proto_hello_ack_unpack(&h, g.payload, g.len), "hello");
    CHECK(h.proto_version == PROTO_VERSION && h.table_hash == PROTO_TABLE_HASH &&
              h.n_params == PROTO_N_PARAMS && h.running == 0U &&
              h.config_source == PROTO_CONFIG_SOURCE_DEFAULTS && h.dirty == 0U,
          "identity");
    g = set_param(PROTO_PID_COMP_MODE, COMP_MODE_SMOOTH, 2U);
    proto_param_value_t v;
    CHECK(g.msg == PROTO_MSG_PARAM_VALUE && proto_param_value_unpack(&v, g.payload, g.len) &&
              v.param == PROTO_PID_COMP_MODE && v.value == COMP_MODE_SMOOTH,
          "set mode");
    CHECK(host.fw[0].comp.cfg.mode == COMP_MODE_SMOOTH, "reached the compensator");
    g = set_param(PROTO_PID_COMP_MODE, 7, 3U);
    proto_error_t e;
    CHECK(proto_error_unpack(&e, g.payload, g.len) && e.code == PROTO_ERR_INVALID_VALUE &&
              e.detail == COMP_ERR_MODE && e.request == PROTO_MSG_PARAM_SET,
          "bad mode");
    CHECK(e.text_count > 10U && memcmp(e.text, "comp.mode:", 10) == 0, "text names the field");
    CHECK(host.fw[0].comp.cfg.mode == COMP_MODE_SMOOTH, "unchanged");
    CHECK(error_code(&(proto_frame_t){0}) == 0xFFU, "helper");
    g = set_param(PROTO_PID_SAMPLE_RATE_HZ, 5000, 4U);
    CHECK(error_code(&g) == PROTO_ERR_READ_ONLY, "read-only");
    g = set_param(999U, 0, 5U);
    CHECK(error_code(&g) == PROTO_ERR_UNKNOWN_PARAM, "unknown id");
    uint8_t p[2] = {PROTO_PID_LOOP_KFF, 0};
    g = request(0U, PROTO_MSG_PARAM_INFO, 6U, p, 2U);
    proto_param_info_ack_t info;
    CHECK(proto_param_info_ack_unpack(&info, g.payload, g.len) &&
              info.key == params_table[PROTO_PID_LOOP_KFF].key &&
              info.default_word == BOWDEN_KFF_RESET && info.flags == 0U,
          "info");
    g = request(0U, PROTO_MSG_HELLO, 7U, NULL, 0U);
    CHECK(proto_hello_ack_unpack(&h, g.payload, g.len) && h.dirty == 1U, "dirty after a set");
}

static void test_dev_persist_survives_power_cycle(void)
{
    dev_host_init(&host);
    (void)set_param(PROTO_PID_LOOP_KP, 700, 1U);
    proto_frame_t g = request(0U, PROTO_MSG_PERSIST, 2U, NULL, 0U);
    proto_ack_t a;
    CHECK(proto_ack_unpack(&a, g.payload, g.len) && a.request == PROTO_MSG_PERSIST && a.value == 1U,
          "persist seq 1");
    (void)set_param(PROTO_PID_LOOP_KP, 701, 3U);
    dev_host_boot(&host); /* power cycle */
    CHECK(host.dev.settings[0].fw.loop.kp == 700 && host.fw[0].cfg.loop.kp == 700, "saved value back");
    CHECK(host.dev.config_source == PROTO_CONFIG_SOURCE_FLASH && host.dev.dirty == 0U, "source");
    g = request(0U, PROTO_MSG_DEFAULTS, 4U, NULL, 0U);
    CHECK(g.msg == PROTO_MSG_ACK && host.dev.settings[0].fw.loop.kp == BOWDEN_KP_RESET, "defaults");
    g = request(0U, PROTO_MSG_LOAD, 5U, NULL, 0U);
    CHECK(g.msg == PROTO_MSG_ACK && host.dev.settings[0].fw.loop.kp == 700, "load");
    /* a power cut during PERSIST: the device boots with the previous record */
    (void)set_param(PROTO_PID_LOOP_KP, 900, 6U);
    flash_ram_cut_after(&host.flash, 300);
    g = request(0U, PROTO_MSG_PERSIST, 7U, NULL, 0U);
    CHECK(error_code(&g) == PROTO_ERR_FLASH, "persist fails");
    dev_host_boot(&host);
    CHECK(host.dev.settings[0].fw.loop.kp == 700, "previous record after the cut");
}

static uint32_t drain_telemetry(uint32_t port, proto_telemetry_t *last, uint32_t *gaps)
{
    static proto_rx_t rx;
    static uint32_t next;
    if (last == NULL) {
        proto_rx_init(&rx);
        next = 0U;
        return 0U;
    }
    uint8_t out[256];
    uint32_t k, n = 0;
    while ((k = dev_tx_bytes(&host.dev, port, out, sizeof out)) > 0U) {
        for (uint32_t i = 0; i < k; ++i) {
            proto_frame_t h;
            if (proto_rx_byte(&rx, out[i], &h) && h.msg == PROTO_MSG_TELEMETRY &&
                proto_telemetry_unpack(last, h.payload, h.len)) {
                *gaps += last->sample != next;
                next = last->sample + 1U;
                ++n;
            }
        }
    }
    return n;
}

/* START's duration_ticks = PROTO_START_DURATION_CONTINUOUS (until STOP), little-endian. */
static const uint8_t CONTINUOUS[4] = {0xFF, 0xFF, 0xFF, 0xFF};

static void test_dev_run_telemetry_and_overflow(void)
{
    dev_host_init(&host);
    (void)set_param(PROTO_PID_SOURCE, FW_SOURCE_WAVE, 1U);
    uint8_t dur[4] = {100, 0, 0, 0}; /* 100 ticks */
    proto_frame_t g = request(0U, PROTO_MSG_START, 2U, dur, 4U);
    proto_ack_t a;
    CHECK(proto_ack_unpack(&a, g.payload, g.len) && a.value == 1000U, "start: tick rate");
    CHECK(host.dev.running == 1U, "running");
    g = set_param(PROTO_PID_LOOP_KP, 5, 3U);
    CHECK(error_code(&g) == PROTO_ERR_BUSY, "busy while running");
    proto_telemetry_t t;
    uint32_t gaps = 0, n = 0;
    (void)drain_telemetry(0U, NULL, NULL);
    for (uint32_t i = 0; i < 100U; ++i) {
        hal_shadow_set(&host.shadow[0], BOWDEN_REG_T_IN, 0xFFFFFF00UL); /* -1 N */
        dev_tick(&host.dev, i * 1000U, 1234);
        n += drain_telemetry(0U, &t, &gaps);
    }
    CHECK(n == 100U && gaps == 0U, "%u frames, %u gaps", n, gaps);
    CHECK(t.sample == 99U && t.time_us == 99000U && t.t_out == 1234 && t.t_in == -256,
          "last frame");
    CHECK(t.t_ref == host.fw[0].tel.t_ref && (t.status & PROTO_STATUS_RUNNING) != 0U, "fields");
    /* mu*phi in force (the configured one: the estimate is off by default), Q3.28 -> UQ2.14 */
    CHECK(t.mu_phi == (uint16_t)(comp_config_exponent_q28(&host.dev.settings[0].fw.comp) >> 14) &&
              t.mu_phi > 0U && t.est_faults == 0U,
          "mu_phi %u", t.mu_phi);
    CHECK(host.dev.running == 0U, "stopped after its duration");
    g = request(0U, PROTO_MSG_START, 3U, (const uint8_t[4]){0, 0, 0, 0}, 4U);
    CHECK(error_code(&g) == PROTO_ERR_INVALID_VALUE && host.dev.running == 0U,
          "a duration of 0 is refused, not endless");
    /* no drain: the transmit buffer fills, telemetry is dropped and counted, replies still fit */
    g = request(0U, PROTO_MSG_START, 4U, CONTINUOUS, 4U);
    for (uint32_t i = 0; i < 200U; ++i) { /* the clock goes on (the host watchdog reads it) */
        dev_tick(&host.dev, 100000U + i * 1000U, 0);
    }
    uint32_t dropped = host.dev.overflow;
    CHECK(dropped > 100U, "%u dropped", dropped);
    g = request(0U, PROTO_MSG_STOP, 5U, NULL, 0U);
    CHECK(g.msg == PROTO_MSG_ACK, "a reply got through a full buffer");
    (void)drain_telemetry(0U, NULL, NULL);
    g = request(0U, PROTO_MSG_START, 6U, CONTINUOUS, 4U);
    gaps = 0;
    dev_tick(&host.dev, 300000U, 0);
    CHECK(drain_telemetry(0U, &t, &gaps) == 1U && t.overflow == dropped &&
              (t.faults & PROTO_FAULT_TX_OVERFLOW) == 0U,
          "new run: overflow count kept, fault bit cleared");
    (void)request(0U, PROTO_MSG_STOP, 7U, NULL, 0U);
}

/* Samples streamed while a run takes them: each tick's T_ref is the next sample, in order, across
 * the stream ring's end many times (chunks of 24 and of 23 against a ring of DEV_STREAM_LEN). */
static void test_dev_stream_across_the_ring_end(void)
{
    dev_host_init(&host);
    (void)request(0U, PROTO_MSG_START, 1U, CONTINUOUS, 4U);
    (void)drain_telemetry(0U, NULL, NULL);
    proto_telemetry_t t;
    uint32_t gaps = 0, wrong = 0, time_us = 0;
    int32_t v = -32768;
    for (uint32_t chunk = 0; chunk < 120U; ++chunk) {
        proto_stream_t s;
        s.samples_count = (uint8_t)(23U + chunk % 2U);
        for (uint32_t i = 0; i < s.samples_count; ++i) {
            s.samples[i] = (int16_t)v;
            v = (v + 2731 > 32767) ? v + 2731 - 65536 : v + 2731;
        }
        uint8_t p[PROTO_MAX_PAYLOAD];
        const uint32_t n = proto_stream_pack(&s, p);
        proto_frame_t g = request(0U, PROTO_MSG_STREAM, (uint8_t)chunk, p, n);
        wrong += g.msg != PROTO_MSG_ACK;
        for (uint32_t i = 0; i < s.samples_count; ++i) {
            dev_tick(&host.dev, time_us += 1000U, 0);
            wrong += drain_telemetry(0U, &t, &gaps) != 1U || t.t_ref != s.samples[i];
        }
    }
    CHECK(wrong == 0U && gaps == 0U && (t.faults & PROTO_FAULT_STREAM_UNDERRUN) == 0U,
          "%u wrong, %u gaps", wrong, gaps);
    (void)request(0U, PROTO_MSG_STOP, 2U, NULL, 0U);
}

static void test_dev_stream_and_faults(void)
{
    dev_host_init(&host);
    proto_stream_t s;
    s.samples_count = 24U;
    for (uint32_t i = 0; i < 24U; ++i) {
        s.samples[i] = (int16_t)(256 * (int32_t)i - 3000); /* of both signs, */
    }
    s.samples[5] = INT16_MIN; /* and both ends */
    s.samples[6] = INT16_MAX;
    uint8_t p[PROTO_MAX_PAYLOAD];
    uint32_t n = proto_stream_pack(&s, p);
    proto_frame_t g = request(0U, PROTO_MSG_STREAM, 1U, p, n);
    proto_ack_t a;
    CHECK(proto_ack_unpack(&a, g.payload, g.len) && a.value == DEV_STREAM_LEN - 24U, "free slots");
    const uint32_t chunks = DEV_STREAM_LEN / 24U; /* whole chunks that fit */
    for (uint32_t i = 1; i < chunks; ++i) {
        g = request(0U, PROTO_MSG_STREAM, 2U, p, n);
    }
    CHECK(proto_ack_unpack(&a, g.payload, g.len) && a.value == DEV_STREAM_LEN - 24U * chunks,
          "free slots after %u chunks", chunks);
    g = request(0U, PROTO_MSG_STREAM, 3U, p, n); /* one chunk more than fits */
    CHECK(error_code(&g) == PROTO_ERR_STREAM_FULL, "full");
    g = request(0U, PROTO_MSG_STREAM, 4U, p, 3U);
    CHECK(error_code(&g) == PROTO_ERR_BAD_LENGTH, "odd length");
    (void)request(0U, PROTO_MSG_START, 5U, CONTINUOUS, 4U);
    (void)drain_telemetry(0U, NULL, NULL);
    proto_telemetry_t t;
    uint32_t gaps = 0;
    for (uint32_t i = 0; i < 24U * chunks; ++i) {
        dev_tick(&host.dev, i, 0);
        (void)drain_telemetry(0U, &t, &gaps);
        CHECK(t.t_ref == s.samples[i % 24U], "sample %u streamed", i);
    }
    CHECK((t.faults & PROTO_FAULT_STREAM_UNDERRUN) == 0U, "no underrun yet");
    for (uint32_t i = 0; i < 20U; ++i) {
        dev_tick(&host.dev, i, 0);
    }
    (void)drain_telemetry(0U, &t, &gaps);
    CHECK((t.faults & PROTO_FAULT_STREAM_UNDERRUN) != 0U && t.t_ref == s.samples[23], "held");
    /* an FPGA fault shows in telemetry and in FAULTS; FAULT_CLEAR while stopped never enables */
    hal_shadow_set(&host.shadow[0], BOWDEN_REG_FAULT, BOWDEN_FAULT_WATCHDOG_MASK);
    dev_tick(&host.dev, 0U, 0);
    (void)drain_telemetry(0U, &t, &gaps);
    CHECK((t.faults & PROTO_FAULT_WATCHDOG) != 0U, "watchdog in telemetry");
    (void)request(0U, PROTO_MSG_STOP, 6U, NULL, 0U);
    g = request(0U, PROTO_MSG_FAULTS_GET, 7U, NULL, 0U);
    proto_faults_t f;
    CHECK(proto_faults_unpack(&f, g.payload, g.len) && f.fpga_fault == BOWDEN_FAULT_WATCHDOG_MASK &&
              (f.device_faults & PROTO_FAULT_STREAM_UNDERRUN) != 0U && f.fault_ticks >= 1U,
          "faults");
    (void)dev_host_shadow(&host)->log_len;
    host.shadow[0].log_len = 0U;
    g = request(0U, PROTO_MSG_FAULT_CLEAR, 8U, NULL, 0U);
    CHECK(g.msg == PROTO_MSG_ACK && host.dev.faults == 0U, "cleared");
    CHECK(host.shadow[0].log_len == 1U && host.shadow[0].log[0].addr == BOWDEN_REG_CTRL &&
              host.shadow[0].log[0].value == BOWDEN_CTRL_FAULT_CLEAR_MASK,
          "only the clear pulse, no ENABLE");
}

static void test_dev_bad_frames_and_versions(void)
{
    dev_host_init(&host);
    proto_frame_t g = request(0U, PROTO_MSG_TELEMETRY, 1U, NULL, 0U);
    CHECK(error_code(&g) == PROTO_ERR_UNKNOWN_MESSAGE, "a device message sent to the device");
    g = request(0U, 31U, 2U, NULL, 0U);
    CHECK(error_code(&g) == PROTO_ERR_UNKNOWN_MESSAGE, "unknown id");
    g = request(0U, PROTO_MSG_PARAM_GET, 3U, (const uint8_t[4]){1, 2, 3, 4}, 4U);
    CHECK(error_code(&g) == PROTO_ERR_BAD_LENGTH, "bad length");
    /* another protocol version: HELLO is answered, the rest refused */
    proto_frame_t f = {PROTO_VERSION + 1U, PROTO_MSG_PARAM_GET, 4U, 2U, {0, 0}};
    uint8_t w[PROTO_MAX_WIRE];
    dev_rx_bytes(&host.dev, 0U, w, proto_encode(&f, w, sizeof w));
    f.msg = PROTO_MSG_HELLO;
    f.len = 0U;
    f.seq = 5U;
    dev_rx_bytes(&host.dev, 0U, w, proto_encode(&f, w, sizeof w));
    proto_rx_t rx;
    proto_rx_init(&rx);
    uint8_t out[256];
    uint32_t k = dev_tx_bytes(&host.dev, 0U, out, sizeof out);
    int saw_version = 0, saw_hello = 0;
    for (uint32_t i = 0; i < k; ++i) {
        proto_frame_t h;
        if (proto_rx_byte(&rx, out[i], &h)) {
            saw_version |= h.seq == 4U && error_code(&h) == PROTO_ERR_VERSION;
            saw_hello |= h.seq == 5U && h.msg == PROTO_MSG_HELLO_ACK;
        }
    }
    CHECK(saw_version && saw_hello, "version refused, hello answered");
    /* garbage is counted in STATS */
    const uint8_t junk[] = {0x00, 0x0A, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x00};
    dev_rx_bytes(&host.dev, 0U, junk, sizeof junk);
    g = request(0U, PROTO_MSG_STATS_GET, 6U, NULL, 0U);
    proto_stats_t st;
    CHECK(proto_stats_unpack(&st, g.payload, g.len) && st.rx_crc_errors == 1U &&
              st.rx_version_errors == 1U && st.rx_bad_messages == 3U && st.rx_frames == 6U,
          "stats: %lu crc, %lu version, %lu bad, %lu frames", (unsigned long)st.rx_crc_errors,
          (unsigned long)st.rx_version_errors, (unsigned long)st.rx_bad_messages,
          (unsigned long)st.rx_frames);
}

static void test_dev_can_port(void)
{
    dev_host_init(&host);
    dev_port_kind(&host.dev, 2U, DEV_PORT_CAN);
    proto_frame_t f = {PROTO_VERSION, PROTO_MSG_HELLO, 9U, 0U, {0}};
    proto_can_frame_t cf[PROTO_CAN_MAX_FRAMES];
    uint32_t k = proto_can_encode(1U, &f, cf, PROTO_CAN_MAX_FRAMES);
    dev_rx_can(&host.dev, 2U, &cf[0]);
    proto_can_frame_t out[64];
    k = dev_tx_can(&host.dev, 2U, out, 64U);
    proto_can_rx_t rx;
    proto_can_rx_init(&rx);
    proto_frame_t g;
    int got = 0;
    for (uint32_t i = 0; i < k; ++i) {
        /* the host reassembles replies addressed from node 1 */
        got += proto_can_rx(&rx, 1U, &out[i], &g);
    }
    proto_hello_ack_t h;
    CHECK(got == 1 && g.msg == PROTO_MSG_HELLO_ACK && proto_hello_ack_unpack(&h, g.payload, g.len) &&
              g.seq == 9U && h.table_hash == PROTO_TABLE_HASH,
          "hello over CAN (%u frames)", k);
    f.msg = PROTO_MSG_START;
    f.seq = 10U;
    f.len = 4U;
    memset(f.payload, 0xFF, 4U); /* PROTO_START_DURATION_CONTINUOUS */
    (void)proto_can_encode(1U, &f, cf, PROTO_CAN_MAX_FRAMES);
    dev_rx_can(&host.dev, 2U, &cf[0]);
    for (uint32_t i = 0; i < 10U; ++i) {
        dev_tick(&host.dev, i * 1000U, 512);
    }
    k = dev_tx_can(&host.dev, 2U, out, 64U);
    CHECK(k == 1U + 20U, "ACK + 10 x (TELEM_A, TELEM_B): %u", k);
    proto_telem_b_t b;
    CHECK(out[1].id == ((1U << 5) | PROTO_MSG_TELEM_A) &&
              out[2].id == ((1U << 5) | PROTO_MSG_TELEM_B) &&
              proto_telem_b_unpack(&b, out[20].data, out[20].len) && b.sample_lo == 9U &&
              b.t_out == 512,
          "telemetry frames");
    /* requests for another node are ignored */
    dev_rx_can(&host.dev, 2U, &(proto_can_frame_t){(2U << 5) | PROTO_MSG_STOP, 1U, {11}});
    CHECK(dev_tx_can(&host.dev, 2U, out, 64U) == 0U && host.dev.running == 1U, "other node");
}

/* Telemetry every dev.telemetry_div ticks: a frame exactly for the samples with sample % div == 0
 * (the device counts on to the next one instead of dividing at every tick), across a run's start,
 * a div changed between runs and within one, and the 32-bit sample count's wrap. */
static void test_dev_telemetry_every_div_ticks(void)
{
    static const struct {
        uint32_t div;
        uint32_t ticks_at; /* the sample count to jump to after 5 ticks (0: none) */
        uint32_t div_then; /* the divisor from tick 7 on, set within the run */
    } cases[] = {
        {3U, 0U, 3U}, {4U, 0U, 4U}, {7U, 0xFFFFFFF0UL, 7U}, {3U, 0xFFFFFFF8UL, 3U},
        {5U, 0U, 2U}, {2U, 0xFFFFFFFAUL, 6U}, {1U, 0xFFFFFFFCUL, 1U}, {1000U, 0U, 1000U},
    };
    for (uint32_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        dev_host_init(&host);
        (void)set_param(PROTO_PID_SOURCE, FW_SOURCE_WAVE, 1U);
        proto_frame_t g = set_param(PROTO_PID_DEV_TELEMETRY_DIV, (int32_t)cases[k].div, 2U);
        CHECK(g.msg != 0U && error_code(&g) == 0xFFU, "div %u accepted", cases[k].div);
        (void)request(0U, PROTO_MSG_START, 3U, CONTINUOUS, 4U);
        proto_rx_t rx;
        proto_rx_init(&rx);
        uint32_t sent = 0, wrong = 0;
        for (uint32_t i = 0; i < 40U; ++i) {
            if (i == 5U && cases[k].ticks_at != 0U) {
                host.fw[0].tel.ticks = cases[k].ticks_at;
            }
            if (i == 7U) { /* PARAM_SET refuses during a run; a changed setting is still obeyed */
                host.dev.settings[0].dev.telemetry_div = cases[k].div_then;
            }
            const uint32_t div = host.dev.settings[0].dev.telemetry_div;
            dev_tick(&host.dev, 1000U * (i + 1U), 0);
            const uint32_t sample = host.fw[0].tel.ticks - 1U;
            uint32_t got = 0;
            uint8_t out[256];
            uint32_t n;
            while ((n = dev_tx_bytes(&host.dev, 0U, out, sizeof out)) > 0U) {
                for (uint32_t j = 0; j < n; ++j) {
                    proto_frame_t h;
                    proto_telemetry_t t;
                    if (proto_rx_byte(&rx, out[j], &h) && h.msg == PROTO_MSG_TELEMETRY &&
                        proto_telemetry_unpack(&t, h.payload, h.len)) {
                        got += 1U;
                        wrong += t.sample != sample;
                    }
                }
            }
            wrong += got != ((sample % div == 0U) ? 1U : 0U);
            sent += got;
        }
        CHECK(wrong == 0U && sent > 0U, "div %u: %u frames, %u wrong", cases[k].div, sent, wrong);
        (void)request(0U, PROTO_MSG_STOP, 4U, NULL, 0U);
    }
}

/* The host watchdog: a run whose port sends no valid frame for PROTO_HOST_WATCHDOG_TIMEOUT_MS
 * stops (loop disabled) and is counted; a frame from the run's port feeds it, another port's
 * does not. */
static void test_dev_host_watchdog(void)
{
    const uint32_t timeout_us = PROTO_HOST_WATCHDOG_TIMEOUT_MS * 1000U;
    dev_host_init(&host);
    dev_tick(&host.dev, 7000U, 0); /* the device's clock is not at 0 when the run starts */
    (void)set_param(PROTO_PID_SOURCE, FW_SOURCE_WAVE, 1U);
    (void)request(0U, PROTO_MSG_START, 2U, CONTINUOUS, 4U);
    CHECK(host.dev.running == 1U, "running");
    dev_tick(&host.dev, 7000U + timeout_us - 1000U, 0);
    CHECK(host.dev.running == 1U, "one tick before the timeout");
    (void)request(0U, PROTO_MSG_FAULTS_GET, 3U, NULL, 0U); /* the run's port: fed */
    (void)drain_telemetry(0U, NULL, NULL);
    (void)request(1U, PROTO_MSG_FAULTS_GET, 4U, NULL, 0U); /* another port: not fed */
    dev_tick(&host.dev, 7000U + 2U * timeout_us - 2000U, 0);
    CHECK(host.dev.running == 1U && host.dev.host_timeouts == 0U, "fed by its own port");
    dev_tick(&host.dev, 7000U + 2U * timeout_us - 1000U, 0);
    CHECK(host.dev.running == 0U && host.dev.host_timeouts == 1U, "stopped at the timeout");
    CHECK((hal_read(host.dev.fw->hal, BOWDEN_REG_CTRL) & BOWDEN_CTRL_ENABLE_MASK) == 0U,
          "loop disabled");
    proto_frame_t g = request(1U, PROTO_MSG_STATS_GET, 5U, NULL, 0U);
    proto_stats_t st;
    CHECK(proto_stats_unpack(&st, g.payload, g.len) && st.host_timeouts == 1U,
          "counted in STATS on any port");
    /* the clock wraps (uint32 microseconds, ~71.6 min): a run across the wrap is not stopped */
    dev_tick(&host.dev, 0xFFFFFFFFU - 1000U, 0);
    (void)request(0U, PROTO_MSG_START, 6U, CONTINUOUS, 4U);
    dev_tick(&host.dev, 0xFFFFFFFFU + timeout_us / 2U, 0);
    CHECK(host.dev.running == 1U && host.dev.host_timeouts == 1U, "across the clock's wrap");
    (void)request(0U, PROTO_MSG_STOP, 8U, NULL, 0U);
}

const unit_test_t dev_tests[] = {
    {"hello_and_params", test_dev_hello_and_params},
    {"persist_survives_power_cycle", test_dev_persist_survives_power_cycle},
    {"run_telemetry_and_overflow", test_dev_run_telemetry_and_overflow},
    {"stream_and_faults", test_dev_stream_and_faults},
    {"stream_across_the_ring_end", test_dev_stream_across_the_ring_end},
    {"bad_frames_and_versions", test_dev_bad_frames_and_versions},
    {"can_port", test_dev_can_port},
    {"host_watchdog", test_dev_host_watchdog},
    {"telemetry_every_div_ticks", test_dev_telemetry_every_div_ticks},
};
const int dev_tests_count = (int)(sizeof dev_tests / sizeof dev_tests[0]);
