/* test_channels.c - a device of several channels (dev.c, flash.c, params.c): parameters by
 * channel, the flash record of every channel, runs of some channels, telemetry per channel, and
 * each channel's firmware bit for bit the firmware of a one-channel device with its settings. */
#include <string.h>

#include "bowden_regs.h"
#include "dev_host.h"
#include "flash_ram.h"
#include "params.h"
#include "test_util.h"
#include "unit.h"

_Static_assert(BOWDEN_CHANNELS_MAX >= 3U, "the host's device holds the channels these tests use");

static dev_host_t many;
static dev_host_t one;

/* Send a request to port 0 of h; return the reply with that seq (msg 0 when none came). */
static proto_frame_t ask(dev_host_t *h, uint8_t msg, uint8_t seq, const uint8_t *payload,
                         uint32_t len)
{
    proto_frame_t f = {PROTO_VERSION, msg, seq, (uint8_t)len, {0}};
    if (len > 0U) {
        memcpy(f.payload, payload, len);
    }
    uint8_t w[PROTO_MAX_WIRE];
    uint32_t n = proto_encode(&f, w, sizeof w);
    dev_rx_bytes(&h->dev, 0U, w, n);
    proto_rx_t rx;
    proto_rx_init(&rx);
    proto_frame_t g = {0, 0, 0, 0, {0}};
    uint8_t out[64];
    uint32_t k;
    while ((k = dev_tx_bytes(&h->dev, 0U, out, sizeof out)) > 0U) {
        for (uint32_t i = 0; i < k; ++i) {
            proto_frame_t r;
            if (proto_rx_byte(&rx, out[i], &r) && r.seq == seq && r.msg != PROTO_MSG_TELEMETRY) {
                g = r;
            }
        }
    }
    return g;
}

static proto_frame_t set_on(dev_host_t *h, uint32_t ch, uint32_t id, int32_t value)
{
    proto_param_set_t m = {(uint16_t)id, value, 1U, {(uint8_t)ch}};
    uint8_t p[8];
    return ask(h, PROTO_MSG_PARAM_SET, 1U, p, proto_param_set_pack(&m, p));
}

static int32_t get_on(dev_host_t *h, uint32_t ch, uint32_t id, uint32_t *got_ch)
{
    proto_param_get_t m = {(uint16_t)id, 1U, {(uint8_t)ch}};
    uint8_t p[4];
    proto_frame_t g = ask(h, PROTO_MSG_PARAM_GET, 2U, p, proto_param_get_pack(&m, p));
    proto_param_value_t v = {0, 0, 0};
    if (g.msg != PROTO_MSG_PARAM_VALUE || !proto_param_value_unpack(&v, g.payload, g.len)) {
        *got_ch = 0xFFU;
        return INT32_MIN;
    }
    *got_ch = v.channel;
    return v.value;
}

static uint32_t error_of(const proto_frame_t *g)
{
    proto_error_t e;
    return (g->msg == PROTO_MSG_ERROR && proto_error_unpack(&e, g->payload, g->len)) ? e.code
                                                                                     : 0xFFU;
}

static proto_frame_t start_mask(dev_host_t *h, uint32_t ticks, int mask)
{
    proto_start_t m;
    m.duration_ticks = ticks;
    m.channel_mask_count = (mask >= 0) ? 1U : 0U;
    m.channel_mask[0] = (uint8_t)((mask >= 0) ? mask : 0);
    uint8_t p[8];
    return ask(h, PROTO_MSG_START, 3U, p, proto_start_pack(&m, p));
}

/* The telemetry frames h sent since the last call, into t[] (at most max). */
static uint32_t take_telemetry(dev_host_t *h, proto_telemetry_t *t, uint32_t max)
{
    proto_rx_t rx;
    proto_rx_init(&rx);
    uint8_t out[256];
    uint32_t k, n = 0;
    while ((k = dev_tx_bytes(&h->dev, 0U, out, sizeof out)) > 0U) {
        for (uint32_t i = 0; i < k; ++i) {
            proto_frame_t r;
            if (proto_rx_byte(&rx, out[i], &r) && r.msg == PROTO_MSG_TELEMETRY && n < max &&
                proto_telemetry_unpack(&t[n], r.payload, r.len)) {
                ++n;
            }
        }
    }
    return n;
}

static void test_channels_params_by_channel(void)
{
    dev_host_init_channels(&many, 3U);
    proto_frame_t g = ask(&many, PROTO_MSG_HELLO, 9U, NULL, 0U);
    proto_hello_ack_t hello;
    CHECK(proto_hello_ack_unpack(&hello, g.payload, g.len) && hello.n_channels == 3U,
          "HELLO: 3 channels");
    CHECK(set_on(&many, 1U, PROTO_PID_LOOP_KP, 700).msg == PROTO_MSG_PARAM_VALUE, "set ch 1");
    uint32_t ch;
    CHECK(get_on(&many, 1U, PROTO_PID_LOOP_KP, &ch) == 700 && ch == 1U, "ch 1 holds it");
    CHECK(get_on(&many, 0U, PROTO_PID_LOOP_KP, &ch) == BOWDEN_KP_RESET && ch == 0U,
          "ch 0 keeps its own");
    CHECK(many.fw[1].cfg.loop.kp == 700 && many.fw[0].cfg.loop.kp == BOWDEN_KP_RESET &&
              many.fw[2].cfg.loop.kp == BOWDEN_KP_RESET,
          "only channel 1's firmware configured");
    /* a device-wide parameter is one value for every channel */
    CHECK(params_is_device(PROTO_PID_DEV_TELEMETRY_DIV) && !params_is_device(PROTO_PID_LOOP_KP),
          "dev.* are the device's");
    (void)set_on(&many, 2U, PROTO_PID_DEV_TELEMETRY_DIV, 5);
    CHECK(get_on(&many, 0U, PROTO_PID_DEV_TELEMETRY_DIV, &ch) == 5 &&
              get_on(&many, 1U, PROTO_PID_DEV_TELEMETRY_DIV, &ch) == 5,
          "dev.telemetry_div set on channel 2 reads the same on 0 and 1");
    /* a channel outside the device, in every request that names one */
    g = set_on(&many, 3U, PROTO_PID_LOOP_KP, 1);
    CHECK(error_of(&g) == PROTO_ERR_INVALID_VALUE, "set on channel 3 of 3");
    CHECK(get_on(&many, 3U, PROTO_PID_LOOP_KP, &ch) == INT32_MIN, "get on channel 3 refused");
    uint8_t fq[1] = {7U};
    g = ask(&many, PROTO_MSG_FAULTS_GET, 4U, fq, 1U);
    CHECK(error_of(&g) == PROTO_ERR_INVALID_VALUE, "FAULTS_GET of channel 7");
    uint8_t st[3] = {3U, 0, 0};
    g = ask(&many, PROTO_MSG_STREAM_CH, 5U, st, 3U);
    CHECK(error_of(&g) == PROTO_ERR_INVALID_VALUE, "STREAM_CH to channel 3");
    g = start_mask(&many, 10U, 0);
    proto_frame_t g3 = start_mask(&many, 10U, 0x08);
    CHECK(error_of(&g) == PROTO_ERR_INVALID_VALUE && error_of(&g3) == PROTO_ERR_INVALID_VALUE &&
              many.dev.running == 0U,
          "START of no channel, or of channel 3, refused and nothing runs");
}

static void test_channels_flash_carries_every_channel(void)
{
    dev_host_init_channels(&many, 3U);
    (void)set_on(&many, 0U, PROTO_PID_LOOP_KP, 600);
    (void)set_on(&many, 1U, PROTO_PID_LOOP_KP, 601);
    (void)set_on(&many, 2U, PROTO_PID_COMP_BAND_N, 77);
    (void)set_on(&many, 1U, PROTO_PID_DEV_CAN_NODE, 9);
    proto_frame_t g = ask(&many, PROTO_MSG_PERSIST, 6U, NULL, 0U);
    CHECK(g.msg == PROTO_MSG_ACK, "persist");
    /* the record: every parameter of channel 0 and the channel parameters of 1 and 2 */
    uint32_t device = 0;
    for (uint32_t i = 0; i < PROTO_N_PARAMS; ++i) {
        device += (uint32_t)params_is_device(i);
    }
    const uint32_t slot = many.flash.words[0][0] == FLASH_MAGIC ? 0U : 1U;
    CHECK(many.flash.words[slot][2] == PROTO_N_PARAMS + 2U * (PROTO_N_PARAMS - device),
          "pairs: %u", many.flash.words[slot][2]);
    dev_host_boot(&many);
    uint32_t ch;
    CHECK(get_on(&many, 0U, PROTO_PID_LOOP_KP, &ch) == 600 &&
              get_on(&many, 1U, PROTO_PID_LOOP_KP, &ch) == 601 &&
              get_on(&many, 2U, PROTO_PID_LOOP_KP, &ch) == BOWDEN_KP_RESET &&
              get_on(&many, 2U, PROTO_PID_COMP_BAND_N, &ch) == 77 &&
              get_on(&many, 0U, PROTO_PID_COMP_BAND_N, &ch) != 77,
          "every channel's own words after a power cycle");
    CHECK(get_on(&many, 2U, PROTO_PID_DEV_CAN_NODE, &ch) == 9 &&
              many.dev.settings[0].dev.can_node == 9U,
          "the device's own word, once");
    CHECK(many.fw[1].cfg.loop.kp == 601, "and in channel 1's firmware");
    /* the same flash booted with fewer channels: channel 0's words, the others' keys skipped */
    many.channels = 1U;
    dev_host_boot(&many);
    CHECK(many.dev.channels == 1U && get_on(&many, 0U, PROTO_PID_LOOP_KP, &ch) == 600 &&
              many.dev.config_source == PROTO_CONFIG_SOURCE_FLASH,
          "a one-channel device loads channel 0 of the record");
    /* a one-channel record (protocol 2's) into a device of 3: channel 0 from it, the rest
     * defaults */
    dev_host_init(&one);
    (void)set_on(&one, 0U, PROTO_PID_LOOP_KP, 555);
    (void)ask(&one, PROTO_MSG_PERSIST, 7U, NULL, 0U);
    memcpy(&many.flash.words, &one.flash.words, sizeof one.flash.words);
    many.channels = 3U;
    dev_host_boot(&many);
    CHECK(get_on(&many, 0U, PROTO_PID_LOOP_KP, &ch) == 555 &&
              get_on(&many, 1U, PROTO_PID_LOOP_KP, &ch) == BOWDEN_KP_RESET,
          "a one-channel record: channel 0, the others at their defaults");
    /* the tagged keys of every channel differ from each other and from every name's key */
    for (uint32_t c = 1; c < BOWDEN_CHANNELS_MAX; ++c) {
        for (uint32_t i = 0; i < PROTO_N_PARAMS; ++i) {
            const uint32_t key = params_channel_key(i, c);
            if (params_is_device(i)) {
                continue;
            }
            CHECK(params_find(key) < 0, "channel %u's key of %u is no name's key", c, i);
            for (uint32_t d = 1; d < c; ++d) {
                for (uint32_t j = 0; j < PROTO_N_PARAMS; ++j) {
                    CHECK(params_channel_key(j, d) != key || params_is_device(j),
                          "keys of (%u, %u) and (%u, %u) differ", c, i, d, j);
                }
            }
        }
    }
}

/* Channel k's firmware in a device of 3 and a one-channel device with the same settings give
 * the same register writes and telemetry, tick for tick (each channel's shadow fed alike). */
static void test_channels_each_is_a_one_channel_device(void)
{
    static const int32_t kp[3] = {300, 700, 1200};
    static const int32_t mode[3] = {COMP_MODE_PAPER, COMP_MODE_SMOOTH, COMP_MODE_NONE};
    for (uint32_t k = 0; k < 3U; ++k) {
        dev_host_init_channels(&many, 3U);
        dev_host_init(&one);
        for (uint32_t c = 0; c < 3U; ++c) {
            (void)set_on(&many, c, PROTO_PID_LOOP_KP, kp[c]);
            (void)set_on(&many, c, PROTO_PID_COMP_MODE, mode[c]);
            (void)set_on(&many, c, PROTO_PID_SOURCE, FW_SOURCE_WAVE);
            (void)set_on(&many, c, PROTO_PID_WAVE_FREQ_HZ, (int32_t)(65536U * (c + 1U)));
        }
        (void)set_on(&one, 0U, PROTO_PID_LOOP_KP, kp[k]);
        (void)set_on(&one, 0U, PROTO_PID_COMP_MODE, mode[k]);
        (void)set_on(&one, 0U, PROTO_PID_SOURCE, FW_SOURCE_WAVE);
        (void)set_on(&one, 0U, PROTO_PID_WAVE_FREQ_HZ, (int32_t)(65536U * (k + 1U)));
        CHECK(start_mask(&many, 2000U, 7).msg == PROTO_MSG_ACK &&
                  start_mask(&one, 2000U, -1).msg == PROTO_MSG_ACK,
              "both start");
        hal_write_t wm[HAL_LOG_CAPACITY], wo[HAL_LOG_CAPACITY];
        uint32_t same = 1U;
        for (uint32_t i = 0; i < 1500U && same; ++i) {
            const uint32_t t_in = (uint32_t)((int32_t)(i * 7U % 4096U) - 2048);
            for (uint32_t c = 0; c < 3U; ++c) {
                hal_shadow_set(&many.shadow[c], BOWDEN_REG_T_IN, t_in + c);
            }
            hal_shadow_set(&one.shadow[0], BOWDEN_REG_T_IN, t_in + k);
            const int32_t t_out[3] = {11, 22, 33};
            dev_tick_channels(&many.dev, i * 1000U, t_out);
            dev_tick(&one.dev, i * 1000U, t_out[k]);
            const uint32_t nm = hal_shadow_drain(&many.shadow[k], wm, HAL_LOG_CAPACITY);
            const uint32_t no = hal_shadow_drain(&one.shadow[0], wo, HAL_LOG_CAPACITY);
            same = nm == no && memcmp(wm, wo, nm * sizeof wm[0]) == 0;
            proto_telemetry_t tm[4], to[2];
            const uint32_t n_many = take_telemetry(&many, tm, 4U);
            const uint32_t n_one = take_telemetry(&one, to, 2U);
            same = same && n_many == 3U && n_one == 1U && tm[k].channel == k &&
                   tm[0].channel == 0U && tm[2].channel == 2U;
            tm[k].channel = 0U; /* the one-channel device's is channel 0 */
            same = same && memcmp(&tm[k], &to[0], sizeof to[0]) == 0;
            CHECK(same, "channel %u, tick %u: writes %u/%u, frames %u/%u", k, i, nm, no, n_many,
                  n_one);
            if (i % 100U == 99U) { /* the host watchdog: a request now and then */
                (void)ask(&many, PROTO_MSG_STATS_GET, 9U, NULL, 0U);
                (void)ask(&one, PROTO_MSG_STATS_GET, 9U, NULL, 0U);
            }
        }
        (void)ask(&many, PROTO_MSG_STOP, 8U, NULL, 0U);
        (void)ask(&one, PROTO_MSG_STOP, 8U, NULL, 0U);
    }
}

static void test_channels_run_of_some_channels(void)
{
    dev_host_init_channels(&many, 3U);
    for (uint32_t c = 0; c < 3U; ++c) {
        (void)set_on(&many, c, PROTO_PID_SOURCE, FW_SOURCE_HOST);
    }
    /* channel 1's stream through STREAM_CH, channel 0's through STREAM */
    uint8_t p[PROTO_MAX_PAYLOAD];
    proto_stream_ch_t s1;
    s1.channel = 1U;
    s1.samples_count = 3U;
    s1.samples[0] = 256;
    s1.samples[1] = 512;
    s1.samples[2] = 768;
    proto_frame_t g = ask(&many, PROTO_MSG_STREAM_CH, 1U, p, proto_stream_ch_pack(&s1, p));
    proto_ack_t a;
    CHECK(proto_ack_unpack(&a, g.payload, g.len) && a.value == DEV_STREAM_LEN - 3U &&
              many.dev.stream_len[0] == 0U && many.dev.stream_len[1] == 3U,
          "STREAM_CH fills channel 1's buffer only");
    g = ask(&many, PROTO_MSG_STREAM_CH, 1U, p, 2U);
    CHECK(error_of(&g) == PROTO_ERR_BAD_LENGTH, "STREAM_CH of half a sample");
    /* run channels 1 and 2 only */
    CHECK(start_mask(&many, 3U, 0x06).msg == PROTO_MSG_ACK && many.dev.run_mask == 0x06U,
          "start 1 and 2");
    CHECK((many.shadow[0].regs[BOWDEN_REG_CTRL / 4U] & BOWDEN_CTRL_ENABLE_MASK) == 0U &&
              (many.shadow[1].regs[BOWDEN_REG_CTRL / 4U] & BOWDEN_CTRL_ENABLE_MASK) != 0U &&
              (many.shadow[2].regs[BOWDEN_REG_CTRL / 4U] & BOWDEN_CTRL_ENABLE_MASK) != 0U,
          "channel 0 stays disabled");
    const int32_t t_out[3] = {0, 0, 0};
    proto_telemetry_t t[8];
    uint32_t n = 0;
    for (uint32_t i = 0; i < 3U; ++i) {
        dev_tick_channels(&many.dev, i * 1000U, t_out);
        n += take_telemetry(&many, &t[n], 8U - n);
    }
    CHECK(n == 6U && t[0].channel == 1U && t[1].channel == 2U && t[0].t_ref == 256 &&
              t[2].t_ref == 512 && t[4].t_ref == 768 && t[5].sample == 2U,
          "two frames a tick, in channel order, channel 1's stream (%u frames)", n);
    CHECK(many.dev.running == 0U && many.dev.run_mask == 0U &&
              (many.shadow[1].regs[BOWDEN_REG_CTRL / 4U] & BOWDEN_CTRL_ENABLE_MASK) == 0U,
          "the run ends on every channel");
    /* FAULTS of a channel: its own registers */
    hal_shadow_set(&many.shadow[2], BOWDEN_REG_FAULT, BOWDEN_FAULT_WATCHDOG_MASK);
    uint8_t fq[1] = {2U};
    g = ask(&many, PROTO_MSG_FAULTS_GET, 2U, fq, 1U);
    proto_faults_t f;
    CHECK(proto_faults_unpack(&f, g.payload, g.len) && f.channel == 2U &&
              f.fpga_fault == BOWDEN_FAULT_WATCHDOG_MASK,
          "FAULTS of channel 2");
    g = ask(&many, PROTO_MSG_FAULTS_GET, 3U, NULL, 0U);
    CHECK(proto_faults_unpack(&f, g.payload, g.len) && f.channel == 0U && f.fpga_fault == 0U,
          "FAULTS without a channel: channel 0's");
}

/* With dev.telemetry_div above 1, channel c sends the samples with sample % div == c % div: each
 * channel its frame every div samples, in channel order within a tick, the channels' frames
 * spread over the ticks (no more than ceil(channels / div) in one). Divisors 2 and 3 (the latter
 * set within the run) and 1 (every channel every tick). */
static void test_channels_telemetry_spread_over_ticks(void)
{
    static const struct {
        uint32_t div;
        uint32_t div_then; /* from tick 11 on */
    } cases[] = {{2U, 2U}, {3U, 3U}, {2U, 3U}, {1U, 1U}, {3U, 1U}};
    for (uint32_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        dev_host_init_channels(&many, 3U);
        for (uint32_t c = 0; c < 3U; ++c) {
            (void)set_on(&many, c, PROTO_PID_SOURCE, FW_SOURCE_WAVE);
        }
        (void)set_on(&many, 0U, PROTO_PID_DEV_TELEMETRY_DIV, (int32_t)cases[k].div);
        CHECK(start_mask(&many, 2000U, -1).msg == PROTO_MSG_ACK, "start");
        const int32_t t_out[3] = {0, 0, 0};
        uint32_t wrong = 0U, sent[3] = {0U, 0U, 0U}, due[3] = {0U, 0U, 0U};
        for (uint32_t i = 0; i < 30U; ++i) {
            if (i == 11U) { /* PARAM_SET refuses during a run; a changed setting is obeyed */
                for (uint32_t c = 0; c < 3U; ++c) {
                    many.dev.settings[c].dev.telemetry_div = cases[k].div_then;
                }
            }
            const uint32_t div = many.dev.settings[0].dev.telemetry_div;
            dev_tick_channels(&many.dev, i * 1000U, t_out);
            proto_telemetry_t t[4];
            const uint32_t n = take_telemetry(&many, t, 4U);
            uint32_t want = 0U;
            for (uint32_t c = 0; c < 3U; ++c) {
                if (i % div == c % div) { /* sample i: fw_start zeroes the count */
                    wrong += want >= n || t[want].channel != c || t[want].sample != i;
                    ++want;
                    ++due[c];
                }
            }
            wrong += n != want || n > (3U + div - 1U) / div;
            for (uint32_t j = 0; j < n && j < 4U; ++j) {
                sent[t[j].channel % 3U] += 1U;
            }
        }
        CHECK(wrong == 0U && sent[0] == due[0] && sent[1] == due[1] && sent[2] == due[2] &&
                  due[2] > 0U,
              "div %u then %u: frames %u %u %u, %u wrong", cases[k].div, cases[k].div_then,
              sent[0], sent[1], sent[2], wrong);
        (void)ask(&many, PROTO_MSG_STOP, 8U, NULL, 0U);
    }
}

const unit_test_t channel_tests[] = {
    {"params_by_channel", test_channels_params_by_channel},
    {"flash_carries_every_channel", test_channels_flash_carries_every_channel},
    {"each_is_a_one_channel_device", test_channels_each_is_a_one_channel_device},
    {"run_of_some_channels", test_channels_run_of_some_channels},
    {"telemetry_spread_over_ticks", test_channels_telemetry_spread_over_ticks},
};
const int channel_tests_count = (int)(sizeof channel_tests / sizeof channel_tests[0]);
