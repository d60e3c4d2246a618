"""`bowden doctor`: print the versions of every tool; fail if one is missing
(cosim.project.doctor)."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    doctor = subparsers.add_parser(
        "doctor", help="print the versions of every tool; fail if one is missing"
    )
    doctor.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from cosim.project.doctor import main as doctor_main  # noqa: PLC0415

    return doctor_main()
