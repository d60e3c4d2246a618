"""`bowden tune`: the tuning procedure of cosim.studies.tune (the `tune` scenario only), its table,
the chosen point as a params file, and the stability margin."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from cosim.parts.interface import INTERFACES
from cosim.project.cliargs import output_dir
from cosim.project.paths import BUILD_DIR, require_project


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "tune",
        help="choose Kp, Ki, the smooth band and the preview horizon on the tune scenario only",
        description=(__doc__ or "").split("\n\n")[0],
    )
    p.add_argument("--out", type=output_dir, default=BUILD_DIR / "tune", help="output folder")
    p.add_argument(
        "--interface",
        choices=INTERFACES,
        default="board",
        help="plant <-> core during the tuning (default board, the chain the demo reports)",
    )
    p.add_argument(
        "--params",
        default=None,
        help='JSON params file the tuning starts from (e.g. {"board": {"adc": "ads1220"}} '
        "for a board with the ADS1220 front-end); the chosen point overrides its gains",
    )
    p.add_argument(
        "--no-confirm",
        action="store_true",
        help="skip the confirmation of the chosen point in the fixed-point chain",
    )
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from cosim.config.run import load_params  # noqa: PLC0415
    from cosim.studies.tune import tune  # noqa: PLC0415

    try:
        require_project()
        base = load_params(args.params)
    except ValueError as exc:
        print(f"bowden tune: {exc}", file=sys.stderr)
        return 2

    def log(line: str) -> None:
        if not args.quiet:
            print(line, file=sys.stderr, flush=True)

    try:
        result = tune(interface=args.interface, cfg=base, confirm=not args.no_confirm, log=log)
    except (RuntimeError, ValueError) as exc:
        print(f"bowden tune: {exc}", file=sys.stderr)
        return 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    params = result.params()
    if args.params is not None:  # the file tuned from, with the chosen point over it
        merged = json.loads(Path(args.params).read_text(encoding="utf-8"))
        for group, values in params.items():
            merged.setdefault(group, {}).update(values)
        params = merged
    (out / "tuned_params.json").write_text(json.dumps(params, indent=2) + "\n")
    summary = result.summary()
    (out / "summary.md").write_text(summary + "\n")
    print(summary)
    print(f"wrote {out / 'tuned_params.json'} (bowden sim --params) and {out / 'summary.md'}")
    return 0
