/* flash_ram.c - the emulated flash of flash_ram.h. */
#include "flash_ram.h"

/* One word operation; 0 when the power is already gone. */
static int alive(flash_ram_t *r)
{
    if (r->dead != 0U) {
        return 0;
    }
    if (r->cut_after == 0) {
        r->dead = 1U;
        return 0;
    }
    if (r->cut_after > 0) {
        --r->cut_after;
    }
    ++r->ops;
    return 1;
}

static int ram_erase(void *ctx, uint32_t slot)
{
    flash_ram_t *r = (flash_ram_t *)ctx;
    if (slot >= FLASH_SLOTS) {
        return -1;
    }
    for (uint32_t i = 0; i < FLASH_RAM_SLOT_WORDS; ++i) {
        if (!alive(r)) {
            return -1;
        }
        r->words[slot][i] = 0xFFFFFFFFUL;
    }
    return 0;
}

static int ram_program(void *ctx, uint32_t slot, uint32_t word, const uint32_t *src, uint32_t n)
{
    flash_ram_t *r = (flash_ram_t *)ctx;
    if (slot >= FLASH_SLOTS || word > FLASH_RAM_SLOT_WORDS || n > FLASH_RAM_SLOT_WORDS - word) {
        return -1;
    }
    for (uint32_t i = 0; i < n; ++i) {
        if (!alive(r)) {
            return -1;
        }
        r->words[slot][word + i] &= src[i]; /* NOR: programming only clears bits */
    }
    return 0;
}

static int ram_read(void *ctx, uint32_t slot, uint32_t word, uint32_t *dst, uint32_t n)
{
    flash_ram_t *r = (flash_ram_t *)ctx;
    if (slot >= FLASH_SLOTS || word > FLASH_RAM_SLOT_WORDS || n > FLASH_RAM_SLOT_WORDS - word) {
        return -1;
    }
    for (uint32_t i = 0; i < n; ++i) {
        dst[i] = r->words[slot][word + i];
    }
    return 0;
}

void flash_ram_init(flash_hal_t *hal, flash_ram_t *ram)
{
    for (uint32_t s = 0; s < FLASH_SLOTS; ++s) {
        for (uint32_t i = 0; i < FLASH_RAM_SLOT_WORDS; ++i) {
            ram->words[s][i] = 0xFFFFFFFFUL;
        }
    }
    ram->cut_after = -1;
    ram->ops = 0U;
    ram->dead = 0U;
    hal->erase = ram_erase;
    hal->program = ram_program;
    hal->read = ram_read;
    hal->ctx = ram;
    hal->slot_words = FLASH_RAM_SLOT_WORDS;
}

void flash_ram_cut_after(flash_ram_t *ram, int32_t ops)
{
    ram->cut_after = ops;
}

void flash_ram_power_on(flash_ram_t *ram)
{
    ram->dead = 0U;
    ram->cut_after = -1;
}
