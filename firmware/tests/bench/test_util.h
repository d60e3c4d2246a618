/* test_util.h - helpers shared by the bench unit tests. */
#ifndef BOWDEN_BENCH_TEST_UTIL_H
#define BOWDEN_BENCH_TEST_UTIL_H

#include <stdint.h>

/* Hex text to bytes; returns the byte count. */
static inline uint32_t tu_unhex(const char *hex, uint8_t *out, uint32_t cap)
{
    uint32_t n = 0;
    while (hex[0] != '\0' && hex[1] != '\0' && n < cap) {
        uint32_t v = 0;
        for (int k = 0; k < 2; ++k) {
            char c = hex[k];
            v = v * 16U + (uint32_t)((c >= 'a') ? (c - 'a' + 10) : (c - '0'));
        }
        out[n++] = (uint8_t)v;
        hex += 2;
    }
    return n;
}

/* xorshift32: deterministic pseudo-random words for the tests. */
static inline uint32_t tu_rand(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

#endif /* BOWDEN_BENCH_TEST_UTIL_H */
