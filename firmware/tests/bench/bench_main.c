/*
 * bench_main.c - the host unit-test program of the bench protocol and device (proto, proto_can,
 * params, flash, dev): the proto, store, dev and channel suites through the firmware's shared runner
 * (firmware/tests/unit_main.c; `--list`, a name filter as argv[1]).
 */
#include "unit.h"

extern const unit_test_t proto_tests[];
extern const int proto_tests_count;
extern const unit_test_t store_tests[];
extern const int store_tests_count;
extern const unit_test_t dev_tests[];
extern const int dev_tests_count;
extern const unit_test_t channel_tests[];
extern const int channel_tests_count;

int main(int argc, char **argv)
{
    static const unit_suite_t suites[] = {
        {"proto", proto_tests, &proto_tests_count},
        {"store", store_tests, &store_tests_count},
        {"dev", dev_tests, &dev_tests_count},
        {"channels", channel_tests, &channel_tests_count},
    };
    return unit_main(argc, argv, suites, (int)(sizeof suites / sizeof suites[0]));
}
