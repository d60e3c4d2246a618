/* dev_host.c - the bench device on the host; see dev_host.h. */
#include "dev_host.h"

uint32_t dev_host_sizeof(void)
{
    return (uint32_t)sizeof(dev_host_t);
}

void dev_host_boot(dev_host_t *h)
{
    for (uint32_t c = 0; c < h->channels; ++c) {
        hal_init_shadow(&h->hal[c], &h->shadow[c]);
        fw_init(&h->fw[c], &h->hal[c]);
    }
    h->flash.cut_after = -1;
    h->flash.dead = 0U;
    dev_init_channels(&h->dev, h->fw, h->channels, &h->flash_hal);
}

void dev_host_init_channels(dev_host_t *h, uint32_t n)
{
    h->channels = (n < 1U) ? 1U : (n > BOWDEN_CHANNELS_MAX) ? BOWDEN_CHANNELS_MAX : n;
    flash_ram_init(&h->flash_hal, &h->flash);
    dev_host_boot(h);
}

void dev_host_init(dev_host_t *h)
{
    dev_host_init_channels(h, 1U);
}

uint32_t dev_host_channels_max(void)
{
    return BOWDEN_CHANNELS_MAX;
}

void dev_host_set_identity(dev_host_t *h, uint32_t proto_version, uint32_t table_hash)
{
    h->dev.id.proto_version = (uint8_t)proto_version;
    h->dev.id.table_hash = table_hash;
}

dev_t *dev_host_dev(dev_host_t *h)
{
    return &h->dev;
}

flash_ram_t *dev_host_flash(dev_host_t *h)
{
    return &h->flash;
}

hal_shadow_t *dev_host_shadow(dev_host_t *h)
{
    return &h->shadow[0];
}

hal_shadow_t *dev_host_shadow_channel(dev_host_t *h, uint32_t ch)
{
    return &h->shadow[(ch < h->channels) ? ch : 0U];
}

uint32_t *dev_host_flash_words(dev_host_t *h)
{
    return &h->flash.words[0][0];
}

uint32_t dev_host_flash_n_words(void)
{
    return FLASH_SLOTS * FLASH_RAM_SLOT_WORDS;
}
