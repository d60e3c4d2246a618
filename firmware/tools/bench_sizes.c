/* bench_sizes.c - sizeof() of the bench protocol's structures on the target, as constants that
 * tools/elf_report.py reads from the compiled object (not linked anywhere). */
#include <stdint.h>

#include "dev.h"
#include "proto.h"
#include "proto_can.h"

const uint32_t sizeof_dev_t = sizeof(dev_t);
const uint32_t sizeof_dev_port_t = sizeof(dev_port_t);
const uint32_t sizeof_settings_t = sizeof(settings_t);
const uint32_t sizeof_proto_rx_t = sizeof(proto_rx_t);
const uint32_t sizeof_proto_can_rx_t = sizeof(proto_can_rx_t);
