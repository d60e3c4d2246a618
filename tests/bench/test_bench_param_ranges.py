"""The words the parameter table says the device accepts for each parameter alone (accept_lo,
accept_hi: the register map's limits or the range the firmware's header documents, read by
firmware/proto/gen_proto.py) against the device's own settings check, on the in-process device:
both ends accepted, one word beyond either refused. `bowden bench diff` and `restore` refuse a
file's value outside them before anything is sent, so a wrong end would refuse a value the device
takes or let through one it refuses."""

import pytest

from cosim.bench.emulate.emulator import SteppedLink
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchClient, DeviceError

# Parameters whose range is narrowed by others: the settings that let each end through.
CONTEXT = {
    "comp.mu": {"comp.phi_rad": 1 << 24},  # mu * phi <= 4: phi 1 rad
    # mu + 48 N * slope >= 0 at the lowest slope: mu 1; every gain within exp(+-4) at the
    # highest: phi 0.5 rad (set first: mu * phi <= 4)
    "comp.mu_slope_per_n": {"comp.phi_rad": 1 << 23, "comp.mu": 1 << 28},
    "comp.lead_ticks": {"comp.preview_ticks": 128},  # L <= P
    "loop.adc_min": {"loop.adc_max": (1 << 23) - 1},  # min <= max
    "loop.adc_max": {"loop.adc_min": -(1 << 23)},
    "est.mu_phi_min": {"est.mu_phi_max": 4 << 28},  # min < max
    "est.mu_phi_max": {"est.mu_phi_min": 0},
}
# Parameters without a range of their own: every word, or a bound set by another parameter.
NO_RANGE = {"wave.freq_hz": "at most half the tick rate", "wave.phase0": "every word is a phase"}


@pytest.fixture(scope="module")
def client():
    c = BenchClient(SteppedLink(ChainConfig()))
    c.connect()
    yield c
    c.link.close()


def _accepts(client, name: str, word: int) -> bool:
    client.simple("DEFAULTS")
    for other, w in CONTEXT.get(name, {}).items():
        client.set_word(other, w)
    try:
        client.set_word(name, word)
    except DeviceError as exc:
        assert exc.code == "INVALID_VALUE", exc
        return False
    return True


def _word_range(p) -> tuple[int, int]:
    return (0, (1 << 32) - 1) if p.unsigned else (-(1 << 31), (1 << 31) - 1)


@pytest.mark.parametrize(
    "p", [p for p in msgs.PARAMS if not p.read_only and p.enum is None], ids=lambda p: p.name
)
def test_accepted_range_is_the_devices(client, p):
    lo, hi = _word_range(p)
    if (p.accept_lo, p.accept_hi) == (lo, hi):
        assert p.name in NO_RANGE, f"{p.name}: no documented range in its header"
        return
    assert p.name not in NO_RANGE
    assert _accepts(client, p.name, p.accept_lo) and _accepts(client, p.name, p.accept_hi)
    if p.accept_lo > lo:
        assert not _accepts(client, p.name, p.accept_lo - 1)
    if p.accept_hi < hi:
        assert not _accepts(client, p.name, p.accept_hi + 1)
    if p.accept_power_of_two:  # inside the range, only its powers of two
        assert _accepts(client, p.name, 2 * p.accept_lo)
        odd = p.accept_lo + 1
        while odd & (odd - 1) == 0:  # the next word above the lower end that is no power of 2
            odd += 1
        assert not _accepts(client, p.name, odd)
        assert not _accepts(client, p.name, 3 * p.accept_lo)


@pytest.mark.parametrize("p", [p for p in msgs.PARAMS if p.enum], ids=lambda p: p.name)
def test_an_enum_takes_its_values_only(client, p):
    for word in p.enum.values():
        assert _accepts(client, p.name, word)
    assert not _accepts(client, p.name, max(p.enum.values()) + 1)
    assert not _accepts(client, p.name, min(p.enum.values()) - 1)


def test_the_documented_ranges_in_si_units():
    """A few ends as the headers write them: a fraction, pi, a rounded decimal, an open end."""
    p = msgs.PARAM_BY_NAME
    assert (p["comp.mu"].accept_lo, p["comp.mu"].accept_hi) == (0, 1 << 28)
    assert p["comp.phi_rad"].accept_hi == 210828714  # comp.h COMP_PHI_MAX_Q24, 4*pi rounded
    assert p["wave.mean_n"].accept_hi == 32767  # 127.996 N
    assert p["loop.kv"].accept_hi == 1 << 20  # fw.h FW_KV_MAX, 1/16 A s/N
    assert p["est.mu_phi_max"].accept_lo == 1 and p["est.mu_phi_min"].accept_hi == (4 << 28) - 1
    assert (p["loop.kv"].unit, p["loop.uff_limit"].unit) == ("A s/N", "A")
    assert [q.name for q in msgs.PARAMS if q.accept_power_of_two] == [
        "est.tau_ticks",
        "corr.tare_ticks",
    ]
