"""The RV32 image's tools: mkimage, rv32_report, rv32_profile."""
