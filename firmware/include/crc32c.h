/*
 * crc32c.h - CRC-32C (Castagnoli; iSCSI, RFC 3720): reflected polynomial 0x82F63B78, initial value
 * and final XOR 0xFFFFFFFF. Check value: crc32c("123456789") = 0xE3069283.
 * A 256-entry table (1 KiB of flash) and one look-up per byte: every frame sent or received runs
 * through it, and on the soft CPU the telemetry frame's CRC was a fifth of the tick (measured
 * with a 16-entry table and two look-ups per byte).
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

/* Continue a CRC over one byte (for a loop that does more with each byte, as the frame encoder
 * does). */
static inline uint32_t crc32c_step(uint32_t crc, uint8_t byte)
{
    return (crc >> 8) ^ crc32c_table[(crc ^ byte) & 0xFFU];
}

/* Continue a CRC over n bytes: crc = crc32c_update(CRC32C_INIT, ...), ..., result = crc ^ ~0. */
uint32_t crc32c_update(uint32_t crc, const uint8_t *data, uint32_t n);
/* The CRC-32C of n bytes. */
uint32_t crc32c(const uint8_t *data, uint32_t n);

#endif /* BOWDEN_CRC32C_H */
