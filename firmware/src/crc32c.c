/* crc32c.c - CRC-32C of crc32c.h, four bits at a time. */
#include "crc32c.h"

/* crc32c_nibble[i] = the reflected CRC of nibble i: i shifted through four rounds of
 * (c >> 1) ^ (0x82F63B78 if c & 1). */
static const uint32_t crc32c_nibble[16] = {
    0x00000000UL, 0x105EC76FUL, 0x20BD8EDEUL, 0x30E349B1UL, 0x417B1DBCUL, 0x5125DAD3UL,
    0x61C69362UL, 0x7198540DUL, 0x82F63B78UL, 0x92A8FC17UL, 0xA24BB5A6UL, 0xB21572C9UL,
    0xC38D26C4UL, 0xD3D3E1ABUL, 0xE330A81AUL, 0xF36E6F75UL,
};

uint32_t crc32c_update(uint32_t crc, const uint8_t *data, uint32_t n)
{
    for (uint32_t i = 0; i < n; ++i) {
        crc ^= data[i];
        crc = (crc >> 4) ^ crc32c_nibble[crc & 0xFU];
        crc = (crc >> 4) ^ crc32c_nibble[crc & 0xFU];
    }
    return crc;
}

uint32_t crc32c(const uint8_t *data, uint32_t n)
{
    return crc32c_update(CRC32C_INIT, data, n) ^ 0xFFFFFFFFUL;
}
