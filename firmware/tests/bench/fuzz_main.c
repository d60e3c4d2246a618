/*
 * fuzz_main.c - bounded random and mutation fuzzing of the bench protocol's decoder and device
 * (fuzz_proto.c), for gcc with ASan + UBSan (no clang needed). Each round builds a valid frame
 * (random message id, seq and payload, sometimes a real request), then sends it intact or mutated
 * (bit flips, byte insertions and deletions, truncation, a garbage run, an overlong run, a stray
 * delimiter), often glued to its neighbours. Checks, besides the harness's invariants: every
 * intact frame sent after any garbage is received (resynchronisation within one frame), and no
 * mutated frame is accepted unless its bytes still form a frame with a valid CRC.
 *
 *   proto_fuzz_san [--frames N] [--seed S]     (default 1,000,000 frames, seed 1)
 * Prints one line with the counts; exit 0, or abort on the first violation.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_proto.h"
#include "proto.h"

static uint64_t rng_state;

static uint32_t rnd(void)
{
    /* xorshift64* */
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (uint32_t)((rng_state * 0x2545F4914F6CDD1DULL) >> 32);
}

/* Every frame goes through the decoder; one round in DEVICE_EVERY also through the device (the
 * dispatcher behind the decoder: the same bytes, so the same accepted frames reach it). */
#define DEVICE_EVERY 8U

static void feed(uint64_t round, const uint8_t *data, size_t n)
{
    if (round % DEVICE_EVERY == 0U) {
        fuzz_feed(data, n);
    } else {
        fuzz_feed_decoder(data, n);
    }
}

int main(int argc, char **argv)
{
    uint64_t frames = 1000000U;
    uint64_t seed = 1U;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (strcmp(argv[i], "--frames") == 0) {
            frames = strtoull(argv[i + 1], NULL, 10);
        } else if (strcmp(argv[i], "--seed") == 0) {
            seed = strtoull(argv[i + 1], NULL, 10);
        }
    }
    rng_state = seed * 0x9E3779B97F4A7C15ULL + 1U;
    fuzz_reset();
    uint64_t intact = 0, mutated = 0;
    uint8_t buf[4 * PROTO_MAX_WIRE + 600];
    for (uint64_t k = 0; k < frames; ++k) {
        proto_frame_t f;
        f.version = (rnd() % 16U == 0U) ? (uint8_t)rnd() : (uint8_t)PROTO_VERSION;
        f.msg = (uint8_t)(rnd() % 24U);
        f.seq = (uint8_t)rnd();
        f.len = (uint8_t)(rnd() % (PROTO_MAX_PAYLOAD + 1U));
        uint32_t zeros = rnd() % 3U;
        for (uint32_t i = 0; i < f.len; ++i) {
            uint32_t r = rnd();
            f.payload[i] = (r % 4U < zeros) ? 0U : (uint8_t)(r >> 8);
        }
        uint32_t n = proto_encode(&f, buf, sizeof buf);
        uint32_t kind = rnd() % 8U;
        if (kind < 3U) { /* intact */
            uint64_t before = fuzz_stats()->accepted;
            feed(k, buf, n);
            /* The frame is the last one accepted (a truncated predecessor that lacked only its
             * final delimiter is completed by this frame's leading one, and is accepted too). */
            const proto_frame_t *g = (const proto_frame_t *)fuzz_last_frame();
            if (fuzz_stats()->accepted < before + 1U || g->msg != f.msg || g->seq != f.seq ||
                g->len != f.len || g->version != f.version ||
                memcmp(g->payload, f.payload, f.len) != 0) {
                fprintf(stderr, "intact frame %llu not received\n", (unsigned long long)k);
                abort();
            }
            ++intact;
            continue;
        }
        ++mutated;
        uint32_t m = n;
        switch (kind) {
        case 3: /* bit flips */
            for (uint32_t j = 1U + rnd() % 3U; j > 0U; --j) {
                buf[rnd() % m] ^= (uint8_t)(1U << (rnd() % 8U));
            }
            break;
        case 4: /* insert or delete a byte */
            if (rnd() & 1U) {
                uint32_t at = rnd() % m;
                memmove(&buf[at + 1U], &buf[at], m - at);
                buf[at] = (uint8_t)rnd();
                ++m;
            } else {
                uint32_t at = rnd() % m;
                memmove(&buf[at], &buf[at + 1U], m - at - 1U);
                --m;
            }
            break;
        case 5: /* truncate (no final delimiter: the next frame's leading one ends it) */
            m = 1U + rnd() % (m - 1U);
            break;
        case 6: /* garbage run, any bytes */
            m = rnd() % 300U;
            for (uint32_t j = 0; j < m; ++j) {
                buf[j] = (uint8_t)rnd();
            }
            break;
        default: /* overlong run of non-zero bytes */
            m = PROTO_MAX_COBS + rnd() % 300U;
            for (uint32_t j = 0; j < m; ++j) {
                buf[j] = (uint8_t)(1U + rnd() % 255U);
            }
            break;
        }
        /* Feed in random splits. */
        uint32_t pos = 0;
        while (pos < m) {
            uint32_t chunk = 1U + rnd() % (m - pos);
            feed(k, &buf[pos], chunk);
            pos += chunk;
        }
    }
    const fuzz_stats_t *s = fuzz_stats();
    printf("proto fuzz: %llu frames (%llu intact, %llu mutated), %llu bytes, %llu accepted "
           "(%llu CRCs rechecked), %llu rejected, seed %llu: no violation\n",
           (unsigned long long)frames, (unsigned long long)intact, (unsigned long long)mutated,
           (unsigned long long)s->bytes, (unsigned long long)s->accepted,
           (unsigned long long)s->crc_checked, (unsigned long long)s->rejected,
           (unsigned long long)seed);
    return 0;
}
