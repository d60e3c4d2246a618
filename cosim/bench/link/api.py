"""Scripting a bench controller from Python: `Bench`, one session with one controller.

```python
from cosim.bench.api import Bench

with Bench("/dev/ttyUSB0") as bench:  # or Bench("auto"), Bench(can="socketcan:can0", node=1)
    print(bench.info().firmware)
    bench.set(comp_mode="smooth", comp_band_n=1.0, loop_kp=0.07)
    print(bench.get("comp.mode", "loop.kp"))  # {'comp.mode': 'smooth', 'loop.kp': 0.0699...}
    run = bench.run("sine", seconds=5, mean_n=8.5, amplitude_n=6.5, freq_hz=0.5, out="x.csv")
    print(run.samples, run.drops, run["T_out_N"].max())  # arrays by trace column
    print(bench.faults())
```

The session checks the device's protocol version and table hash when it opens (a mismatch is a
`cosim.bench.link.client.VersionMismatchError`), stops a stream it finds running, and stops the
device again when it closes, however the `with` block ends: the motor output is never left
enabled by a script that fails. Every failure is a `cosim.bench.link.client.BenchError` (or one of
its subclasses) with a one-line message: a value a parameter or a run cannot take (out of
range, not finite, of the wrong type: a bool is not a number) is a `ProtocolError` naming it and
what it accepts, a session or file that cannot be used (a plant parameter the FMU has not, an
`out` that is a folder or cannot be written) a `cosim.bench.link.client.BenchUsageError`, both
raised before anything is sent or written. `set` is all or nothing: a value the device's settings
check refuses puts back those written before it. A closed session refuses every call.

Parameter names are the device's (`bowden bench get` lists them): `comp.mode`, `loop.kp`,
`wave.mean_n`, ...; as keywords of `set`, the first dot may be written as an underscore
(`loop_kp=0.07`), or pass a dict: `set(**{"loop.kp": 0.07})`. Values are in SI units (the unit
is part of the name's documentation) or mode names.

`Bench(emulate=True)` without a port runs the emulated controller in this process, stepped as
fast as it computes rather than in real time (the recordings are those of `bowden emulate`,
sample for sample): scripts and their tests run without hardware.

This module is the stable surface for scripts; `cosim.bench.link.client` underneath holds the links
and the protocol and may change.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cosim.parts.geometry import in_workspace
from cosim.results.trace import META_RANGES, meta_path

from . import messages as msgs
from . import protocol
from .client import (
    BenchClient,
    BenchError,
    BenchUsageError,
    CanLink,
    DeviceInfo,
    SerialLink,
    fault_names,
)
from .protocol import param, value_from_word
from .recorder import WAVE_KINDS, RunResult, keep_recording, record_run

__all__ = [
    "Bench",
    "BenchError",
    "BenchUsageError",
    "DeviceInfo",
    "Faults",
    "ProtocolError",
    "Run",
    "WAVE_KINDS",
]

_GROUPS = tuple(sorted({p.name.split(".")[0] for p in msgs.PARAMS if "." in p.name}))


class ProtocolError(protocol.ProtocolError, BenchError):
    """A value a parameter or a run cannot take, named with what it accepts (raised before
    anything is sent). Both a `BenchError` and a `cosim.bench.link.protocol.ProtocolError` (a
    ValueError), so that either `except` takes it."""


@contextlib.contextmanager
def _refusals() -> Iterator[None]:
    """The protocol layer's refusals as this module's ProtocolError (a BenchError)."""
    try:
        yield
    except ProtocolError:
        raise
    except protocol.ProtocolError as exc:
        raise ProtocolError(str(exc)) from None


def _show(value: object, limit: int = 40) -> str:
    """A value as the caller wrote it, on one line and shortened (10**400 is not printed)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        return f"an integer of {len(str(abs(value)))} digits"
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_bool(value: object) -> bool:
    return isinstance(value, bool | np.bool_)


def _number(value: object, name: str, *, positive: bool = False) -> float:
    """A finite number (not a bool, not text) as a float; ProtocolError naming `name`."""
    kind = "a finite number > 0" if positive else "a finite number"
    if _is_bool(value) or isinstance(value, str | bytes):
        raise ProtocolError(f"{name}={_show(value)}: expected {kind}")
    try:
        v = float(value)  # type: ignore[arg-type]
    except OverflowError:  # a whole number beyond every double
        v = math.inf
    except (TypeError, ValueError):
        raise ProtocolError(f"{name}={_show(value)}: expected {kind}") from None
    if not math.isfinite(v) or (positive and v <= 0):
        raise ProtocolError(f"{name}={_show(value)}: expected {kind}")
    return v


def _flag(value: object, name: str) -> bool:
    if not _is_bool(value):
        raise BenchUsageError(f"{name}={_show(value)}: expected True or False")
    return bool(value)


def _word(p: msgs.Param, value: object) -> int:
    """A parameter's word from a value in SI units or a mode name: ProtocolError naming the
    parameter for a bool (True is not 1 A/N), a number beyond every word or anything else it
    cannot take."""
    expected = f"one of {', '.join(p.enum)}" if p.enum else "a number"
    if _is_bool(value):
        raise ProtocolError(f"{p.name}={value}: a bool is not a number; expected {expected}")
    if isinstance(value, str) and (len(value) > 40 or not value.isprintable()):
        raise ProtocolError(f"{p.name}={_show(value)}: expected {expected}")  # kept to one line
    with _refusals():
        try:
            return protocol.word_from_value(p, value)  # type: ignore[arg-type]
        except OverflowError:  # float() of a whole number beyond every double
            lo, hi = p.lo / (1 << p.frac), p.hi / (1 << p.frac)
            unit = f" {p.unit}" if p.unit else ""
            raise ProtocolError(
                f"{p.name}={_show(value)}: outside [{lo:g}, {hi:g}]{unit}"
            ) from None


def param_name(key: str) -> str:
    """A parameter's name from a keyword of `Bench.set`: `loop_kp` -> `loop.kp` (a name with a
    dot is taken as it is). ProtocolError when no parameter has that name."""
    if not isinstance(key, str):
        raise ProtocolError(f"parameter name {_show(key)}: expected a str such as 'loop.kp'")
    if key not in msgs.PARAM_BY_NAME:
        group, sep, rest = key.partition("_")
        if sep and group in _GROUPS and f"{group}.{rest}" in msgs.PARAM_BY_NAME:
            key = f"{group}.{rest}"
    with _refusals():
        return param(key).name


@dataclass(frozen=True)
class Faults:
    """The faults the controller holds: the FPGA loop's latched faults and the device's own, by
    name (empty lists when there are none), and the ticks spent with a fault."""

    fpga: list[str]
    device: list[str]
    fault_ticks: int

    def __bool__(self) -> bool:
        return bool(self.fpga or self.device)


@dataclass
class Run:
    """A recorded run: the trace file (the trace format, with its .meta.json), its columns as
    arrays, and what the recording got (`samples`, `expected`, `drops`, `faults`)."""

    trace: Path
    columns: dict[str, np.ndarray]
    result: RunResult = field(repr=False)

    def __getitem__(self, column: str) -> np.ndarray:
        """A column by its trace name: `t_s`, `T_ref_N`, `T_c_N`, `T_in_N`, `T_out_N`,
        `current_A`, `sample`, `device_time_s`, `faults`, `status`, ..."""
        return self.columns[column]

    @property
    def samples(self) -> int:
        return self.result.samples

    @property
    def expected(self) -> int:
        return self.result.expected

    @property
    def drops(self) -> int:
        """Samples missing from the recording (gaps in the sample index; never filled in)."""
        return self.result.drops

    @property
    def complete(self) -> bool:
        return self.result.samples == self.result.expected and not self.result.drops

    @property
    def faults(self) -> list[str]:
        """The fault bits seen in any telemetry frame of the run, by name."""
        return fault_names(self.result.faults)


# The end-effector's position when none is given: ChainConfig's default (scenarios.HOME_M).
_HOME_M = (0.0, 0.5, 0.0)


class _ClosedLink:
    """The link of a closed session: every use is a BenchError. (The emulator frees its plant
    when its session closes: stepping it again would crash the interpreter.)"""

    def __init__(self, url: str) -> None:
        self.url = url
        self.stats = protocol.DecoderStats()

    def _closed(self, *_args, **_kw):
        raise BenchError(f"{self.url}: the session is closed")

    send = write_raw = recv = _closed

    def close(self) -> None:
        pass


class Bench:
    """One session with one controller; use it as a context manager (see the module docstring).

    Exactly one of `port` (a pyserial URL, or `"auto"`: the only controller on the ports
    pyserial lists), `can` (a python-can `INTERFACE:CHANNEL`, with `node`) or `emulate=True`
    alone. `emulate=True` with `can` starts the real-time emulator on that bus in this process
    (python-can's `virtual` interface reaches only this process). `timeout_s`: how long to wait
    for each reply. `plant`: FMU parameters of the emulated plant (with `emulate`), as
    `bowden emulate --plant`, checked against the FMU's names and ranges; `chain`: the emulated
    bench (`cosim.bench.emulate.host_device.ChainConfig`: its position, routing and plant),
    instead of `plant`. After `close()` every call raises a BenchError.
    """

    def __init__(
        self,
        port: str | None = None,
        *,
        can: str | None = None,
        node: int = msgs.CAN_DEFAULT_NODE,
        baud: int = 921_600,
        timeout_s: float = 1.0,
        emulate: bool = False,
        plant: dict | None = None,
        chain=None,
        channels: int = 1,
    ) -> None:
        self._closed = False
        self._emulator = None
        self._chain = None  # the emulated bench's ChainConfig (with `emulate`)
        self.link = None
        self.client: BenchClient | None = None
        emulate = _flag(emulate, "emulate")
        port = _link_text(port, "port")
        can = _link_text(can, "can")
        if port is not None and can is not None:
            raise BenchError("give a port or a CAN bus, not both")
        if port is None and can is None and not emulate:
            raise BenchError("give a port (or 'auto'), a CAN bus, or emulate=True")
        if emulate and port is not None:
            raise BenchError("emulate works with a CAN bus or alone (`bowden emulate` for serial)")
        if not emulate and (plant is not None or chain is not None):
            raise BenchUsageError("plant and chain describe the emulated bench: give emulate=True")
        if can is not None and (_is_bool(node) or not isinstance(node, int)):
            raise BenchUsageError(f"node={_show(node)}: expected a whole number (a CAN node id)")
        if port is not None and (_is_bool(baud) or not isinstance(baud, int) or baud <= 0):
            raise BenchUsageError(f"baud={_show(baud)}: expected a whole number > 0")
        timeout_s = _number(timeout_s, "timeout_s", positive=True)
        if channels != 1 and not emulate:
            raise BenchUsageError("channels sets the emulated device's: give emulate=True")
        if emulate:
            chain = self._chain = _emulated_chain(plant, chain)
        try:
            if emulate and can is None:
                self.link = _emulated(chain, None, channels)
            elif can is not None:
                if emulate:
                    self._emulator = _emulated(chain, can, channels)
                self.link = CanLink(can, node=node)
            elif port is not None:
                if port == "auto":
                    from .discover import PROBE_TIMEOUT_S, auto_port  # noqa: PLC0415

                    port = auto_port(baud=baud, timeout_s=min(timeout_s, PROBE_TIMEOUT_S))
                self.link = SerialLink(port, baud=baud)
            self.client = BenchClient(self.link, timeout_s=timeout_s)
            self.connect_info = self.client.connect()
            """What HELLO said when the session opened (after stopping a run it found)."""
        except BaseException:
            self.close(stop=False)
            raise

    # --- session -----------------------------------------------------------------------------

    def __enter__(self) -> Bench:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self, stop: bool = True) -> None:
        """Stop the device (best effort: the link may be gone) and close the link. Idempotent;
        afterwards every call raises a BenchError."""
        self._closed = True
        link, self.link = self.link, None
        try:
            if link is not None and stop and self.client is not None:
                try:
                    self.client.request("STOP")
                except BenchError:
                    pass
        finally:
            if link is not None:
                if self.client is not None:
                    self.client.link = _ClosedLink(link.url)
                link.close()
            if self._emulator is not None:
                emulator, self._emulator = self._emulator, None
                emulator.stop()

    def _live(self) -> BenchClient:
        if self._closed or self.client is None:
            raise BenchError("this Bench session is closed (open a new Bench)")
        return self.client

    @property
    def url(self) -> str:
        """Where the controller is (the port's URL or the CAN bus)."""
        return self.client.link.url if self.client is not None else ""

    def info(self) -> DeviceInfo:
        """Who the device is (firmware, build, protocol, table hash) and its state now: running,
        where its configuration came from (`defaults`, `flash`, ...), unsaved changes."""
        return self._live().hello()

    # --- parameters ----------------------------------------------------------------------------

    def get(self, *names: str) -> dict[str, float | str]:
        """Parameter values in SI units (or mode names), by name; every parameter when no name
        is given."""
        client = self._live()
        wanted = [param_name(n) for n in names] or [p.name for p in msgs.PARAMS]
        return {n: value_from_word(param(n), client.get_word(n)) for n in wanted}

    def set(self, **values: float | str) -> dict[str, float | str]:
        """Write parameters (in RAM: `persist` keeps them), all or nothing: every value is
        checked before any is sent (a bool is refused: it is not a value), and when the device's
        settings check refuses one, those already written are put back. Returns the values now
        in force (rounded to the device's fixed point)."""
        from .paramset import write_all  # noqa: PLC0415

        client = self._live()
        todo = []
        given: dict[str, str] = {}
        for key, value in values.items():
            name = param_name(key)
            if name in given:
                raise ProtocolError(f"{name} given twice (as {given[name]} and {key})")
            given[name] = key
            p = param(name)
            if p.read_only:
                raise ProtocolError(f"{p.name} is read-only")
            todo.append((p, _word(p, value)))
        done = write_all(client, todo, "set")
        return {p.name: value_from_word(p, w) for p, w in done}

    def persist(self) -> int:
        """Save the parameters in the device's flash; returns the flash record's sequence."""
        return self._live().simple("PERSIST")

    def faults(self, clear: bool = False) -> Faults:
        """The faults held now (and clear them afterwards with `clear=True`)."""
        clear = _flag(clear, "clear")
        client = self._live()
        f = client.faults()
        out = Faults(
            fpga=fault_names(f["fpga_fault"] & 0x0F),
            device=fault_names(f["device_faults"]),
            fault_ticks=f["fault_ticks"],
        )
        if clear:
            client.simple("FAULT_CLEAR")
        return out

    # --- runs --------------------------------------------------------------------------------

    def run(
        self,
        waveform: str | Sequence[float] | np.ndarray,
        seconds: float,
        *,
        out: str | Path | None = None,
        mean_n: float = 8.5,
        amplitude_n: float = 6.5,
        freq_hz: float = 0.5,
        position_m: tuple[float, float, float] | None = None,
        loop_routing: bool | None = None,
        sheath_length_m: float | None = None,
        on_telemetry: Callable[[dict], None] | None = None,
    ) -> Run:
        """Run a waveform for `seconds` and record it.

        `waveform`: one of `WAVE_KINDS` (the device generates it from `mean_n`, `amplitude_n`,
        `freq_hz`), or T_ref samples in N, one per device tick, streamed to the device.
        `out`: the trace CSV to write (default: a new file in a temporary folder); its
        `.meta.json` goes beside it. The run records into `NAME.partial.csv` first, moved onto
        `out` when the run ends: a run that records nothing leaves an earlier file as it was.
        `position_m`, `loop_routing`, `sheath_length_m`: the bench as the trace's sidecar
        describes it (the bench measures none of them); default, and with `emulate` the only
        values taken: the emulated bench's (`chain`, `plant`), else (0, 0.5, 0) m, True, 1 m.
        `on_telemetry`: called with every telemetry frame as it arrives (fields as
        `cosim.bench.link.messages` names them, words not SI), from the thread that records: it must
        not block.

        Every argument is checked before anything is sent or written (the device checks its
        own limits of the waveform's values: a DeviceError). The device stops by itself after
        `seconds`; an exception or Ctrl-C stops it at once (an exception raised by
        `on_telemetry` is raised as it is, after the device stopped).
        """
        client = self._live()
        seconds = _number(seconds, "seconds", positive=True)
        kind, stream = _waveform(waveform)
        if kind != "stream":
            mean_n, amplitude_n, freq_hz = (
                _checked_wave(name, value)
                for name, value in (
                    ("mean_n", mean_n),
                    ("amplitude_n", amplitude_n),
                    ("freq_hz", freq_hz),
                )
            )
        position_m, loop_routing, sheath_length_m = self._geometry(
            position_m, loop_routing, sheath_length_m
        )
        if on_telemetry is not None and not callable(on_telemetry):
            raise BenchUsageError(f"on_telemetry={_show(on_telemetry)}: expected a function")
        target = _trace_target(out)
        partial = target.with_name(f"{target.stem}.partial{target.suffix}")
        try:
            result = record_run(
                client,
                partial,
                seconds=seconds,
                waveform=kind,
                mean_n=mean_n,
                amplitude_n=amplitude_n,
                freq_hz=freq_hz,
                stream_words=stream,
                position_m=position_m,
                loop_routing=loop_routing,
                sheath_length_m=sheath_length_m,
                tap=on_telemetry,
            )
        except BaseException as exc:
            try:
                client.request("STOP")
            except BenchError:
                pass
            finally:
                keep_recording(partial, target)
            if isinstance(exc, OSError):  # a full disk, a folder removed under the run
                raise BenchError(f"out={target}: {exc.strerror or exc} (device stopped)") from None
            if isinstance(exc, protocol.ProtocolError) and not isinstance(exc, BenchError):
                raise ProtocolError(str(exc)) from None
            raise
        if not keep_recording(partial, target):
            raise BenchError(f"out={target}: the run recorded no sample ({result.summary()})")
        return Run(trace=target, columns=_read_columns(target), result=result)

    def _geometry(self, position_m, loop_routing, sheath_length_m) -> tuple:
        """The run's position, routing and sheath length, checked (with `emulate`: the
        emulated bench's, which a different value would misdescribe)."""
        chain = self._chain
        bench = (
            (tuple(float(v) for v in chain.position_m), bool(chain.loop_routing), _sheath_m(chain))
            if chain is not None
            else (_HOME_M, True, 1.0)
        )
        if position_m is None:
            position_m = bench[0]
        if isinstance(position_m, str | bytes) or not isinstance(position_m, Sequence | np.ndarray):
            raise ProtocolError(f"position_m={_show(position_m)}: expected (x, y, z) in m")
        if len(position_m) != 3:
            raise ProtocolError(f"position_m={_show(position_m)}: expected (x, y, z) in m")
        position = tuple(_number(v, "position_m") for v in position_m)
        routing = bench[1] if loop_routing is None else _flag(loop_routing, "loop_routing")
        length = (
            bench[2] if sheath_length_m is None else _number(sheath_length_m, "sheath_length_m")
        )
        lo, hi, unit, _ = META_RANGES["sheath_length_m"]
        if not lo <= length <= hi:
            raise ProtocolError(f"sheath_length_m={length:g}: outside [{lo:g}, {hi:g}] {unit}")
        if chain is not None:
            for name, given, held, how in (
                ("position_m", position, bench[0], "chain=ChainConfig(position_m=...)"),
                ("loop_routing", routing, bench[1], "chain=ChainConfig(loop_routing=...)"),
                ("sheath_length_m", length, bench[2], "plant={'sheath_length': ...}"),
            ):
                if given != held:
                    raise BenchUsageError(
                        f"{name}={_show(given)}: the emulated bench has {_show(held)} "
                        f"(set it when the session opens: Bench(emulate=True, {how}))"
                    )
        if not bool(in_workspace(*position, length)):
            raise ProtocolError(
                f"position_m={_show(position)}: outside the workspace of a {length:g} m sheath "
                f"(sqrt(x^2 + y^2 + z^2) <= {length:g} m and y >= 0)"
            )
        return position, routing, length


def _link_text(value: object, name: str) -> str | None:
    """`port` or `can` as text (a path-like port is taken as its path)."""
    if value is None:
        return None
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str) or not value.strip():
        what = "a pyserial URL or 'auto'" if name == "port" else "INTERFACE:CHANNEL"
        raise BenchUsageError(f"{name}={_show(value)}: expected {what}")
    return value


def _emulated_chain(plant, chain):
    """The emulated bench from `plant` or `chain`, checked before anything starts: the plant's
    parameters against the FMU's (names, types, ranges), the rates, the position."""
    from dataclasses import replace  # noqa: PLC0415

    from cosim.bench.emulate.host_device import ChainConfig  # noqa: PLC0415
    from cosim.config.run import plant_overrides  # noqa: PLC0415 (reads the built FMU)

    if plant is not None and chain is not None:
        raise BenchUsageError("give plant or chain (with its plant), not both")
    if chain is None:
        chain = ChainConfig()
    elif not isinstance(chain, ChainConfig):
        raise BenchUsageError(
            f"chain={_show(chain)}: expected a cosim.bench.emulate.host_device.ChainConfig"
        )
    source, overrides = ("plant", plant) if plant is not None else ("chain.plant", chain.plant)
    if overrides is not None:
        if isinstance(overrides, dict):  # numpy scalars as the numbers they hold
            overrides = {
                k: v.item() if isinstance(v, np.generic) else v for k, v in overrides.items()
            }
        try:
            checked = plant_overrides(overrides, source)
        except ValueError as exc:
            raise BenchUsageError(str(exc)) from None
        chain = replace(chain, plant=checked or None)
    try:
        chain.decimation  # noqa: B018 (the rates' check)
    except ValueError as exc:
        raise BenchUsageError(f"chain: {exc}") from None
    pos = chain.position_m
    if isinstance(pos, str | bytes) or not isinstance(pos, Sequence | np.ndarray) or len(pos) != 3:
        raise BenchUsageError(f"chain.position_m={_show(pos)}: expected (x, y, z) in m")
    x, y, z = (_number(v, "chain.position_m") for v in pos)
    length = _sheath_m(chain)
    if not bool(in_workspace(x, y, z, length)):
        raise BenchUsageError(
            f"the emulated end-effector at ({x:g}, {y:g}, {z:g}) m is outside the workspace of "
            f"a {length:g} m sheath (sqrt(x^2 + y^2 + z^2) <= {length:g} m and y >= 0)"
        )
    if not _is_bool(chain.loop_routing):
        raise BenchUsageError(f"chain.loop_routing={_show(chain.loop_routing)}: expected a bool")
    return chain


def _sheath_m(chain) -> float:
    """The emulated plant's sheath length: its override, or the FMU's start value."""
    from cosim.parts.plant import fmu_variables  # noqa: PLC0415

    length = (chain.plant or {}).get("sheath_length")
    return float(length if length is not None else fmu_variables()["sheath_length"].start)


def _emulated(chain, can: str | None, channels: int = 1):
    """The stepped link (alone) or the real-time emulator on `can`, started; what fails while
    the plant FMU and the device are built is one BenchError. The C chain has the ideal
    interface only: another (`chain.interface`) runs on the Python engine."""
    engine = "native" if chain.interface == "ideal" else "python"
    try:
        if can is None:
            from cosim.bench.emulate.emulator import SteppedLink  # noqa: PLC0415

            return SteppedLink(chain, engine=engine, channels=channels)
        from cosim.bench.emulate.emulator import Emulator  # noqa: PLC0415

        return Emulator(
            pty=False, tcp_port=None, can=can, chain=chain, engine=engine, channels=channels
        ).start()
    except BenchError:
        raise
    except Exception as exc:  # noqa: BLE001 (the FMU's, ctypes', python-can's: named below)
        raise BenchError(f"the emulated bench did not start: {_one_line(exc)}") from None


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _checked_wave(name: str, value: object) -> float:
    """mean_n, amplitude_n, freq_hz: numbers the device's wave.* parameters take."""
    v = _number(value, name)
    _word(param(f"wave.{name}"), v)
    return v


def _waveform(waveform) -> tuple[str, list[int] | None]:
    """A waveform's name, or T_ref samples in N as the stream's words (ProtocolError naming the
    first sample that does not fit)."""
    expected = f"one of {', '.join(WAVE_KINDS)} or a sequence of T_ref samples in N"
    if isinstance(waveform, str):
        if waveform not in WAVE_KINDS:
            raise ProtocolError(f"waveform {waveform!r}: expected {expected}")
        return waveform, None
    samples = np.asarray(waveform) if not isinstance(waveform, bytes | dict | set) else None
    if samples is not None and samples.dtype.kind == "O":
        try:
            samples = samples.astype(float)
        except (TypeError, ValueError, OverflowError):
            samples = None
    if samples is None or samples.dtype.kind not in "iuf" or samples.ndim != 1:
        raise ProtocolError(f"waveform {_show(waveform)}: expected {expected}")
    if samples.size == 0:
        raise ProtocolError("waveform: no samples (expected T_ref samples in N, one per tick)")
    p = param("wave.mean_n")
    # The STREAM message carries each sample as a signed word of its field's size (Q7.8 N).
    field = msgs.MESSAGES["STREAM"].fields[-1]
    top = 1 << (8 * field.size - 1)
    words = []
    for i, v in enumerate(samples.tolist()):
        try:
            word = _word(p, v)
        except ProtocolError as exc:
            raise ProtocolError(f"waveform[{i}]: {exc}") from None
        if not -top <= word < top:
            raise ProtocolError(
                f"waveform[{i}]={v:g}: outside [{-top * field.scale:g}, "
                f"{(top - 1) * field.scale:g}] {field.unit} (a T_ref sample of the stream)"
            )
        words.append(word)
    return "stream", words


def _trace_target(out) -> Path:
    """`out` checked before anything is sent or written: a CSV file name (not a folder) in a
    folder that exists or can be made and can be written (a probe file is made and removed)."""
    if out is None:
        return Path(tempfile.mkdtemp(prefix="bowden-run-")) / "run.csv"
    text = os.fspath(out) if isinstance(out, str | os.PathLike) else None
    if not isinstance(text, str) or not text.strip():
        raise BenchUsageError(f"out={_show(out)}: expected a CSV file name (str or Path)")
    path = Path(text)
    if text.endswith(os.sep) or path.is_dir():
        raise BenchUsageError(f"out={text}: is a folder; give a CSV file name (e.g. run.csv)")
    partial = path.with_name(f"{path.stem}.partial{path.suffix}")
    for p in (path, partial, meta_path(path), meta_path(partial)):
        if p.exists() and not p.is_file():
            raise BenchUsageError(f"out={text}: {p} is not a regular file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BenchUsageError(
            f"out={text}: cannot make its folder {path.parent} ({exc.strerror or exc})"
        ) from None
    try:
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"):
            pass
    except OSError as exc:
        raise BenchUsageError(
            f"out={text}: cannot write in {path.parent} ({exc.strerror or exc})"
        ) from None
    return path


def _read_columns(path: Path) -> dict[str, np.ndarray]:
    """A recording's columns as float arrays (also one with gaps, which the trace reader
    `cosim.results.trace` refuses)."""
    with path.open() as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        return {name: np.zeros(0) for name in header}
    return {name: data[:, i] for i, name in enumerate(header)}
