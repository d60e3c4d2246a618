/*
 * fuzz_proto.c - the fuzz harness of the bench protocol's receive side: the serial decoder
 * (proto_rx_byte) and the whole device behind it (dev_rx_bytes, dev_rx_can, dev_tick), fed
 * arbitrary bytes. Invariants, checked on every frame: the decoder never accepts a frame whose
 * CRC-32C fails (recomputed here with an independent bitwise CRC over an independent COBS decode
 * of the same bytes), decoded lengths stay within bounds, the decoder fed a whole buffer at once
 * (proto_rx_bytes) accepts the same frames and counts the same errors as byte by byte, and the
 * device's buffers stay consistent. ASan and UBSan catch the rest (out-of-bounds, overflow, undefined shifts).
 *
 * Used by fuzz_main.c (random and mutated frames, gcc, in `make test`) and by libFuzzer
 * (LLVMFuzzerTestOneInput, clang: `make fuzz-proto-libfuzzer`).
 */
#include "fuzz_proto.h"

#include <stdio.h>
#include <stdlib.h>

#include "dev_host.h"

static dev_host_t dev;
static proto_rx_t rx;
static proto_rx_t rx_bulk; /* the same bytes through proto_rx_bytes */
static uint8_t seg[PROTO_MAX_COBS + 8];
static uint32_t seg_len;
static uint32_t seg_over;
static fuzz_stats_t stats;
static int ready;
static proto_frame_t last;

static void fail(const char *what)
{
    fprintf(stderr, "fuzz invariant violated: %s\n", what);
    abort();
}

/* Bitwise CRC-32C, independent of crc32c.c's table. */
static uint32_t ref_crc(const uint8_t *p, uint32_t n)
{
    uint32_t c = 0xFFFFFFFFUL;
    for (uint32_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) {
            c = (c >> 1) ^ ((c & 1U) ? 0x82F63B78UL : 0U);
        }
    }
    return ~c;
}

/* COBS decode, independent of proto.c's; -1 on error. */
static int32_t ref_cobs(const uint8_t *in, uint32_t n, uint8_t *out)
{
    uint32_t o = 0;
    uint32_t i = 0;
    while (i < n) {
        uint32_t code = in[i];
        if (code == 0U || i + code > n) {
            return -1;
        }
        for (uint32_t k = 1; k < code; ++k) {
            out[o++] = in[i + k];
        }
        i += code;
        if (code != 0xFFU && i < n) {
            out[o++] = 0U;
        }
    }
    return (int32_t)o;
}

void fuzz_reset(void)
{
    dev_host_init(&dev);
    dev_port_kind(&dev.dev, 2U, DEV_PORT_CAN);
    proto_rx_init(&rx);
    proto_rx_init(&rx_bulk);
    seg_len = seg_over = 0U;
    ready = 1;
}

const fuzz_stats_t *fuzz_stats(void)
{
    return &stats;
}

const void *fuzz_last_frame(void)
{
    return &last;
}

static void feed_device(const uint8_t *data, size_t n);

static void check_accepted(const proto_frame_t *f)
{
    uint8_t raw[PROTO_MAX_COBS + 8];
    if (seg_over) {
        fail("accepted an overlong frame");
    }
    int32_t n = ref_cobs(seg, seg_len, raw);
    if (n < (int32_t)(PROTO_HEADER_LEN + PROTO_CRC_LEN)) {
        fail("accepted a frame that does not COBS-decode or is short");
    }
    uint32_t body = (uint32_t)n - PROTO_CRC_LEN;
    uint32_t crc = (uint32_t)raw[body] | ((uint32_t)raw[body + 1U] << 8) |
                   ((uint32_t)raw[body + 2U] << 16) | ((uint32_t)raw[body + 3U] << 24);
    if (ref_crc(raw, body) != crc) {
        fail("accepted a frame whose CRC fails");
    }
    if (f->len != body - PROTO_HEADER_LEN || f->len > PROTO_MAX_PAYLOAD || f->msg != raw[1] ||
        f->seq != raw[2]) {
        fail("decoded frame differs from its bytes");
    }
    ++stats.crc_checked;
}

static uint32_t frame_digest(uint32_t digest, const proto_frame_t *f)
{
    const uint8_t head[4] = {f->version, f->msg, f->seq, f->len};
    digest = ref_crc(head, 4U) ^ (digest * 31U);
    return ref_crc(f->payload, f->len) ^ (digest * 31U);
}

/* The same bytes through proto_rx_bytes, a buffer at a time: the same frames in the same order
 * and the same error counts as the byte-by-byte decoder. */
static void bulk_matches(const uint8_t *data, size_t n, uint32_t accepted, uint32_t digest)
{
    uint32_t got_n = 0U;
    uint32_t got_digest = 0U;
    size_t i = 0;
    while (i < n) {
        proto_frame_t f;
        int got;
        uint32_t used = proto_rx_bytes(&rx_bulk, &data[i], (uint32_t)(n - i), &f, &got);
        if (used == 0U || used > n - i || (got != 0 && data[i + used - 1U] != 0U)) {
            fail("proto_rx_bytes: bytes used");
        }
        i += used;
        if (got != 0) {
            ++got_n;
            got_digest = frame_digest(got_digest, &f);
        }
    }
    const proto_rx_stats_t *a = &rx.stats;
    const proto_rx_stats_t *b = &rx_bulk.stats;
    if (got_n != accepted || got_digest != digest || a->frames != b->frames ||
        a->crc_errors != b->crc_errors || a->framing_errors != b->framing_errors ||
        a->short_frames != b->short_frames || a->overlong != b->overlong ||
        rx.len != rx_bulk.len || rx.discard != rx_bulk.discard) {
        fail("proto_rx_bytes differs from proto_rx_byte");
    }
}

void fuzz_feed(const uint8_t *data, size_t n)
{
    fuzz_feed_decoder(data, n);
    feed_device(data, n);
}

void fuzz_feed_decoder(const uint8_t *data, size_t n)
{
    if (!ready) {
        fuzz_reset();
    }
    proto_rx_stats_t before = rx.stats;
    uint32_t accepted = 0U;
    uint32_t digest = 0U; /* of the accepted frames in order, byte by byte */
    for (size_t i = 0; i < n; ++i) {
        uint8_t b = data[i];
        proto_frame_t f;
        int got = proto_rx_byte(&rx, b, &f);
        if (b == 0U) {
            if (got) {
                check_accepted(&f);
                ++stats.accepted;
                ++accepted;
                digest = frame_digest(digest, &f);
                last = f;
            }
            seg_len = seg_over = 0U;
        } else if (got) {
            fail("a frame completed on a non-delimiter byte");
        } else if (seg_len < sizeof seg) {
            seg[seg_len++] = b;
        } else {
            seg_over = 1U;
        }
    }
    bulk_matches(data, n, accepted, digest);
    stats.bytes += n;
    stats.rejected += (rx.stats.crc_errors - before.crc_errors) +
                      (rx.stats.framing_errors - before.framing_errors) +
                      (rx.stats.short_frames - before.short_frames) +
                      (rx.stats.overlong - before.overlong);
}

/* The device: the same bytes on its serial port, 10-byte chunks as CAN frames, a tick. */
static void feed_device(const uint8_t *data, size_t n)
{
    dev_rx_bytes(&dev.dev, 0U, data, (uint32_t)n);
    for (size_t i = 0; i + 2U <= n; i += 10U) {
        proto_can_frame_t cf;
        cf.id = ((uint32_t)data[i] | ((uint32_t)data[i + 1U] << 8)) & 0x7FFU;
        cf.len = (uint8_t)(data[i] % 9U);
        for (uint32_t k = 0; k < 8U; ++k) {
            cf.data[k] = (i + 2U + k < n) ? data[i + 2U + k] : 0U;
        }
        dev_rx_can(&dev.dev, 2U, &cf);
    }
    dev_tick(&dev.dev, (uint32_t)stats.bytes, (int32_t)n);
    uint8_t out[512];
    proto_can_frame_t cout[64];
    while (dev_tx_bytes(&dev.dev, 0U, out, sizeof out) > 0U) {
    }
    while (dev_tx_can(&dev.dev, 2U, cout, 64U) > 0U) {
    }
    if (dev.dev.ports[0].tx_len > DEV_TX_BYTES || dev.dev.stream_len[0] > DEV_STREAM_LEN ||
        dev.shadow[0].log_len > HAL_LOG_CAPACITY) {
        fail("device buffer bookkeeping");
    }
    dev.shadow[0].log_len = 0U; /* the FPGA side would drain the register writes */
}

#ifdef FUZZ_LIBFUZZER
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_feed(data, size);
    return 0;
}
#endif
