/*
 * spi_flash.h - the settings store's flash (flash.h) on the board's SPI NOR flash, through the
 * SoC's SPI master (soc.h). Commands of the common 25-series NOR flash (the iCEBreaker's W25Q128JV,
 * the ULX3S's IS25LP128; Winbond W25Q128JV data sheet, sec. 8): 0x03 read, 0x06 write enable,
 * 0x20 4-KiB sector erase, 0x02 page program (256-byte pages), 0x05 status (bit 0 busy),
 * 0xAB release from power-down.
 *
 * The two settings slots are two 4-KiB sectors at SPI_FLASH_SETTINGS_ADDR, clear of the bitstream
 * (the UP5K's is 104 KiB, the LFE5U-25F's under 1 MiB) at the flash's first megabyte.
 */
#ifndef BOWDEN_SPI_FLASH_H
#define BOWDEN_SPI_FLASH_H

#include <stdint.h>

#include "flash.h"

#define SPI_FLASH_SETTINGS_ADDR 0x100000UL
#define SPI_FLASH_SECTOR_BYTES 4096UL
#define SPI_FLASH_PAGE_BYTES 256UL
/* Time limits of a busy flash, clocks of the SoC (data sheet maxima: sector erase 400 ms, page
 * program 3 ms), so that a dead flash returns an error instead of hanging the device. */
#define SPI_FLASH_ERASE_MAX_MS 500UL
#define SPI_FLASH_PROGRAM_MAX_MS 5UL

/* Bind flash_hal_t to the SPI flash (wakes the flash from power-down). */
void spi_flash_init(flash_hal_t *f);

#endif /* BOWDEN_SPI_FLASH_H */
