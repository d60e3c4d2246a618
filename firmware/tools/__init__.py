"""Reports on the firmware's objects and benchmarks: elf_report, bench_callgrind."""
