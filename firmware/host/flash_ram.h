/*
 * flash_ram.h - an emulated flash for the host (the emulator, the unit tests and the fuzzer): two
 * slots of NOR flash in RAM (erase sets words to 0xFFFFFFFF, programming can only clear bits),
 * with a power cut that can be armed after any number of word operations: from then on every
 * erase and program does nothing, as if the supply had dropped, until flash_ram_power_on.
 * Erase works word by word, so a cut in the middle of an erase leaves a half-erased slot.
 */
#ifndef BOWDEN_FLASH_RAM_H
#define BOWDEN_FLASH_RAM_H

#include <stdint.h>

#include "flash.h"

/* A 4-KiB sector, as the SoC's SPI flash: room for a record of 4 channels (about 460 words). */
#define FLASH_RAM_SLOT_WORDS 1024U

typedef struct {
    uint32_t words[FLASH_SLOTS][FLASH_RAM_SLOT_WORDS];
    int32_t cut_after; /* word operations left before the power cut; -1: no cut armed */
    uint32_t ops;      /* word operations done (erased or programmed words) */
    uint32_t dead;     /* 1 after the cut */
} flash_ram_t;

/* A blank flash (every word erased) behind `hal`. */
void flash_ram_init(flash_hal_t *hal, flash_ram_t *ram);
/* Cut the power after `ops` further word operations (-1: never). */
void flash_ram_cut_after(flash_ram_t *ram, int32_t ops);
/* Power back: operations work again (the contents are what the cut left). */
void flash_ram_power_on(flash_ram_t *ram);

#endif /* BOWDEN_FLASH_RAM_H */
