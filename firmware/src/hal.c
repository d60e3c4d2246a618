/* hal.c - the three register back ends of hal.h. */
#include "hal.h"

#include "bowden_regs.h"

/* The generated map must fit the shadow window (fails to compile when the map outgrows it). */
typedef char hal_window_holds_map[(BOWDEN_REG_TC_EFF / 4U < HAL_SHADOW_WORDS) ? 1 : -1];

static uint32_t mmio_read(void *ctx, uint32_t addr)
{
    volatile uint32_t *base = (volatile uint32_t *)ctx;
    return base[addr / 4U];
}

static void mmio_write(void *ctx, uint32_t addr, uint32_t value)
{
    volatile uint32_t *base = (volatile uint32_t *)ctx;
    base[addr / 4U] = value;
}

void hal_init_mmio(hal_t *h, volatile uint32_t *base)
{
    h->read = mmio_read;
    h->write = mmio_write;
    /* The context pointer carries the base; the qualifier is restored in mmio_read/write. */
    h->ctx = (void *)(uintptr_t)base;
}

void hal_init_transport(hal_t *h, hal_read_fn read, hal_write_fn write, void *ctx)
{
    h->read = read;
    h->write = write;
    h->ctx = ctx;
}

static int shadow_index(hal_shadow_t *s, uint32_t addr, uint32_t *index)
{
    if ((addr & 3U) != 0U || addr / 4U >= HAL_SHADOW_WORDS) {
        ++s->bad_access;
        return 0;
    }
    *index = addr / 4U;
    return 1;
}

static uint32_t shadow_read(void *ctx, uint32_t addr)
{
    hal_shadow_t *s = (hal_shadow_t *)ctx;
    uint32_t i;
    return shadow_index(s, addr, &i) ? s->regs[i] : 0U;
}

static void shadow_write(void *ctx, uint32_t addr, uint32_t value)
{
    hal_shadow_t *s = (hal_shadow_t *)ctx;
    uint32_t i;
    if (!shadow_index(s, addr, &i)) {
        return;
    }
    s->regs[i] = value;
    if (s->log_len < HAL_LOG_CAPACITY) {
        s->log[s->log_len].addr = addr;
        s->log[s->log_len].value = value;
        ++s->log_len;
    } else {
        ++s->log_dropped;
    }
}

void hal_init_shadow(hal_t *h, hal_shadow_t *shadow)
{
    for (uint32_t i = 0; i < HAL_SHADOW_WORDS; ++i) {
        shadow->regs[i] = 0U;
    }
    shadow->log_len = 0U;
    shadow->log_dropped = 0U;
    shadow->bad_access = 0U;
    h->read = shadow_read;
    h->write = shadow_write;
    h->ctx = shadow;
}

void hal_shadow_set(hal_shadow_t *shadow, uint32_t addr, uint32_t value)
{
    uint32_t i;
    if (shadow_index(shadow, addr, &i)) {
        shadow->regs[i] = value;
    }
}

uint32_t hal_shadow_drain(hal_shadow_t *shadow, hal_write_t *out, uint32_t max)
{
    uint32_t n = (shadow->log_len < max) ? shadow->log_len : max;
    for (uint32_t i = 0; i < n; ++i) {
        out[i] = shadow->log[i];
    }
    /* Keep the writes that did not fit, oldest first. */
    for (uint32_t i = n; i < shadow->log_len; ++i) {
        shadow->log[i - n] = shadow->log[i];
    }
    shadow->log_len -= n;
    return n;
}
