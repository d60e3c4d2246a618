/* proto.c - serial framing of proto.h: COBS, CRC-32C, the receive state machine. */
#include "proto.h"

#include "crc32c.h"

uint32_t proto_cobs_encode(const uint8_t *in, uint32_t n, uint8_t *out)
{
    uint32_t code_at = 0; /* where the current block's code byte goes */
    uint32_t o = 1;
    uint8_t code = 1;
    for (uint32_t i = 0; i < n; ++i) {
        if (in[i] == 0U) {
            out[code_at] = code;
            code_at = o++;
            code = 1;
        } else {
            out[o++] = in[i];
            ++code;
            /* A full block of 254 bytes has no implied zero; a new block starts only if more
             * data follows (the canonical encoding). */
            if (code == 0xFFU && i + 1U < n) {
                out[code_at] = code;
                code_at = o++;
                code = 1;
            }
        }
    }
    out[code_at] = code;
    return o;
}

int32_t proto_cobs_decode(const uint8_t *in, uint32_t n, uint8_t *out, uint32_t cap)
{
    uint32_t i = 0;
    uint32_t o = 0;
    while (i < n) {
        uint32_t code = in[i++];
        if (code == 0U || i + code - 1U > n) {
            return -1;
        }
        for (uint32_t k = 1; k < code; ++k) {
            if (in[i] == 0U || o >= cap) {
                return -1;
            }
            out[o++] = in[i++];
        }
        /* A block shorter than 254 bytes stands for a zero, except at the very end. */
        if (code < 0xFFU && i < n) {
            if (o >= cap) {
                return -1;
            }
            out[o++] = 0U;
        }
    }
    return (int32_t)o;
}

void proto_rx_init(proto_rx_t *rx)
{
    rx->len = 0U;
    rx->discard = 0U;
    rx->stats = (proto_rx_stats_t){0};
}

static uint32_t get_u32_le(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}

/* A complete frame between two delimiters: decode, check, copy out. */
static int rx_frame(proto_rx_t *rx, proto_frame_t *out)
{
    uint8_t raw[PROTO_MAX_RAW];
    int32_t n = proto_cobs_decode(rx->buf, rx->len, raw, PROTO_MAX_RAW);
    if (n < 0) {
        ++rx->stats.framing_errors;
        return 0;
    }
    if ((uint32_t)n < PROTO_HEADER_LEN + PROTO_CRC_LEN) {
        ++rx->stats.short_frames;
        return 0;
    }
    uint32_t body = (uint32_t)n - PROTO_CRC_LEN;
    if (crc32c(raw, body) != get_u32_le(&raw[body])) {
        ++rx->stats.crc_errors;
        return 0;
    }
    out->version = raw[0];
    out->msg = raw[1];
    out->seq = raw[2];
    out->len = (uint8_t)(body - PROTO_HEADER_LEN); /* <= PROTO_MAX_PAYLOAD: raw is bounded */
    for (uint32_t i = 0; i < out->len; ++i) {
        out->payload[i] = raw[PROTO_HEADER_LEN + i];
    }
    ++rx->stats.frames;
    return 1;
}

int proto_rx_byte(proto_rx_t *rx, uint8_t byte, proto_frame_t *out)
{
    if (byte != 0U) {
        if (rx->discard != 0U) {
            return 0;
        }
        if (rx->len < PROTO_MAX_COBS) {
            rx->buf[rx->len++] = byte;
        } else {
            ++rx->stats.overlong;
            rx->discard = 1U;
            rx->len = 0U;
        }
        return 0;
    }
    /* Delimiter: an empty frame (two delimiters in a row) is not an error. */
    int got = 0;
    if (rx->discard == 0U && rx->len > 0U) {
        got = rx_frame(rx, out);
    }
    rx->len = 0U;
    rx->discard = 0U;
    return got;
}

uint32_t proto_encode(const proto_frame_t *f, uint8_t *out, uint32_t cap)
{
    if (f->len > PROTO_MAX_PAYLOAD) {
        return 0U;
    }
    uint8_t raw[PROTO_MAX_RAW];
    uint32_t n = 0;
    raw[n++] = f->version;
    raw[n++] = f->msg;
    raw[n++] = f->seq;
    for (uint32_t i = 0; i < f->len; ++i) {
        raw[n++] = f->payload[i];
    }
    uint32_t crc = crc32c(raw, n);
    raw[n++] = (uint8_t)crc;
    raw[n++] = (uint8_t)(crc >> 8);
    raw[n++] = (uint8_t)(crc >> 16);
    raw[n++] = (uint8_t)(crc >> 24);
    uint32_t need = n + n / 254U + 1U + 2U;
    if (cap < need) {
        return 0U;
    }
    out[0] = 0U;
    uint32_t m = proto_cobs_encode(raw, n, &out[1]);
    out[1U + m] = 0U;
    return m + 2U;
}
