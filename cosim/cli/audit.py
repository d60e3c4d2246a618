"""`bowden audit DATA.csv [--out DIR] [--emit-params FILE]`: the model audit from the command
line. Prints a progress line on stderr while it fits and a short summary at the end; writes
DIR/audit.json, DIR/report.md and the plots it links."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from cosim.audit.params import FIG14_DEFAULT_DURATION_S
from cosim.project.cliargs import output_dir, unwritable

from . import output_reader_gone


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "audit",
        help="model audit: what the simulation gets wrong on measured data, the cause, the gain",
        description=(
            "Fit the plant model to measured tension data (t_s, T_in_N, T_out_N; optional "
            "x_m, y_m, z_m and a DATA.meta.json sidecar), name what it gets wrong from the FMU's "
            "effects, extend it and measure the gain on held-out data."
        ),
    )
    p.add_argument("data", help="measured trace: CSV with t_s, T_in_N, T_out_N (and more)")
    p.add_argument(
        "--out",
        default=None,
        type=output_dir,
        help="output folder (default: DATA's folder/<stem>_audit)",
    )
    p.add_argument(
        "--emit-params",
        default=None,
        metavar="FILE",
        help="write the extended model's parameters for `bowden sim --params FILE` and measure "
        "what they change in fig14",
    )
    p.add_argument(
        "--fig14-duration",
        type=float,
        default=FIG14_DEFAULT_DURATION_S,
        metavar="S",
        help=f"simulated seconds of the fig14 comparison (default {FIG14_DEFAULT_DURATION_S:g})",
    )
    p.add_argument(
        "--resample",
        action="store_true",
        help="put a record whose timestamps jitter (a PC's clock) on a uniform grid at its "
        "sample rate by linear interpolation (noted in the report)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress line")
    p.set_defaults(func=main)


class _Bar:
    """One stderr line: fraction done and what is being fitted."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.start = time.perf_counter()

    def __call__(self, message: str, fraction: float) -> None:
        from cosim.cli import check_interrupted  # noqa: PLC0415

        check_interrupted()  # a signal whose exception a __del__ swallowed ends the audit here
        if not self.enabled:
            return
        filled = int(round(20 * fraction))
        line = (
            f"\raudit [{'#' * filled}{'-' * (20 - filled)}] {100 * fraction:3.0f} % "
            f"{time.perf_counter() - self.start:5.1f} s  {message[:70]:<70}"
        )
        sys.stderr.write(line)
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")
            sys.stderr.flush()


def main(args: argparse.Namespace) -> int:
    from cosim.results import trace  # noqa: PLC0415

    data_path = Path(args.data)
    if not (math.isfinite(args.fig14_duration) and 2.0 <= args.fig14_duration <= 30.0):
        print(
            f"bowden audit: --fig14-duration must be in [2, 30] s; got {args.fig14_duration!r}",
            file=sys.stderr,
        )
        return 2
    out_dir = Path(args.out) if args.out else data_path.with_name(data_path.stem + "_audit")
    emit = Path(args.emit_params) if args.emit_params else None
    # A path that cannot be written is said before the audit runs, not after a minute of fits.
    out_name = "--out" if args.out else "the output folder"
    for option, path, folder in ((out_name, out_dir, True), ("--emit-params", emit, False)):
        problem = path is not None and unwritable(path, folder)
        if problem:
            print(f"bowden audit: {option} cannot be written: {problem}", file=sys.stderr)
            return 2
    try:
        tr = trace.read_trace(data_path, mode="measured", resample=args.resample)
    except trace.TraceError as exc:
        print(f"bowden audit: {exc}", file=sys.stderr)
        return 2
    # The fits' libraries (scipy, numba, matplotlib: 2 s of a command's 2.5) only once the
    # arguments and the file are known good: a mistyped path or option is said at once.
    from cosim.audit import core, params, report  # noqa: PLC0415

    try:
        data = core.prepare(tr, str(data_path))
    except (trace.TraceError, core.AuditError) as exc:
        print(f"bowden audit: {exc}", file=sys.stderr)
        return 2
    bar = _Bar(not args.quiet)
    try:
        result = core.run(data, progress=bar)
        emitted = None
        if emit is not None:
            bar("fig14: default compensator against the emitted parameters", 1.0)
            emitted, notes = params.emitted_params(result)
            params.check_params(emit, emitted)
            fig = params.fig14_change(
                emitted, data.inputs.loop_routing, args.fig14_duration, progress=False
            )
            result.extras["emitted_params"] = {"file": str(emit), "params": emitted, "notes": notes}
            result.extras["fig14"] = fig
        bar.close()
        # The set (audit.json, report.md, plots, and the --params file) is written to temporary
        # names and moved in place together at the end: an interrupted audit leaves the previous
        # set, or none, never half of one.
        _write_set(out_dir, result, emit, emitted, report)
    except FileNotFoundError as exc:  # the FMU is not built
        bar.close()
        print(f"bowden audit: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # --out or --emit-params cannot be written
        bar.close()
        if output_reader_gone(exc):
            raise  # `... | head`: main() ends quietly
        where = f": {exc.filename}" if exc.filename else ""
        print(f"bowden audit: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1
    except (RuntimeError, ValueError) as exc:
        bar.close()
        print(f"bowden audit: {exc}", file=sys.stderr)
        return 1
    print(report.summary(result))
    if "fig14" in result.extras:
        print("  params   " + f"wrote {args.emit_params}; " + result.extras["fig14"]["text"])
        for note in result.extras["emitted_params"]["notes"]:
            print(f"           note: {note}")
    n_plots = len(result.extras.get("plots", []))
    print(f"wrote {out_dir / 'audit.json'}, {out_dir / 'report.md'} and {n_plots} plots")
    return 0


def _write_set(out_dir: Path, result, emit: Path | None, emitted: dict | None, report) -> None:
    """Write the output folder's files and the --params file as one set (as `bowden sim` does):
    into a staging folder inside out_dir (and a temporary name beside the --params file), then
    moved in place at the end, audit.json last, so that an interrupted or failed audit leaves
    the files of an earlier one whole and never a report without its audit.json."""
    import json  # noqa: PLC0415
    import os  # noqa: PLC0415
    import shutil  # noqa: PLC0415
    import tempfile  # noqa: PLC0415

    out_dir.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".writing-", dir=out_dir))
    tmp_params = None
    try:
        names = report.plots(stage, result)
        result.extras["plots"] = names
        data_dict = report.write_json(stage / "audit.json", result)
        (stage / "report.md").write_text(report.markdown(result, data_dict, names))
        if emit is not None and emitted is not None:
            emit.parent.mkdir(parents=True, exist_ok=True)
            fd, name = tempfile.mkstemp(prefix=f".{emit.name}.", dir=emit.parent)
            tmp_params = Path(name)
            with open(fd, "w") as fh:
                fh.write(json.dumps(emitted, indent=2) + "\n")
        for name in [*names, "report.md", "audit.json"]:
            os.replace(stage / name, out_dir / name)
        if tmp_params is not None:
            os.replace(tmp_params, emit)
            tmp_params = None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if tmp_params is not None:
            tmp_params.unlink(missing_ok=True)
