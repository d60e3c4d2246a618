/* test_store.c - parameters by id (params.c) and the two-record flash store (flash.c). */
#include <string.h>

#include "flash.h"
#include "crc32c.h"
#include "flash_ram.h"
#include "params.h"
#include "test_util.h"
#include "unit.h"

static void test_params_get_set(void)
{
    settings_t s;
    settings_default(&s);
    int32_t w = 0;
    int32_t status = 0;
    CHECK(params_get(&s, PROTO_PID_COMP_MU, &w) == 0 && w == s.fw.comp.mu_q28, "get mu");
    /* mu = 0.09 in Q3.28 */
    int32_t mu = 24159191;
    CHECK(params_set(&s, PROTO_PID_COMP_MU, mu, &status) == 0 && s.fw.comp.mu_q28 == mu, "set mu");
    CHECK(params_set(&s, PROTO_PID_LOOP_KFF, 800, &status) == 0 && s.fw.loop.kff == 800, "kff");
    CHECK(params_set(&s, PROTO_PID_DEV_TELEMETRY_DIV, 4, &status) == 0 &&
              s.dev.telemetry_div == 4U,
          "telemetry_div");
    /* rejected values change nothing and name the field */
    settings_t before = s;
    CHECK(params_set(&s, PROTO_PID_COMP_MU, (int32_t)(2L << 28), &status) ==
                  (int32_t)PROTO_ERR_INVALID_VALUE &&
              status == COMP_ERR_MU,
          "mu = 2 rejected");
    CHECK(memcmp(&s, &before, sizeof s) == 0, "nothing changed");
    CHECK(strncmp(settings_strerror(status), "comp.mu:", 8) == 0, "message names the field");
    CHECK(params_set(&s, PROTO_PID_LOOP_KFF, 40000, &status) == (int32_t)PROTO_ERR_INVALID_VALUE &&
              status == FW_ERR_KFF,
          "kff beyond the register");
    CHECK(params_set(&s, PROTO_PID_DEV_CAN_NODE, 64, &status) ==
                  (int32_t)PROTO_ERR_INVALID_VALUE &&
              status == SETTINGS_ERR_CAN_NODE,
          "node 64");
    CHECK(params_set(&s, PROTO_PID_DEV_TELEMETRY_DIV, 0, &status) ==
                  (int32_t)PROTO_ERR_INVALID_VALUE,
          "div 0");
    CHECK(params_set(&s, PROTO_PID_TICK_RATE_HZ, 500, &status) == (int32_t)PROTO_ERR_READ_ONLY,
          "read-only");
    CHECK(params_set(&s, PROTO_N_PARAMS, 0, &status) == (int32_t)PROTO_ERR_UNKNOWN_PARAM, "id");
    CHECK(params_get(&s, PROTO_N_PARAMS, &w) == (int32_t)PROTO_ERR_UNKNOWN_PARAM, "get id");
    CHECK(memcmp(&s, &before, sizeof s) == 0, "still nothing changed");
    /* keys find their ids */
    for (uint32_t i = 0; i < PROTO_N_PARAMS; ++i) {
        CHECK(params_find(params_table[i].key) == (int32_t)i, "key of %u", i);
    }
    CHECK(params_find(0x12345678UL) == -1, "unknown key");
}

static void setup(flash_hal_t *hal, flash_ram_t *ram, settings_t *s)
{
    flash_ram_init(hal, ram);
    settings_default(s);
}

static void test_flash_round_trip_and_alternation(void)
{
    flash_hal_t hal;
    static flash_ram_t ram;
    settings_t s, got;
    setup(&hal, &ram, &s);
    uint32_t seq = 0;
    settings_default(&got);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_ERR_EMPTY, "blank flash is empty");
    s.fw.comp.mode = COMP_MODE_SMOOTH;
    s.fw.loop.kp = 1234;
    CHECK(flash_store(&hal, &s, &seq) == FLASH_OK && seq == 1U, "first store");
    CHECK(ram.words[0][0] == FLASH_MAGIC && ram.words[1][0] == 0xFFFFFFFFUL, "slot 0 written");
    settings_default(&got);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_OK && seq == 1U, "load");
    CHECK(memcmp(&got, &s, sizeof s) == 0, "same settings back");
    s.fw.loop.kp = 999;
    CHECK(flash_store(&hal, &s, &seq) == FLASH_OK && seq == 2U, "second store");
    CHECK(ram.words[1][1] == 2U && ram.words[0][1] == 1U, "slot 1 written, slot 0 kept");
    CHECK(flash_store(&hal, &s, &seq) == FLASH_OK && seq == 3U && ram.words[0][1] == 3U,
          "third store back in slot 0");
    settings_default(&got);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_OK && seq == 3U && got.fw.loop.kp == 999, "newest");
}

/* A power cut after every possible number of word operations of a store: the flash then loads
 * either the old settings or the new ones, never anything else and never nothing. */
static void test_flash_power_cut_anywhere(void)
{
    flash_hal_t hal;
    static flash_ram_t ram;
    settings_t old_s, new_s, got;
    setup(&hal, &ram, &old_s);
    uint32_t seq;
    old_s.fw.loop.kp = 111;
    new_s = old_s;
    new_s.fw.loop.kp = 222;
    new_s.fw.comp.band_n_q8 = 77;
    CHECK(flash_store(&hal, &old_s, &seq) == FLASH_OK, "old stored");
    CHECK(flash_store(&hal, &old_s, &seq) == FLASH_OK, "both slots hold a record");
    flash_ram_t saved = ram;
    uint32_t ops_full = 0;
    {
        ram.ops = 0U;
        CHECK(flash_store(&hal, &new_s, &seq) == FLASH_OK, "full store");
        ops_full = ram.ops;
        ram = saved;
    }
    CHECK(ops_full > FLASH_RAM_SLOT_WORDS, "erase + program counted (%u ops)", ops_full);
    uint32_t n_old = 0, n_new = 0;
    for (uint32_t cut = 0; cut <= ops_full; ++cut) {
        ram = saved;
        flash_ram_cut_after(&ram, (int32_t)cut);
        int32_t st = flash_store(&hal, &new_s, &seq);
        CHECK(cut == ops_full ? st == FLASH_OK : st == FLASH_ERR_WRITE, "cut %u: store %d", cut,
              st);
        flash_ram_power_on(&ram);
        settings_default(&got);
        CHECK(flash_load(&hal, &got, &seq) == FLASH_OK, "cut %u: a record loads", cut);
        int is_old = memcmp(&got, &old_s, sizeof got) == 0;
        int is_new = memcmp(&got, &new_s, sizeof got) == 0;
        CHECK(is_old || is_new, "cut %u: old or new settings", cut);
        n_old += (uint32_t)is_old;
        n_new += (uint32_t)is_new;
    }
    CHECK(n_new == 1U && n_old == ops_full, "new only once complete (%u old, %u new)", n_old, n_new);
}

/* Records from another firmware: unknown keys are skipped, missing parameters keep their
 * defaults, a torn header is ignored, and a newest record that fails the check gives way to the
 * older one. */
static void test_flash_foreign_and_invalid_records(void)
{
    flash_hal_t hal;
    static flash_ram_t ram;
    settings_t s, got;
    setup(&hal, &ram, &s);
    uint32_t seq;
    /* hand-made record: one unknown key, then kp = 321 */
    uint32_t rec[3 + 4 + 1] = {FLASH_MAGIC, 5U, 2U, 0xDEADBEEFUL, 1U,
                               params_table[PROTO_PID_LOOP_KP].key, 321U, 0U};
    uint8_t bytes[7 * 4];
    for (uint32_t i = 0; i < 7U; ++i) {
        for (uint32_t b = 0; b < 4U; ++b) {
            bytes[4U * i + b] = (uint8_t)(rec[i] >> (8U * b));
        }
    }
    rec[7] = crc32c(bytes, sizeof bytes);
    (void)hal.erase(hal.ctx, 0U);
    (void)hal.program(hal.ctx, 0U, 0U, rec, 8U);
    settings_default(&got);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_OK && seq == 5U, "foreign record loads");
    settings_default(&s);
    s.fw.loop.kp = 321;
    CHECK(memcmp(&got, &s, sizeof s) == 0, "kp taken, the rest default");
    /* torn header: absurd pair count */
    ram.words[1][0] = FLASH_MAGIC;
    ram.words[1][1] = 6U;
    ram.words[1][2] = 0x7FFFFFFFUL;
    settings_default(&got);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_OK && seq == 5U, "torn record ignored");
    /* a newer record whose settings fail the check (mu = 3) gives way to the older one */
    settings_t bad;
    settings_default(&bad);
    bad.fw.comp.mu_q28 = (int32_t)(3L << 28);
    uint32_t seq2;
    CHECK(flash_store(&hal, &bad, &seq2) == FLASH_OK && seq2 == 6U, "store writes any settings");
    settings_default(&got);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_OK && seq == 5U && got.fw.loop.kp == 321,
          "older valid record used");
    /* both invalid */
    CHECK(flash_store(&hal, &bad, &seq2) == FLASH_OK, "second bad record");
    settings_default(&got);
    settings_t def;
    settings_default(&def);
    CHECK(flash_load(&hal, &got, &seq) == FLASH_ERR_INVALID && memcmp(&got, &def, sizeof got) == 0,
          "no valid settings: defaults untouched");
}

const unit_test_t store_tests[] = {
    {"params_get_set", test_params_get_set},
    {"flash_round_trip_and_alternation", test_flash_round_trip_and_alternation},
    {"flash_power_cut_anywhere", test_flash_power_cut_anywhere},
    {"flash_foreign_and_invalid_records", test_flash_foreign_and_invalid_records},
};
const int store_tests_count = (int)(sizeof store_tests / sizeof store_tests[0]);
