/* unit.h - a tiny test harness for the firmware's host unit tests (plain C, no framework). */
#ifndef BOWDEN_UNIT_H
#define BOWDEN_UNIT_H

#include <stdio.h>

extern int unit_checks;
extern int unit_failures;

/* CHECK(cond, fmt, ...): count a check; on failure print where and the values that differ. */
#define CHECK(cond, ...)                                                                        \
    do {                                                                                        \
        ++unit_checks;                                                                          \
        if (!(cond)) {                                                                          \
            ++unit_failures;                                                                    \
            printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);                              \
            printf(__VA_ARGS__);                                                                \
            printf("\n");                                                                       \
        }                                                                                       \
    } while (0)

/* Each test is a void function registered in the table of its file. */
typedef struct {
    const char *name;
    void (*fn)(void);
} unit_test_t;

/* A suite: its name and the table of one test file (count is that file's `<suite>_tests_count`). */
typedef struct {
    const char *name;
    const unit_test_t *tests;
    const int *count;
} unit_suite_t;

/*
 * The body of a unit-test program's main (unit_main.c): runs every test of the suites (or those
 * whose suite.name contains argv[1]), prints one line per test and a summary, returns non-zero on
 * any failure or when no test matched. `--list` prints the test names (suite.name), one per line.
 */
int unit_main(int argc, char **argv, const unit_suite_t *suites, int n_suites);

#endif /* BOWDEN_UNIT_H */
