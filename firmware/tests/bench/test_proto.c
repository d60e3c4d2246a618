/* test_proto.c - CRC-32C, COBS, the serial framing and the CAN mapping, with the shared vectors. */
#include <string.h>

#include "crc32c.h"
#include "proto.h"
#include "proto_can.h"
#include "proto_vectors.h"
#include "test_util.h"
#include "unit.h"

static void test_crc32c_check_value(void)
{
    /* The catalogue check value of CRC-32C (RFC 3720, iSCSI): "123456789" -> 0xE3069283. */
    const uint8_t s[] = "123456789";
    CHECK(crc32c(s, 9U) == 0xE3069283UL, "crc %08lX", (unsigned long)crc32c(s, 9U));
    uint32_t c = crc32c_update(CRC32C_INIT, s, 4U);
    c = crc32c_update(c, s + 4, 5U) ^ 0xFFFFFFFFUL;
    CHECK(c == 0xE3069283UL, "chained %08lX", (unsigned long)c);
    CHECK(crc32c(s, 0U) == 0U, "empty");
}

/* CRC-32C by its definition, a bit at a time: the oracle of the byte table. */
static uint32_t crc32c_bitwise(const uint8_t *data, uint32_t n)
{
    uint32_t crc = CRC32C_INIT;
    for (uint32_t i = 0; i < n; ++i) {
        crc ^= data[i];
        for (int k = 0; k < 8; ++k) {
            crc = (crc >> 1) ^ ((crc & 1U) ? 0x82F63B78UL : 0UL);
        }
    }
    return crc ^ 0xFFFFFFFFUL;
}

static void test_crc32c_table_is_the_definition(void)
{
    /* Every entry of the table is reached by a one-byte message, then longer mixed messages. */
    for (uint32_t b = 0; b < 256U; ++b) {
        const uint8_t one = (uint8_t)b;
        CHECK(crc32c(&one, 1U) == crc32c_bitwise(&one, 1U), "byte %02lX", (unsigned long)b);
    }
    uint8_t buf[300];
    uint32_t x = 12345U;
    for (uint32_t i = 0; i < sizeof buf; ++i) {
        x = x * 1103515245U + 12345U;
        buf[i] = (uint8_t)(x >> 16);
    }
    for (uint32_t n = 0; n <= sizeof buf; n += 13U) {
        CHECK(crc32c(buf, n) == crc32c_bitwise(buf, n), "%lu bytes", (unsigned long)n);
    }
}

static void test_crc32c_residue(void)
{
    /* A message followed by its CRC (least significant byte first) leaves the register at the
     * residue; one bit flipped anywhere, in the message or the CRC, does not. */
    uint8_t buf[40];
    for (uint32_t n = 0; n + 4U <= sizeof buf; n += 7U) {
        for (uint32_t i = 0; i < n; ++i) {
            buf[i] = (uint8_t)(i * 37U + n);
        }
        uint32_t crc = crc32c(buf, n);
        for (uint32_t k = 0; k < 4U; ++k) {
            buf[n + k] = (uint8_t)(crc >> (8U * k));
        }
        CHECK(crc32c_update(CRC32C_INIT, buf, n + 4U) == CRC32C_RESIDUE, "%lu bytes",
              (unsigned long)n);
        for (uint32_t bit = 0; bit < 8U * (n + 4U); bit += 5U) {
            buf[bit / 8U] ^= (uint8_t)(1U << (bit % 8U));
            CHECK(crc32c_update(CRC32C_INIT, buf, n + 4U) != CRC32C_RESIDUE, "bit %lu of %lu",
                  (unsigned long)bit, (unsigned long)n);
            buf[bit / 8U] ^= (uint8_t)(1U << (bit % 8U));
        }
    }
}

/* COBS examples of Cheshire & Baker's encoding (as tabulated by the COBS literature). */
static void test_cobs_examples(void)
{
    static const struct {
        const char *in;
        const char *out;
    } ex[] = {
        {"00", "0101"},           {"0000", "010101"},       {"001100", "01021101"},
        {"11220033", "0311220233"}, {"11223344", "0511223344"}, {"11000000", "0211010101"},
        {"", "01"},
    };
    for (unsigned i = 0; i < sizeof ex / sizeof ex[0]; ++i) {
        uint8_t in[16], want[16], got[16], back[16];
        uint32_t n = tu_unhex(ex[i].in, in, 16U);
        uint32_t m = tu_unhex(ex[i].out, want, 16U);
        uint32_t k = proto_cobs_encode(in, n, got);
        CHECK(k == m && memcmp(got, want, m) == 0, "example %u", i);
        int32_t d = proto_cobs_decode(got, k, back, 16U);
        CHECK(d == (int32_t)n && memcmp(back, in, n) == 0, "decode example %u", i);
    }
    /* 254 non-zero bytes: one full block, no trailing block; 255: a second block. */
    uint8_t in[300], enc[310], dec[300];
    for (uint32_t i = 0; i < 300; ++i) {
        in[i] = (uint8_t)(1U + i % 255U);
    }
    CHECK(proto_cobs_encode(in, 254U, enc) == 255U && enc[0] == 0xFFU, "254 bytes");
    CHECK(proto_cobs_encode(in, 255U, enc) == 257U && enc[255] == 2U, "255 bytes");
    CHECK(proto_cobs_decode(enc, 257U, dec, 300U) == 255 && memcmp(dec, in, 255U) == 0, "back");
}

static void test_cobs_round_trip_and_errors(void)
{
    uint32_t seed = 12345U;
    uint8_t in[600], enc[620], dec[600];
    for (int trial = 0; trial < 2000; ++trial) {
        uint32_t n = tu_rand(&seed) % 600U;
        uint32_t zeros = tu_rand(&seed) % 4U; /* from no zeros to mostly zeros */
        for (uint32_t i = 0; i < n; ++i) {
            uint32_t r = tu_rand(&seed);
            in[i] = (r % 4U < zeros) ? 0U : (uint8_t)(r >> 8);
        }
        uint32_t k = proto_cobs_encode(in, n, enc);
        CHECK(k <= n + n / 254U + 1U, "size bound %u for %u", k, n);
        CHECK(memchr(enc, 0, k) == NULL, "no zero in the encoding");
        int32_t d = proto_cobs_decode(enc, k, dec, 600U);
        CHECK(d == (int32_t)n && memcmp(dec, in, n) == 0, "round trip of %u bytes", n);
    }
    const uint8_t past_end[] = {0x05, 0x11, 0x22};
    CHECK(proto_cobs_decode(past_end, 3U, enc, 16U) == -1, "code past the end");
    const uint8_t zero_in[] = {0x03, 0x00, 0x22};
    CHECK(proto_cobs_decode(zero_in, 3U, enc, 16U) == -1, "zero inside");
    const uint8_t big[] = {0x04, 0x11, 0x22, 0x33};
    CHECK(proto_cobs_decode(big, 4U, enc, 2U) == -1, "more than cap");
}

static int feed(proto_rx_t *rx, const uint8_t *b, uint32_t n, proto_frame_t *last)
{
    int got = 0;
    for (uint32_t i = 0; i < n; ++i) {
        got += proto_rx_byte(rx, b[i], last);
    }
    return got;
}

/* Every shared vector: the payload packs and unpacks to the typed values, the frame encodes to
 * the wire bytes and decodes back, and the CAN frames match. */
/* proto_encode and proto_encode_in_place against the definition: 0x00, COBS (proto_cobs_encode,
 * byte by byte) of the header, the payload and their CRC-32C (the table's), 0x00; every payload
 * length, payloads from all zeros to none, the in-place one from raw bytes at out[2]. */
static void test_encoders_are_the_definition(void)
{
    uint32_t x = 12345U, bad = 0U, runs = 0U;
    for (uint32_t len = 0; len <= PROTO_MAX_PAYLOAD; ++len) {
        for (uint32_t density = 0; density <= 4U; ++density) {
            for (uint32_t rep = 0; rep < 8U; ++rep) {
                proto_frame_t f = {PROTO_VERSION, (uint8_t)(rep * 37U), (uint8_t)(rep & 1U),
                                   (uint8_t)len, {0}};
                for (uint32_t i = 0; i < len; ++i) {
                    x = x * 1664525U + 1013904223U;
                    /* a zero with probability density / 4 */
                    f.payload[i] = ((x >> 24) % 4U < density) ? 0U : (uint8_t)(1U + (x >> 8) % 255U);
                }
                uint8_t raw[PROTO_MAX_RAW];
                raw[0] = f.version;
                raw[1] = f.msg;
                raw[2] = f.seq;
                memcpy(&raw[3], f.payload, len);
                const uint32_t crc = crc32c(raw, 3U + len);
                for (uint32_t i = 0; i < 4U; ++i) {
                    raw[3U + len + i] = (uint8_t)(crc >> (8U * i));
                }
                uint8_t want[PROTO_MAX_WIRE + 8];
                want[0] = 0U;
                const uint32_t m = proto_cobs_encode(raw, 7U + len, &want[1]);
                want[1U + m] = 0U;
                const uint32_t n = m + 2U;
                uint8_t got[PROTO_MAX_WIRE + 8];
                memset(got, 0xAA, sizeof got);
                bad += proto_encode(&f, got, sizeof got) != n || memcmp(got, want, n) != 0 ||
                       got[n] != 0xAAU;
                memset(got, 0xAA, sizeof got);
                memcpy(&got[2], raw, 3U + len);
                bad += proto_encode_in_place(got, len) != n || memcmp(got, want, n) != 0 ||
                       got[n] != 0xAAU;
                ++runs;
            }
        }
    }
    CHECK(bad == 0U, "%u of %u frames differ", bad, 2U * runs);
    uint8_t big[PROTO_MAX_WIRE + 8];
    CHECK(proto_encode_in_place(big, PROTO_MAX_PAYLOAD + 1U) == 0U, "over-long refused");
}

static void test_shared_vectors(void)
{
    uint32_t typed_index[32] = {0};
    for (uint32_t v = 0; v < PROTO_N_VECTORS; ++v) {
        const proto_vector_t *pv = &proto_vectors[v];
        proto_frame_t f = {PROTO_VERSION, pv->msg, pv->seq, 0U, {0}};
        f.len = (uint8_t)tu_unhex(pv->payload_hex, f.payload, PROTO_MAX_PAYLOAD);
        CHECK(f.len == pv->payload_len, "vector %u payload length", v);
        uint8_t wire[PROTO_MAX_WIRE], want[PROTO_MAX_WIRE];
        uint32_t n = proto_encode(&f, wire, sizeof wire);
        uint32_t m = tu_unhex(pv->wire_hex, want, sizeof want);
        CHECK(n == m && memcmp(wire, want, m) == 0, "vector %u (msg %u) wire bytes", v, pv->msg);
        proto_rx_t rx;
        proto_rx_init(&rx);
        proto_frame_t g;
        CHECK(feed(&rx, want, m, &g) == 1, "vector %u decodes", v);
        CHECK(g.msg == f.msg && g.seq == f.seq && g.len == f.len &&
                  memcmp(g.payload, f.payload, f.len) == 0,
              "vector %u round trip", v);
        /* Typed values: unpack must give them, pack must give the payload. */
        uint32_t j = typed_index[pv->msg]++;
        uint8_t buf[PROTO_MAX_PAYLOAD];
        int ok = 1;
        uint32_t len = 0;
#define TYPED(NAME, name)                                                                      \
    case PROTO_MSG_##NAME: {                                                                   \
        proto_##name##_t u;                                                                    \
        ok = proto_##name##_unpack(&u, f.payload, f.len) &&                                    \
             proto_equal_##name(&u, &proto_vectors_##name[j]);                                 \
        len = proto_##name##_pack(&proto_vectors_##name[j], buf);                              \
        ok = ok && len == f.len && memcmp(buf, f.payload, len) == 0;                           \
        break;                                                                                 \
    }
        switch (pv->msg) {
            TYPED(HELLO_ACK, hello_ack)
            TYPED(PARAM_GET, param_get)
            TYPED(PARAM_SET, param_set)
            TYPED(PARAM_VALUE, param_value)
            TYPED(PARAM_INFO, param_info)
            TYPED(PARAM_INFO_ACK, param_info_ack)
            TYPED(START, start)
            TYPED(STREAM, stream)
            TYPED(STREAM_CH, stream_ch)
            TYPED(FAULTS_GET, faults_get)
            TYPED(FAULTS, faults)
            TYPED(STATS, stats)
            TYPED(ACK, ack)
            TYPED(ERROR, error)
            TYPED(TELEMETRY, telemetry)
            TYPED(TEXT_GET, text_get)
            TYPED(TEXT, text)
        default:
            ok = f.len == 0U;
            break;
        }
#undef TYPED
        CHECK(ok, "vector %u (msg %u): typed values", v, pv->msg);
        /* CAN */
        proto_can_frame_t cf[PROTO_CAN_MAX_FRAMES];
        uint32_t k = proto_can_encode(PROTO_CAN_DEFAULT_NODE, &f, cf, PROTO_CAN_MAX_FRAMES);
        if (pv->msg == PROTO_MSG_TELEMETRY) {
            CHECK(k == 2U, "telemetry takes two CAN frames");
            continue;
        }
        CHECK(k == pv->can_frames, "vector %u: %u CAN frames, expected %u", v, k, pv->can_frames);
        proto_can_rx_t crx;
        proto_can_rx_init(&crx);
        int done = 0;
        for (uint32_t i = 0; i < k && i < pv->can_frames; ++i) {
            uint8_t d[8];
            uint32_t dl = tu_unhex(pv->can_hex[i], d, 8U);
            CHECK(cf[i].id == pv->can_id[i] && cf[i].len == dl && memcmp(cf[i].data, d, dl) == 0,
                  "vector %u CAN frame %u", v, i);
            done += proto_can_rx(&crx, PROTO_CAN_DEFAULT_NODE, &cf[i], &g);
        }
        CHECK(done == 1 && g.msg == f.msg && g.seq == f.seq && g.len == f.len &&
                  memcmp(g.payload, f.payload, f.len) == 0,
              "vector %u CAN round trip", v);
    }
}

static uint32_t make_frame(uint8_t msg, uint8_t seq, uint8_t len, uint8_t fill, uint8_t *wire)
{
    proto_frame_t f = {PROTO_VERSION, msg, seq, len, {0}};
    for (uint32_t i = 0; i < len; ++i) {
        f.payload[i] = (uint8_t)(fill + i * 7U);
    }
    return proto_encode(&f, wire, PROTO_MAX_WIRE);
}

/* Garbage, split delivery, truncation, overlong runs and bad CRCs: rejected, counted, and the
 * next frame is received (resynchronisation at the next delimiter). */
static void test_decoder_robustness(void)
{
    proto_rx_t rx;
    proto_rx_init(&rx);
    proto_frame_t g;
    uint8_t w[PROTO_MAX_WIRE];
    uint32_t n = make_frame(PROTO_MSG_PARAM_SET, 9U, 6U, 0x10U, w);
    /* byte by byte */
    CHECK(feed(&rx, w, n, &g) == 1 && g.seq == 9U, "one frame");
    /* garbage without a delimiter, then a frame (its leading delimiter ends the garbage) */
    const uint8_t junk[] = {0x55, 0x13, 0x11, 0x0D, 0x03, 0xFF};
    CHECK(feed(&rx, junk, sizeof junk, &g) == 0, "junk alone");
    CHECK(feed(&rx, w, n, &g) == 1, "frame after junk");
    CHECK(rx.stats.framing_errors + rx.stats.crc_errors + rx.stats.short_frames == 1U,
          "junk counted once");
    /* truncated: the frame cut before its end, then a whole one */
    uint32_t before = rx.stats.crc_errors + rx.stats.framing_errors + rx.stats.short_frames;
    CHECK(feed(&rx, w, n - 4U, &g) == 0, "truncated");
    CHECK(feed(&rx, w, n, &g) == 1, "frame after truncated");
    CHECK(rx.stats.crc_errors + rx.stats.framing_errors + rx.stats.short_frames == before + 1U,
          "truncated counted");
    /* every single-bit flip of the encoded body is rejected (CRC-32C detects them all) */
    uint32_t accepted = 0;
    for (uint32_t i = 1; i + 1U < n; ++i) {
        for (uint32_t b = 0; b < 8U; ++b) {
            uint8_t c[PROTO_MAX_WIRE];
            memcpy(c, w, n);
            c[i] ^= (uint8_t)(1U << b);
            accepted += (uint32_t)feed(&rx, c, n, &g);
        }
    }
    CHECK(accepted == 0U, "%u bit flips accepted", accepted);
    CHECK(feed(&rx, w, n, &g) == 1, "frame after the flips");
    /* overlong: a run of non-zero bytes beyond the buffer, then a frame */
    uint8_t longrun[400];
    memset(longrun, 0x41, sizeof longrun);
    uint32_t ol = rx.stats.overlong;
    CHECK(feed(&rx, longrun, sizeof longrun, &g) == 0, "overlong");
    CHECK(rx.stats.overlong == ol + 1U, "overlong counted once");
    CHECK(feed(&rx, w, n, &g) == 1, "frame after overlong");
    /* short: a valid COBS body of 3 bytes */
    const uint8_t shortf[] = {0x00, 0x04, 0x01, 0x02, 0x03, 0x00};
    uint32_t sh = rx.stats.short_frames;
    CHECK(feed(&rx, shortf, sizeof shortf, &g) == 0 && rx.stats.short_frames == sh + 1U, "short");
    /* empty frames (delimiter runs) are not errors */
    const uint8_t zeros[] = {0, 0, 0, 0};
    uint32_t errs = rx.stats.crc_errors + rx.stats.framing_errors + rx.stats.short_frames;
    CHECK(feed(&rx, zeros, 4U, &g) == 0, "zeros");
    CHECK(rx.stats.crc_errors + rx.stats.framing_errors + rx.stats.short_frames == errs,
          "delimiters are not errors");
    /* the largest payload passes, one more byte cannot be encoded */
    proto_frame_t big = {PROTO_VERSION, 1U, 1U, (uint8_t)PROTO_MAX_PAYLOAD, {0}};
    CHECK(proto_encode(&big, w, sizeof w) > 0U, "largest frame");
    CHECK(feed(&rx, w, proto_encode(&big, w, sizeof w), &g) == 1 && g.len == PROTO_MAX_PAYLOAD,
          "largest frame received");
    big.len = (uint8_t)(PROTO_MAX_PAYLOAD + 1U);
    CHECK(proto_encode(&big, w, sizeof w) == 0U, "too long to encode");
    CHECK(proto_encode(&g, w, 10U) == 0U, "cap too small");
    /* random garbage: never more accepted frames than valid CRCs (the checker recomputes) */
    uint32_t seed = 77U;
    uint8_t rnd[4096];
    for (uint32_t i = 0; i < sizeof rnd; ++i) {
        rnd[i] = (uint8_t)(tu_rand(&seed) % 5U == 0U ? 0U : tu_rand(&seed));
    }
    CHECK(feed(&rx, rnd, sizeof rnd, &g) == 0, "random garbage accepted");
    CHECK(feed(&rx, w, make_frame(3U, 4U, 2U, 1U, w), &g) == 1, "frame after random garbage");
}

static void test_can_rx_errors(void)
{
    proto_can_rx_t rx;
    proto_can_rx_init(&rx);
    proto_frame_t g;
    proto_frame_t f = {PROTO_VERSION, PROTO_MSG_ERROR, 5U, 0U, {0}};
    proto_error_t e = {PROTO_MSG_PARAM_SET, PROTO_ERR_INVALID_VALUE, 3, 20U, "comp.mu: outside [0,"};
    f.len = (uint8_t)proto_error_pack(&e, f.payload);
    proto_can_frame_t cf[PROTO_CAN_MAX_FRAMES];
    uint32_t k = proto_can_encode(1U, &f, cf, PROTO_CAN_MAX_FRAMES);
    CHECK(k == 5U, "26 bytes + length in 5 segments, got %u", k);
    /* another node's frames are ignored */
    CHECK(proto_can_rx(&rx, 2U, &cf[0], &g) == 0 && rx.stats.framing_errors == 0U, "other node");
    /* a missing segment drops the message */
    int got = 0;
    for (uint32_t i = 0; i < k; ++i) {
        if (i != 2U) {
            got += proto_can_rx(&rx, 1U, &cf[i], &g);
        }
    }
    CHECK(got == 0 && rx.stats.framing_errors >= 1U, "gap detected");
    /* then the whole message */
    for (uint32_t i = 0; i < k; ++i) {
        got += proto_can_rx(&rx, 1U, &cf[i], &g);
    }
    CHECK(got == 1 && g.len == f.len && memcmp(g.payload, f.payload, f.len) == 0, "complete");
    /* a length beyond the largest payload is refused */
    proto_can_frame_t bad = cf[0];
    bad.data[2] = (uint8_t)(PROTO_MAX_PAYLOAD + 1U);
    uint32_t fe = rx.stats.framing_errors;
    CHECK(proto_can_rx(&rx, 1U, &bad, &g) == 0 && rx.stats.framing_errors == fe + 1U, "length");
    proto_can_frame_t empty = {cf[0].id, 0U, {0}};
    CHECK(proto_can_rx(&rx, 1U, &empty, &g) == 0 && rx.stats.short_frames == 1U, "empty");
    /* telemetry: two frames, A then B, with the sample's low byte pairing them */
    proto_telemetry_t t = {1000U, 0x12345678UL, 3U, 100, -200, 300,
                           -400, 500, 0x11U, 0x21U, 0x8000U, 0x5U, 2U};
    f.msg = PROTO_MSG_TELEMETRY;
    f.len = (uint8_t)proto_telemetry_pack(&t, f.payload);
    CHECK(proto_can_encode(1U, &f, cf, 2U) == 2U, "telemetry frames");
    proto_telem_a_t a;
    proto_telem_b_t b;
    CHECK(proto_telem_a_unpack(&a, cf[0].data, cf[0].len) && a.sample_lo16 == (uint16_t)t.sample && a.channel == 2U &&
              a.t_ref == 100 && a.t_c == -200,
          "TELEM_A");
    CHECK(proto_telem_b_unpack(&b, cf[1].data, cf[1].len) && b.sample_lo == 0x78U &&
              b.t_in == 300 && b.t_out == -400 && b.current == 500 && b.faults == 0x11U,
          "TELEM_B");
    CHECK(cf[0].id == ((1U << 5) | PROTO_MSG_TELEM_A), "id = node << 5 | message");
}

const unit_test_t proto_tests[] = {
    {"crc32c_check_value", test_crc32c_check_value},
    {"crc32c_table_is_the_definition", test_crc32c_table_is_the_definition},
    {"crc32c_residue", test_crc32c_residue},
    {"cobs_examples", test_cobs_examples},
    {"cobs_round_trip_and_errors", test_cobs_round_trip_and_errors},
    {"encoders_are_the_definition", test_encoders_are_the_definition},
    {"shared_vectors", test_shared_vectors},
    {"decoder_robustness", test_decoder_robustness},
    {"can_rx_errors", test_can_rx_errors},
};
const int proto_tests_count = (int)(sizeof proto_tests / sizeof proto_tests[0]);
