/*
 * unit_main.c - the runner shared by the host unit-test programs (test_main.c for the firmware,
 * bench/bench_main.c for the bench protocol and device): unit_main() of unit.h.
 */
#include <stdio.h>
#include <string.h>

#include "unit.h"

int unit_checks = 0;
int unit_failures = 0;

static int run_suite(const unit_suite_t *suite, const char *filter, int list_only)
{
    int ran = 0;
    for (int i = 0; i < *suite->count; ++i) {
        const unit_test_t *t = &suite->tests[i];
        if (list_only) {
            printf("%s.%s\n", suite->name, t->name);
            continue;
        }
        char full[128];
        (void)snprintf(full, sizeof full, "%s.%s", suite->name, t->name);
        if (filter != NULL && strstr(full, filter) == NULL) {
            continue;
        }
        int before = unit_failures;
        int checks = unit_checks;
        t->fn();
        printf("%s %s.%s (%d checks)\n", unit_failures == before ? "PASS" : "FAIL", suite->name,
               t->name, unit_checks - checks);
        ++ran;
    }
    return ran;
}

int unit_main(int argc, char **argv, const unit_suite_t *suites, int n_suites)
{
    const char *filter = (argc > 1) ? argv[1] : NULL;
    int list_only = filter != NULL && strcmp(filter, "--list") == 0;
    if (list_only) {
        filter = NULL;
    }
    int ran = 0;
    for (int s = 0; s < n_suites; ++s) {
        ran += run_suite(&suites[s], filter, list_only);
    }
    if (list_only) {
        return 0;
    }
    printf("%d tests, %d checks, %d failed\n", ran, unit_checks, unit_failures);
    return (unit_failures == 0 && ran > 0) ? 0 : 1;
}
