/* proto_can.c - the CAN mapping of proto_can.h. */
#include "proto_can.h"

#define CAN_MSG_MASK ((1U << PROTO_CAN_MESSAGE_BITS) - 1U)
#define CAN_NODE_MASK ((1U << PROTO_CAN_NODE_BITS) - 1U)

void proto_can_rx_init(proto_can_rx_t *rx)
{
    rx->active = 0U;
    rx->got = 0U;
    rx->stats = (proto_rx_stats_t){0};
}

static uint32_t can_id(uint32_t node, uint32_t msg)
{
    return ((node & CAN_NODE_MASK) << PROTO_CAN_MESSAGE_BITS) | (msg & CAN_MSG_MASK);
}

int proto_can_rx(proto_can_rx_t *rx, uint32_t node, const proto_can_frame_t *cf,
                 proto_frame_t *out)
{
    if ((cf->id >> PROTO_CAN_MESSAGE_BITS) != (node & CAN_NODE_MASK) || cf->len > 8U) {
        return 0;
    }
    uint8_t msg = (uint8_t)(cf->id & CAN_MSG_MASK);
    if (cf->len < 1U) {
        ++rx->stats.short_frames;
        return 0;
    }
    if (!proto_msg_can_segmented(msg)) {
        out->version = (uint8_t)PROTO_VERSION;
        out->msg = msg;
        out->seq = cf->data[0];
        out->len = (uint8_t)(cf->len - 1U);
        for (uint32_t i = 0; i < out->len; ++i) {
            out->payload[i] = cf->data[1U + i];
        }
        ++rx->stats.frames;
        return 1;
    }
    if (cf->len < 2U) {
        ++rx->stats.short_frames;
        return 0;
    }
    uint8_t seq = cf->data[0];
    uint8_t index = cf->data[1];
    uint32_t first = 2U;
    if (index == 0U) {
        if (rx->active != 0U) { /* the previous message never completed */
            ++rx->stats.framing_errors;
        }
        if (cf->len < 3U || cf->data[2] > PROTO_MAX_PAYLOAD) {
            ++rx->stats.framing_errors;
            rx->active = 0U;
            return 0;
        }
        rx->active = 1U;
        rx->msg = msg;
        rx->seq = seq;
        rx->next = 0U;
        rx->expected = cf->data[2];
        rx->got = 0U;
        first = 3U;
    } else if (rx->active == 0U || msg != rx->msg || seq != rx->seq || index != rx->next) {
        ++rx->stats.framing_errors;
        rx->active = 0U;
        return 0;
    }
    for (uint32_t i = first; i < cf->len; ++i) {
        if (rx->got >= rx->expected) { /* more data than announced */
            ++rx->stats.framing_errors;
            rx->active = 0U;
            return 0;
        }
        rx->buf[rx->got++] = cf->data[i];
    }
    rx->next = (uint8_t)(index + 1U);
    if (rx->got < rx->expected) {
        return 0;
    }
    rx->active = 0U;
    out->version = (uint8_t)PROTO_VERSION;
    out->msg = rx->msg;
    out->seq = rx->seq;
    out->len = rx->expected;
    for (uint32_t i = 0; i < rx->got; ++i) {
        out->payload[i] = rx->buf[i];
    }
    ++rx->stats.frames;
    return 1;
}

static uint32_t encode_telemetry(uint32_t node, const proto_frame_t *f, proto_can_frame_t *out,
                                 uint32_t cap)
{
    proto_telemetry_t t;
    if (cap < 2U || !proto_telemetry_unpack(&t, f->payload, f->len)) {
        return 0U;
    }
    proto_telem_a_t a = {(uint16_t)t.sample, t.channel, t.t_ref, t.t_c};
    proto_telem_b_t b = {(uint8_t)t.sample, t.t_in, t.t_out, t.current, t.faults};
    out[0].id = can_id(node, PROTO_MSG_TELEM_A);
    out[0].len = (uint8_t)proto_telem_a_pack(&a, out[0].data);
    out[1].id = can_id(node, PROTO_MSG_TELEM_B);
    out[1].len = (uint8_t)proto_telem_b_pack(&b, out[1].data);
    return 2U;
}

uint32_t proto_can_encode(uint32_t node, const proto_frame_t *f, proto_can_frame_t *out,
                          uint32_t cap)
{
    if (f->msg == PROTO_MSG_TELEMETRY) {
        return encode_telemetry(node, f, out, cap);
    }
    uint32_t id = can_id(node, f->msg);
    if (!proto_msg_can_segmented(f->msg)) {
        if (f->len > PROTO_CAN_SINGLE_MAX || cap < 1U) {
            return 0U;
        }
        out[0].id = id;
        out[0].len = (uint8_t)(1U + f->len);
        out[0].data[0] = f->seq;
        for (uint32_t i = 0; i < f->len; ++i) {
            out[0].data[1U + i] = f->payload[i];
        }
        return 1U;
    }
    if (f->len > PROTO_MAX_PAYLOAD) {
        return 0U;
    }
    /* The length byte, then the payload, 6 bytes a frame. */
    uint32_t total = 1U + f->len;
    uint32_t frames = (total + PROTO_CAN_SEG_DATA - 1U) / PROTO_CAN_SEG_DATA;
    if (cap < frames) {
        return 0U;
    }
    for (uint32_t k = 0; k < frames; ++k) {
        proto_can_frame_t *c = &out[k];
        c->id = id;
        c->data[0] = f->seq;
        c->data[1] = (uint8_t)k;
        uint32_t n = 2U;
        for (uint32_t j = k * PROTO_CAN_SEG_DATA; j < total && j < (k + 1U) * PROTO_CAN_SEG_DATA;
             ++j) {
            c->data[n++] = (j == 0U) ? f->len : f->payload[j - 1U];
        }
        c->len = (uint8_t)n;
    }
    return frames;
}
