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
`cosim.bench.client.VersionMismatchError`), stops a stream it finds running, and stops the
device again when it closes, however the `with` block ends: the motor output is never left
enabled by a script that fails. Every failure is a `cosim.bench.client.BenchError` (or its
subclasses) with a one-line message; values out of range are `ProtocolError`s naming the
parameter and its range, raised before anything is sent.

Parameter names are the device's (`bowden bench get` lists them): `comp.mode`, `loop.kp`,
`wave.mean_n`, ...; as keywords of `set`, the first dot may be written as an underscore
(`loop_kp=0.07`), or pass a dict: `set(**{"loop.kp": 0.07})`. Values are in SI units (the unit
is part of the name's documentation) or mode names.

`Bench(emulate=True)` without a port runs the emulated controller in this process, stepped as
fast as it computes rather than in real time (the recordings are those of `bowden emulate`,
sample for sample): scripts and their tests run without hardware.

This module is the stable surface for scripts; `cosim.bench.client` underneath holds the links
and the protocol and may change.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import messages as msgs
from .client import BenchClient, BenchError, CanLink, DeviceInfo, SerialLink, fault_names
from .protocol import ProtocolError, param, value_from_word, word_from_value
from .recorder import WAVE_KINDS, RunResult, record_run

__all__ = ["Bench", "BenchError", "DeviceInfo", "Faults", "ProtocolError", "Run", "WAVE_KINDS"]

_GROUPS = tuple(sorted({p.name.split(".")[0] for p in msgs.PARAMS if "." in p.name}))


def param_name(key: str) -> str:
    """A parameter's name from a keyword of `Bench.set`: `loop_kp` -> `loop.kp` (a name with a
    dot is taken as it is). ProtocolError when no parameter has that name."""
    if key not in msgs.PARAM_BY_NAME:
        group, sep, rest = key.partition("_")
        if sep and group in _GROUPS and f"{group}.{rest}" in msgs.PARAM_BY_NAME:
            key = f"{group}.{rest}"
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


class Bench:
    """One session with one controller; use it as a context manager (see the module docstring).

    Exactly one of `port` (a pyserial URL, or `"auto"`: the only controller on the ports
    pyserial lists), `can` (a python-can `INTERFACE:CHANNEL`, with `node`) or `emulate=True`
    alone. `emulate=True` with `can` starts the real-time emulator on that bus in this process
    (python-can's `virtual` interface reaches only this process). `timeout_s`: how long to wait
    for each reply. `plant`: FMU parameters of the emulated plant (with `emulate`), as
    `bowden emulate --plant`; `chain`: the emulated bench (`cosim.bench.device.ChainConfig`).
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
    ) -> None:
        if port is not None and can is not None:
            raise BenchError("give a port or a CAN bus, not both")
        if port is None and can is None and not emulate:
            raise BenchError("give a port (or 'auto'), a CAN bus, or emulate=True")
        if emulate and port is not None:
            raise BenchError("emulate works with a CAN bus or alone (`bowden emulate` for serial)")
        self._emulator = None
        self.link = None
        if emulate:
            from .device import ChainConfig  # noqa: PLC0415

            chain = chain or ChainConfig(plant=plant or None)
        try:
            if emulate and can is not None:
                from .emulator import Emulator  # noqa: PLC0415

                self._emulator = Emulator(pty=False, tcp_port=None, can=can, chain=chain).start()
            if emulate and can is None:
                from .emulator import SteppedLink  # noqa: PLC0415

                self.link = SteppedLink(chain)
            elif can is not None:
                self.link = CanLink(can, node=node)
            else:
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
        """Stop the device (best effort: the link may be gone) and close the link. Idempotent."""
        if self.link is not None:
            if stop:
                try:
                    self.client.request("STOP")
                except BenchError:
                    pass
            self.link.close()
            self.link = None
        if self._emulator is not None:
            self._emulator.stop()
            self._emulator = None

    @property
    def url(self) -> str:
        """Where the controller is (the port's URL or the CAN bus)."""
        return self.client.link.url

    def info(self) -> DeviceInfo:
        """Who the device is (firmware, build, protocol, table hash) and its state now: running,
        where its configuration came from (`defaults`, `flash`, ...), unsaved changes."""
        return self.client.hello()

    # --- parameters ----------------------------------------------------------------------------

    def get(self, *names: str) -> dict[str, float | str]:
        """Parameter values in SI units (or mode names), by name; every parameter when no name
        is given."""
        wanted = [param_name(n) for n in names] or [p.name for p in msgs.PARAMS]
        return {n: value_from_word(param(n), self.client.get_word(n)) for n in wanted}

    def set(self, **values: float | str) -> dict[str, float | str]:
        """Write parameters (in RAM: `persist` keeps them); every value is checked before any is
        sent. Returns the values now in force (rounded to the device's fixed point)."""
        todo = []
        for key, value in values.items():
            p = param(param_name(key))
            if p.read_only:
                raise ProtocolError(f"{p.name} is read-only")
            todo.append((p, word_from_value(p, value)))
        return {p.name: value_from_word(p, self.client.set_word(p.name, w)) for p, w in todo}

    def persist(self) -> int:
        """Save the parameters in the device's flash; returns the flash record's sequence."""
        return self.client.simple("PERSIST")

    def faults(self, clear: bool = False) -> Faults:
        """The faults held now (and clear them afterwards with `clear=True`)."""
        f = self.client.faults()
        out = Faults(
            fpga=fault_names(f["fpga_fault"] & 0x0F),
            device=fault_names(f["device_faults"]),
            fault_ticks=f["fault_ticks"],
        )
        if clear:
            self.client.simple("FAULT_CLEAR")
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
        position_m: tuple[float, float, float] = (0.0, 0.5, 0.0),
        loop_routing: bool = True,
        sheath_length_m: float = 1.0,
        on_telemetry: Callable[[dict], None] | None = None,
    ) -> Run:
        """Run a waveform for `seconds` and record it.

        `waveform`: one of `WAVE_KINDS` (the device generates it from `mean_n`, `amplitude_n`,
        `freq_hz`), or T_ref samples in N, one per device tick, streamed to the device.
        `out`: the trace CSV to write (default: a new file in a temporary folder); its
        `.meta.json` goes beside it. `on_telemetry`: called with every telemetry frame as it
        arrives (fields as `cosim.bench.messages` names them, words not SI), from the thread
        that records: it must not block.

        The device stops by itself after `seconds`; an exception or Ctrl-C stops it at once.
        """
        if out is None:
            out = Path(tempfile.mkdtemp(prefix="bowden-run-")) / "run.csv"
        stream = None
        if isinstance(waveform, str):
            if waveform not in WAVE_KINDS:
                raise ProtocolError(
                    f"waveform {waveform!r}: expected one of {', '.join(WAVE_KINDS)} or samples"
                )
            kind = waveform
        else:
            stream = [word_from_value(param("wave.mean_n"), v) for v in np.asarray(waveform)]
            kind = "stream"
        try:
            result = record_run(
                self.client,
                out,
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
        except BaseException:
            try:
                self.client.request("STOP")
            except BenchError:
                pass
            raise
        return Run(trace=Path(out), columns=_read_columns(Path(out)), result=result)


def _read_columns(path: Path) -> dict[str, np.ndarray]:
    """A recording's columns as float arrays (also one with gaps, which the trace reader
    `cosim.results.trace` refuses)."""
    with path.open() as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        return {name: np.zeros(0) for name in header}
    return {name: data[:, i] for i, name in enumerate(header)}
