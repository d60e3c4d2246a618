"""`bowden sweep SPEC.yaml --out DIR`: many native closed-loop runs on Dask, one table.

The command line only: it parses the arguments and calls cosim.studies.sweep.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from cosim.project.cliargs import output_dir, shown


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep",
        help="many native closed-loop runs over a grid or a random sample, on Dask",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("spec", help="the sweep specification (YAML; cosim/studies/sweep/spec.py)")
    p.add_argument("--out", required=True, type=output_dir, help="output folder")
    p.add_argument(
        "--scheduler",
        default=None,
        help="address of a running Dask scheduler (tcp://HOST:PORT); default: a local cluster",
    )
    p.add_argument(
        "--workers", type=int, default=None, help="local cluster: worker processes (default: cores)"
    )
    p.add_argument(
        "--retry-failed",
        action="store_true",
        help="run again the points recorded as failed (by default a resume keeps them)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    import yaml  # noqa: PLC0415

    from cosim.project.paths import require_project  # noqa: PLC0415
    from cosim.studies.sweep.spec import SpecError, load_spec  # noqa: PLC0415
    from cosim.studies.workers import MAX_WORKERS  # noqa: PLC0415

    try:
        spec = load_spec(args.spec)
        if args.workers is not None and not 1 <= args.workers <= MAX_WORKERS:
            raise SpecError(f"--workers must be in [1, {MAX_WORKERS}]; got {args.workers}")
        if args.workers is not None and args.scheduler is not None:
            raise SpecError(
                "--workers sizes the local cluster; with --scheduler the cluster's own workers "
                "run the points (give one or the other)"
            )
        if args.out.exists() and not args.out.is_dir():  # before the scheduler is asked
            raise SpecError(f"--out {shown(args.out)}: is a file, not a folder")
        if args.scheduler is not None and "://" not in args.scheduler:
            raise SpecError(
                f"--scheduler must be an address like tcp://HOST:PORT; got {args.scheduler!r}"
            )
        require_project()
        if args.scheduler is not None:  # before anything is written, within a stated time
            from cosim.studies.sweep.scheduler import probe  # noqa: PLC0415

            probe(args.scheduler)
    except (SpecError, ValueError, FileNotFoundError) as exc:
        print(f"bowden sweep: {exc}", file=sys.stderr)
        return 2
    spec_dict = yaml.safe_load(Path(args.spec).read_text(encoding="utf-8"))
    return run_and_report(
        spec, spec_dict, Path(args.out), args.scheduler, args.workers, args.quiet, args.retry_failed
    )


def run_and_report(
    spec, spec_dict, out: Path, scheduler, workers, quiet, retry_failed=False
) -> int:
    from cosim.studies.sweep.atomic import write_text  # noqa: PLC0415
    from cosim.studies.sweep.run import TABLE, run_sweep  # noqa: PLC0415
    from cosim.studies.sweep.table import plot_sweep, summary, write_table  # noqa: PLC0415

    def log(msg: str) -> None:
        if not quiet:
            print(msg, file=sys.stderr, flush=True)

    from cosim.studies.sweep.run import OutDirError  # noqa: PLC0415

    try:
        rows = run_sweep(
            spec, spec_dict, out, scheduler, workers, not quiet, log, retry_failed=retry_failed
        )
    except OutDirError as exc:  # --out a file, or holding another run's points: a usage error
        print(f"bowden sweep: {exc}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError, TimeoutError) as exc:
        print(f"bowden sweep: {exc}", file=sys.stderr)
        return 1
    write_table(rows, out / TABLE)
    plots = plot_sweep(rows, list(spec.axes), out)
    write_text(
        out / "summary.json",
        json.dumps(
            {
                "points": len(rows),
                "failed": sum(r.get("status") != "ok" for r in rows),
                "table": TABLE,
                "plots": [p.name for p in plots],
            },
            indent=2,
        )
        + "\n",
    )
    print(summary(rows))
    print(f"wrote {out / TABLE} ({len(rows)} points) and {len(plots)} plots")
    return 0
