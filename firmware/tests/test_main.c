/*
 * test_main.c - the host unit-test program of the firmware: the fxp, comp, fric_est, fric_corr and fw suites through
 * the shared runner (unit_main.c; `--list`, a name filter as argv[1]).
 */
#include "unit.h"

extern const unit_test_t fxp_tests[];
extern const int fxp_tests_count;
extern const unit_test_t comp_tests[];
extern const int comp_tests_count;
extern const unit_test_t fric_est_tests[];
extern const int fric_est_tests_count;
extern const unit_test_t fric_corr_tests[];
extern const int fric_corr_tests_count;
extern const unit_test_t fw_tests[];
extern const int fw_tests_count;

int main(int argc, char **argv)
{
    static const unit_suite_t suites[] = {
        {"fxp", fxp_tests, &fxp_tests_count},
        {"comp", comp_tests, &comp_tests_count},
        {"fric_est", fric_est_tests, &fric_est_tests_count},
        {"fric_corr", fric_corr_tests, &fric_corr_tests_count},
        {"fw", fw_tests, &fw_tests_count},
    };
    return unit_main(argc, argv, suites, (int)(sizeof suites / sizeof suites[0]));
}
