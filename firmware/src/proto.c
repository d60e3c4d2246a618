/* proto.c - serial framing of proto.h: COBS, CRC-32C, the receive state machine. */
#include "proto.h"

#include "crc32c.h"

/* COBS written a byte at a time, so that a frame is encoded from its parts without first being
 * copied into one buffer. The current block's code byte is its length so far, o - code. Pointers,
 * not indices: a data byte is then one store and one increment (the frame encoder's loop runs at
 * every tick on the soft CPU). */
typedef struct {
    uint8_t *start; /* the first block's code byte */
    uint8_t *code;  /* where the current block's code byte goes */
    uint8_t *o;     /* where the next byte goes */
} cobs_writer_t;

/* One byte of a message shorter than a COBS block (254 bytes): a zero closes the block with its
 * code, any other byte is data. */
static void cobs_put_short(cobs_writer_t *w, uint8_t b)
{
    if (b == 0U) {
        *w->code = (uint8_t)(w->o - w->code);
        w->code = w->o++;
    } else {
        *w->o++ = b;
    }
}

/* One byte of any message; `more`: bytes still to come after it. A full block of 254 bytes has no
 * implied zero; a new block starts only if more data follows (the canonical encoding). */
static void cobs_put(cobs_writer_t *w, uint8_t b, uint32_t more)
{
    cobs_put_short(w, b);
    if (w->o - w->code == 0xFF && more != 0U) {
        *w->code = 0xFFU;
        w->code = w->o++;
    }
}

/* The last block's code; the encoded length. */
static uint32_t cobs_end(cobs_writer_t *w)
{
    *w->code = (uint8_t)(w->o - w->code);
    return (uint32_t)(w->o - w->start);
}

uint32_t proto_cobs_encode(const uint8_t *in, uint32_t n, uint8_t *out)
{
    cobs_writer_t w = {out, out, &out[1]};
    for (uint32_t i = 0; i < n; ++i) {
        cobs_put(&w, in[i], n - 1U - i);
    }
    return cobs_end(&w);
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

static void rx_restart(proto_rx_t *rx)
{
    rx->len = 0U;
    rx->discard = 0U;
    rx->code = 0U;
    rx->left = 0U;
    rx->n = 0U;
    rx->crc = CRC32C_INIT;
}

void proto_rx_init(proto_rx_t *rx)
{
    rx_restart(rx);
    rx->stats = (proto_rx_stats_t){0};
}

/* A word that may alias any object (the payload's copy a word at a time). */
typedef uint32_t __attribute__((may_alias)) proto_word_t;

/* At a delimiter: the frame decoded so far checked and copied out (1), or counted as an error. */
static int rx_frame(proto_rx_t *rx, proto_frame_t *out)
{
    if (rx->left != 0U) { /* the last block's code points past the delimiter */
        ++rx->stats.framing_errors;
        return 0;
    }
    if (rx->n < PROTO_HEADER_LEN + PROTO_CRC_LEN) {
        ++rx->stats.short_frames;
        return 0;
    }
    /* The CRC run over the body and its own CRC field ends at the residue exactly when the field
     * is the body's CRC (crc32c.h). */
    if (rx->crc != CRC32C_RESIDUE) {
        ++rx->stats.crc_errors;
        return 0;
    }
    const uint32_t len = rx->n - PROTO_HEADER_LEN - PROTO_CRC_LEN; /* <= PROTO_MAX_PAYLOAD */
    out->version = rx->raw[0];
    out->msg = rx->raw[1];
    out->seq = rx->raw[2];
    out->len = (uint8_t)len;
    /* Four bytes an iteration: on the soft CPU a byte-wise copy was a tenth of a long frame's
     * handling (make soc-profile's method, on a run fed with full STREAM frames). A word at a
     * time where both ends are word-aligned (raw_pad puts the payload there; the caller's frame
     * may be aligned too): on the soft CPU four loads and four stores less a word. */
    const uint8_t *src = &rx->raw[PROTO_HEADER_LEN];
    uint8_t *dst = out->payload;
    uint32_t i = 0;
    if ((((uintptr_t)src | (uintptr_t)dst) & 3U) == 0U) {
        for (; i + 4U <= len; i += 4U) {
            *(proto_word_t *)(void *)&dst[i] = *(const proto_word_t *)(const void *)&src[i];
        }
    }
    for (; i + 4U <= len; i += 4U) {
        dst[i] = src[i];
        dst[i + 1U] = src[i + 1U];
        dst[i + 2U] = src[i + 2U];
        dst[i + 3U] = src[i + 3U];
    }
    for (; i < len; ++i) {
        dst[i] = src[i];
    }
    ++rx->stats.frames;
    return 1;
}

/* At most PROTO_MAX_COBS encoded bytes are taken, which decode to at most PROTO_MAX_RAW. */
_Static_assert(PROTO_MAX_COBS - 1U <= PROTO_MAX_RAW, "a frame's decoded bytes fit raw");

uint32_t proto_rx_bytes(proto_rx_t *rx, const uint8_t *data, uint32_t n, proto_frame_t *out,
                        int *got)
{
    *got = 0;
    /* The decoder's state in locals while bytes come: a store to raw may alias any object, which
     * would otherwise reload them at every byte. */
    uint32_t len = rx->len;
    uint32_t discard = rx->discard;
    uint32_t code = rx->code;
    uint32_t left = rx->left;
    uint32_t o = rx->n;
    uint32_t crc = crc32c_begin(rx->crc);
    uint32_t i = 0;
    while (i < n) {
        /* A run of the current block's data bytes, in a loop of its own (the one that costs on a
         * small CPU): up to the block's end, the bytes at hand, the frame's limit or a zero,
         * each byte exactly as the byte-wise steps below would take it. */
        if (left != 0U && discard == 0U && len < PROTO_MAX_COBS) {
            uint32_t run = n - i;
            run = (run < left) ? run : left;
            run = (run < PROTO_MAX_COBS - len) ? run : PROTO_MAX_COBS - len;
            const uint8_t *src = &data[i];
            const uint8_t *const end = src + run;
            uint8_t *dst = &rx->raw[o];
            /* Two bytes an iteration while neither is a zero (on the soft CPU a byte's loop
             * overhead was a third of its work: a full STREAM frame's decoding most of its
             * handling); the pair that holds a zero, and a last odd byte, go byte-wise below. */
            for (; end - src >= 2; src += 2, dst += 2) {
                const uint8_t b0 = src[0];
                const uint8_t b1 = src[1];
                if (b0 == 0U || b1 == 0U) {
                    break;
                }
                dst[0] = b0;
                crc = crc32c_step(crc, b0);
                dst[1] = b1;
                crc = crc32c_step(crc, b1);
            }
            for (; src < end; ++src, ++dst) {
                const uint8_t byte = *src;
                if (byte == 0U) {
                    break;
                }
                *dst = byte;
                crc = crc32c_step(crc, byte);
            }
            const uint32_t k = (uint32_t)(src - &data[i]);
            i += k;
            len += k;
            left -= k;
            o += k;
            if (i == n) {
                break;
            }
        }
        const uint8_t byte = data[i++];
        if (byte != 0U) {
            if (discard != 0U) {
                continue;
            }
            if (len >= PROTO_MAX_COBS) {
                ++rx->stats.overlong;
                discard = 1U;
                continue;
            }
            ++len;
            if (left != 0U) { /* a data byte of the current block */
                rx->raw[o++] = byte;
                crc = crc32c_step(crc, byte);
                --left;
            } else { /* a code byte: a block shorter than 254 bytes before it stood for a zero */
                if (code != 0U && code < 0xFFU) {
                    rx->raw[o++] = 0U;
                    crc = crc32c_step(crc, 0U);
                }
                code = byte;
                left = byte - 1U;
            }
            continue;
        }
        /* Delimiter: an empty frame (two delimiters in a row) is not an error. */
        crc = crc32c_end(crc);
        if (discard == 0U && len > 0U) {
            rx->left = left;
            rx->n = o;
            rx->crc = crc;
            *got = rx_frame(rx, out);
        }
        rx_restart(rx);
        len = 0U;
        discard = 0U;
        code = 0U;
        left = 0U;
        o = 0U;
        crc = crc32c_begin(CRC32C_INIT);
        if (*got != 0) {
            break;
        }
    }
    rx->len = len;
    rx->discard = discard;
    rx->code = code;
    rx->left = left;
    rx->n = o;
    rx->crc = crc32c_end(crc);
    return i;
}

int proto_rx_byte(proto_rx_t *rx, uint8_t byte, proto_frame_t *out)
{
    int got;
    (void)proto_rx_bytes(rx, &byte, 1U, out, &got);
    return got;
}

uint32_t proto_wire_len(const proto_frame_t *f)
{
    /* A frame is shorter than a COBS block (254 bytes): one code byte, and the two delimiters. */
    _Static_assert(PROTO_MAX_RAW < 254U, "a frame fits one COBS block");
    return (f->len > PROTO_MAX_PAYLOAD) ? 0U
                                        : PROTO_HEADER_LEN + f->len + PROTO_CRC_LEN + 1U + 2U;
}

/* n bytes of a message shorter than a COBS block through the writer and the CRC. Each byte is
 * stored where the writer stands whatever its value: a zero's slot is where the next block's code
 * goes, written when that block closes, so a zero costs the code's store only and a data byte no
 * branch taken. Four bytes an iteration (on the soft CPU a byte's loop overhead was as much as
 * its work: the telemetry frames' encoding was a quarter of the tick with four cables). */
static inline uint32_t cobs_crc_short(cobs_writer_t *w, const uint8_t *p, uint32_t n,
                                      uint32_t crc)
{
    uint8_t *o = w->o;
    uint8_t *code = w->code;
    const uint8_t *const end = p + n;
    for (; end - p >= 4; p += 4, o += 4) {
        const uint8_t b0 = p[0];
        const uint8_t b1 = p[1];
        const uint8_t b2 = p[2];
        const uint8_t b3 = p[3];
        crc = crc32c_step(crc, b0);
        o[0] = b0;
        crc = crc32c_step(crc, b1);
        o[1] = b1;
        crc = crc32c_step(crc, b2);
        o[2] = b2;
        crc = crc32c_step(crc, b3);
        o[3] = b3;
        if (b0 == 0U) {
            *code = (uint8_t)(o - code);
            code = o;
        }
        if (b1 == 0U) {
            *code = (uint8_t)(&o[1] - code);
            code = &o[1];
        }
        if (b2 == 0U) {
            *code = (uint8_t)(&o[2] - code);
            code = &o[2];
        }
        if (b3 == 0U) {
            *code = (uint8_t)(&o[3] - code);
            code = &o[3];
        }
    }
    for (; p < end; ++p, ++o) {
        const uint8_t b = *p;
        crc = crc32c_step(crc, b);
        *o = b;
        if (b == 0U) {
            *code = (uint8_t)(o - code);
            code = o;
        }
    }
    w->o = o;
    w->code = code;
    return crc;
}

/* cobs_crc_short for bytes already where the writer stands (w->o == p): only each zero's link,
 * no byte stored again. */
static inline uint32_t cobs_crc_link(cobs_writer_t *w, uint32_t n, uint32_t crc)
{
    uint8_t *p = w->o;
    uint8_t *code = w->code;
    uint8_t *const end = p + n;
    for (; end - p >= 4; p += 4) {
        for (uint32_t k = 0; k < 4U; ++k) { /* unrolled by the compiler */
            const uint8_t b = p[k];
            crc = crc32c_step(crc, b);
            if (b == 0U) {
                *code = (uint8_t)(&p[k] - code);
                code = &p[k];
            }
        }
    }
    for (; p < end; ++p) {
        const uint8_t b = *p;
        crc = crc32c_step(crc, b);
        if (b == 0U) {
            *code = (uint8_t)(p - code);
            code = p;
        }
    }
    w->o = p;
    w->code = code;
    return crc;
}

uint32_t proto_encode_in_place(uint8_t *out, uint32_t len)
{
    if (len > PROTO_MAX_PAYLOAD) {
        return 0U;
    }
    /* The same bytes as proto_encode: a short frame's COBS is its raw bytes one place on, each
     * zero replaced by the distance to the next (the code bytes), so the raw bytes at out[2] are
     * left where they are and only the codes are written. */
    uint32_t crc = crc32c_begin(CRC32C_INIT);
    out[0] = 0U;
    cobs_writer_t w = {&out[1], &out[1], &out[2]};
    crc = cobs_crc_link(&w, PROTO_HEADER_LEN + len, crc);
    crc = crc32c_end(crc) ^ 0xFFFFFFFFUL;
    for (uint32_t i = 0; i < PROTO_CRC_LEN; ++i) {
        cobs_put_short(&w, (uint8_t)(crc >> (8U * i)));
    }
    uint32_t m = cobs_end(&w);
    out[1U + m] = 0U;
    return m + 2U;
}

uint32_t proto_encode(const proto_frame_t *f, uint8_t *out, uint32_t cap)
{
    const uint32_t need = proto_wire_len(f);
    if (need == 0U || cap < need) {
        return 0U;
    }
    /* The header, the payload and the CRC go through COBS where they are (no raw copy), the CRC
     * taken in the same pass. No block fills (proto_wire_len): each byte is a code or data. */
    const uint8_t head[PROTO_HEADER_LEN] = {f->version, f->msg, f->seq};
    uint32_t crc = crc32c_begin(CRC32C_INIT);
    out[0] = 0U;
    cobs_writer_t w = {&out[1], &out[1], &out[2]};
    crc = cobs_crc_short(&w, head, PROTO_HEADER_LEN, crc);
    crc = cobs_crc_short(&w, f->payload, f->len, crc);
    crc = crc32c_end(crc) ^ 0xFFFFFFFFUL;
    for (uint32_t i = 0; i < PROTO_CRC_LEN; ++i) {
        cobs_put_short(&w, (uint8_t)(crc >> (8U * i)));
    }
    uint32_t m = cobs_end(&w);
    out[1U + m] = 0U;
    return m + 2U;
}
