/* flash.c - two-record settings store of flash.h. */
#include "flash.h"

#include "crc32c.h"
#include "params.h"

/* Pairs of a record of n channels: every parameter of channel 0, the channel's own ones of the
 * others (the device's settings, dev.*, are saved once). */
static uint32_t record_pairs(uint32_t n)
{
    uint32_t device = 0U;
    for (uint32_t i = 0; i < PROTO_N_PARAMS; ++i) {
        device += (uint32_t)params_is_device(i);
    }
    return PROTO_N_PARAMS + (n - 1U) * (PROTO_N_PARAMS - device);
}

static uint32_t crc_words(const uint32_t *w, uint32_t n)
{
    uint32_t crc = CRC32C_INIT;
    for (uint32_t i = 0; i < n; ++i) {
        uint8_t b[4] = {(uint8_t)w[i], (uint8_t)(w[i] >> 8), (uint8_t)(w[i] >> 16),
                        (uint8_t)(w[i] >> 24)};
        crc = crc32c_update(crc, b, 4U);
    }
    return crc ^ 0xFFFFFFFFUL;
}

/* Read slot `slot` into rec; 1 when it holds a record with a good CRC (*n_words its length). */
static int read_record(const flash_hal_t *f, uint32_t slot, uint32_t *rec, uint32_t *n_words)
{
    if (f->read(f->ctx, slot, 0U, rec, FLASH_HEADER_WORDS) != 0 || rec[0] != FLASH_MAGIC) {
        return 0;
    }
    uint32_t pairs = rec[2];
    /* A pair count from a torn write can be anything: bound it before using it. */
    if (pairs > PROTO_N_PARAMS * BOWDEN_CHANNELS_MAX + 32U || FLASH_HEADER_WORDS + 2U * pairs + 1U > f->slot_words) {
        return 0;
    }
    uint32_t n = FLASH_HEADER_WORDS + 2U * pairs;
    if (f->read(f->ctx, slot, FLASH_HEADER_WORDS, &rec[FLASH_HEADER_WORDS], 2U * pairs + 1U) != 0) {
        return 0;
    }
    if (crc_words(rec, n) != rec[n]) {
        return 0;
    }
    *n_words = n + 1U;
    return 1;
}

/* Serial-number order of two sequence numbers: 1 when a is after b. */
static int seq_after(uint32_t a, uint32_t b)
{
    return (a - b) != 0U && (a - b) < 0x80000000UL;
}

/* The record buffer holds the largest record load accepts (32 unknown keys beyond the table). */
#define RECORD_MAX_WORDS (FLASH_HEADER_WORDS + 2U * (PROTO_N_PARAMS * BOWDEN_CHANNELS_MAX + 32U) + 1U)

int32_t flash_store(const flash_hal_t *f, const settings_t *settings, uint32_t *seq)
{
    return flash_store_channels(f, settings, 1U, seq);
}

int32_t flash_store_channels(const flash_hal_t *f, const settings_t *settings, uint32_t n_ch,
                             uint32_t *seq)
{
    if (n_ch < 1U || n_ch > BOWDEN_CHANNELS_MAX) {
        return FLASH_ERR_SIZE;
    }
    const uint32_t pairs = record_pairs(n_ch);
    const uint32_t record_words = FLASH_HEADER_WORDS + 2U * pairs + 1U;
    if (record_words > f->slot_words) {
        return FLASH_ERR_SIZE;
    }
    /* The slot to write: the one that does not hold the newest valid record. */
    uint32_t rec[RECORD_MAX_WORDS];
    uint32_t n;
    int valid[FLASH_SLOTS];
    uint32_t seqs[FLASH_SLOTS] = {0U, 0U};
    for (uint32_t s = 0; s < FLASH_SLOTS; ++s) {
        valid[s] = read_record(f, s, rec, &n);
        seqs[s] = rec[1];
    }
    uint32_t target = 0U;
    uint32_t next = 1U;
    if (valid[0] && (!valid[1] || seq_after(seqs[0], seqs[1]))) {
        target = 1U;
        next = seqs[0] + 1U;
    } else if (valid[1]) {
        target = 0U;
        next = seqs[1] + 1U;
    }
    rec[0] = FLASH_MAGIC;
    rec[1] = next;
    rec[2] = pairs;
    uint32_t at = FLASH_HEADER_WORDS;
    for (uint32_t ch = 0; ch < n_ch; ++ch) {
        for (uint32_t i = 0; i < PROTO_N_PARAMS; ++i) {
            if (ch != 0U && params_is_device(i)) {
                continue; /* once, with channel 0 */
            }
            int32_t word;
            (void)params_get(&settings[ch], i, &word);
            rec[at++] = params_channel_key(i, ch);
            rec[at++] = (uint32_t)word;
        }
    }
    rec[record_words - 1U] = crc_words(rec, record_words - 1U);
    if (f->erase(f->ctx, target) != 0 || f->program(f->ctx, target, 0U, rec, record_words) != 0) {
        return FLASH_ERR_WRITE;
    }
    uint32_t back[RECORD_MAX_WORDS];
    if (!read_record(f, target, back, &n) || n != record_words || back[1] != next) {
        return FLASH_ERR_WRITE;
    }
    *seq = next;
    return FLASH_OK;
}

/* The parameter id and channel (< n) of a record's key: 1 when this firmware knows it. */
static int find_channel_key(uint32_t key, uint32_t n, uint32_t *id, uint32_t *ch)
{
    for (uint32_t c = 0; c < n; ++c) {
        /* Undo channel c's tag and look the name's key up; the tag must be the one it has. */
        const uint32_t name_key = (c == 0U) ? key : key ^ (uint32_t)(c * 0x9E3779B9UL);
        const int32_t i = params_find(name_key);
        if (i >= 0 && params_channel_key((uint32_t)i, c) == key) {
            *id = (uint32_t)i;
            *ch = c;
            return 1;
        }
    }
    return 0;
}

/* Apply a record's pairs onto a copy of base[0 .. n); 1 when every channel passes the check.
 * Pairs are copied without a check of their own (ADC_MIN and ADC_MAX, say, are only valid
 * together); the whole is checked once. The device's settings go to every channel's copy. */
static int apply_record(const uint32_t *rec, settings_t *out, const settings_t *base, uint32_t n)
{
    for (uint32_t c = 0; c < n; ++c) {
        out[c] = base[c];
    }
    uint32_t pairs = rec[2];
    for (uint32_t i = 0; i < pairs; ++i) {
        uint32_t id;
        uint32_t ch;
        if (!find_channel_key(rec[FLASH_HEADER_WORDS + 2U * i], n, &id, &ch) ||
            (params_table[id].flags & PROTO_PARAM_READ_ONLY) != 0U) {
            continue; /* a parameter (or channel) this firmware lacks, or one fixed by hardware */
        }
        const int32_t word = (int32_t)rec[FLASH_HEADER_WORDS + 2U * i + 1U];
        for (uint32_t c = 0; c < n; ++c) {
            if (c == ch || params_is_device(id)) {
                params_word_write(&out[c], params_table[id].offset, word);
            }
        }
    }
    for (uint32_t c = 0; c < n; ++c) {
        if (settings_check(&out[c]) != 0) {
            return 0;
        }
    }
    return 1;
}

int32_t flash_load(const flash_hal_t *f, settings_t *settings, uint32_t *seq)
{
    return flash_load_channels(f, settings, 1U, seq);
}

int32_t flash_load_channels(const flash_hal_t *f, settings_t *settings, uint32_t n_ch, uint32_t *seq)
{
    if (n_ch < 1U || n_ch > BOWDEN_CHANNELS_MAX) {
        return FLASH_ERR_SIZE;
    }
    /* One record buffer, not one a slot: the slots are read once for their validity and
     * sequence numbers, and the one to apply again unless the buffer still holds it (the buffer
     * is the largest thing on the stack: 2.2 KB for four channels). */
    uint32_t rec[RECORD_MAX_WORDS];
    uint32_t n;
    int valid[FLASH_SLOTS];
    uint32_t seqs[FLASH_SLOTS] = {0U, 0U};
    uint32_t held = FLASH_SLOTS; /* the slot whose record rec holds; none yet */
    for (uint32_t s = 0; s < FLASH_SLOTS; ++s) {
        valid[s] = read_record(f, s, rec, &n);
        held = valid[s] ? s : FLASH_SLOTS; /* a failed read leaves rec part written */
        if (valid[s]) {
            seqs[s] = rec[1];
        }
    }
    if (!valid[0] && !valid[1]) {
        return FLASH_ERR_EMPTY;
    }
    /* Newest first. */
    uint32_t order[FLASH_SLOTS] = {0U, 1U};
    if (valid[1] && (!valid[0] || seq_after(seqs[1], seqs[0]))) {
        order[0] = 1U;
        order[1] = 0U;
    }
    settings_t trial[BOWDEN_CHANNELS_MAX];
    for (uint32_t k = 0; k < FLASH_SLOTS; ++k) {
        uint32_t slot = order[k];
        if (!valid[slot]) {
            continue;
        }
        if (slot != held) {
            held = read_record(f, slot, rec, &n) ? slot : FLASH_SLOTS;
            if (held != slot) {
                continue; /* changed since the first read: as an invalid record */
            }
        }
        if (apply_record(rec, trial, settings, n_ch)) {
            for (uint32_t c = 0; c < n_ch; ++c) {
                settings[c] = trial[c];
            }
            *seq = rec[1];
            return FLASH_OK;
        }
    }
    return FLASH_ERR_INVALID;
}
