/*
 * soc.h - the memory map of bowden_soc (hdl/soc/bowden_soc.v) as the RV32 firmware sees it.
 *
 *   0x0000_0000  ROM: the image (code, read-only data, initial .data), from $readmemh
 *   0x1000_0000  RAM: .data, .bss, stack
 *   0x2000_0000  the tension loop's register map (bowden_regs.h: byte offsets from this base)
 *   0x3000_0000  UART, timer, SPI flash master, system words
 *
 * The RTL's copy of these addresses is hdl/soc/bowden_soc.v; tests/soc checks that the two agree.
 */
#ifndef BOWDEN_SOC_H
#define BOWDEN_SOC_H

#include <stdint.h>

#define SOC_ROM_BASE 0x00000000UL
#define SOC_RAM_BASE 0x10000000UL
#define SOC_REGS_BASE 0x20000000UL
#define SOC_IO_BASE 0x30000000UL

/* UART (8N1; the divider is fixed by the RTL's CLK_HZ and BAUD parameters). */
#define SOC_UART_DATA 0x00U   /* write: queue a byte; read: bit 8 = a byte was there, [7:0] it */
#define SOC_UART_STATUS 0x04U /* [0] TX FIFO full, [1] RX byte waiting, [2] RX overrun (sticky,
                                 write 1 to clear), [3] framing error seen (sticky, same),
                                 [31:16] bytes waiting in the TX FIFO */
#define SOC_UART_TX_DEPTH 512U /* the TX FIFO's bytes (bowden_soc.v UART_FIFO_AW 9) */
/* Timer: a free-running clock counter and a periodic tick count (the firmware's tick). */
#define SOC_TIMER_COUNT 0x10U  /* clocks since reset (wraps) */
#define SOC_TIMER_PERIOD 0x14U /* WO: the tick count goes up every PERIOD clocks (at most the
                                  clock in Hz); 0 stops it */
#define SOC_TIMER_TICKS 0x18U  /* [15:0] periods since reset (wraps; RO) */
/* SPI flash master (mode 0): the firmware drives chip select and sends/receives byte by byte. */
#define SOC_SPI_CS 0x20U   /* WO: [0] 1 = chip select asserted (pin low) */
#define SOC_SPI_DATA 0x24U /* write: send a byte (and receive one); read: bit 8 busy, [7:0] last byte
                              received */
/* System. */
#define SOC_SYS_CLK_HZ 0x30U /* the SoC's clock in Hz (RO) */
#define SOC_SYS_MARK 0x34U   /* WO: [7:0] the firmware's phase (the simulation probes it) */
#define SOC_SYS_CHANNELS 0x38U /* the cables the SoC drives (RO): register banks 0 .. n - 1 */
/* CRC-32C unit (soc_crc32c.v; crc32c.h's CRC32C_UNIT_ADDR, which the build sets to
 * SOC_IO_BASE + SOC_CRC_STATE): a byte written to DATA is taken in the next 8 clocks, and an
 * access meanwhile waits for it. */
#define SOC_CRC_STATE 0x40U /* the register (before the final XOR): write to begin or resume */
#define SOC_CRC_DATA 0x44U  /* WO: [7:0] the next byte */

/* Phases the firmware writes to SOC_SYS_MARK. */
#define SOC_MARK_BOOT 1U  /* start-up, before dev_init */
#define SOC_MARK_IDLE 2U  /* main loop, waiting */
#define SOC_MARK_TICK 3U  /* inside the tick (dev_tick) */
#define SOC_MARK_RX 4U    /* handling received bytes */

static inline uint32_t soc_io_read(uint32_t off)
{
    return *(volatile uint32_t *)(SOC_IO_BASE + off);
}

static inline void soc_io_write(uint32_t off, uint32_t v)
{
    *(volatile uint32_t *)(SOC_IO_BASE + off) = v;
}

#endif /* BOWDEN_SOC_H */
