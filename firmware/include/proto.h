/*
 * proto.h - the bench protocol's serial framing (firmware/proto/PROTOCOL.md): a frame is
 *   [version u8][message u8][seq u8][payload 0..PROTO_MAX_PAYLOAD][CRC-32C u32 LE]
 * COBS-encoded (Cheshire & Baker, IEEE/ACM ToN 1999) and sent between two 0x00 delimiters.
 *
 * The receiver is a byte-at-a-time state machine with one fixed buffer: no allocation, constant
 * work per byte, and every byte sequence ends in a valid frame, a counted rejection or more
 * waiting. It resynchronises at the next 0x00 whatever came before: garbage, a frame cut short,
 * an overlong run (dropped up to the next delimiter), a COBS code pointing past the frame end, a
 * frame shorter than header + CRC, or a CRC mismatch. Nothing is accepted whose CRC fails.
 */
#ifndef BOWDEN_PROTO_H
#define BOWDEN_PROTO_H

#include <stdint.h>

#include "proto_msgs.h"

#define PROTO_HEADER_LEN 3U
#define PROTO_CRC_LEN 4U
/* Largest unencoded frame; COBS adds one code byte per 254 data bytes and one at the start. */
#define PROTO_MAX_RAW (PROTO_HEADER_LEN + PROTO_MAX_PAYLOAD + PROTO_CRC_LEN)
#define PROTO_MAX_COBS (PROTO_MAX_RAW + PROTO_MAX_RAW / 254U + 1U)
/* Largest frame on the wire, both delimiters included. */
#define PROTO_MAX_WIRE (PROTO_MAX_COBS + 2U)

/* A decoded frame (or one to send). */
typedef struct {
    uint8_t version; /* the frame's version byte (PROTO_VERSION when this side sends it) */
    uint8_t msg;     /* message id (PROTO_MSG_*) */
    uint8_t seq;     /* request id, echoed by the reply; 0 for device-initiated frames */
    uint8_t len;     /* payload bytes */
    uint8_t payload[PROTO_MAX_PAYLOAD];
} proto_frame_t;

/* Receive counters (the dispatcher adds version and message errors). */
typedef struct {
    uint32_t frames;         /* accepted: CRC good */
    uint32_t crc_errors;     /* CRC mismatch */
    uint32_t framing_errors; /* COBS code pointing past the end of the frame */
    uint32_t overlong;       /* more than PROTO_MAX_COBS bytes before a delimiter */
    uint32_t short_frames;   /* fewer than header + CRC bytes */
} proto_rx_stats_t;

/* The receiver decodes COBS as the bytes arrive, with the CRC register run over the decoded
 * bytes, so a frame is complete and checked at its delimiter without a second pass. */
typedef struct {
    proto_rx_stats_t stats; /* first: a reader through an FFI finds it at offset 0 */
    uint32_t len;     /* encoded bytes of the frame received so far */
    uint32_t discard; /* 1: overlong, dropping bytes up to the next delimiter */
    uint32_t code;    /* the current COBS block's code byte (0 before the first) */
    uint32_t left;    /* data bytes still to come in the current block */
    uint32_t n;       /* decoded bytes in raw */
    uint32_t crc;     /* CRC-32C register over raw */
    uint8_t raw_pad;  /* unused: puts a frame's payload (raw[3] on) at a word boundary */
    uint8_t raw[PROTO_MAX_RAW]; /* the frame decoded so far */
} proto_rx_t;

void proto_rx_init(proto_rx_t *rx);

/* Feed one received byte. Returns 1 when it completed a frame whose CRC is good (written to
 * *out), 0 otherwise. */
int proto_rx_byte(proto_rx_t *rx, uint8_t byte, proto_frame_t *out);
/* Feed up to n received bytes, as many calls of proto_rx_byte: stops after the delimiter that
 * completed a good frame (written to *out, *got = 1; else *got = 0). Returns the bytes used. */
uint32_t proto_rx_bytes(proto_rx_t *rx, const uint8_t *data, uint32_t n, proto_frame_t *out,
                        int *got);

/* Encode a frame for the wire: 0x00, COBS(header + payload + CRC), 0x00. Returns the bytes
 * written to out, or 0 when f->len exceeds PROTO_MAX_PAYLOAD or cap < the encoded size
 * (PROTO_MAX_WIRE always suffices). */
uint32_t proto_encode(const proto_frame_t *f, uint8_t *out, uint32_t cap);
/* proto_encode's bytes for a frame whose raw bytes are already in the output: the header (version,
 * msg, seq) at out[2] and its len payload bytes after it; the delimiters, the code bytes and the
 * CRC are written around and among them (out must hold the frame's wire length, proto_wire_len).
 * Returns that length, or 0 when len exceeds PROTO_MAX_PAYLOAD. A frame packed straight into a
 * transmit buffer is encoded without being copied (the soft CPU's telemetry, dev.c). */
uint32_t proto_encode_in_place(uint8_t *out, uint32_t len);
/* The bytes proto_encode writes for f, or 0 when f->len exceeds PROTO_MAX_PAYLOAD. */
uint32_t proto_wire_len(const proto_frame_t *f);

/* COBS of n bytes without delimiter; out needs n + n/254 + 1 bytes. Returns the length. */
uint32_t proto_cobs_encode(const uint8_t *in, uint32_t n, uint8_t *out);
/* Inverse of proto_cobs_encode for n bytes without delimiter; returns the decoded length, or -1
 * for a zero byte, a code pointing past the end, or more than cap decoded bytes. */
int32_t proto_cobs_decode(const uint8_t *in, uint32_t n, uint8_t *out, uint32_t cap);

#endif /* BOWDEN_PROTO_H */
