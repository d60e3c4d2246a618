"""Direct access to the few ports the closed loop reads and writes at every sample or bus clock.

cocotb 2.1's `handle.value` builds a LogicArray from the simulator's binary string for every
read (about 2.5 us here) and checks the range and type of every write (about 1.3 us); at two
reads and one write per sample, and a few per bus clock, that is a tenth of the real-time budget
of a 10 kHz loop. The ports involved are at most 32 bits wide and two-state in Verilator, so the
integer the GPI reads (get_signal_val_long, 0.07 us) and the integer write that `.value = int`
ends in (set_signal_val_int, 0.3 us) carry the same values.

These are private cocotb APIs (cocotb 2.1.0 is pinned in requirements.txt): `check_port` compares
each fast reader with the public `.value` once at set-up and fails loudly if they differ or are
missing, as cosim/engines/cocotb/runner.py does for the build command it overrides. Writes take the
direct path only when COCOTB_TRUST_INERTIAL_WRITES is on (the runner sets it), where cocotb's
own `.value = int` makes the same immediate call; otherwise they go through `.value`.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from cocotb import handle as _handle


class FastIOError(RuntimeError):
    """cocotb's private signal API is not what this module was written for."""


def unsigned_reader(sig) -> Callable[[], int]:
    """A function returning the port's value as an unsigned integer (ports of <= 32 bits)."""
    width = len(sig)
    if width > 32:
        raise FastIOError(f"{sig._name}: {width} bits; the fast reader takes <= 32")
    mask = (1 << width) - 1
    read = sig._handle.get_signal_val_long
    if width == 32 or sig._handle.get_signed():
        return lambda: read() & mask  # the GPI may give these sign-extended
    return read


def signed_reader(sig) -> Callable[[], int]:
    """A function returning the port's value as a two's complement integer (<= 32 bits)."""
    read = unsigned_reader(sig)
    width = len(sig)
    mask, sign = (1 << width) - 1, 1 << (width - 1)

    def signed() -> int:
        v = read() & mask
        return v - (sign << 1) if v & sign else v

    return signed


def writer(sig) -> Callable[[int], None]:
    """A function writing an integer to the port, as `sig.value = v` does."""
    if len(sig) > 32:
        raise FastIOError(f"{sig._name}: {len(sig)} bits; the fast writer takes <= 32")
    if not _handle._trust_inertial:
        return partial(setattr, sig, "value")
    return partial(sig._handle.set_signal_val_int, _handle._GPISetAction.DEPOSIT.value)


def check_port(sig, read: Callable[[], int], signed: bool = False) -> None:
    """Fail loudly when the fast reader of `sig` disagrees with cocotb's public value."""
    try:
        value = sig.value
        if not value.is_resolvable:
            return  # X or Z (Icarus before the port is driven): nothing to compare yet
        if signed:
            public = value.to_signed()
        else:  # a LogicArray, or a Logic for a one-bit port
            public = value.to_unsigned() if hasattr(value, "to_unsigned") else int(value)
        fast = read()
    except (AttributeError, TypeError, ValueError) as exc:
        raise FastIOError(f"{sig._name}: cocotb's signal API changed ({exc})") from exc
    if fast != public:
        raise FastIOError(f"{sig._name}: fast read {fast} != cocotb's value {public}")
