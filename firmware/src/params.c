/* params.c - parameter access of params.h. */
#include "params.h"

#include <stddef.h>

/* The word lives at a generated offset in settings_t. Every parameter is an int32_t or
 * uint32_t member (the generator refuses any other type), so the address is aligned and an
 * int32_t lvalue may access it (C11 6.5p7: the signed or unsigned type of the effective type). */
static void word_read(const settings_t *s, uint32_t offset, int32_t *word)
{
    *word = *(const int32_t *)(const void *)((const uint8_t *)s + offset);
}

void params_word_write(settings_t *s, uint32_t offset, int32_t word)
{
    *(int32_t *)(void *)((uint8_t *)s + offset) = word;
}

int32_t params_get(const settings_t *s, uint32_t id, int32_t *word)
{
    if (id >= PROTO_N_PARAMS) {
        return (int32_t)PROTO_ERR_UNKNOWN_PARAM;
    }
    word_read(s, params_table[id].offset, word);
    return 0;
}

int32_t params_set(settings_t *s, uint32_t id, int32_t word, int32_t *status)
{
    *status = 0;
    if (id >= PROTO_N_PARAMS) {
        return (int32_t)PROTO_ERR_UNKNOWN_PARAM;
    }
    if ((params_table[id].flags & PROTO_PARAM_READ_ONLY) != 0U) {
        return (int32_t)PROTO_ERR_READ_ONLY;
    }
    /* Tried in place, the old word put back on a refusal: the same outcome as a trial copy,
     * without two copies of the whole settings (on a small CPU, a good part of a request's
     * handling). */
    int32_t old;
    word_read(s, params_table[id].offset, &old);
    params_word_write(s, params_table[id].offset, word);
    int32_t err = settings_check(s);
    if (err != 0) {
        params_word_write(s, params_table[id].offset, old);
        *status = err;
        return (int32_t)PROTO_ERR_INVALID_VALUE;
    }
    return 0;
}

int32_t params_find(uint32_t key)
{
    for (uint32_t i = 0; i < PROTO_N_PARAMS; ++i) {
        if (params_table[i].key == key) {
            return (int32_t)i;
        }
    }
    return -1;
}

int params_is_device(uint32_t id)
{
    if (id >= PROTO_N_PARAMS) {
        return 0;
    }
    const uint32_t at = params_table[id].offset;
    return at >= offsetof(settings_t, dev) && at < offsetof(settings_t, dev) + sizeof(dev_config_t);
}

uint32_t params_channel_key(uint32_t id, uint32_t ch)
{
    const uint32_t key = params_table[id].key;
    return (ch == 0U || params_is_device(id)) ? key : key ^ (uint32_t)(ch * 0x9E3779B9UL);
}
