"""The bench device on the host, and the closed loop it drives, through ctypes.

`build/bench/host/libbowden_bench.so` (`make bench-build`) holds the firmware's target code
(compensator, tick, waveforms), the device side of the protocol (firmware/src/dev.c: dispatcher,
parameters, flash store, telemetry), an emulated flash, and the emulator's loop in C
(cosim/bench/emulate/native/emu.c: the bit-exact model of the FPGA loop, the ideal ADC and the
plant FMU).

- `Device`: one device (dev_host_t): bytes or CAN frames in and out per port, the tick, power
  cycles, the flash image.
- `LoopChain`: the emulator's coupling to the loop model, in one class: the FPGA loop, the ADC and
  the plant FMU around a Device, with the co-simulation's timing
  (cosim.engines.reference.run_model_chain: sample k0 = D*i, the firmware's tick, its register
  writes landing before sample k0 + 2). Two engines, identical sample by sample (tests/bench):
  `native` (C, emu_step: one call per tick) and `python` (cosim.parts.rtl_model.TensionLoopModel +
  cosim.parts.plant.Plant: the definition, too slow for real time on a loaded machine).
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cosim.parts import regmap, rtl_model
from cosim.project.paths import BUILD_DIR

LIB_PATH = BUILD_DIR / "bench" / "host" / "libbowden_bench.so"

PORT_SERIAL, PORT_CAN = 0, 1
HAL_LOG_CAPACITY = 64


class CanFrame(ctypes.Structure):
    """proto_can_frame_t"""

    _fields_ = [("id", ctypes.c_uint32), ("len", ctypes.c_uint8), ("data", ctypes.c_uint8 * 8)]


class HalWrite(ctypes.Structure):
    """hal_write_t"""

    _fields_ = [("addr", ctypes.c_uint32), ("value", ctypes.c_uint32)]


class EmuLoop(ctypes.Structure):
    """emu_loop_t (cosim/bench/emulate/native/emu.h)"""

    _fields_ = [
        (n, ctypes.c_int32)
        for n in (
            "tc kff kp ki_ts i_limit slew wdt_timeout adc_offset adc_gain adc_min adc_max "
            "adc_stale oc_timeout tc_min uff"
        ).split()
    ] + [
        ("enable", ctypes.c_uint32),
        ("slew_en", ctypes.c_uint32),
        ("raw", ctypes.c_int32),
        ("fresh", ctypes.c_uint32),
        ("tc_written", ctypes.c_uint32),
        ("integ_reset_pending", ctypes.c_uint32),
        ("fault_clear_pending", ctypes.c_uint32),
        ("stale_cnt", ctypes.c_uint32),
        ("wdt_cnt", ctypes.c_uint32),
        ("oc_cnt", ctypes.c_uint32),
        ("faults", ctypes.c_uint32),
        ("sample_count", ctypes.c_uint32),
        ("t_in", ctypes.c_int32),
        ("u", ctypes.c_int32),
        ("out_en", ctypes.c_uint32),
        ("saturated", ctypes.c_uint32),
        ("sat_hi", ctypes.c_uint32),
        ("sat_lo", ctypes.c_uint32),
        ("wdt_ramp", ctypes.c_uint32),
        ("integ", ctypes.c_int64),
        ("tc_eff", ctypes.c_int32),
        ("wdt_ramp_step", ctypes.c_int32),
    ]


class Emu(ctypes.Structure):
    """emu_t (cosim/bench/emulate/native/emu.h)"""

    _fields_ = [
        ("set_real", ctypes.c_void_p),
        ("do_step", ctypes.c_void_p),
        ("get_real", ctypes.c_void_p),
        ("component", ctypes.c_void_p),
        ("in_vr", ctypes.c_uint32 * 5),
        ("out_vr", ctypes.c_uint32 * 8),
        ("u", ctypes.c_double * 5),
        ("y", ctypes.c_double * 8),
        ("time_s", ctypes.c_double),
        ("dt_s", ctypes.c_double),
        ("decimation", ctypes.c_uint32),
        ("adc_offset", ctypes.c_int32),
        ("adc_gain", ctypes.c_int32),
        ("loop", EmuLoop),
        ("code", ctypes.c_int32),
        ("pending", HalWrite * HAL_LOG_CAPACITY),
        ("n_pending", ctypes.c_uint32),
        ("pending_wait", ctypes.c_uint32),
        ("log_dropped", ctypes.c_uint32),
        ("fmi_error", ctypes.c_uint32),
        ("samples", ctypes.c_uint64),
        ("rec_u", ctypes.POINTER(ctypes.c_int16)),
        ("rec_tc", ctypes.POINTER(ctypes.c_int16)),
        ("rec_cap", ctypes.c_uint32),
        ("rec_len", ctypes.c_uint32),
    ]


_lib: ctypes.CDLL | None = None


def load_library(path: Path | None = None) -> ctypes.CDLL:
    """Load libbowden_bench.so once and declare the signatures used here."""
    global _lib
    if _lib is not None and path is None:
        return _lib
    p = Path(path) if path is not None else LIB_PATH
    if not p.exists():
        raise FileNotFoundError(f"{p} does not exist: build it with `make bench-build`")
    lib = ctypes.CDLL(str(p))
    u32, i32, vp = ctypes.c_uint32, ctypes.c_int32, ctypes.c_void_p
    sigs = {
        "dev_host_sizeof": (u32, []),
        "dev_host_init": (None, [vp]),
        "dev_host_init_channels": (None, [vp, u32]),
        "dev_host_channels_max": (u32, []),
        "dev_host_boot": (None, [vp]),
        "dev_host_set_identity": (None, [vp, u32, u32]),
        "dev_host_dev": (vp, [vp]),
        "dev_host_shadow": (vp, [vp]),
        "dev_host_shadow_channel": (vp, [vp, u32]),
        "dev_host_flash": (vp, [vp]),
        "dev_host_flash_words": (vp, [vp]),
        "dev_host_flash_n_words": (u32, []),
        "dev_port_kind": (None, [vp, u32, u32]),
        "dev_rx_bytes": (None, [vp, u32, ctypes.c_char_p, u32]),
        "dev_rx_can": (None, [vp, u32, ctypes.POINTER(CanFrame)]),
        "dev_tx_bytes": (u32, [vp, u32, vp, u32]),
        "dev_tx_can": (u32, [vp, u32, ctypes.POINTER(CanFrame), u32]),
        "dev_tick": (None, [vp, u32, i32]),
        "dev_tick_channels": (None, [vp, u32, ctypes.POINTER(i32)]),
        "dev_overrun": (None, [vp]),
        "hal_shadow_set": (None, [vp, u32, u32]),
        "hal_shadow_drain": (u32, [vp, ctypes.POINTER(HalWrite), u32]),
        "emu_init": (None, [ctypes.POINTER(Emu)]),
        "emu_step": (ctypes.c_int, [ctypes.POINTER(Emu), vp, u32]),
        "emu_step_channels": (ctypes.c_int, [ctypes.POINTER(Emu), u32, vp, u32]),
        "emu_adc_code": (i32, [ctypes.c_double, i32, i32]),
        "emu_loop_reset": (None, [ctypes.POINTER(EmuLoop)]),
        "emu_loop_write": (None, [ctypes.POINTER(EmuLoop), u32, u32]),
        "emu_loop_adc": (None, [ctypes.POINTER(EmuLoop), i32]),
        "emu_loop_tick": (None, [ctypes.POINTER(EmuLoop)]),
        "emu_loop_status": (u32, [ctypes.POINTER(EmuLoop)]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
    if path is None:
        _lib = lib
    return lib


class Device:
    """One bench device on the host (firmware + protocol + emulated flash), by port.

    Ports 0..2; each is serial (default) or CAN (`set_port_kind`). Telemetry flows while a run is
    active and `tick` is called at the tick rate (the emulator does both). `channels` cables
    (1 .. `channels_max()`), each with its own firmware and register shadow.
    """

    N_PORTS = 3

    def __init__(self, channels: int = 1) -> None:
        self._lib = load_library()
        top = self._lib.dev_host_channels_max()
        if not 1 <= channels <= top:
            raise ValueError(f"channels must be in 1..{top}; got {channels}")
        self.channels = channels
        self._buf = ctypes.create_string_buffer(self._lib.dev_host_sizeof())
        self.ptr = ctypes.cast(self._buf, ctypes.c_void_p)
        self._lib.dev_host_init_channels(self.ptr, channels)
        self.dev = self._lib.dev_host_dev(self.ptr)
        self.shadow = self._lib.dev_host_shadow(self.ptr)
        self.shadows = [self._lib.dev_host_shadow_channel(self.ptr, c) for c in range(channels)]
        self._out = ctypes.create_string_buffer(4096)
        self._can = (CanFrame * 64)()

    @staticmethod
    def channels_max() -> int:
        """The most channels the host library holds (its BOWDEN_CHANNELS_MAX)."""
        return load_library().dev_host_channels_max()

    def set_port_kind(self, port: int, kind: int) -> None:
        self._lib.dev_port_kind(self.dev, port, kind)

    def rx_bytes(self, port: int, data: bytes) -> None:
        if data:
            self._lib.dev_rx_bytes(self.dev, port, bytes(data), len(data))

    def tx_bytes(self, port: int, max_bytes: int = 4096) -> bytes:
        n = self._lib.dev_tx_bytes(self.dev, port, self._out, min(max_bytes, 4096))
        return self._out.raw[:n]

    def rx_can(self, port: int, can_id: int, data: bytes) -> None:
        f = CanFrame(id=can_id, len=len(data))
        f.data[: len(data)] = list(data)
        self._lib.dev_rx_can(self.dev, port, ctypes.byref(f))

    def tx_can(self, port: int, max_frames: int = 64) -> list[tuple[int, bytes]]:
        n = self._lib.dev_tx_can(self.dev, port, self._can, min(max_frames, 64))
        return [(f.id, bytes(f.data[: f.len])) for f in self._can[:n]]

    def tick(self, time_us: int, t_out_word: int) -> None:
        self._lib.dev_tick(self.dev, time_us & 0xFFFFFFFF, t_out_word)

    def overrun(self) -> None:
        """Report a late tick (the device's OVERRUN fault)."""
        self._lib.dev_overrun(self.dev)

    def boot(self) -> None:
        """Power cycle: everything but the flash starts afresh (ports back to serial)."""
        self._lib.dev_host_boot(self.ptr)

    def set_identity(self, proto_version: int, table_hash: int) -> None:
        """Pose as another firmware build (to try the host's version check)."""
        self._lib.dev_host_set_identity(self.ptr, proto_version, table_hash)

    def flash_image(self) -> bytes:
        n = self._lib.dev_host_flash_n_words()
        return ctypes.string_at(self._lib.dev_host_flash_words(self.ptr), 4 * n)

    def load_flash_image(self, image: bytes) -> None:
        """Put a saved flash image back and boot from it."""
        n = self._lib.dev_host_flash_n_words()
        if len(image) != 4 * n:
            raise ValueError(f"flash image of {len(image)} bytes, expected {4 * n}")
        ctypes.memmove(self._lib.dev_host_flash_words(self.ptr), image, len(image))
        self.boot()

    def shadow_set(self, addr: int, value: int) -> None:
        self._lib.hal_shadow_set(self.shadow, addr, value & 0xFFFFFFFF)

    def drain_writes(self) -> list[tuple[int, int]]:
        buf = (HalWrite * HAL_LOG_CAPACITY)()
        n = self._lib.hal_shadow_drain(self.shadow, buf, HAL_LOG_CAPACITY)
        return [(w.addr, w.value) for w in buf[:n]]


# --- the closed loop around the device -----------------------------------------------------------


@dataclass
class ChainConfig:
    """What the emulated bench is: rates, where the end-effector sits, the plant's parameters."""

    sample_rate_hz: float = 10_000.0  # FPGA loop
    tick_rate_hz: float = 1_000.0  # firmware tick (the device's tick_rate_hz)
    position_m: tuple[float, float, float] = (0.0, 0.5, 0.0)  # scenarios.HOME_M
    loop_routing: bool = True
    plant: dict | None = None  # FMU parameter overrides by name
    # The board's sensing and actuation between plant and loop (cosim.parts.interface: ideal, adc,
    # board); the native engine has the ideal one, the others run on the Python engine.
    interface: str = "ideal"

    @property
    def decimation(self) -> int:
        d = self.sample_rate_hz / self.tick_rate_hz
        if abs(d - round(d)) > 1e-9 or round(d) < 2:
            raise ValueError(
                f"sample_rate_hz / tick_rate_hz must be a whole number >= 2; got "
                f"{self.sample_rate_hz:g} / {self.tick_rate_hz:g}"
            )
        return int(round(d))


def _open_plant(cfg: ChainConfig):
    from cosim.parts.plant import Plant  # noqa: PLC0415 (fmpy is imported when a chain starts)

    params = {"drive_mode": 0, "loop_routing": bool(cfg.loop_routing)}
    params.update(cfg.plant or {})
    x, y, z = (float(v) for v in cfg.position_m)
    return Plant(params=params, inputs={"x": x, "y": y, "z": z})


def _tension_word(t_n: float) -> int:
    """T as the Q7.8 word an ideal load cell gives (round half to even, saturated)."""
    return max(-32768, min(32767, round(t_n * 256.0)))


class LoopChain:
    """The FPGA loop, the load-cell ADC and the plant FMU around a Device, one tick per `step`.

    engine "native": emu_step in C; "python": the same steps with rtl_model.TensionLoopModel and
    cosim.parts.plant.Plant (the definition the native engine is held to). `record=n` keeps the
    command word and T_c of the first n samples (tests). A device of several channels gets a loop
    and a plant per channel (the same plant parameters, each its own FMU instance), all stepped in
    one emu_step_channels per tick; native engine only (the python engine is the one-channel
    definition). `plant` is channel 0's; `plants` every channel's.
    """

    ENGINES = ("native", "python")

    def __init__(
        self, device: Device, cfg: ChainConfig, engine: str = "native", record: int = 0
    ) -> None:
        if engine not in self.ENGINES:
            raise ValueError(f"engine must be one of {', '.join(self.ENGINES)}; got {engine!r}")
        if engine == "native" and cfg.interface != "ideal":
            raise ValueError(
                f"interface {cfg.interface!r} runs on the python engine (the C chain has the "
                "ideal interface only)"
            )
        if engine != "native" and device.channels > 1:
            raise ValueError(
                f"{device.channels} channels run on the native engine (the python engine is the "
                "one-channel definition)"
            )
        self.device = device
        self.cfg = cfg
        self.engine = engine
        self.decimation = cfg.decimation
        self.dt_s = 1.0 / cfg.sample_rate_hz
        self.plants = [_open_plant(cfg) for _ in range(device.channels)]
        self.plant = self.plants[0]
        self.adc_offset = rtl_model.DEFAULT_ADC_OFFSET  # the physical ADC: default calibration
        self.adc_gain = rtl_model.DEFAULT_ADC_GAIN
        self.ticks = 0
        self._rec_u = np.zeros(record, dtype=np.int16)
        self._rec_tc = np.zeros(record, dtype=np.int16)
        if engine == "native":
            self._init_native(record)
        else:
            self._init_python()

    # --- native ------------------------------------------------------------------------------

    def _init_native(self, record: int) -> None:
        lib = load_library()
        emus = (Emu * len(self.plants))()
        for c, (p, e) in enumerate(zip(self.plants, emus, strict=True)):
            e.set_real = ctypes.cast(p._set_real, ctypes.c_void_p).value  # noqa: SLF001
            e.do_step = ctypes.cast(p._do_step, ctypes.c_void_p).value  # noqa: SLF001
            e.get_real = ctypes.cast(p._get_real, ctypes.c_void_p).value  # noqa: SLF001
            e.component = p._c  # noqa: SLF001
            e.in_vr[:] = list(p._in_vr)  # noqa: SLF001
            e.out_vr[:] = list(p._out_vr)  # noqa: SLF001
            e.u[:] = list(p.u)
            e.y[:] = list(p.y)
            e.time_s = p.time_s
            e.dt_s = self.dt_s
            e.decimation = self.decimation
            e.adc_offset = self.adc_offset
            e.adc_gain = self.adc_gain
            if record and c == 0:  # channel 0's samples (tests)
                e.rec_u = self._rec_u.ctypes.data_as(ctypes.POINTER(ctypes.c_int16))
                e.rec_tc = self._rec_tc.ctypes.data_as(ctypes.POINTER(ctypes.c_int16))
                e.rec_cap = record
            lib.emu_init(ctypes.byref(e))
        self._emus = emus
        self._emu = emus[0]
        self._emu_p = ctypes.cast(emus, ctypes.POINTER(Emu))
        self._lib = lib

    # --- python ------------------------------------------------------------------------------

    def _init_python(self) -> None:
        from cosim.config.run import SimConfig  # noqa: PLC0415
        from cosim.parts.interface import make_chain  # noqa: PLC0415

        self.model = rtl_model.TensionLoopModel()
        self._names = {reg.addr: name for name, reg in regmap.REGISTERS.items()}
        # The co-simulation's interface stage (cosim/parts/interface.py): ideal ADC and drive,
        # the board's ADC, or the board's ADC and PWM -> ESCON, with the datasheet defaults of
        # BoardParams.
        sim = SimConfig()
        sim.sample_rate_hz = self.cfg.sample_rate_hz
        self._iface = make_chain(sim, self.cfg.interface, True, self.adc_offset, self.adc_gain)
        self._code = self._iface.start(self.plant.y[self.plant.T_IN_MEAS])
        self._k = 0
        self._pending: list[tuple[int, int]] = []
        self._wait = 0
        self._rec_len = 0

    def _py_sample(self) -> None:
        m, p = self.model, self.plant
        if self._pending and self._wait == 0:
            for addr, value in self._pending:
                name = self._names.get(addr)
                if name is None or regmap.REGISTERS[name].fields[0].access not in ("rw", "w1p"):
                    continue  # read-only registers ignore writes
                m.write(name, value if name == "CTRL" else regmap.decode(name, value))
            self._pending = []
        if self._code is not None:  # the board's ADC has no new sample every tick
            m.adc_sample(self._code)
        out = m.tick()
        if self._rec_len < len(self._rec_u):
            self._rec_u[self._rec_len] = out.u
            self._rec_tc[self._rec_len] = out.tc_eff
            self._rec_len += 1
        y = p.y
        for dt_s, current_a in self._iface.drive(self._k, out.u):
            p.u[p.CURRENT_CMD] = current_a
            y = p.step(dt_s)
        self._code = self._iface.sense(self._k, y[p.T_IN_MEAS])
        self._k += 1
        if self._wait > 0:
            self._wait -= 1

    def _py_step(self, time_us: int) -> None:
        m, dev = self.model, self.device
        t_out = _tension_word(self.plant.y[self.plant.T_OUT_MEAS])
        # The far-end load cell as the front-end's second channel codes it (as the C chain).
        code_out = rtl_model.adc_code_from_tension(
            self.plant.y[self.plant.T_OUT_MEAS], self.adc_offset, self.adc_gain
        )
        self._py_sample()
        status = (
            (regmap.STATUS_OUT_EN if m.out_en else 0)
            | (regmap.STATUS_SATURATED if m.saturated else 0)
            | (regmap.STATUS_FAULT_ACTIVE if m.faults else 0)
            | (regmap.STATUS_WDT_RAMP if m.wdt_ramp else 0)
        )
        dev.shadow_set(regmap.STATUS, status)
        dev.shadow_set(regmap.FAULT, m.faults)
        dev.shadow_set(regmap.T_IN, m.t_in)
        dev.shadow_set(regmap.U, m.u)
        dev.shadow_set(regmap.SAMPLE_COUNT, m.sample_count)
        dev.shadow_set(regmap.T_OUT, code_out & 0xFFFFFF)  # a 24-bit code
        dev.shadow_set(regmap.ADC_FLAGS, 0)
        dev.tick(time_us, t_out)
        self._pending = dev.drain_writes()
        self._wait = 1
        for _ in range(1, self.decimation):
            self._py_sample()

    # --- both --------------------------------------------------------------------------------

    def step(self) -> None:
        """One tick period: D FPGA samples and the device's tick."""
        time_us = round(self.ticks * 1e6 / self.cfg.tick_rate_hz) & 0xFFFFFFFF
        if self.engine == "native":
            st = self._lib.emu_step_channels(self._emu_p, len(self._emus), self.device.ptr, time_us)
            if st:
                detail = self.plant.messages[-1] if self.plant.messages else f"status {st}"
                raise RuntimeError(
                    f"the plant FMU failed at t = {self._emu.time_s:.4f} s: {detail}"
                )
        else:
            self._py_step(time_us)
        self.ticks += 1

    @property
    def recorded(self) -> tuple[np.ndarray, np.ndarray]:
        """The command words and T_c of the recorded samples."""
        n = self._emu.rec_len if self.engine == "native" else self._rec_len
        return self._rec_u[:n].copy(), self._rec_tc[:n].copy()

    @property
    def time_s(self) -> float:
        return self._emu.time_s if self.engine == "native" else self.plant.time_s

    def close(self) -> None:
        for p in self.plants:
            p.close()
