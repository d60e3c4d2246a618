/*
 * proto_can.h - the bench protocol on classic CAN 2.0A (firmware/proto/PROTOCOL.md): 11-bit id =
 * node << 5 | message, 8 data bytes. Byte 0 is the request id (seq). A message whose payload never
 * exceeds 7 bytes takes one frame [seq][payload]; a longer one (proto_msg_can_segmented) is sent
 * as segments [seq][index][6 bytes], the first segment's data starting with the payload length.
 * TELEMETRY goes as two frames, TELEM_A and TELEM_B, without seq. CAN has its own CRC-15 and
 * retransmission, so there is no CRC-32C; the protocol version is checked by HELLO.
 *
 * The receiver reassembles one segmented message at a time per port; a segment out of order, of
 * another message or seq while one is in progress, or a length beyond PROTO_MAX_PAYLOAD, drops
 * the message and counts a framing error.
 */
#ifndef BOWDEN_PROTO_CAN_H
#define BOWDEN_PROTO_CAN_H

#include <stdint.h>

#include "proto.h"

#define PROTO_CAN_SINGLE_MAX 7U /* payload bytes of a single frame */
#define PROTO_CAN_SEG_DATA 6U   /* payload bytes per segment */
/* Most frames one message takes: the largest payload plus its length byte, 6 bytes a frame. */
#define PROTO_CAN_MAX_FRAMES ((PROTO_MAX_PAYLOAD + 1U + PROTO_CAN_SEG_DATA - 1U) / PROTO_CAN_SEG_DATA)

typedef struct {
    uint32_t id;  /* 11-bit identifier */
    uint8_t len;  /* data length code, 0..8 */
    uint8_t data[8];
} proto_can_frame_t;

typedef struct {
    uint32_t active;   /* a segmented message is being reassembled */
    uint8_t msg;
    uint8_t seq;
    uint8_t next;      /* index of the next segment expected */
    uint8_t expected;  /* payload length announced by the first segment */
    uint32_t got;      /* payload bytes received */
    uint8_t buf[PROTO_MAX_PAYLOAD];
    proto_rx_stats_t stats; /* frames, framing_errors, short_frames (crc/overlong unused) */
} proto_can_rx_t;

void proto_can_rx_init(proto_can_rx_t *rx);

/* Feed one received CAN frame; frames for another node are ignored. Returns 1 when a message is
 * complete (written to *out, version PROTO_VERSION), 0 otherwise. */
int proto_can_rx(proto_can_rx_t *rx, uint32_t node, const proto_can_frame_t *cf,
                 proto_frame_t *out);

/* Split a message into CAN frames for `node`: returns how many were written to out, or 0 when
 * they do not fit cap (PROTO_CAN_MAX_FRAMES always suffices) or the payload is too long for the
 * message. TELEMETRY becomes TELEM_A + TELEM_B. */
uint32_t proto_can_encode(uint32_t node, const proto_frame_t *f, proto_can_frame_t *out,
                          uint32_t cap);

#endif /* BOWDEN_PROTO_CAN_H */
