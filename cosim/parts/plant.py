"""Fast per-sample handle on the plant FMU (build/fmu/BowdenPlant.fmu, made by `make fmu`).

fmpy loads and instantiates the FMU; the per-sample path then calls the binary's
fmi2SetReal / fmi2DoStep / fmi2GetReal directly through ctypes with value references and
buffers prepared once, which costs about a microsecond per call instead of fmpy's wrappers.

    from cosim.parts.plant import Plant
    plant = Plant({"mu": 0.075, "loop_routing": True}, inputs={"x": 0.0, "y": 0.6, "z": -0.2})
    for k in range(n):
        plant.u[Plant.CURRENT_CMD] = current_a     # inputs held over the step
        out = plant.step(1e-4)                     # ctypes array, index with Plant.T_IN_MEAS...
        t_in_meas = out[Plant.T_IN_MEAS]
    plant.close()

Errors (a parameter out of range, a position outside the workspace, ...) raise PlantError with
the FMU's own message, which names the variable and its allowed range.
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
import shutil
import tempfile
import time
from collections.abc import Mapping
from ctypes import c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p
from dataclasses import dataclass
from pathlib import Path

from cosim.project.paths import BUILD_DIR

FMU_PATH = BUILD_DIR / "fmu" / "BowdenPlant.fmu"

# Unpacked copies are named UNPACK_PREFIX + "<pid>_" + a random part, so that one left by a
# process killed between unpacking and loading (SIGKILL, os._exit in that window) can be told
# from one in use; ORPHAN_AGE_S is far beyond the unpack-and-load time (well under a second).
UNPACK_PREFIX = "bowden_fmu_"
ORPHAN_AGE_S = 60.0
_orphans_swept = False

# Order of Plant.u and of the array Plant.step returns (names from the contract).
INPUT_NAMES = ("current_cmd", "T_in_cmd", "x", "y", "z")
OUTPUT_NAMES = (
    "T_in",
    "T_out",
    "T_in_meas",
    "T_out_meas",
    "phi",
    "motor_angle",
    "motor_speed",
    "current",
)

# The fields a C harness holds to step this plant's FMU itself, in this order inside its spec
# structure (bn_spec_t of the native engine, soc_spec_t of the simulated board): the instance,
# fmi2SetReal / fmi2DoStep / fmi2GetReal, the value references of INPUT_NAMES and OUTPUT_NAMES,
# the inputs and outputs as they are now and the plant's time. Plant.link fills them.
FMU_LINK_FIELDS = [
    ("fmu_component", c_void_p),
    ("fmu_set_real", c_void_p),
    ("fmu_do_step", c_void_p),
    ("fmu_get_real", c_void_p),
    ("in_vr", c_uint * len(INPUT_NAMES)),
    ("out_vr", c_uint * len(OUTPUT_NAMES)),
    ("u0", c_double * len(INPUT_NAMES)),
    ("y0", c_double * len(OUTPUT_NAMES)),
    ("time0_s", c_double),
]


def remove_orphaned_unpacks(folder: str | Path | None = None) -> list[Path]:
    """Remove the unpacked FMUs in folder (the temp folder by default) that a process left
    when it was killed while unpacking or loading: older than ORPHAN_AGE_S and named after a
    process that no longer runs. Others' folders (another user's, a live process's, a recent
    one) are kept. Returns the folders removed."""
    removed = []
    for d in Path(folder or tempfile.gettempdir()).glob(UNPACK_PREFIX + "*"):
        pid_text = d.name[len(UNPACK_PREFIX) :].split("_", 1)[0]
        if not pid_text.isdigit():
            continue
        try:
            if time.time() - d.stat().st_mtime < ORPHAN_AGE_S:
                continue
            os.kill(int(pid_text), 0)
        except ProcessLookupError:
            shutil.rmtree(d, ignore_errors=True)
            if not d.exists():
                removed.append(d)
        except (OSError, OverflowError):  # gone already, a live process of another user, no pid
            continue
    return removed


class PlantError(RuntimeError):
    """An FMI call of the plant failed; the message is the FMU's log message."""


@dataclass(frozen=True)
class Variable:
    """One variable of the FMU as its modelDescription.xml declares it."""

    name: str
    type: str  # Real | Integer | Boolean
    causality: str  # parameter | input | output
    start: float | int | bool | None
    lo: float | None  # allowed range (the FMU refuses values outside it)
    hi: float | None
    unit: str | None


def fmu_variables(fmu_path: str | Path | None = None) -> dict[str, Variable]:
    """The FMU's variables by name, read from its modelDescription.xml (no instance): the
    allowed ranges that `Plant` would enforce, for checking a configuration before a run."""
    path = Path(fmu_path) if fmu_path is not None else FMU_PATH
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist: run `make fmu` first")
    return _fmu_variables(str(path.resolve()), path.stat().st_mtime_ns)


@functools.lru_cache(maxsize=4)
def _fmu_variables(path: str, _mtime_ns: int) -> dict[str, Variable]:
    from fmpy import read_model_description  # noqa: PLC0415

    def number(text, kind):
        if text is None:
            return None
        return int(text) if kind == "Integer" else float(text)

    out = {}
    for v in read_model_description(path).modelVariables:
        if v.type == "Boolean":
            start = None if v.start is None else str(v.start).lower() == "true"
        else:
            start = number(v.start, v.type)
        out[v.name] = Variable(
            name=v.name,
            type=v.type,
            causality=v.causality,
            start=start,
            lo=number(v.min, v.type),
            hi=number(v.max, v.type),
            unit=getattr(v, "unit", None),
        )
    return out


class Plant:
    """One instance of the BowdenPlant FMU, initialised and ready to step.

    params: parameter name -> value (Real, Integer or Boolean as in modelDescription.xml).
    inputs: initial input values by name (the position must lie in the workspace at start).
    """

    # indices into Plant.u
    CURRENT_CMD, T_IN_CMD, X, Y, Z = range(5)
    # indices into the output array
    T_IN, T_OUT, T_IN_MEAS, T_OUT_MEAS, PHI, MOTOR_ANGLE, MOTOR_SPEED, CURRENT = range(8)

    def __init__(
        self,
        params: Mapping[str, float | int | bool] | None = None,
        inputs: Mapping[str, float] | None = None,
        fmu_path: str | Path | None = None,
        start_time_s: float = 0.0,
        instance_name: str = "plant",
    ) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import (
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )

        path = Path(fmu_path) if fmu_path is not None else FMU_PATH
        if not path.exists():
            raise FileNotFoundError(f"{path} does not exist: run `make fmu` first")
        # The unpacked copy lives only until the FMU's library is loaded and instantiated: the
        # FMU reads no file after that (it ignores fmuResourceLocation), and on POSIX a loaded
        # library stays mapped after its file is removed. So a process that ends without
        # closing its Plant (a pool worker's os._exit, a signal) leaves nothing in the temp
        # folder; where the removal fails (a DLL in use on Windows) close() removes it.
        self._fmu = None
        global _orphans_swept
        if not _orphans_swept:
            _orphans_swept = True
            remove_orphaned_unpacks()
        self._unzip_dir = extract(
            str(path), tempfile.mkdtemp(prefix=f"{UNPACK_PREFIX}{os.getpid()}_")
        )
        try:
            self.model_description = read_model_description(self._unzip_dir)
            self.variables = {v.name: v for v in self.model_description.modelVariables}
            self.messages: list[str] = []

            def _log(_env, _name, _status, _category, fmt, arg):
                # The FMU always logs format "%s" with one preformatted string (fmi2_plumbing.c).
                text = arg if fmt == b"%s" and arg is not None else fmt
                self.messages.append(text.decode("utf-8", "replace"))

            # fmpy's native logger proxy keeps one global Python logger, which a closed Plant would
            # leave dangling; this logger reads the one variadic argument itself instead.
            logger_type = ctypes.CFUNCTYPE(
                None, c_void_p, c_char_p, c_int, c_char_p, c_char_p, c_char_p
            )
            self._logger = logger_type(_log)
            self._callbacks = fmi2CallbackFunctions()
            self._callbacks.logger = ctypes.cast(self._logger, fmi2CallbackLoggerTYPE)
            libc = ctypes.CDLL(None)
            self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(libc.calloc)
            self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(libc.free)

            self._fmu = FMU2Slave(
                guid=self.model_description.guid,
                unzipDirectory=self._unzip_dir,
                modelIdentifier=self.model_description.coSimulation.modelIdentifier,
                instanceName=instance_name,
            )
            self._fmu.instantiate(callbacks=self._callbacks)
        finally:
            shutil.rmtree(self._unzip_dir, ignore_errors=True)
        self._c = self._fmu.component
        # Fresh function pointers (dll[name]) without argtypes: the arguments are passed as
        # prepared ctypes objects, which skips ctypes' per-call conversion (about 1.5 us a step).
        dll = self._fmu.dll
        self._set_real, self._do_step, self._get_real = (
            dll["fmi2SetReal"],
            dll["fmi2DoStep"],
            dll["fmi2GetReal"],
        )
        for func in (self._set_real, self._do_step, self._get_real):
            func.restype = c_int
        self._cp = c_void_p(self._c)
        self._t = c_double(start_time_s)
        self._h = c_double(0.0)
        self._true = c_int(1)
        self._n_in = c_size_t(len(INPUT_NAMES))
        self._n_out = c_size_t(len(OUTPUT_NAMES))
        self._in_vr = (c_uint * len(INPUT_NAMES))(*(self.vr(n) for n in INPUT_NAMES))
        self._out_vr = (c_uint * len(OUTPUT_NAMES))(*(self.vr(n) for n in OUTPUT_NAMES))
        self.u = (c_double * len(INPUT_NAMES))(
            *(float(self.variables[n].start) for n in INPUT_NAMES)
        )
        self.y = (c_double * len(OUTPUT_NAMES))()
        self.time_s = float(start_time_s)

        self._call("fmi2SetupExperiment", self._fmu.setupExperiment, startTime=start_time_s)
        self._call("fmi2EnterInitializationMode", self._fmu.enterInitializationMode)
        for name, value in (params or {}).items():
            self.set(name, value)
        for name, value in (inputs or {}).items():
            self.u[INPUT_NAMES.index(name)] = float(value)
        self._check(self._set_real(self._cp, self._in_vr, self._n_in, self.u), "fmi2SetReal")
        self._call("fmi2ExitInitializationMode", self._fmu.exitInitializationMode)
        self._check(self._get_real(self._cp, self._out_vr, self._n_out, self.y), "fmi2GetReal")

    # --- errors -----------------------------------------------------------------------------

    def _check(self, status: int, what: str) -> None:
        if status > 1:  # fmi2Error, fmi2Fatal
            detail = self.messages[-1] if self.messages else "no message"
            raise PlantError(f"{what} failed: {detail}")

    def _call(self, what: str, func, *args, **kwargs):
        try:
            return func(*args, **kwargs)
        except Exception as exc:  # fmpy raises FMICallException without the log message
            detail = self.messages[-1] if self.messages else str(exc)
            raise PlantError(f"{what} failed: {detail}") from exc

    # --- by name ----------------------------------------------------------------------------

    def vr(self, name: str) -> int:
        """Value reference of the variable `name` (KeyError names the unknown variable)."""
        if name not in self.variables:
            raise KeyError(f"BowdenPlant has no variable {name!r}")
        return self.variables[name].valueReference

    def set(self, name: str, value: float | int | bool) -> None:
        """Set a variable by name (parameters only before the first step: they are fixed)."""
        var = self.variables.get(name)
        if var is None:
            raise KeyError(f"BowdenPlant has no variable {name!r}")
        if var.causality == "input" and name in INPUT_NAMES:
            self.u[INPUT_NAMES.index(name)] = float(value)
        if var.type == "Real":
            fn, conv = self._fmu.setReal, float
        elif var.type == "Integer":
            fn, conv = self._fmu.setInteger, int
            if not (isinstance(value, int) or (math.isfinite(value) and float(value).is_integer())):
                raise PlantError(
                    f"{name} = {value} is not a whole number; allowed range is "
                    f"[{var.min}, {var.max}]"
                )
        else:
            fn, conv = self._fmu.setBoolean, bool
        self._call(f"setting {name} = {value}", fn, [var.valueReference], [conv(value)])

    def get(self, name: str) -> float | int | bool:
        """Read any variable by name."""
        var = self.variables.get(name)
        if var is None:
            raise KeyError(f"BowdenPlant has no variable {name!r}")
        getter = {"Real": self._fmu.getReal, "Integer": self._fmu.getInteger}.get(
            var.type, self._fmu.getBoolean
        )
        return self._call(f"reading {name}", getter, [var.valueReference])[0]

    def output(self, name: str) -> float:
        """An output from the last step, by name."""
        return self.y[OUTPUT_NAMES.index(name)]

    # --- per sample -------------------------------------------------------------------------

    def step(self, dt_s: float) -> ctypes.Array:
        """Hand all inputs in `u` to the FMU, advance by dt_s and return the outputs array."""
        h = self._h
        if h.value != dt_s:
            h.value = dt_s
        self._t.value = self.time_s
        c = self._cp
        if self._set_real(c, self._in_vr, self._n_in, self.u):
            self._check(2, "fmi2SetReal")
        if self._do_step(c, self._t, h, self._true):
            self._check(2, f"fmi2DoStep at t = {self.time_s} s")
        self.time_s += dt_s
        self._get_real(c, self._out_vr, self._n_out, self.y)
        return self.y

    def input_setter(self, name: str):
        """A setter of one Real input that `u` does not carry (e.g. `end_displacement`, which a
        joint sets when the FMU is composed with one): `setter(value)` calls fmi2SetReal on that
        value reference alone, for a per-sample loop; the value holds over the following
        steps. An out-of-range value raises PlantError with the FMU's message."""
        var = self.variables.get(name)
        if var is None or var.causality != "input" or var.type != "Real":
            raise KeyError(f"BowdenPlant has no Real input {name!r}")
        vr = (c_uint * 1)(var.valueReference)
        buf = (c_double * 1)()
        one, cp, set_real = c_size_t(1), self._cp, self._set_real

        def setter(value: float) -> None:
            buf[0] = value
            if set_real(cp, vr, one, buf):
                self._check(2, f"fmi2SetReal({name} = {value})")

        return setter

    def step_current(self, current_a: float, dt_s: float) -> ctypes.Array:
        """Drive mode 0 shortcut: set current_cmd, step, return the outputs array."""
        self.u[0] = current_a
        return self.step(dt_s)

    def link(self, spec: ctypes.Structure) -> None:
        """Fill the FMU_LINK_FIELDS of a C harness's `spec`: the harness then steps this FMU
        directly, from the plant's present inputs, outputs and time."""
        dll = self._fmu.dll
        spec.fmu_component = self._c
        spec.fmu_set_real = ctypes.cast(dll["fmi2SetReal"], c_void_p).value
        spec.fmu_do_step = ctypes.cast(dll["fmi2DoStep"], c_void_p).value
        spec.fmu_get_real = ctypes.cast(dll["fmi2GetReal"], c_void_p).value
        spec.in_vr[:] = list(self._in_vr)
        spec.out_vr[:] = list(self._out_vr)
        spec.u0[:] = list(self.u)
        spec.y0[:] = list(self.y)
        spec.time0_s = self.time_s

    # --- FMU state --------------------------------------------------------------------------

    def get_state(self):
        """Save the complete FMU state (free it with free_state)."""
        return self._call("fmi2GetFMUstate", self._fmu.getFMUState)

    def set_state(self, state) -> None:
        self._call("fmi2SetFMUstate", self._fmu.setFMUState, state)

    def free_state(self, state) -> None:
        self._fmu.freeFMUState(state)

    def close(self) -> None:
        """Terminate, free the instance and delete the unpacked FMU."""
        if self._fmu is not None:
            try:
                self._fmu.terminate()
            except Exception:  # noqa: BLE001 (closing after an error must still free)
                pass
            self._fmu.freeInstance()
            self._fmu = None
            shutil.rmtree(self._unzip_dir, ignore_errors=True)

    def __enter__(self) -> Plant:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 (interpreter shutdown)
            pass


def output_names() -> tuple[str, ...]:
    """Names of the outputs in the order of the array Plant.step returns."""
    return OUTPUT_NAMES
