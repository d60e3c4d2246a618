/* settings.c - defaults, check and messages of settings.h. */
#include "settings.h"

#include "proto_msgs.h"

void settings_default(settings_t *s)
{
    fw_config_default(&s->fw);
    s->dev.telemetry_div = 1U;
    s->dev.can_node = PROTO_CAN_DEFAULT_NODE;
}

int32_t settings_check(const settings_t *s)
{
    int32_t err = fw_config_check(&s->fw);
    if (err != FW_OK) {
        return err;
    }
    if (s->dev.telemetry_div < 1U || s->dev.telemetry_div > 1000U) {
        return SETTINGS_ERR_TELEMETRY_DIV;
    }
    if (s->dev.can_node >= (1U << PROTO_CAN_NODE_BITS)) {
        return SETTINGS_ERR_CAN_NODE;
    }
    return 0;
}

const char *settings_strerror(int32_t code)
{
    switch (code) {
    case SETTINGS_ERR_TELEMETRY_DIV:
        return "dev.telemetry_div: outside [1, 1000] ticks";
    case SETTINGS_ERR_CAN_NODE:
        return "dev.can_node: outside [0, 63]";
    default:
        return fw_strerror(code);
    }
}
