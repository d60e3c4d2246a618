/*
 * settings.h - everything a parameter can address: the firmware's configuration (fw_config_t:
 * the compensator, the waveform, the FPGA loop's register words) and the device's own settings
 * (dev_config_t), with the factory defaults, the check of the whole and the message of each
 * status code.
 *
 * The bottom of the settings chain: settings <- params (read and write by parameter id) <- flash
 * (the saved records) <- dev (the protocol's device side). settings uses none of them, so the
 * parameter table (generated from settings_t, firmware/proto/gen_proto.py), the flash records and
 * the device all agree on one structure and one check.
 */
#ifndef BOWDEN_SETTINGS_H
#define BOWDEN_SETTINGS_H

#include <stdint.h>

#include "fw.h"

/* The most channels (cables) a build holds: one settings_t, one fw_t and one register bank
 * (bowden_regs.h, BOWDEN_REG_AT) per channel. 1 unless the build sets it: every channel costs RAM
 * (its settings, its firmware state, its stream buffer in dev.h), so a board builds what it
 * drives; the host's device (the emulator, the tests) builds 4. The channels a device runs, at
 * most this, are given at dev_init_channels. */
#ifndef BOWDEN_CHANNELS_MAX
#define BOWDEN_CHANNELS_MAX 1U
#endif

/* Status codes of settings_check, after the firmware's (fw.h: up to 56). */
#define SETTINGS_ERR_TELEMETRY_DIV 60
#define SETTINGS_ERR_CAN_NODE 61

/* The device's own settings. */
typedef struct {
    uint32_t telemetry_div; /* telemetry every N ticks, [1, 1000]; default 1 */
    uint32_t can_node;      /* CAN node id, [0, 63]; default 1 */
} dev_config_t;

/* Everything a parameter can address on one channel (the parameter table is generated from this
 * structure): the channel's firmware configuration, and the device's own settings (dev.*), which
 * a device of several channels holds once, in channel 0's settings_t (params_is_device). */
typedef struct {
    fw_config_t fw;
    dev_config_t dev;
} settings_t;

/* Factory defaults: fw_config_default and telemetry every tick, CAN node 1. */
void settings_default(settings_t *s);
/* 0 or the status code of the first bad field (fw_config_check, then SETTINGS_ERR_*). */
int32_t settings_check(const settings_t *s);
/* The message of a status code (fw_strerror, and the device settings' own). */
const char *settings_strerror(int32_t code);

#endif /* BOWDEN_SETTINGS_H */
