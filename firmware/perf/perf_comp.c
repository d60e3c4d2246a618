/*
 * perf_comp.c - host driver for the instruction count of one compensator step (callgrind).
 *
 *   valgrind --tool=callgrind --toggle-collect=comp_step_q7_8 perf_comp SCENARIO STEPS
 *
 * counts only the instructions executed inside comp_step_q7_8 (including its return), so the
 * loop and the input generation here are excluded; dividing by STEPS gives instructions per step.
 * Scenarios: paper (Eq. 15-16, defaults), smooth (smooth inverse, defaults), smooth-blend (the
 * longest path: band 128 N so every step blends both branches, with offset and friction slope).
 * The reference is the paper's Fig. 14 waveform: a 0 .. 15 N sine at 0.5 Hz sampled at 1 kHz,
 * precomputed in Q7.8 by the integer generator of wave.h.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "comp.h"
#include "wave.h"

#define MAX_STEPS 1000000

static int16_t ref[MAX_STEPS];

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: %s paper|smooth|smooth-blend|preview-spread STEPS\n", argv[0]);
        return 2;
    }
    long steps = strtol(argv[2], NULL, 10);
    if (steps < 1 || steps > MAX_STEPS) {
        fprintf(stderr, "STEPS: outside [1, %d]\n", MAX_STEPS);
        return 2;
    }
    comp_config_t cfg;
    comp_config_default(&cfg);
    if (strcmp(argv[1], "paper") == 0) {
        cfg.mode = COMP_MODE_PAPER;
    } else if (strcmp(argv[1], "smooth") == 0) {
        cfg.mode = COMP_MODE_SMOOTH;
    } else if (strcmp(argv[1], "smooth-blend") == 0) {
        cfg.mode = COMP_MODE_SMOOTH;
        cfg.band_n_q8 = COMP_BAND_MAX_Q8;
        cfg.offset_n_q8 = Q7_8_ONE / 2;
        cfg.mu_slope_per_n_q28 = (q3_28_t)(Q3_28_ONE / 2000);
    } else if (strcmp(argv[1], "preview-spread") == 0) {
        cfg.mode = COMP_MODE_PREVIEW;
        cfg.dead_zone_spread_q28 = (q3_28_t)(Q3_28_ONE / 2); /* the dead-zone inverse */
    } else {
        fprintf(stderr, "SCENARIO: one of paper, smooth, smooth-blend, preview-spread; got %s\n", argv[1]);
        return 2;
    }
    comp_t c;
    comp_init(&c);
    if (comp_configure(&c, &cfg) != COMP_OK) {
        fprintf(stderr, "configuration rejected\n");
        return 1;
    }
    wave_t w;
    wave_config_t wc;
    wave_config_default(&wc);
    if (wave_configure(&w, &wc, 1000U) != WAVE_OK) {
        return 1;
    }
    for (long i = 0; i < steps; ++i) {
        ref[i] = wave_next_q7_8(&w);
    }
    long checksum = 0;
    for (long i = 0; i < steps; ++i) {
        checksum += comp_step_q7_8(&c, ref[i]);
    }
    printf("%s: %ld steps, checksum %ld\n", argv[1], steps, checksum);
    return 0;
}
