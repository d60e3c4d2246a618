/*
 * bench_main.c - the host unit-test program of the bench protocol and device (proto, proto_can,
 * params, flash, dev). Same harness and interface as firmware/tests/test_main.c: runs every test
 * (or those whose name contains argv[1]), `--list` prints the names.
 */
#include <stdio.h>
#include <string.h>

#include "unit.h"

int unit_checks = 0;
int unit_failures = 0;

extern const unit_test_t proto_tests[];
extern const int proto_tests_count;
extern const unit_test_t store_tests[];
extern const int store_tests_count;
extern const unit_test_t dev_tests[];
extern const int dev_tests_count;

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
    run_suite("proto", proto_tests, proto_tests_count, filter, &ran);
    run_suite("store", store_tests, store_tests_count, filter, &ran);
    run_suite("dev", dev_tests, dev_tests_count, filter, &ran);
    if (list_only) {
        return 0;
    }
    printf("%d tests, %d checks, %d failed\n", ran, unit_checks, unit_failures);
    return (unit_failures == 0 && ran > 0) ? 0 : 1;
}
