/*
 * params.h - generic read and write of the settings (settings.h) by parameter id: the table
 * params_table, generated from settings_t by firmware/proto/gen_proto.py into params_table.c, has
 * one entry per 32-bit word. A write is checked with the whole configuration (settings_check) on
 * a copy, so a rejected value changes nothing.
 */
#ifndef BOWDEN_PARAMS_H
#define BOWDEN_PARAMS_H

#include <stdint.h>

#include "proto_msgs.h"
#include "settings.h"

/* One entry per word of settings_t, in id order (params_table.c, generated). */
extern const proto_param_t params_table[PROTO_N_PARAMS];

/* The word of parameter `id` into *word: 0, or PROTO_ERR_UNKNOWN_PARAM. */
int32_t params_get(const settings_t *s, uint32_t id, int32_t *word);

/* Write parameter `id`: 0, PROTO_ERR_UNKNOWN_PARAM, PROTO_ERR_READ_ONLY, or
 * PROTO_ERR_INVALID_VALUE with the settings' status code (settings_strerror) in *status. */
int32_t params_set(settings_t *s, uint32_t id, int32_t word, int32_t *status);

/* Store a word at a parameter's offset without any check (flash_load checks the whole). */
void params_word_write(settings_t *s, uint32_t offset, int32_t word);

/* 1 when parameter `id` is one of the device's own settings (dev.*: one value for every
 * channel, held in channel 0's settings_t), 0 when each channel has its own (or id is unknown). */
int params_is_device(uint32_t id);

/* The key of parameter `id` for channel `ch` in a flash record: its name's CRC-32C for channel
 * 0 and a device-wide parameter, else that key XOR ch * 0x9E3779B9 (the 32-bit golden ratio,
 * which spreads the channels' keys; a test holds them distinct from every other key). */
uint32_t params_channel_key(uint32_t id, uint32_t ch);

/* The id of the parameter whose name has CRC-32C `key`, or -1. */
int32_t params_find(uint32_t key);

#endif /* BOWDEN_PARAMS_H */
