/*
 * fw_host.h - host-only glue of libbowden_fw.so for the co-simulation (cosim/parts/firmware.py,
 * ctypes):
 * a firmware instance bound to a register shadow, batch runs of the compensator and its twin,
 * and the sizes of the structures so the Python side can check its mirrors of them.
 */
#ifndef BOWDEN_FW_HOST_H
#define BOWDEN_FW_HOST_H

#include <stdint.h>

#include "comp.h"
#include "comp_f64.h"
#include "fw.h"
#include "hal.h"

/* A firmware instance on the host: its HAL is the register shadow with write log. */
typedef struct {
    hal_t hal;
    hal_shadow_t shadow;
    fw_t fw;
} fw_host_t;

/* Which structure fw_host_sizeof reports. */
#define FW_HOST_SIZEOF_COMP 0
#define FW_HOST_SIZEOF_COMP_CONFIG 1
#define FW_HOST_SIZEOF_COMP_F64 2
#define FW_HOST_SIZEOF_COMP_F64_CONFIG 3
#define FW_HOST_SIZEOF_FW_HOST 4
#define FW_HOST_SIZEOF_FW_CONFIG 5
#define FW_HOST_SIZEOF_TELEMETRY 6

/* sizeof() of a structure (FW_HOST_SIZEOF_*), 0 for an unknown one. */
uint32_t fw_host_sizeof(int32_t which);

void fw_host_init(fw_host_t *h);
int32_t fw_host_configure(fw_host_t *h, const fw_config_t *cfg);
void fw_host_start(fw_host_t *h);
void fw_host_stop(fw_host_t *h);
void fw_host_fault_clear(fw_host_t *h);
int16_t fw_host_tick(fw_host_t *h, int16_t t_ref);
void fw_host_shadow_set(fw_host_t *h, uint32_t addr, uint32_t value);
uint32_t fw_host_shadow_get(const fw_host_t *h, uint32_t addr);
/* Drain up to max logged writes into addrs[]/values[]; returns how many. */
uint32_t fw_host_drain(fw_host_t *h, uint32_t *addrs, uint32_t *values, uint32_t max);
void fw_host_telemetry(const fw_host_t *h, fw_telemetry_t *out);
/* Writes lost to a full log, and accesses outside the register window. */
uint32_t fw_host_log_dropped(const fw_host_t *h);
uint32_t fw_host_bad_access(const fw_host_t *h);

/* n steps of the fixed-point compensator / its twin over an array (for tests and the reference). */
void comp_run_q7_8(comp_t *c, const int16_t *t_ref, int16_t *t_c, uint32_t n);
void comp_run_f64(comp_f64_t *c, const double *t_ref_n, double *t_c_n, uint32_t n);

#endif /* BOWDEN_FW_HOST_H */
