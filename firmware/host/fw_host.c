/* fw_host.c - host-only glue of libbowden_fw.so; see fw_host.h. */
#include "fw_host.h"

uint32_t fw_host_sizeof(int32_t which)
{
    switch (which) {
    case FW_HOST_SIZEOF_COMP:
        return (uint32_t)sizeof(comp_t);
    case FW_HOST_SIZEOF_COMP_CONFIG:
        return (uint32_t)sizeof(comp_config_t);
    case FW_HOST_SIZEOF_COMP_F64:
        return (uint32_t)sizeof(comp_f64_t);
    case FW_HOST_SIZEOF_COMP_F64_CONFIG:
        return (uint32_t)sizeof(comp_f64_config_t);
    case FW_HOST_SIZEOF_FW_HOST:
        return (uint32_t)sizeof(fw_host_t);
    case FW_HOST_SIZEOF_FW_CONFIG:
        return (uint32_t)sizeof(fw_config_t);
    case FW_HOST_SIZEOF_TELEMETRY:
        return (uint32_t)sizeof(fw_telemetry_t);
    default:
        return 0U;
    }
}

void fw_host_init(fw_host_t *h)
{
    hal_init_shadow(&h->hal, &h->shadow);
    fw_init(&h->fw, &h->hal);
}

int32_t fw_host_configure(fw_host_t *h, const fw_config_t *cfg)
{
    return fw_configure(&h->fw, cfg);
}

void fw_host_start(fw_host_t *h)
{
    fw_start(&h->fw);
}

void fw_host_stop(fw_host_t *h)
{
    fw_stop(&h->fw);
}

void fw_host_fault_clear(fw_host_t *h)
{
    fw_fault_clear(&h->fw);
}

int16_t fw_host_tick(fw_host_t *h, int16_t t_ref)
{
    return fw_tick(&h->fw, t_ref);
}

void fw_host_shadow_set(fw_host_t *h, uint32_t addr, uint32_t value)
{
    hal_shadow_set(&h->shadow, addr, value);
}

uint32_t fw_host_shadow_get(const fw_host_t *h, uint32_t addr)
{
    if ((addr & 3U) != 0U || addr / 4U >= HAL_SHADOW_WORDS) {
        return 0U;
    }
    return h->shadow.regs[addr / 4U];
}

uint32_t fw_host_drain(fw_host_t *h, uint32_t *addrs, uint32_t *values, uint32_t max)
{
    hal_write_t buf[HAL_LOG_CAPACITY];
    uint32_t n = hal_shadow_drain(&h->shadow, buf, max < HAL_LOG_CAPACITY ? max : HAL_LOG_CAPACITY);
    for (uint32_t i = 0; i < n; ++i) {
        addrs[i] = buf[i].addr;
        values[i] = buf[i].value;
    }
    return n;
}

void fw_host_telemetry(const fw_host_t *h, fw_telemetry_t *out)
{
    *out = h->fw.tel;
}

uint32_t fw_host_log_dropped(const fw_host_t *h)
{
    return h->shadow.log_dropped;
}

uint32_t fw_host_bad_access(const fw_host_t *h)
{
    return h->shadow.bad_access;
}

void comp_run_q7_8(comp_t *c, const int16_t *t_ref, int16_t *t_c, uint32_t n)
{
    for (uint32_t i = 0; i < n; ++i) {
        t_c[i] = comp_step_q7_8(c, t_ref[i]);
    }
}

void comp_run_f64(comp_f64_t *c, const double *t_ref_n, double *t_c_n, uint32_t n)
{
    for (uint32_t i = 0; i < n; ++i) {
        t_c_n[i] = comp_step_f64(c, t_ref_n[i]);
    }
}
