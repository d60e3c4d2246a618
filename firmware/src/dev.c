/* dev.c - the device side of the bench protocol (dev.h). */
#include "dev.h"

#include "bowden_regs.h"
#include "params.h"

/* Room kept free for replies when telemetry is queued: two of the largest frames. */
#define RESERVE_BYTES (2U * PROTO_MAX_WIRE)
#define RESERVE_CAN (2U * PROTO_CAN_MAX_FRAMES)
/* Device faults a new run starts without (CONFIG stays until FAULT_CLEAR or PERSIST). */
#define RUN_FAULTS (PROTO_FAULT_STREAM_UNDERRUN | PROTO_FAULT_TX_OVERFLOW | PROTO_FAULT_OVERRUN)

void dev_port_kind(dev_t *d, uint32_t port, uint32_t kind)
{
    if (port >= DEV_PORTS) {
        return;
    }
    dev_port_t *p = &d->ports[port];
    p->kind = kind;
    proto_rx_init(&p->rx);
    proto_can_rx_init(&p->can_rx);
    p->tx_head = p->tx_len = 0U;
    p->can_head = p->can_len = 0U;
    p->version_errors = p->bad_messages = p->tx_frames = p->tx_overflow = 0U;
}

static void stream_clear(dev_t *d)
{
    for (uint32_t c = 0; c < BOWDEN_CHANNELS_MAX; ++c) {
        d->stream_head[c] = d->stream_len[c] = 0U;
        d->stream_last[c] = 0;
    }
}

/* Every channel's settings to the factory defaults. */
static void settings_default_all(dev_t *d)
{
    for (uint32_t c = 0; c < d->channels; ++c) {
        settings_default(&d->settings[c]);
    }
}

/* Every channel's firmware to its settings (checked by the caller: params_set, flash_load, or
 * the defaults). */
static void configure_all(dev_t *d)
{
    for (uint32_t c = 0; c < d->channels; ++c) {
        fw_configure_checked(&d->fw[c], &d->settings[c].fw);
    }
}

void dev_init(dev_t *d, fw_t *fw, const flash_hal_t *flash)
{
    dev_init_channels(d, fw, 1U, flash);
}

void dev_init_channels(dev_t *d, fw_t *fw, uint32_t n, const flash_hal_t *flash)
{
    d->fw = fw;
    d->channels = (n < 1U) ? 1U : (n > BOWDEN_CHANNELS_MAX) ? BOWDEN_CHANNELS_MAX : n;
    d->run_mask = 0U;
    d->flash = flash;
    d->id.proto_version = (uint8_t)PROTO_VERSION;
    d->id.fw_major = (uint8_t)DEV_FW_VERSION_MAJOR;
    d->id.fw_minor = (uint8_t)DEV_FW_VERSION_MINOR;
    d->id.fw_patch = (uint8_t)DEV_FW_VERSION_PATCH;
    d->id.build_id = (uint32_t)BOWDEN_BUILD_ID;
    d->id.table_hash = PROTO_TABLE_HASH;
    d->faults = 0U;
    d->overflow = 0U;
    d->time_us = 0U;
    d->host_seen_us = d->host_timeouts = 0U;
    d->running = d->run_ticks = d->run_limit = d->owner = 0U;
    d->dirty = 0U;
    for (uint32_t c = 0; c < BOWDEN_CHANNELS_MAX; ++c) {
        d->tel_div[c] = d->tel_sample[c] = d->tel_left[c] = 0U;
    }
    settings_default_all(d);
    d->config_source = PROTO_CONFIG_SOURCE_DEFAULTS;
    if (flash != 0) {
        uint32_t seq;
        int32_t err = flash_load_channels(flash, d->settings, d->channels, &seq);
        if (err == FLASH_OK) {
            d->config_source = PROTO_CONFIG_SOURCE_FLASH;
        } else if (err == FLASH_ERR_INVALID) {
            d->config_source = PROTO_CONFIG_SOURCE_FLASH_INVALID;
            d->faults |= PROTO_FAULT_CONFIG;
        }
    }
    configure_all(d); /* checked by flash_load or the defaults */
    stream_clear(d);
    for (uint32_t i = 0; i < DEV_PORTS; ++i) {
        dev_port_kind(d, i, DEV_PORT_SERIAL);
    }
}

/* --- transmit ------------------------------------------------------------------------------ */

_Static_assert((DEV_TX_BYTES & (DEV_TX_BYTES - 1U)) == 0U,
               "DEV_TX_BYTES a power of two: the ring's index wraps with a mask, not a division");

/* Where the next byte queued on a serial port goes. */
static uint32_t tx_tail(const dev_port_t *p)
{
    return (p->tx_head + p->tx_len) % DEV_TX_BYTES;
}

static int can_push(dev_port_t *p, const proto_can_frame_t *f, uint32_t n, uint32_t reserve)
{
    if (DEV_TX_CAN_FRAMES - p->can_len < n + reserve) {
        return 0;
    }
    for (uint32_t i = 0; i < n; ++i) {
        p->can_tx[(p->can_head + p->can_len + i) % DEV_TX_CAN_FRAMES] = f[i];
    }
    p->can_len += n;
    return 1;
}

/* n bytes written at the ring's tail `at` (through its end into the room past it) made part of
 * the ring: the part past the end moved to its start, which is free (tx_len + n <= DEV_TX_BYTES,
 * checked by the caller). */
static void tx_commit(dev_port_t *p, uint32_t at, uint32_t n)
{
    if (at + n > DEV_TX_BYTES) {
        for (uint32_t i = 0; i < at + n - DEV_TX_BYTES; ++i) {
            p->tx[i] = p->tx[DEV_TX_BYTES + i];
        }
    }
    p->tx_len += n;
}

/* A frame to a CAN port, apart from send_frame: its frame array on the stack would otherwise be
 * set up for every serial frame too (on the soft CPU the telemetry frames are most of the tick). */
__attribute__((noinline)) static int send_can(dev_t *d, dev_port_t *p, const proto_frame_t *f,
                                              int telemetry)
{
    proto_can_frame_t cf[PROTO_CAN_MAX_FRAMES];
    uint32_t n = proto_can_encode(d->settings[0].dev.can_node, f, cf, PROTO_CAN_MAX_FRAMES);
    return n != 0U && can_push(p, cf, n, telemetry ? RESERVE_CAN : 0U);
}

/* A frame queued (ok) or refused for want of room, counted on its port; returns ok. */
static inline int tx_counted(dev_port_t *p, int ok)
{
    if (ok) {
        ++p->tx_frames;
    } else {
        ++p->tx_overflow;
    }
    return ok;
}

/* Queue a frame on a port; telemetry leaves the reserve free. 1 when queued. */
static int send_frame(dev_t *d, uint32_t port, const proto_frame_t *f, int telemetry)
{
    dev_port_t *p = &d->ports[port];
    int ok;
    if (p->kind == DEV_PORT_CAN) {
        ok = send_can(d, p, f, telemetry);
    } else {
        /* Encoded in place in the ring (a copy less on every frame: on the soft CPU the
         * telemetry frames are most of the tick); a frame that reaches the ring's end is encoded
         * into the room past it, and only that part is moved to the ring's start (before, the
         * whole frame went through a buffer: the worst tick was the one where a frame wrapped). */
        const uint32_t n = proto_wire_len(f);
        const uint32_t at = tx_tail(p);
        if (n == 0U || DEV_TX_BYTES - p->tx_len < n + (telemetry ? RESERVE_BYTES : 0U)) {
            ok = 0;
        } else {
            ok = proto_encode(f, &p->tx[at], n) == n;
            if (ok) {
                tx_commit(p, at, n);
            }
        }
    }
    return tx_counted(p, ok);
}

uint32_t dev_tx_bytes(dev_t *d, uint32_t port, uint8_t *out, uint32_t max)
{
    if (port >= DEV_PORTS) {
        return 0U;
    }
    dev_port_t *p = &d->ports[port];
    uint32_t n = (p->tx_len < max) ? p->tx_len : max;
    for (uint32_t i = 0; i < n; ++i) {
        out[i] = p->tx[p->tx_head];
        p->tx_head = (p->tx_head + 1U) % DEV_TX_BYTES;
    }
    p->tx_len -= n;
    return n;
}

uint32_t dev_tx_can(dev_t *d, uint32_t port, proto_can_frame_t *out, uint32_t max)
{
    if (port >= DEV_PORTS) {
        return 0U;
    }
    dev_port_t *p = &d->ports[port];
    uint32_t n = (p->can_len < max) ? p->can_len : max;
    for (uint32_t i = 0; i < n; ++i) {
        out[i] = p->can_tx[p->can_head];
        p->can_head = (p->can_head + 1U) % DEV_TX_CAN_FRAMES;
    }
    p->can_len -= n;
    return n;
}

/* --- replies ------------------------------------------------------------------------------- */

static void frame_init(proto_frame_t *f, uint32_t msg, uint32_t seq)
{
    f->version = (uint8_t)PROTO_VERSION;
    f->msg = (uint8_t)msg;
    f->seq = (uint8_t)seq;
    f->len = 0U;
}

static void reply_ack(dev_t *d, uint32_t port, const proto_frame_t *req, uint32_t value)
{
    proto_ack_t m = {req->msg, value};
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_ACK, req->seq);
    f.len = (uint8_t)proto_ack_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static void reply_error(dev_t *d, uint32_t port, const proto_frame_t *req, uint32_t code,
                        int32_t detail, const char *text)
{
    proto_error_t m;
    m.request = req->msg;
    m.code = (uint8_t)code;
    m.detail = detail;
    m.text_count = 0U;
    while (text != 0 && text[m.text_count] != '\0' && m.text_count < PROTO_ERROR_TEXT_MAX) {
        m.text[m.text_count] = text[m.text_count];
        ++m.text_count;
    }
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_ERROR, req->seq);
    f.len = (uint8_t)proto_error_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static void reply_param(dev_t *d, uint32_t port, const proto_frame_t *req, uint32_t ch,
                        uint32_t id)
{
    proto_param_value_t m;
    m.channel = (uint8_t)ch;
    m.param = (uint16_t)id;
    (void)params_get(&d->settings[ch], id, &m.value);
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_PARAM_VALUE, req->seq);
    f.len = (uint8_t)proto_param_value_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static void reply_busy(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    reply_error(d, port, req, PROTO_ERR_BUSY, 0, "a run is active: STOP first");
}

/* --- requests ------------------------------------------------------------------------------ */

/* The channel an optional trailing channel field names (absent: channel 0). */
static uint32_t opt_channel(uint32_t count, const uint8_t *channel)
{
    return (count != 0U) ? channel[0] : 0U;
}

/* 1 when ch is a channel of this device; else an ERROR naming the range. */
static int channel_ok(dev_t *d, uint32_t port, const proto_frame_t *req, uint32_t ch)
{
    if (ch < d->channels) {
        return 1;
    }
    reply_error(d, port, req, PROTO_ERR_INVALID_VALUE, (int32_t)d->channels,
                "channel >= n_channels (HELLO)");
    return 0;
}

static void stop_run(dev_t *d)
{
    for (uint32_t c = 0; c < d->channels; ++c) {
        fw_stop(&d->fw[c]); /* every channel, run or not: TC = 0 and disabled is always safe */
    }
    d->running = 0U;
    d->run_mask = 0U;
    stream_clear(d);
}

static void on_hello(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    proto_hello_ack_t m;
    m.proto_version = d->id.proto_version;
    m.fw_major = d->id.fw_major;
    m.fw_minor = d->id.fw_minor;
    m.fw_patch = d->id.fw_patch;
    m.build_id = d->id.build_id;
    m.table_hash = d->id.table_hash;
    m.n_params = (uint16_t)PROTO_N_PARAMS;
    m.running = (uint8_t)d->running;
    m.config_source = (uint8_t)d->config_source;
    m.dirty = (uint8_t)d->dirty;
    m.n_channels = (uint8_t)d->channels;
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_HELLO_ACK, req->seq);
    f.version = d->id.proto_version;
    f.len = (uint8_t)proto_hello_ack_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static void on_param_set(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    proto_param_set_t m;
    (void)proto_param_set_unpack(&m, req->payload, req->len);
    if (d->running != 0U) {
        reply_busy(d, port, req);
        return;
    }
    const uint32_t ch = opt_channel(m.channel_count, m.channel);
    if (!channel_ok(d, port, req, ch)) {
        return;
    }
    /* A device-wide parameter (dev.*) is written in every channel's copy, checked in the
     * addressed one (the copies are alike, so one check speaks for all). */
    int32_t status;
    int32_t err = params_set(&d->settings[ch], m.param, m.value, &status);
    if (err == (int32_t)PROTO_ERR_INVALID_VALUE) {
        reply_error(d, port, req, (uint32_t)err, status, settings_strerror(status));
    } else if (err == (int32_t)PROTO_ERR_READ_ONLY) {
        reply_error(d, port, req, (uint32_t)err, 0, "read-only parameter");
    } else if (err != 0) {
        reply_error(d, port, req, (uint32_t)err, (int32_t)PROTO_N_PARAMS, "unknown parameter id");
    } else {
        if (params_is_device(m.param)) {
            for (uint32_t c = 0; c < d->channels; ++c) {
                d->settings[c].dev = d->settings[ch].dev;
            }
        }
        fw_configure_checked(&d->fw[ch], &d->settings[ch].fw); /* checked by params_set */
        d->dirty = 1U;
        reply_param(d, port, req, ch, m.param);
    }
}

static void on_param_info(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    proto_param_info_t q;
    (void)proto_param_info_unpack(&q, req->payload, req->len);
    if (q.param >= PROTO_N_PARAMS) {
        reply_error(d, port, req, PROTO_ERR_UNKNOWN_PARAM, (int32_t)PROTO_N_PARAMS,
                    "unknown parameter id");
        return;
    }
    settings_t def;
    settings_default(&def);
    proto_param_info_ack_t m;
    m.param = q.param;
    m.key = params_table[q.param].key;
    (void)params_get(&def, q.param, &m.default_word);
    m.flags = params_table[q.param].flags;
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_PARAM_INFO_ACK, req->seq);
    f.len = (uint8_t)proto_param_info_ack_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static void on_persist(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    uint32_t seq = 0U;
    int32_t err = (d->flash != 0) ? flash_store_channels(d->flash, d->settings, d->channels, &seq)
                                  : FLASH_ERR_WRITE;
    if (err != FLASH_OK) {
        d->faults |= PROTO_FAULT_CONFIG;
        reply_error(d, port, req, PROTO_ERR_FLASH, err, "flash write failed");
        return;
    }
    d->dirty = 0U;
    d->config_source = PROTO_CONFIG_SOURCE_FLASH;
    d->faults &= ~(uint32_t)PROTO_FAULT_CONFIG;
    reply_ack(d, port, req, seq);
}

static void on_load(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    /* Onto the defaults, into the device only when the whole record passes (flash_load leaves
     * its argument as it was on an error). */
    settings_t s[BOWDEN_CHANNELS_MAX];
    for (uint32_t c = 0; c < d->channels; ++c) {
        settings_default(&s[c]);
    }
    uint32_t seq = 0U;
    int32_t err = (d->flash != 0) ? flash_load_channels(d->flash, s, d->channels, &seq)
                                  : FLASH_ERR_EMPTY;
    if (err != FLASH_OK) {
        reply_error(d, port, req, PROTO_ERR_FLASH, err,
                    err == FLASH_ERR_EMPTY ? "no saved configuration"
                                           : "saved configuration rejected by the check");
        return;
    }
    for (uint32_t c = 0; c < d->channels; ++c) {
        d->settings[c] = s[c];
    }
    configure_all(d); /* checked by flash_load */
    d->dirty = 0U;
    d->config_source = PROTO_CONFIG_SOURCE_FLASH;
    reply_ack(d, port, req, seq);
}

static void on_start(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    proto_start_t m;
    (void)proto_start_unpack(&m, req->payload, req->len);
    if (d->running != 0U) {
        reply_busy(d, port, req);
        return;
    }
    /* A zero duration is a host's rounding to nothing, never "forever": a run without an end
     * must be asked for by name (PROTO_START_DURATION_CONTINUOUS). */
    if (m.duration_ticks == 0U) {
        reply_error(d, port, req, PROTO_ERR_INVALID_VALUE, 0,
                    "duration 0: >= 1 tick or CONTINUOUS");
        return;
    }
    /* Absent: every channel. */
    const uint32_t mask = (m.channel_mask_count != 0U) ? m.channel_mask[0]
                                                       : (1U << d->channels) - 1U;
    if (mask == 0U || (mask >> d->channels) != 0U) {
        reply_error(d, port, req, PROTO_ERR_INVALID_VALUE, (int32_t)d->channels,
                    "channel_mask: none, or a channel >= n_channels");
        return;
    }
    for (uint32_t c = 0; c < d->channels; ++c) {
        if (((mask >> c) & 1U) != 0U) {
            fw_start(&d->fw[c]);
        }
    }
    d->run_mask = mask;
    d->running = 1U;
    d->owner = port;
    d->host_seen_us = d->time_us;
    d->run_ticks = 0U;
    d->run_limit = (m.duration_ticks == PROTO_START_DURATION_CONTINUOUS) ? 0U : m.duration_ticks;
    d->faults &= ~(uint32_t)RUN_FAULTS;
    reply_ack(d, port, req, d->settings[0].fw.tick_rate_hz);
}

/* One STREAM sample from its two payload bytes (little-endian int16, as proto_stream_unpack reads
 * it). */
static int16_t sample_le(const uint8_t *b)
{
    const uint32_t u = (uint32_t)b[0] | ((uint32_t)b[1] << 8);
    return (int16_t)((int32_t)u - ((u >> 15) << 16));
}

/* `n` samples from little-endian payload bytes into dst. Where the target keeps an int16 as its
 * little-endian bytes (the soft CPU, the Cortex-M4, the host), that is a copy of the bytes, taken a
 * word (two samples) at a time when both ends are word-aligned: on the soft CPU that took the
 * handling of a full STREAM frame's delimiter (its last bytes decoded, the samples queued, the ACK)
 * from 3 414 clocks to 3 054 with four cables (tests/soc/tb_soc_tick.py's streamed run). */
typedef uint32_t __attribute__((may_alias)) dev_word_t;

static void samples_from_le(int16_t *dst, const uint8_t *le, uint32_t n)
{
    uint32_t i = 0;
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) && \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if ((((uintptr_t)dst | (uintptr_t)le) & 3U) == 0U) {
        dev_word_t *const dw = (dev_word_t *)(void *)dst;
        const dev_word_t *const sw = (const dev_word_t *)(const void *)le;
        for (; i + 2U <= n; i += 2U) {
            dw[i / 2U] = sw[i / 2U];
        }
    }
#endif
    for (; i < n; ++i) {
        dst[i] = sample_le(&le[2U * i]);
    }
}

/* `count` samples (little-endian int16 from a STREAM or STREAM_CH payload, checked by dispatch)
 * into channel c's stream buffer: taken from the payload straight into the ring, not through the
 * message's unpacked array first (on the soft CPU the unpacking and the copy were a third of a
 * full STREAM frame's handling). */
static void stream_put(dev_t *d, uint32_t port, const proto_frame_t *req, uint32_t c,
                       const uint8_t *le, uint32_t count)
{
    uint32_t free_slots = DEV_STREAM_LEN - d->stream_len[c];
    if (count > free_slots) {
        reply_error(d, port, req, PROTO_ERR_STREAM_FULL, (int32_t)free_slots,
                    "stream buffer full");
        return;
    }
    /* Into the ring in at most two contiguous pieces (the end of the array, then its start). */
    const uint32_t tail = (d->stream_head[c] + d->stream_len[c]) % DEV_STREAM_LEN;
    const uint32_t first = (count < DEV_STREAM_LEN - tail) ? count : DEV_STREAM_LEN - tail;
    samples_from_le(&d->stream[c][tail], le, first);
    samples_from_le(d->stream[c], &le[2U * first], count - first);
    d->stream_len[c] += count;
    reply_ack(d, port, req, DEV_STREAM_LEN - d->stream_len[c]);
}

/* STREAM (channel 0) and STREAM_CH (its channel first): the lengths are checked by dispatch, so
 * the payload holds whole samples, as proto_stream_unpack and proto_stream_ch_unpack would take
 * them. */
static void on_stream(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    if (req->msg == PROTO_MSG_STREAM) {
        stream_put(d, port, req, 0U, req->payload, req->len / 2U);
        return;
    }
    const uint32_t ch = req->payload[0];
    if (channel_ok(d, port, req, ch)) {
        stream_put(d, port, req, ch, &req->payload[1], (req->len - 1U) / 2U);
    }
}

static void on_faults(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    proto_faults_get_t q;
    (void)proto_faults_get_unpack(&q, req->payload, req->len);
    const uint32_t ch = opt_channel(q.channel_count, q.channel);
    if (!channel_ok(d, port, req, ch)) {
        return;
    }
    const fw_t *fw = &d->fw[ch];
    proto_faults_t m;
    m.channel = (uint8_t)ch;
    m.fpga_fault = hal_read(fw->hal, BOWDEN_REG_FAULT);
    m.fpga_status = hal_read(fw->hal, BOWDEN_REG_STATUS);
    m.device_faults = d->faults;
    m.fault_ticks = fw->tel.fault_ticks;
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_FAULTS, req->seq);
    f.len = (uint8_t)proto_faults_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static void on_fault_clear(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    for (uint32_t c = 0; c < d->channels; ++c) {
        if (d->running != 0U && ((d->run_mask >> c) & 1U) != 0U) {
            fw_fault_clear(&d->fw[c]);
        } else {
            /* fw_fault_clear keeps ENABLE set; stopped, only the clear pulse is written. */
            hal_write(d->fw[c].hal, BOWDEN_REG_CTRL, BOWDEN_CTRL_FAULT_CLEAR_MASK);
        }
    }
    d->faults = 0U;
    reply_ack(d, port, req, 0U);
}

static void on_stats(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    dev_port_t *p = &d->ports[port];
    const proto_rx_stats_t *s = (p->kind == DEV_PORT_CAN) ? &p->can_rx.stats : &p->rx.stats;
    proto_stats_t m;
    m.rx_frames = s->frames;
    m.rx_crc_errors = s->crc_errors;
    m.rx_framing_errors = s->framing_errors;
    m.rx_overlong = s->overlong;
    m.rx_short = s->short_frames;
    m.rx_version_errors = p->version_errors;
    m.rx_bad_messages = p->bad_messages;
    m.tx_frames = p->tx_frames;
    m.tx_overflow = p->tx_overflow;
    m.host_timeouts = d->host_timeouts;
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_STATS, req->seq);
    f.len = (uint8_t)proto_stats_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

/* The rest of a status code's message: ERROR carries its first PROTO_ERROR_TEXT_MAX characters. */
static void on_text_get(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    proto_text_get_t q;
    (void)proto_text_get_unpack(&q, req->payload, req->len);
    const char *text = settings_strerror(q.status);
    uint32_t total = 0U;
    while (text[total] != '\0' && total < 0xFFFFU) {
        ++total;
    }
    proto_text_t m;
    m.offset = q.offset;
    m.total = (uint16_t)total;
    m.text_count = 0U;
    while ((uint32_t)q.offset + m.text_count < total && m.text_count < PROTO_TEXT_TEXT_MAX) {
        m.text[m.text_count] = text[q.offset + m.text_count];
        ++m.text_count;
    }
    proto_frame_t f;
    frame_init(&f, PROTO_MSG_TEXT, req->seq);
    f.len = (uint8_t)proto_text_pack(&m, f.payload);
    (void)send_frame(d, port, &f, 0);
}

static int is_request(uint32_t msg)
{
    switch (msg) {
    case PROTO_MSG_PARAM_GET:
    case PROTO_MSG_PARAM_SET:
    case PROTO_MSG_PARAM_INFO:
    case PROTO_MSG_PERSIST:
    case PROTO_MSG_LOAD:
    case PROTO_MSG_DEFAULTS:
    case PROTO_MSG_START:
    case PROTO_MSG_STOP:
    case PROTO_MSG_STREAM:
    case PROTO_MSG_STREAM_CH:
    case PROTO_MSG_FAULTS_GET:
    case PROTO_MSG_FAULT_CLEAR:
    case PROTO_MSG_STATS_GET:
    case PROTO_MSG_TEXT_GET:
        return 1;
    default:
        return 0;
    }
}

static void dispatch(dev_t *d, uint32_t port, const proto_frame_t *req)
{
    dev_port_t *p = &d->ports[port];
    if (port == d->owner) { /* any valid frame keeps the run's host watchdog fed */
        d->host_seen_us = d->time_us;
    }
    if (req->msg == PROTO_MSG_HELLO) { /* any version, any payload: always answered */
        on_hello(d, port, req);
        return;
    }
    if (req->version != d->id.proto_version) {
        ++p->version_errors;
        reply_error(d, port, req, PROTO_ERR_VERSION, (int32_t)d->id.proto_version,
                    "protocol version differs: send HELLO");
        return;
    }
    if (!is_request(req->msg)) {
        ++p->bad_messages;
        reply_error(d, port, req, PROTO_ERR_UNKNOWN_MESSAGE, req->msg, "unknown request");
        return;
    }
    uint32_t min = proto_msg_min_len(req->msg);
    uint32_t max = proto_msg_max_len(req->msg);
    /* STREAM carries whole samples: an odd length is wrong too (STREAM_CH: after its channel). */
    if (req->len < min || req->len > max ||
        (req->msg == PROTO_MSG_STREAM && (req->len & 1U) != 0U) ||
        (req->msg == PROTO_MSG_STREAM_CH && (req->len & 1U) == 0U)) {
        ++p->bad_messages;
        reply_error(d, port, req, PROTO_ERR_BAD_LENGTH, req->len, "wrong payload length");
        return;
    }
    switch (req->msg) {
    case PROTO_MSG_PARAM_GET: {
        proto_param_get_t m;
        (void)proto_param_get_unpack(&m, req->payload, req->len);
        if (m.param >= PROTO_N_PARAMS) {
            reply_error(d, port, req, PROTO_ERR_UNKNOWN_PARAM, (int32_t)PROTO_N_PARAMS,
                        "unknown parameter id");
        } else if (channel_ok(d, port, req, opt_channel(m.channel_count, m.channel))) {
            reply_param(d, port, req, opt_channel(m.channel_count, m.channel), m.param);
        }
        break;
    }
    case PROTO_MSG_PARAM_SET:
        on_param_set(d, port, req);
        break;
    case PROTO_MSG_PARAM_INFO:
        on_param_info(d, port, req);
        break;
    case PROTO_MSG_PERSIST:
    case PROTO_MSG_LOAD:
    case PROTO_MSG_DEFAULTS:
        if (d->running != 0U) {
            reply_busy(d, port, req);
        } else if (req->msg == PROTO_MSG_PERSIST) {
            on_persist(d, port, req);
        } else if (req->msg == PROTO_MSG_LOAD) {
            on_load(d, port, req);
        } else {
            settings_default_all(d);
            configure_all(d); /* the defaults are valid */
            d->dirty = 1U;
            reply_ack(d, port, req, 0U);
        }
        break;
    case PROTO_MSG_START:
        on_start(d, port, req);
        break;
    case PROTO_MSG_STOP: {
        uint32_t ticks = d->run_ticks;
        stop_run(d); /* also when stopped: TC = 0 and the loop disabled is always safe */
        reply_ack(d, port, req, ticks);
        break;
    }
    case PROTO_MSG_STREAM:
    case PROTO_MSG_STREAM_CH:
        on_stream(d, port, req);
        break;
    case PROTO_MSG_FAULTS_GET:
        on_faults(d, port, req);
        break;
    case PROTO_MSG_FAULT_CLEAR:
        on_fault_clear(d, port, req);
        break;
    case PROTO_MSG_TEXT_GET:
        on_text_get(d, port, req);
        break;
    default: /* PROTO_MSG_STATS_GET: is_request lists no other */
        on_stats(d, port, req);
        break;
    }
}

void dev_rx_bytes(dev_t *d, uint32_t port, const uint8_t *data, uint32_t n)
{
    if (port >= DEV_PORTS || d->ports[port].kind != DEV_PORT_SERIAL) {
        return;
    }
    /* Word-aligned: a STREAM payload (at offset 4) is then copied a word at a time. */
    _Alignas(4) proto_frame_t f;
    uint32_t i = 0;
    while (i < n) {
        int got;
        i += proto_rx_bytes(&d->ports[port].rx, &data[i], n - i, &f, &got);
        if (got != 0) {
            dispatch(d, port, &f);
        }
    }
}

void dev_rx_can(dev_t *d, uint32_t port, const proto_can_frame_t *cf)
{
    if (port >= DEV_PORTS || d->ports[port].kind != DEV_PORT_CAN) {
        return;
    }
    proto_frame_t f;
    if (proto_can_rx(&d->ports[port].can_rx, d->settings[0].dev.can_node, cf, &f)) {
        dispatch(d, port, &f);
    }
}

/* --- the tick ------------------------------------------------------------------------------ */

static int16_t sat_q7_8(int32_t v)
{
    return (int16_t)((v > Q7_8_MAX) ? Q7_8_MAX : (v < Q7_8_MIN) ? Q7_8_MIN : v);
}

void dev_tick(dev_t *d, uint32_t time_us, int32_t t_out_q8)
{
    /* Channel 0's reading; any other channel's is 0 (a board of several calls
     * dev_tick_channels), never read past the caller's one word. */
    int32_t t_out[BOWDEN_CHANNELS_MAX] = {0};
    t_out[0] = t_out_q8;
    dev_tick_channels(d, time_us, t_out);
}

/* Channel c's T_ref of this tick: from the waveform (fw_tick's own) or the channel's stream. */
static q7_8_t stream_take(dev_t *d, uint32_t c)
{
    if (d->settings[c].fw.source != FW_SOURCE_HOST) {
        return 0;
    }
    if (d->stream_len[c] == 0U) {
        d->faults |= PROTO_FAULT_STREAM_UNDERRUN; /* hold the last sample and say so */
        return d->stream_last[c];
    }
    const q7_8_t t_ref = d->stream[c][d->stream_head[c]];
    d->stream_head[c] = (d->stream_head[c] + 1U) % DEV_STREAM_LEN;
    --d->stream_len[c];
    d->stream_last[c] = t_ref;
    return t_ref;
}

/* Channel c's telemetry frame of this tick, to the run's port. */
static void send_telemetry(dev_t *d, uint32_t c, uint32_t time_us, int32_t t_out_q8)
{
    const fw_telemetry_t *t = &d->fw[c].tel;
    proto_telemetry_t m;
    m.channel = (uint8_t)c;
    m.time_us = time_us;
    m.sample = t->ticks - 1U; /* fw_start zeroes ticks, fw_tick counts this one */
    m.overflow = d->overflow;
    m.t_ref = sat_q7_8(t->t_ref);
    m.t_c = sat_q7_8(t->t_c);
    m.t_in = sat_q7_8(t->t_in);
    m.t_out = sat_q7_8(t_out_q8);
    m.current = (int16_t)t->u; /* U is a 16-bit register word */
    m.faults = (uint8_t)(((t->fault << PROTO_FAULT_FPGA_SHIFT) & PROTO_FAULT_FPGA_MASK) |
                         d->faults);
    m.status = (uint8_t)(PROTO_STATUS_RUNNING |
                         ((t->status << PROTO_STATUS_FPGA_SHIFT) & PROTO_STATUS_FPGA_MASK) |
                         ((t->direction > 0) ? PROTO_STATUS_LOADING : 0U));
    /* mu*phi from Q3.28 (>= 0: the estimate's bounds and the exponent's check keep it so) to
     * UQ2.14, truncated, saturated at the field's top. */
    int32_t mu_phi_q14 = t->est_mu_phi_q28 >> 14;
    m.mu_phi = (uint16_t)((mu_phi_q14 < 0) ? 0 : (mu_phi_q14 > 0xFFFF) ? 0xFFFF : mu_phi_q14);
    m.est_faults = (uint8_t)t->est_faults;
    dev_port_t *p = &d->ports[d->owner];
    int ok;
    if (p->kind == DEV_PORT_CAN) {
        proto_frame_t f;
        frame_init(&f, PROTO_MSG_TELEMETRY, 0U);
        f.len = (uint8_t)proto_telemetry_pack(&m, f.payload);
        ok = send_frame(d, d->owner, &f, 1);
    } else {
        /* send_frame's bytes, the frame packed straight into the ring and encoded there (on the
         * soft CPU the telemetry frames are most of the tick: a copy of each byte less). */
        _Static_assert(PROTO_TELEMETRY_MIN_LEN == PROTO_TELEMETRY_MAX_LEN, "a fixed length");
        const uint32_t n = PROTO_HEADER_LEN + PROTO_TELEMETRY_MAX_LEN + PROTO_CRC_LEN + 3U;
        ok = DEV_TX_BYTES - p->tx_len >= n + RESERVE_BYTES;
        if (ok) {
            const uint32_t at = tx_tail(p);
            uint8_t *const out = &p->tx[at];
            out[2] = (uint8_t)PROTO_VERSION;
            out[3] = (uint8_t)PROTO_MSG_TELEMETRY;
            out[4] = 0U; /* seq: a frame the device sends unasked */
            const uint32_t len = proto_telemetry_pack(&m, &out[2U + PROTO_HEADER_LEN]);
            ok = proto_encode_in_place(out, len) == n;
            if (ok) {
                tx_commit(p, at, n);
            }
        }
        tx_counted(p, ok);
    }
    if (!ok) {
        ++d->overflow;
        d->faults |= PROTO_FAULT_TX_OVERFLOW;
    }
}

/* Whether channel c's sample has a telemetry frame: sample % div == c % div. Each channel keeps
 * its rate (a frame every div samples) and the channels' frames are spread over the ticks: with
 * four channels at div 2, channels 0 and 2 send on even samples and 1 and 3 on odd ones, so no
 * tick encodes every channel's frame (on the soft CPU a frame is some 1 700 clocks: four in one
 * tick took the tick past half its period). One channel, or div 1, sends what it always sent.
 * The ticks left to the next such sample are counted down; the division is done only where
 * counting would go wrong: a count that did not step by one from the channel's last (a new run),
 * its wrap to 0 (2^32 need not be a multiple of div) and a changed div. The soft CPU has no
 * divider: its division routine cost some 190 clocks a cable at every tick. */
static int telemetry_due(dev_t *d, uint32_t c, uint32_t sample, uint32_t div)
{
    if (div == 1U) { /* every sample; a divisor set later differs from tel_div and is divided */
        d->tel_div[c] = 1U;
        return 1;
    }
    if (sample == 0U || sample != d->tel_sample[c] + 1U || div != d->tel_div[c]) {
        const uint32_t r = sample % div;
        const uint32_t slot = (c < div) ? c : c % div; /* c < BOWDEN_CHANNELS_MAX: rarely divided */
        d->tel_div[c] = div;
        d->tel_left[c] = (r <= slot) ? slot - r : slot + div - r;
    }
    d->tel_sample[c] = sample;
    if (d->tel_left[c] != 0U) {
        --d->tel_left[c];
        return 0;
    }
    d->tel_left[c] = div - 1U;
    return 1;
}

void dev_tick_channels(dev_t *d, uint32_t time_us, const int32_t *t_out_q8)
{
    d->time_us = time_us;
    if (d->running == 0U) {
        return;
    }
    /* Host watchdog: the run's port fell silent (unsigned difference: the clock may wrap). */
    if (time_us - d->host_seen_us >= (uint32_t)PROTO_HOST_WATCHDOG_TIMEOUT_MS * 1000U) {
        stop_run(d);
        ++d->host_timeouts;
        return;
    }
    /* Every channel's loop first, then the telemetry: the register writes of one tick land
     * together, whatever the link costs. */
    for (uint32_t c = 0; c < d->channels; ++c) {
        if (((d->run_mask >> c) & 1U) != 0U) {
            (void)fw_tick(&d->fw[c], stream_take(d, c));
        }
    }
    ++d->run_ticks;
    const uint32_t div = d->settings[0].dev.telemetry_div;
    for (uint32_t c = 0; c < d->channels; ++c) {
        if (((d->run_mask >> c) & 1U) == 0U) {
            continue;
        }
        if (telemetry_due(d, c, d->fw[c].tel.ticks - 1U, div)) {
            send_telemetry(d, c, time_us, t_out_q8[c]);
        }
    }
    if (d->run_limit != 0U && d->run_ticks >= d->run_limit) {
        stop_run(d);
    }
}

void dev_overrun(dev_t *d)
{
    d->faults |= PROTO_FAULT_OVERRUN;
}
