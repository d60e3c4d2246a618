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

#endif /* BOWDEN_UNIT_H */
