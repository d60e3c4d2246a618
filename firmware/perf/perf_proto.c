/*
 * perf_proto.c - driver for the instruction counts of the bench protocol under callgrind
 * (cosim/perf/rig.py collects inside perf_run only):
 *   perf_proto decode N   decode N telemetry frames, byte by byte (proto_rx_byte)
 *   perf_proto encode N   pack and encode N telemetry frames (proto_telemetry_pack, proto_encode)
 * Instructions per frame = callgrind's total / N.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "proto.h"

#define FRAMES_IN_BUFFER 64U

static uint8_t wire[FRAMES_IN_BUFFER][PROTO_MAX_WIRE];
static uint32_t wire_len[FRAMES_IN_BUFFER];
volatile uint32_t sink;

static void make_frame(uint32_t i, proto_frame_t *f)
{
    proto_telemetry_t t = {i * 1000U, i, 0U, (int16_t)(i * 37U), (int16_t)(i * 41U),
                           (int16_t)(i * 43U), (int16_t)(i * 47U), (int16_t)(i * 3U), 0U, 0x23U,
                           (uint16_t)(i * 5U), 0U, 0U};
    f->version = (uint8_t)PROTO_VERSION;
    f->msg = PROTO_MSG_TELEMETRY;
    f->seq = 0U;
    f->len = (uint8_t)proto_telemetry_pack(&t, f->payload);
}

/* The measured work: N frames decoded or encoded. noinline so that callgrind can toggle on it. */
__attribute__((noinline)) void perf_run(int decode, uint32_t n);
__attribute__((noinline)) void perf_run(int decode, uint32_t n)
{
    if (decode) {
        proto_rx_t rx;
        proto_rx_init(&rx);
        proto_frame_t f;
        for (uint32_t i = 0; i < n; ++i) {
            const uint8_t *w = wire[i % FRAMES_IN_BUFFER];
            uint32_t m = wire_len[i % FRAMES_IN_BUFFER];
            for (uint32_t k = 0; k < m; ++k) {
                sink += (uint32_t)proto_rx_byte(&rx, w[k], &f);
            }
        }
    } else {
        uint8_t out[PROTO_MAX_WIRE];
        proto_frame_t f;
        for (uint32_t i = 0; i < n; ++i) {
            make_frame(i, &f);
            sink += proto_encode(&f, out, sizeof out);
        }
    }
}

int main(int argc, char **argv)
{
    if (argc != 3 || (strcmp(argv[1], "decode") != 0 && strcmp(argv[1], "encode") != 0)) {
        fprintf(stderr, "usage: perf_proto decode|encode N\n");
        return 2;
    }
    uint32_t n = (uint32_t)strtoul(argv[2], NULL, 10);
    for (uint32_t i = 0; i < FRAMES_IN_BUFFER; ++i) {
        proto_frame_t f;
        make_frame(i, &f);
        wire_len[i] = proto_encode(&f, wire[i], PROTO_MAX_WIRE);
    }
    perf_run(strcmp(argv[1], "decode") == 0, n);
    printf("%s %u frames, sink %u\n", argv[1], n, sink);
    return 0;
}
