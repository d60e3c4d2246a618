/*
 * params.h - generic read and write of the device's settings by parameter id (the generated
 * table proto_params: one entry per 32-bit word of dev_settings_t). A write is checked with the
 * whole configuration (dev_settings_check) on a copy, so a rejected value changes nothing.
 */
#ifndef BOWDEN_PARAMS_H
#define BOWDEN_PARAMS_H

#include <stdint.h>

#include "dev.h"

/* The word of parameter `id` into *word: 0, or PROTO_ERR_UNKNOWN_PARAM. */
int32_t params_get(const dev_settings_t *s, uint32_t id, int32_t *word);

/* Write parameter `id`: 0, PROTO_ERR_UNKNOWN_PARAM, PROTO_ERR_READ_ONLY, or
 * PROTO_ERR_INVALID_VALUE with the firmware's status code (dev_strerror) in *status. */
int32_t params_set(dev_settings_t *s, uint32_t id, int32_t word, int32_t *status);

/* Store a word at a parameter's offset without any check (flash_load checks the whole). */
void params_word_write(dev_settings_t *s, uint32_t offset, int32_t word);

/* The id of the parameter whose name has CRC-32C `key`, or -1. */
int32_t params_find(uint32_t key);

#endif /* BOWDEN_PARAMS_H */
