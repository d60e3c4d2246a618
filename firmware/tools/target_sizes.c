/* target_sizes.c - sizeof() of the firmware's structures on the target, as constants that
 * tools/elf_report.py reads from the compiled object for the size report (not linked anywhere). */
#include <stdint.h>

#include "comp.h"
#include "fw.h"
#include "hal.h"
#include "wave.h"

const uint32_t sizeof_comp_t = sizeof(comp_t);
const uint32_t sizeof_wave_t = sizeof(wave_t);
const uint32_t sizeof_fw_t = sizeof(fw_t);
const uint32_t sizeof_hal_t = sizeof(hal_t);
const uint32_t sizeof_fw_config_t = sizeof(fw_config_t);
