/*
 * dev_host.h - the bench device on the host (the emulator and the tests, through ctypes): the
 * firmware on the register shadow, the device (dev.h) and an emulated flash (flash_ram.h).
 * dev_host_boot is a power cycle: everything but the flash starts afresh.
 * With several channels each has its own firmware and register shadow (the shadow of its bank:
 * the addresses a channel's HAL takes are those of bank 0, as a HAL based at BOWDEN_REG_AT(k, 0)
 * gives them on a board).
 */
#ifndef BOWDEN_DEV_HOST_H
#define BOWDEN_DEV_HOST_H

#include <stdint.h>

#include "dev.h"
#include "flash_ram.h"
#include "fw.h"
#include "hal.h"

typedef struct {
    uint32_t channels; /* [1, BOWDEN_CHANNELS_MAX] */
    hal_t hal[BOWDEN_CHANNELS_MAX];
    hal_shadow_t shadow[BOWDEN_CHANNELS_MAX];
    fw_t fw[BOWDEN_CHANNELS_MAX];
    flash_hal_t flash_hal;
    flash_ram_t flash;
    dev_t dev;
} dev_host_t;

uint32_t dev_host_sizeof(void);
/* A device of one channel with a blank flash, booted. */
void dev_host_init(dev_host_t *h);
/* A device of n channels (clamped to [1, BOWDEN_CHANNELS_MAX]) with a blank flash, booted. */
void dev_host_init_channels(dev_host_t *h, uint32_t n);
/* The most channels this build holds (BOWDEN_CHANNELS_MAX). */
uint32_t dev_host_channels_max(void);
/* Power cycle: the shadow, the firmware and the device start afresh; the flash keeps its words. */
void dev_host_boot(dev_host_t *h);
/* Pose as another build (tests and `bowden emulate --table-hash`): HELLO reports these. */
void dev_host_set_identity(dev_host_t *h, uint32_t proto_version, uint32_t table_hash);

dev_t *dev_host_dev(dev_host_t *h);
flash_ram_t *dev_host_flash(dev_host_t *h);
hal_shadow_t *dev_host_shadow(dev_host_t *h);
/* Channel ch's register shadow (ch < channels; channel 0's for any other). */
hal_shadow_t *dev_host_shadow_channel(dev_host_t *h, uint32_t ch);
/* The flash's words (FLASH_SLOTS * FLASH_RAM_SLOT_WORDS), for saving and restoring an image. */
uint32_t *dev_host_flash_words(dev_host_t *h);
uint32_t dev_host_flash_n_words(void);

#endif /* BOWDEN_DEV_HOST_H */
