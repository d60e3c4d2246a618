/* fuzz_proto.h - the fuzz harness of the serial decoder and the device (fuzz_proto.c). */
#ifndef BOWDEN_FUZZ_PROTO_H
#define BOWDEN_FUZZ_PROTO_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
    uint64_t bytes;
    uint64_t accepted;   /* frames the decoder accepted */
    uint64_t crc_checked; /* of which the harness recomputed the CRC independently: all */
    uint64_t rejected;   /* frames rejected (crc, framing, short, overlong) */
} fuzz_stats_t;

/* Feed bytes to a decoder and to a device (serial and CAN ports), checking the invariants; aborts
 * on a violation (an accepted frame whose CRC the harness's own bitwise CRC-32C refuses). */
void fuzz_feed(const uint8_t *data, size_t n);
/* The same without the device (the decoder alone). */
void fuzz_feed_decoder(const uint8_t *data, size_t n);
/* Reset the harness (a fresh device and decoder). */
void fuzz_reset(void);
const fuzz_stats_t *fuzz_stats(void);
/* The last frame the decoder accepted (version, msg, seq, len, payload). */
const void *fuzz_last_frame(void);

#endif /* BOWDEN_FUZZ_PROTO_H */
