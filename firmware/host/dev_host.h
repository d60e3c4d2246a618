/*
 * dev_host.h - the bench device on the host (the emulator and the tests, through ctypes): the
 * firmware on the register shadow, the device (dev.h) and an emulated flash (flash_ram.h).
 * dev_host_boot is a power cycle: everything but the flash starts afresh.
 */
#ifndef BOWDEN_DEV_HOST_H
#define BOWDEN_DEV_HOST_H

#include <stdint.h>

#include "dev.h"
#include "flash_ram.h"
#include "fw.h"
#include "hal.h"

typedef struct {
    hal_t hal;
    hal_shadow_t shadow;
    fw_t fw;
    flash_hal_t flash_hal;
    flash_ram_t flash;
    dev_t dev;
} dev_host_t;

uint32_t dev_host_sizeof(void);
/* A device with a blank flash, booted. */
void dev_host_init(dev_host_t *h);
/* Power cycle: the shadow, the firmware and the device start afresh; the flash keeps its words. */
void dev_host_boot(dev_host_t *h);
/* Pose as another build (tests and `bowden emulate --table-hash`): HELLO reports these. */
void dev_host_set_identity(dev_host_t *h, uint32_t proto_version, uint32_t table_hash);

dev_t *dev_host_dev(dev_host_t *h);
flash_ram_t *dev_host_flash(dev_host_t *h);
hal_shadow_t *dev_host_shadow(dev_host_t *h);
/* The flash's words (FLASH_SLOTS * FLASH_RAM_SLOT_WORDS), for saving and restoring an image. */
uint32_t *dev_host_flash_words(dev_host_t *h);
uint32_t dev_host_flash_n_words(void);

#endif /* BOWDEN_DEV_HOST_H */
