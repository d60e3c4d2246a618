/*
 * libc.c - the C library functions the compiler may call on its own (structure copies and
 * clears, memcmp for comparisons it folds) and the 32-bit division helpers of a CPU without a
 * divider (RV32IM's Zmmul subset: picorv32 with ENABLE_DIV 0, see hdl/soc/bowden_soc.v); the
 * firmware links without any library, so any other missing symbol (a soft-float helper, libm)
 * fails the link.
 */
#include <stddef.h>
#include <stdint.h>

void *memcpy(void *dst, const void *src, size_t n);
void *memmove(void *dst, const void *src, size_t n);
void *memset(void *dst, int c, size_t n);
int memcmp(const void *a, const void *b, size_t n);
uint32_t __udivsi3(uint32_t n, uint32_t d);
uint32_t __umodsi3(uint32_t n, uint32_t d);
int32_t __divsi3(int32_t n, int32_t d);
int32_t __modsi3(int32_t n, int32_t d);

void *memcpy(void *dst, const void *src, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    if ((((uintptr_t)d | (uintptr_t)s | n) & 3U) == 0U) {
        uint32_t *dw = (uint32_t *)dst;
        const uint32_t *sw = (const uint32_t *)src;
        size_t words = n / 4U;
        size_t i = 0;
        /* Four words a step: the loop's own instructions cost as much as a copy on picorv32. */
        for (; i + 4U <= words; i += 4U) {
            uint32_t a = sw[i], b = sw[i + 1U], c = sw[i + 2U], e = sw[i + 3U];
            dw[i] = a;
            dw[i + 1U] = b;
            dw[i + 2U] = c;
            dw[i + 3U] = e;
        }
        for (; i < words; ++i) {
            dw[i] = sw[i];
        }
        return dst;
    }
    for (size_t i = 0; i < n; ++i) {
        d[i] = s[i];
    }
    return dst;
}

void *memmove(void *dst, const void *src, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    if (d < s) {
        for (size_t i = 0; i < n; ++i) {
            d[i] = s[i];
        }
    } else {
        for (size_t i = n; i > 0U; --i) {
            d[i - 1U] = s[i - 1U];
        }
    }
    return dst;
}

void *memset(void *dst, int c, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    size_t i = 0;
    /* Words while aligned (structure clears are), then bytes. */
    if (((uintptr_t)d & 3U) == 0U) {
        uint32_t w = (uint32_t)(uint8_t)c * 0x01010101UL;
        for (; i + 4U <= n; i += 4U) {
            *(uint32_t *)(void *)(d + i) = w;
        }
    }
    for (; i < n; ++i) {
        d[i] = (uint8_t)c;
    }
    return dst;
}

int memcmp(const void *a, const void *b, size_t n)
{
    const uint8_t *x = (const uint8_t *)a;
    const uint8_t *y = (const uint8_t *)b;
    for (size_t i = 0; i < n; ++i) {
        if (x[i] != y[i]) {
            return (int)x[i] - (int)y[i];
        }
    }
    return 0;
}

/* Restoring division, one quotient bit per step; d == 0 gives all ones (RISC-V's DIVU result).
 * The divisor is first shifted up under the dividend's top bit, so only the quotient's own bits
 * are stepped (a small quotient takes few steps), and every shift is by one place: picorv32's
 * two-stage shifter takes up to seven clocks for a shift by a variable amount. */
static uint32_t udivmod(uint32_t n, uint32_t d, uint32_t *rem)
{
    if (d == 0U) {
        *rem = n;
        return 0xFFFFFFFFUL;
    }
    uint32_t bit = 1U;
    while (d < n && (d & 0x80000000UL) == 0U) {
        d <<= 1;
        bit <<= 1;
    }
    /* Now n < 2d (d >= n, or d's top bit set): the quotient has no bit above `bit`. */
    uint32_t q = 0U;
    while (bit != 0U) {
        if (n >= d) {
            n -= d;
            q |= bit;
        }
        d >>= 1;
        bit >>= 1;
    }
    *rem = n;
    return q;
}

uint32_t __udivsi3(uint32_t n, uint32_t d)
{
    uint32_t r;
    return udivmod(n, d, &r);
}

uint32_t __umodsi3(uint32_t n, uint32_t d)
{
    uint32_t r;
    (void)udivmod(n, d, &r);
    return r;
}

/* Signed: truncating towards zero, as C's / and %. */
int32_t __divsi3(int32_t n, int32_t d)
{
    uint32_t un = n < 0 ? 0U - (uint32_t)n : (uint32_t)n;
    uint32_t ud = d < 0 ? 0U - (uint32_t)d : (uint32_t)d;
    uint32_t r;
    uint32_t q = udivmod(un, ud, &r);
    return (int32_t)(((n < 0) != (d < 0)) ? 0U - q : q);
}

int32_t __modsi3(int32_t n, int32_t d)
{
    uint32_t un = n < 0 ? 0U - (uint32_t)n : (uint32_t)n;
    uint32_t ud = d < 0 ? 0U - (uint32_t)d : (uint32_t)d;
    uint32_t r;
    (void)udivmod(un, ud, &r);
    return (int32_t)(n < 0 ? 0U - r : r);
}

#if !defined(__riscv_mul) && !defined(__riscv_zmmul)
/* A CPU without a multiplier (hdl/soc/bowden_soc.v CPU_MUL 0, measured in hdl/README.md "The
 * CPU, measured"): shift-and-add, one bit of the multiplier per step, stopping when the rest of
 * it is zero. Both give the low bits of the product, which are the same signed or unsigned. */
uint32_t __mulsi3(uint32_t a, uint32_t b);
uint64_t __muldi3(uint64_t a, uint64_t b);

uint32_t __mulsi3(uint32_t a, uint32_t b)
{
    uint32_t r = 0U;
    while (b != 0U) {
        if ((b & 1U) != 0U) {
            r += a;
        }
        a <<= 1;
        b >>= 1;
    }
    return r;
}

uint64_t __muldi3(uint64_t a, uint64_t b)
{
    uint32_t al = (uint32_t)a;
    uint32_t bl = (uint32_t)b;
    /* the 64-bit product of the low words, then the cross terms into the high word */
    uint64_t wide = 0U;
    uint64_t aw = al;
    for (uint32_t m = bl; m != 0U; m >>= 1) {
        if ((m & 1U) != 0U) {
            wide += aw;
        }
        aw <<= 1;
    }
    uint32_t cross = __mulsi3(al, (uint32_t)(b >> 32)) + __mulsi3((uint32_t)(a >> 32), bl);
    return wide + ((uint64_t)cross << 32);
}
#endif
