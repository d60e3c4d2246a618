/*
 * crc32c.h - CRC-32C (Castagnoli; iSCSI, RFC 3720): reflected polynomial 0x82F63B78, initial value
 * and final XOR 0xFFFFFFFF. Check value: crc32c("123456789") = 0xE3069283.
 * A 256-entry table (1 KiB of flash) and one look-up per byte: every frame sent or received runs
 * through it, and on the soft CPU the telemetry frame's CRC was a fifth of the tick (measured
 * with a 16-entry table and two look-ups per byte). The soft CPU's SoC has a CRC unit, which the
 * frame encoder and receiver use there (crc32c_begin below).
 */
#ifndef BOWDEN_CRC32C_H
#define BOWDEN_CRC32C_H

#include <stdint.h>

#define CRC32C_INIT 0xFFFFFFFFUL
/* The register (before the final XOR) after a message followed by its own CRC, least significant
 * byte first: the same for every message, and reached only when those four bytes are the
 * message's CRC (the "residue" of CRC-32/ISCSI in Greg Cook's CRC RevEng catalogue). */
#define CRC32C_RESIDUE 0xB798B438UL

/* The table of crc32c.c: the CRC of each byte value. */
extern const uint32_t crc32c_table[256];

/* One byte through the table (whatever the target). */
static inline uint32_t crc32c_table_step(uint32_t crc, uint8_t byte)
{
    return (crc >> 8) ^ crc32c_table[(crc ^ byte) & 0xFFU];
}

/* A CRC in a loop that does more with each byte (the frame encoder and receiver):
 *     crc = crc32c_begin(crc);  ...  crc = crc32c_step(crc, byte);  ...  crc = crc32c_end(crc);
 * Where the target has a CRC unit (CRC32C_UNIT_ADDR: its register's address, the data register
 * the word after; bowden_soc's, firmware/soc/soc.h), the CRC runs in the unit, one store a byte
 * instead of a table look-up, and crc32c_end reads it back; the unit holds one CRC, so no other
 * begin may come between a begin and its end. Elsewhere the CRC is the variable itself. */
#if defined(CRC32C_UNIT_ADDR)
static inline uint32_t crc32c_begin(uint32_t crc)
{
    *(volatile uint32_t *)(CRC32C_UNIT_ADDR) = crc;
    return crc;
}

/* The unit takes a byte in 8 clocks and holds the bus meanwhile: the compiler barrier keeps the
 * caller's other loads and stores of a byte between two steps, not all steps back to back
 * (make soc-profile: 9 clocks a store when grouped). */
static inline uint32_t crc32c_step(uint32_t crc, uint8_t byte)
{
    *(volatile uint32_t *)(CRC32C_UNIT_ADDR + 4U) = byte;
    __asm__ volatile("" ::: "memory");
    return crc;
}

static inline uint32_t crc32c_end(uint32_t crc)
{
    (void)crc;
    return *(volatile uint32_t *)(CRC32C_UNIT_ADDR);
}
#else
static inline uint32_t crc32c_begin(uint32_t crc)
{
    return crc;
}

static inline uint32_t crc32c_step(uint32_t crc, uint8_t byte)
{
    return crc32c_table_step(crc, byte);
}

static inline uint32_t crc32c_end(uint32_t crc)
{
    return crc;
}
#endif

/* Continue a CRC over n bytes: crc = crc32c_update(CRC32C_INIT, ...), ..., result = crc ^ ~0.
 * Always the table, never the unit: callable anywhere, even between a crc32c_begin and its end. */
uint32_t crc32c_update(uint32_t crc, const uint8_t *data, uint32_t n);
/* The CRC-32C of n bytes. */
uint32_t crc32c(const uint8_t *data, uint32_t n);

#endif /* BOWDEN_CRC32C_H */
