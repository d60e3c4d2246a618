/* spi_flash.c - flash.h's flash on the SPI NOR flash; see spi_flash.h. */
#include "spi_flash.h"

#include "soc.h"

static uint8_t spi_xfer(uint8_t b)
{
    soc_io_write(SOC_SPI_DATA, b);
    uint32_t v;
    do {
        v = soc_io_read(SOC_SPI_DATA);
    } while ((v & 0x100U) != 0U);
    return (uint8_t)v;
}

static void spi_select(uint32_t on)
{
    soc_io_write(SOC_SPI_CS, on);
}

static void cmd_addr(uint8_t cmd, uint32_t addr)
{
    spi_select(1U);
    (void)spi_xfer(cmd);
    (void)spi_xfer((uint8_t)(addr >> 16));
    (void)spi_xfer((uint8_t)(addr >> 8));
    (void)spi_xfer((uint8_t)addr);
}

static void cmd_only(uint8_t cmd)
{
    spi_select(1U);
    (void)spi_xfer(cmd);
    spi_select(0U);
}

/* Wait until the flash is not busy, at most max_ms; 0 when it became ready. */
static int wait_ready(uint32_t max_ms)
{
    uint32_t clk_hz = soc_io_read(SOC_SYS_CLK_HZ);
    uint32_t limit = max_ms * (clk_hz / 1000U);
    uint32_t t0 = soc_io_read(SOC_TIMER_COUNT);
    for (;;) {
        spi_select(1U);
        (void)spi_xfer(0x05U);
        uint8_t status = spi_xfer(0x00U);
        spi_select(0U);
        if ((status & 0x01U) == 0U) {
            return 0;
        }
        if (soc_io_read(SOC_TIMER_COUNT) - t0 > limit) {
            return -1;
        }
    }
}

static uint32_t slot_addr(uint32_t slot, uint32_t word)
{
    return SPI_FLASH_SETTINGS_ADDR + slot * SPI_FLASH_SECTOR_BYTES + 4U * word;
}

static int flash_erase(void *ctx, uint32_t slot)
{
    (void)ctx;
    if (slot >= FLASH_SLOTS) {
        return -1;
    }
    cmd_only(0x06U);
    cmd_addr(0x20U, slot_addr(slot, 0U));
    spi_select(0U);
    return wait_ready(SPI_FLASH_ERASE_MAX_MS);
}

static int flash_program(void *ctx, uint32_t slot, uint32_t word, const uint32_t *src, uint32_t n)
{
    (void)ctx;
    if (slot >= FLASH_SLOTS || word + n > SPI_FLASH_SECTOR_BYTES / 4U) {
        return -1;
    }
    uint32_t addr = slot_addr(slot, word);
    uint32_t i = 0U;
    while (i < n) {
        /* One page program per 256-byte page: words up to the page's end. */
        uint32_t room = (SPI_FLASH_PAGE_BYTES - (addr & (SPI_FLASH_PAGE_BYTES - 1U))) / 4U;
        uint32_t chunk = (n - i < room) ? n - i : room;
        cmd_only(0x06U);
        cmd_addr(0x02U, addr);
        for (uint32_t k = 0U; k < chunk; ++k) {
            uint32_t w = src[i + k];
            (void)spi_xfer((uint8_t)w); /* little-endian, as flash.h's CRC reads the words */
            (void)spi_xfer((uint8_t)(w >> 8));
            (void)spi_xfer((uint8_t)(w >> 16));
            (void)spi_xfer((uint8_t)(w >> 24));
        }
        spi_select(0U);
        if (wait_ready(SPI_FLASH_PROGRAM_MAX_MS) != 0) {
            return -1;
        }
        i += chunk;
        addr += 4U * chunk;
    }
    return 0;
}

static int flash_read(void *ctx, uint32_t slot, uint32_t word, uint32_t *dst, uint32_t n)
{
    (void)ctx;
    if (slot >= FLASH_SLOTS || word + n > SPI_FLASH_SECTOR_BYTES / 4U) {
        return -1;
    }
    cmd_addr(0x03U, slot_addr(slot, word));
    for (uint32_t k = 0U; k < n; ++k) {
        uint32_t w = spi_xfer(0U);
        w |= (uint32_t)spi_xfer(0U) << 8;
        w |= (uint32_t)spi_xfer(0U) << 16;
        w |= (uint32_t)spi_xfer(0U) << 24;
        dst[k] = w;
    }
    spi_select(0U);
    return 0;
}

void spi_flash_init(flash_hal_t *f)
{
    spi_select(0U);
    cmd_only(0xABU); /* release from power-down (the FPGA may leave the flash asleep) */
    f->erase = flash_erase;
    f->program = flash_program;
    f->read = flash_read;
    f->ctx = 0;
    f->slot_words = SPI_FLASH_SECTOR_BYTES / 4U;
}
