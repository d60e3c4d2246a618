"""The bending angle over the workspace: calibrate's map step.

Loop routing keeps the sheath's bending angle near 2 pi wherever the end-effector is (paper,
Sec. IV), but a real sheath sags under its own weight, is pushed sideways and stretched as the
end-effector moves (the FMU's bending-angle error: fmu/README.md, "Effects"), so the friction's
exponent mu*phi changes with the position. Calibrate's identification at one position (home)
sees mu*phi there only; a compensator without a far-end sensor that runs elsewhere carries that
position's error in full, since nothing measures it while running.

The map step (calibrate.make_bend_map, which records; this module fits and reads) records the
first pieces of the identification (MAP_PIECES: the start and the
full range at the slow and the medium rate, long enough for the audit's blocks) at home and at a
few further positions, and fits to each recording the one number that scales the bending angle
of home's audited model (so every term the friction multiplies by phi: mu, its tension slope,
the breakaway, the speed terms; `fit_ratio`). The ratio at a position over the one at home is
k = phi(p) / phi(home): home's own recording of the same sequence takes out what home's model
misses (an effect the audit saw but did not name, a slack below the range's low end), which
would otherwise bias every position alike. The map is the plane
through those ratios, k(p) = 1 + G . (p - home), least squares over the positions (the minimum-
norm G when they do not span three directions: no change along a direction not measured), and
k held to [K_MIN, K_MAX] (`BendMap.ratio`). The host that places the end-effector sets the
compensator's angle for each position from it, comp.phi_rad(p) = comp.phi_rad(home) k(p)
(`BendMap.phi_at`); every term the compensator multiplies by phi follows (firmware/include/comp.h).

A plane is the first order of whatever the sheath does; a rig whose error bends over the
workspace wants more positions than directions, and the fit's residual over them
(`BendMap.residual`) says how far the plane misses.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# The further positions of the map when none are given, m (x, y, z; home is HOME_M = (0, 0.5,
# 0)): 0.2 m from home along each axis, inside the workspace of a 1 m sheath (radius <= 1 m,
# y >= 0) and inside the span of the positions the sweeps run at (cosim/studies/sweep/examples).
DEFAULT_POSITIONS_M: tuple[tuple[float, float, float], ...] = (
    (0.2, 0.5, 0.0),
    (0.0, 0.7, 0.0),
    (0.0, 0.5, 0.2),
)
# The identification's pieces recorded at each further position: the start, the full range at the
# slow rate with holds, and at the medium rate (10.7 s: the audit's blocks need 10 s).
MAP_PIECES = 3
# The ratios a map gives: a bending angle a quarter smaller or a third larger than home's is
# beyond what a sheath's sag or stretch makes of 2 pi (the FMU's errors reach +-0.6 rad at the
# workspace's edge, 10 %); a fit that ends at a bound is refused.
K_MIN = 0.75
K_MAX = 1.33
FILE = "bend_map.json"


class BendMapError(ValueError):
    """A map that cannot be made or read; the message names the position or the file."""


@dataclass
class Point:
    """One position of the map: the ratio fitted there and how well it fits."""

    position_m: tuple[float, float, float]
    ratio: float  # phi(p) / phi(home) as the friction sees it
    rms_home_n: float  # the recording against home's model as it is (k = 1)
    rms_fit_n: float  # ... with the fitted k
    file: str = ""  # the recording


@dataclass
class BendMap:
    """k(p) = 1 + gradient_per_m . (p - home_m), within [K_MIN, K_MAX]."""

    home_m: tuple[float, float, float]
    gradient_per_m: tuple[float, float, float]
    points: list[Point] = field(default_factory=list)
    # the ratio fitted at home itself, which the points' ratios are divided by (make): 1 where
    # home's audited model is the plant, else what it misses of the map's sequence
    home_ratio: float = 1.0

    def ratio(self, position_m: Sequence[float]) -> float:
        d = np.asarray(position_m, dtype=float) - np.asarray(self.home_m, dtype=float)
        k = 1.0 + float(np.dot(self.gradient_per_m, d))
        return min(K_MAX, max(K_MIN, k))

    def phi_at(self, phi_home_rad: float, position_m: Sequence[float]) -> float:
        """The compensator's bending angle at `position_m`, from its angle at home."""
        return float(phi_home_rad) * self.ratio(position_m)

    @property
    def residual(self) -> float:
        """The largest |k_fitted - k(p)| over the map's positions: how far the plane misses."""
        return max((abs(p.ratio - self.ratio(p.position_m)) for p in self.points), default=0.0)

    def to_dict(self) -> dict:
        return {
            "home_m": list(self.home_m),
            "gradient_per_m": list(self.gradient_per_m),
            "residual": self.residual,
            "home_ratio": self.home_ratio,
            "points": [
                {**dataclasses.asdict(p), "position_m": list(p.position_m)} for p in self.points
            ],
            "law": "comp.phi_rad(p) = comp.phi_rad(home) * clip(1 + gradient_per_m . (p - home_m), "
            f"{K_MIN}, {K_MAX})",
        }

    @classmethod
    def from_dict(cls, doc: dict, source: str = "bend map") -> BendMap:
        try:
            home = _triple(doc["home_m"], f"{source}: home_m")
            grad = _triple(doc["gradient_per_m"], f"{source}: gradient_per_m")
            points = [
                Point(
                    _triple(p["position_m"], f"{source}: a point's position_m"),
                    float(p["ratio"]),
                    float(p["rms_home_n"]),
                    float(p["rms_fit_n"]),
                    str(p.get("file", "")),
                )
                for p in doc.get("points", [])
            ]
        except (KeyError, TypeError, ValueError) as exc:
            raise BendMapError(f"{source}: not a bending-angle map ({exc})") from None
        return cls(home, grad, points, float(doc.get("home_ratio", 1.0)))

    def write(self, path: Path) -> None:
        from cosim.bench.link.paramset import write_atomic  # noqa: PLC0415

        write_atomic(path, json.dumps(self.to_dict(), indent=2) + "\n")


def read(path: Path) -> BendMap:
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise BendMapError(f"{path}: cannot read a bending-angle map ({exc})") from None
    return BendMap.from_dict(doc, str(path))


def _triple(v, what: str) -> tuple[float, float, float]:
    t = tuple(float(x) for x in v)
    if len(t) != 3 or not all(math.isfinite(x) for x in t):
        raise BendMapError(f"{what}: expected three finite numbers (x, y, z in m), got {v!r}")
    return t  # type: ignore[return-value]


def parse_positions(text: str, option: str = "--map") -> tuple[tuple[float, float, float], ...]:
    """'x,y,z;x,y,z;...' in m (the command line's `option`)."""
    out = []
    for part in text.split(";"):
        if not part.strip():
            continue
        bits = part.split(",")
        try:
            vals = tuple(float(b) for b in bits)
        except ValueError:
            vals = ()
        if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
            raise BendMapError(
                f"{option}: {part.strip()!r} is not a position x,y,z in m "
                "(positions apart by ';', e.g. '0.2,0.5,0;0,0.7,0')"
            )
        out.append(vals)
    if not out:
        raise BendMapError(f"{option}: no position given (e.g. '0.2,0.5,0;0,0.7,0')")
    return tuple(out)  # type: ignore[return-value]


def positions_of(option: str | None, sheath_length_m: float = 1.0) -> tuple:
    """The positions of a `--map` option: none without it, DEFAULT_POSITIONS_M for its bare
    form ("default"), else parse_positions; each inside the workspace of the sheath
    (BendMapError naming the first that is not)."""
    from cosim.parts.geometry import in_workspace  # noqa: PLC0415

    if option is None:
        return ()
    positions = DEFAULT_POSITIONS_M if option == "default" else parse_positions(option)
    for p in positions:
        if not bool(in_workspace(*p, sheath_length_m)):
            raise BendMapError(
                f"--map: position {show_position(p)} m is outside the workspace of a "
                f"{sheath_length_m:g} m sheath (sqrt(x^2 + y^2 + z^2) <= {sheath_length_m:g} m "
                "and y >= 0)"
            )
    return positions


def fit_ratio(data, params: dict, phi_home_rad: float) -> tuple[float, float, float]:
    """(k, RMS at k = 1, RMS at k) of a recording `data` (cosim.audit.data.AuditData, made at
    some position) against home's model `params` (FMU names, the audit's extended model): the
    twin driven by the recording's input tension with the bending angle k * phi_home_rad (home's
    angle as the audit saw it, its position-dependent errors 0), over the samples after the
    warm-up. k on [K_MIN, K_MAX] by a bounded scalar search; a k at a bound raises
    BendMapError."""
    from scipy.optimize import minimize_scalar  # noqa: PLC0415

    from cosim.audit import twin  # noqa: PLC0415
    from cosim.audit.data import WARMUP  # noqa: PLC0415

    p = {k: v for k, v in params.items() if not k.startswith("phi_offset_per_")}
    base = data.inputs
    n = len(base.t_in_n)
    keep = data.roles != WARMUP
    y = data.t_out_n[keep]

    def rms(k: float) -> float:
        inputs = dataclasses.replace(base, phi_rad=np.full(n, k * phi_home_rad), position_m=None)
        r = y - twin.simulate(inputs, p)[keep]
        return math.sqrt(float(np.mean(r * r)))

    res = minimize_scalar(rms, bounds=(K_MIN, K_MAX), method="bounded", options={"xatol": 1e-6})
    k = float(res.x)
    if min(k - K_MIN, K_MAX - k) < 1e-3:
        raise BendMapError(
            f"{data.source}: the bending angle's ratio to home's ends at a bound of "
            f"[{K_MIN}, {K_MAX}] ({k:.4f}): the recording is not the plant at home moved"
        )
    return k, rms(1.0), float(res.fun)


def fit_plane(home_m, points: list[Point]) -> BendMap:
    """The least-squares plane k(p) = 1 + G . (p - home) through the points (minimum norm)."""
    h = np.asarray(home_m, dtype=float)
    if not points:
        raise BendMapError("a bending-angle map needs at least one position besides home")
    d = np.array([np.asarray(p.position_m, dtype=float) - h for p in points])
    if np.any(np.linalg.norm(d, axis=1) < 1e-3):
        raise BendMapError("a map position is home itself (within 1 mm): give positions apart")
    k = np.array([p.ratio - 1.0 for p in points])
    g, *_ = np.linalg.lstsq(d, k, rcond=None)
    return BendMap(tuple(float(v) for v in h), tuple(float(v) for v in g), list(points))  # type: ignore[arg-type]


def point_of(path: Path, position_m, params: dict, phi_home_rad: float, tare_n: float) -> Point:
    """The map's point of a recording at `position_m` (the far-end cell's tare `tare_n` taken
    off T_out, as calibrate does)."""
    from cosim.audit import core  # noqa: PLC0415
    from cosim.results import trace as trace_mod  # noqa: PLC0415

    try:
        tr = trace_mod.read_trace(path, mode="measured")
        tr.columns["T_out_N"] = tr.columns["T_out_N"] - tare_n
        data = core.prepare(tr, str(path))
    except (trace_mod.TraceError, core.AuditError) as exc:
        raise BendMapError(f"{path}: {exc}") from None
    k, rms_home, rms_fit = fit_ratio(data, params, phi_home_rad)
    pos = tuple(float(v) for v in position_m)
    return Point(pos, k, rms_home, rms_fit, Path(path).name)  # type: ignore[arg-type]


def show_position(p) -> str:
    return "(" + ", ".join(f"{float(v):g}" for v in p) + ")"


def emulated_at(plant: dict | None, loop_routing: bool = True):
    """bench_at for an emulated bench: the plant `plant` (FMU parameters) with the end-effector
    at p, stopped and closed afterwards."""
    import contextlib  # noqa: PLC0415

    from cosim.bench.emulate.host_device import ChainConfig  # noqa: PLC0415
    from cosim.bench.link.api import Bench  # noqa: PLC0415

    @contextlib.contextmanager
    def at(p):
        chain = ChainConfig(
            position_m=tuple(float(v) for v in p), loop_routing=loop_routing, plant=plant
        )
        with Bench(emulate=True, chain=chain) as bench:
            client = bench.client
            yield client, lambda: client.request("STOP")

    return at


def main(argv: list[str] | None = None) -> int:
    """`python -m cosim.bench.rig.bend_map FILE --phi-home RAD --at X,Y,Z[;X,Y,Z...]`: the
    compensator's bending angle at each position from a calibration's map."""
    import argparse  # noqa: PLC0415
    import sys  # noqa: PLC0415

    ap = argparse.ArgumentParser(
        prog="python -m cosim.bench.rig.bend_map",
        description="The compensator's bending angle (comp.phi_rad) at positions of the "
        "end-effector, from the map `bowden bench calibrate --map` wrote (bend_map.json) and "
        "the device's angle at home (calibration.json's device_phi_rad).",
    )
    ap.add_argument("file", help="bend_map.json of a calibration")
    ap.add_argument("--phi-home", type=float, required=True, metavar="RAD", help="comp.phi_rad")
    ap.add_argument("--at", required=True, metavar="X,Y,Z;...", help="positions in m")
    args = ap.parse_args(argv)
    try:
        m = read(Path(args.file))
        if not (math.isfinite(args.phi_home) and 0.0 < args.phi_home <= 4.0 * math.pi):
            raise BendMapError(f"--phi-home {args.phi_home:g}: expected an angle in (0, 4 pi] rad")
        positions = parse_positions(args.at, "--at")
    except BendMapError as exc:
        print(f"bend_map: {exc}", file=sys.stderr)
        return 2
    for p in positions:
        k = m.ratio(p)
        print(f"{show_position(p)} m: k {k:.4f}, comp.phi_rad {m.phi_at(args.phi_home, p):.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
