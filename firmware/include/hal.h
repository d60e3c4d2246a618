/*
 * hal.h - register access to the FPGA's tension loop (register map: bowden_regs.h, generated).
 *
 * One interface, three back ends:
 *  - MMIO: the registers are memory-mapped (an FPGA SoC, or an MCU with an external bus);
 *    addresses in bowden_regs.h are byte offsets from the base.
 *  - transport: a pair of functions supplied by the board code (for example the SPI bridge of the
 *    RTL, which carries one 32-bit register read or write per frame).
 *  - shadow (host, for the co-simulation): reads come from a register shadow that the host fills
 *    with the values it read from the RTL; every write updates the shadow and is appended to a
 *    write log that the host drains and replays on the RTL over AXI4-Lite.
 * Register words are 32 bits; signed fields (TC, T_IN, U) are sign-extended
 * (hdl/README.md, Register map).
 */
#ifndef BOWDEN_HAL_H
#define BOWDEN_HAL_H

#include <stdint.h>

typedef uint32_t (*hal_read_fn)(void *ctx, uint32_t addr);
typedef void (*hal_write_fn)(void *ctx, uint32_t addr, uint32_t value);

typedef struct {
    hal_read_fn read;
    hal_write_fn write;
    void *ctx;
} hal_t;

/* The shadow covers byte addresses [0, HAL_SHADOW_WORDS * 4): the whole register window. */
#define HAL_SHADOW_WORDS 64U
/* Writes held until the host drains them; a tick writes one (TC), start-up about fifteen. */
#define HAL_LOG_CAPACITY 64U

typedef struct {
    uint32_t addr;
    uint32_t value;
} hal_write_t;

typedef struct {
    uint32_t regs[HAL_SHADOW_WORDS];
    hal_write_t log[HAL_LOG_CAPACITY];
    uint32_t log_len;     /* writes in the log */
    uint32_t log_dropped; /* writes lost because the log was full (the host drained too late) */
    uint32_t bad_access;  /* accesses outside the window or not 4-byte aligned (ignored) */
} hal_shadow_t;

/* Memory-mapped registers at `base`. */
void hal_init_mmio(hal_t *h, volatile uint32_t *base);

/* Registers behind a transport (SPI bridge, ...): the board code supplies read and write. */
void hal_init_transport(hal_t *h, hal_read_fn read, hal_write_fn write, void *ctx);

/* Host register shadow with write log; clears the shadow and the log. */
void hal_init_shadow(hal_t *h, hal_shadow_t *shadow);

/* Set a shadow register without logging it (the host mirrors what it read from the RTL). */
void hal_shadow_set(hal_shadow_t *shadow, uint32_t addr, uint32_t value);

/* Copy up to `max` logged writes, oldest first, into `out`, remove them from the log and return
 * how many were copied. */
uint32_t hal_shadow_drain(hal_shadow_t *shadow, hal_write_t *out, uint32_t max);

#if defined(HAL_MMIO_ONLY)
/* A build whose every HAL is memory-mapped (the soft CPU's: firmware/soc/main.c binds each cable
 * with hal_init_mmio and nothing else): the access inline, the same load or store mmio_read and
 * mmio_write make, without the indirect call (on the soft CPU some 30 clocks a register, and a
 * cable's tick reads and writes some ten). */
static inline uint32_t hal_read(const hal_t *h, uint32_t addr)
{
    return ((volatile uint32_t *)h->ctx)[addr / 4U];
}

static inline void hal_write(const hal_t *h, uint32_t addr, uint32_t value)
{
    ((volatile uint32_t *)h->ctx)[addr / 4U] = value;
}
#else
static inline uint32_t hal_read(const hal_t *h, uint32_t addr)
{
    return h->read(h->ctx, addr);
}

static inline void hal_write(const hal_t *h, uint32_t addr, uint32_t value)
{
    h->write(h->ctx, addr, value);
}
#endif

#endif /* BOWDEN_HAL_H */
