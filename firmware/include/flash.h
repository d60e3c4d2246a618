/*
 * flash.h - the device's settings in flash: two records, each with a sequence number and a
 * CRC-32C, written alternately, so that a power cut in the middle of a write (erase or program)
 * leaves the other record intact and loadable.
 *
 * Record (32-bit words, in one slot = one erasable sector):
 *   [0] magic FLASH_MAGIC, [1] sequence number, [2] n pairs,
 *   [3 .. 3 + 2n) pairs (parameter key = CRC-32C of its name, 32-bit word),
 *   [3 + 2n] CRC-32C of the words before it (little-endian bytes).
 * Keys rather than parameter ids: a firmware update that adds, removes or reorders parameters
 * keeps every saved value whose name it still knows (unknown keys are skipped, new parameters
 * keep their defaults), and the loaded settings are checked as a whole before they are used.
 *
 * A device of several channels writes channel 0's pairs (and the device's own settings, dev.*)
 * as one channel does, then each further channel's own parameters under its channel key
 * (params_channel_key): a one-channel record is the record of before, a firmware of fewer
 * channels skips the keys of the channels it lacks, and one of more keeps the defaults on the
 * channels the record lacks.
 *
 * Store: erase and write the slot that does not hold the newest valid record, with sequence
 * number newest + 1, then read it back. Load: the valid record with the highest sequence number
 * (serial-number arithmetic) whose settings pass the check, else the other one.
 */
#ifndef BOWDEN_FLASH_H
#define BOWDEN_FLASH_H

#include <stdint.h>

#include "settings.h"

#define FLASH_MAGIC 0x46435742UL /* "BWCF" little-endian */
#define FLASH_SLOTS 2U
#define FLASH_HEADER_WORDS 3U

#define FLASH_OK 0
#define FLASH_ERR_EMPTY 1   /* no valid record */
#define FLASH_ERR_INVALID 2 /* valid records, but their settings fail the check */
#define FLASH_ERR_WRITE 3   /* erase, program or read-back failed */
#define FLASH_ERR_SIZE 4    /* a record does not fit the slot */

/* The board's flash: erase a slot (all words to 0xFFFFFFFF), program words (NOR: bits can only be
 * cleared), read words. Each returns 0 on success. */
typedef struct {
    int (*erase)(void *ctx, uint32_t slot);
    int (*program)(void *ctx, uint32_t slot, uint32_t word, const uint32_t *src, uint32_t n);
    int (*read)(void *ctx, uint32_t slot, uint32_t word, uint32_t *dst, uint32_t n);
    void *ctx;
    uint32_t slot_words; /* capacity of a slot in words */
} flash_hal_t;

/* Write the settings (every parameter of the generated table) as the next record. Returns
 * FLASH_OK and the record's sequence number in *seq, or FLASH_ERR_*. */
int32_t flash_store(const flash_hal_t *f, const settings_t *settings, uint32_t *seq);

/* Load the newest valid record onto *settings (which holds the defaults: parameters absent from
 * the record keep them) if the result passes settings_check; FLASH_OK and *seq, or
 * FLASH_ERR_EMPTY / FLASH_ERR_INVALID with *settings unchanged. */
int32_t flash_load(const flash_hal_t *f, settings_t *settings, uint32_t *seq);

/* flash_store and flash_load for n channels (settings[0 .. n), 1 <= n <= BOWDEN_CHANNELS_MAX;
 * every channel checked, none changed on an error). A bad n is FLASH_ERR_SIZE. */
int32_t flash_store_channels(const flash_hal_t *f, const settings_t *settings, uint32_t n,
                             uint32_t *seq);
int32_t flash_load_channels(const flash_hal_t *f, settings_t *settings, uint32_t n, uint32_t *seq);

#endif /* BOWDEN_FLASH_H */
