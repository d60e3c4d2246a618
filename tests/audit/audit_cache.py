"""The audit of a record, reused by input hash.

An audit is a pure function of the record it reads and of the code and libraries that compute it:
no random draw, no clock, no thread order enters its result. `audit(path, cache_dir)` runs
`core.run(core.prepare(read_trace(path)))` and keeps the result in `cache_dir/audit/` under a
digest of the record's bytes (the CSV and its sidecar), every source the audit can reach (the
packages at or below it in tests/test_layers.py's ranks, and the C the twin's compensator and the
plant are built from) and the versions of Python and the numerical libraries. While those are
unchanged the kept result is returned; any change to them runs the audit again. With `cache_dir`
None (BOWDEN_TEST_CACHE=0) it always runs.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import os
import pickle
import sys
from importlib import metadata
from pathlib import Path

from cosim.audit import core
from cosim.project.paths import REPO_ROOT
from cosim.results import trace

# What the audit's result can depend on, beyond the record: cosim's packages ranked at or below
# cosim.audit (tests/test_layers.py RANKS; cosim.bench's link and emulators are below it too, but
# the audit imports neither), and the C sources of the compensator and the plant (with the
# generator of the plant's parameters, whose defaults it writes into the model).
SOURCES = (
    "cosim/__init__.py",
    "cosim/_early.py",
    "cosim/_signals.py",
    "cosim/project",
    "cosim/parts",
    "cosim/config",
    "cosim/results",
    "cosim/engines",
    "cosim/audit",
    "firmware/src",
    "firmware/include",
    "fmu/src",
    "fmu/gen_model.py",
)
LIBRARIES = ("numpy", "scipy", "numba", "llvmlite")


@functools.cache
def code_digest() -> bytes:
    """The digest of SOURCES and the libraries' versions (once per test process)."""
    h = hashlib.sha256(sys.version.encode())
    for lib in LIBRARIES:
        h.update(f"{lib}={metadata.version(lib)}".encode())
    for entry in SOURCES:
        root = REPO_ROOT / entry
        files = [root] if root.is_file() else sorted(root.rglob("*"))
        for f in files:
            if f.is_file() and f.suffix in (".py", ".c", ".h") and "__pycache__" not in f.parts:
                h.update(str(f.relative_to(REPO_ROOT)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.digest()


def record_digest(path: Path) -> str:
    h = hashlib.sha256(code_digest())
    for f in (path, trace.meta_path(path)):
        h.update(f.read_bytes() if f.exists() else b"(none)")
        h.update(b"\0")
    return h.hexdigest()[:32]


def audit(path: str | Path, cache_dir: Path | None) -> core.AuditResult:
    """The audit of the measured record at `path` (see the module)."""
    path = Path(path)
    if cache_dir is None:
        return core.run(core.prepare(trace.read_trace(path, "measured"), str(path)))
    entry = cache_dir / "audit" / f"{record_digest(path)}.pickle"
    try:
        with entry.open("rb") as f:
            res = pickle.load(f)
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError):
        res = core.run(core.prepare(trace.read_trace(path, "measured"), str(path)))
        entry.parent.mkdir(parents=True, exist_ok=True)
        tmp = entry.with_suffix(f".{os.getpid()}.tmp")
        with tmp.open("wb") as f:
            pickle.dump(res, f, protocol=pickle.HIGHEST_PROTOCOL)
        tmp.replace(entry)  # whole or absent, whichever worker writes it
        return res
    # The same record under another name (each test writes its own): the name it is read as.
    return dataclasses.replace(res, data=dataclasses.replace(res.data, source=str(path)))


def run_cached(cache_dir: Path | None):
    """core.run with its result kept in `cache_dir/audit/` under a digest of the prepared data
    (every array and setting of it but the source's name, which names a test's own folder) and
    the code: for a procedure that audits data it prepared itself (the bench's calibrate, on
    the stepped emulator's recording, tare taken off; `bowden audit` run in the test's process),
    which `audit` cannot key by a file's bytes. A progress callback sees every step of a fresh
    audit and, for a reused one, a single last step. With a rule of its own, or cache_dir None,
    it always runs."""
    original = core.run

    def run(data, rule=core.RULE, progress=None):
        if cache_dir is None or rule is not core.RULE:
            return original(data, rule, progress)
        h = hashlib.sha256(code_digest())
        h.update(pickle.dumps(dataclasses.replace(data, source=""), protocol=4))
        entry = cache_dir / "audit" / f"prepared-{h.hexdigest()[:32]}.pickle"
        try:
            with entry.open("rb") as f:
                res = pickle.load(f)
        except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError):
            res = original(data, progress=progress)
            entry.parent.mkdir(parents=True, exist_ok=True)
            tmp = entry.with_suffix(f".{os.getpid()}.tmp")
            with tmp.open("wb") as f:
                pickle.dump(res, f, protocol=pickle.HIGHEST_PROTOCOL)
            tmp.replace(entry)
            return res
        if progress is not None:
            progress("reused from the test cache", 1.0)
        return dataclasses.replace(res, data=dataclasses.replace(res.data, source=data.source))

    return run
