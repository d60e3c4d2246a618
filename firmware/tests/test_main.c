/*
 * test_main.c - the host unit-test program of the firmware. Runs every test (or those whose name
 * contains argv[1]), prints one line per test and a summary, exits non-zero on any failure or when
 * no test matched. `--list` prints the test names (suite.name), one per line.
 */
#include <stdio.h>
#include <string.h>

#include "unit.h"

int unit_checks = 0;
int unit_failures = 0;

extern const unit_test_t fxp_tests[];
extern const int fxp_tests_count;
extern const unit_test_t comp_tests[];
extern const int comp_tests_count;
extern const unit_test_t fw_tests[];
extern const int fw_tests_count;

static int list_only = 0;

static void run_suite(const char *suite, const unit_test_t *tests, int count, const char *filter,
                      int *ran)
{
    for (int i = 0; i < count; ++i) {
        if (list_only) {
            printf("%s.%s\n", suite, tests[i].name);
            continue;
        }
        char full[128];
        (void)snprintf(full, sizeof full, "%s.%s", suite, tests[i].name);
        if (filter != NULL && strstr(full, filter) == NULL) {
            continue;
        }
        int before = unit_failures;
        int checks = unit_checks;
        tests[i].fn();
        printf("%s %s.%s (%d checks)\n", unit_failures == before ? "PASS" : "FAIL", suite,
               tests[i].name, unit_checks - checks);
        ++*ran;
    }
}

int main(int argc, char **argv)
{
    const char *filter = (argc > 1) ? argv[1] : NULL;
    if (filter != NULL && strcmp(filter, "--list") == 0) {
        list_only = 1;
        filter = NULL;
    }
    int ran = 0;
    run_suite("fxp", fxp_tests, fxp_tests_count, filter, &ran);
    run_suite("comp", comp_tests, comp_tests_count, filter, &ran);
    run_suite("fw", fw_tests, fw_tests_count, filter, &ran);
    if (list_only) {
        return 0;
    }
    printf("%d tests, %d checks, %d failed\n", ran, unit_checks, unit_failures);
    return (unit_failures == 0 && ran > 0) ? 0 : 1;
}
