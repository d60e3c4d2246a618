"""The firmware's rate feedforward (fw.h, loop.kv and loop.uff_limit): at each tick after TC it
writes UFF = clamp(round(kv * (T_c - T_c,prev) * f_tick), +-uff_limit) (Q3.12 A) when the word
changes, none at the first tick after start, zero at stop; off (kv 0) it writes nothing."""

import pytest

from cosim.engines.fwbridge import KV_FRAC, kv_word
from cosim.parts import firmware as fw
from cosim.parts import regmap


def _firmware(kv: int, uff_limit: int | None = None) -> fw.Firmware:
    loop = {"kv": kv}
    if uff_limit is not None:
        loop["uff_limit"] = uff_limit
    # Compensator "none": T_c is T_ref's word, so the rate is exactly the reference's.
    f = fw.Firmware(fw.FirmwareConfig(comp=fw.CompensatorParams(mode="none"), loop=loop))
    f.start()
    f.drain_writes()
    return f


def _expected(kv: int, dtc: int, lim: int, tick_rate_hz: int = 1000) -> int:
    """The word from exact integers: floor((kv * dtc * f + 2^19) / 2^20), clamped."""
    v = (kv * dtc * tick_rate_hz + (1 << 19)) >> 20
    return max(-lim, min(lim, v))


def _uff_writes(writes):
    return [v for a, v in writes if a == regmap.UFF]


def test_uff_follows_the_rate_of_t_c_rounded_and_written_on_change():
    kv = kv_word(0.001)  # 1 mA per N/s
    assert kv == round(0.001 * (1 << KV_FRAC))
    f = _firmware(kv)
    words = [0, 0, 256, 512, 700, 700, 650, 3000, 3000, 0, 1]  # Q7.8 T_c words (>= 0: the floor)
    written = 0
    prev = None
    for w in words:
        f.tick_word(w)
        ws = f.drain_writes()
        assert ws[0] == (regmap.TC, w & 0xFFFFFFFF)
        exp = 0 if prev is None else _expected(kv, w - prev, 2048)  # default bound 0.5 A
        if exp != written:
            assert _uff_writes(ws) == [exp & 0xFFFFFFFF], (w, prev)
            written = exp
        else:
            assert _uff_writes(ws) == [], (w, prev)
        prev = w
    # 1 N per tick at 1 kHz is 1000 N/s: 1 A, above the default bound 0.5 A (2048).
    assert _expected(kv, 256, 2048) == 2048
    # 0.25 N per tick (250 N/s): 0.25 A = 1024 exactly.
    assert _expected(kv, 64, 2048) == 1024


def test_uff_is_bounded_at_full_scale_both_ways():
    """The largest gain and full-scale swings of T_c (0 <-> 127.996 N: T_c has the floor 0):
    the word stops at +-uff_limit, for the limit at full scale (UQ3.12 32767) and at 1 A; the
    int64 product (fw.c) does not overflow there."""
    assert fw.FW_KV_MAX * 65535 * 65535 < 1 << 53  # kv * |dT_c| * f_tick, all at their bounds
    for lim in (32767, 4096):
        f = _firmware(fw.FW_KV_MAX, lim)
        f.tick_word(0)
        f.drain_writes()
        f.tick_word(32767)
        assert _uff_writes(f.drain_writes()) == [lim]
        f.tick_word(0)
        assert _uff_writes(f.drain_writes()) == [(-lim) & 0xFFFFFFFF]
        f.tick_word(0)  # no change: rate 0
        assert _uff_writes(f.drain_writes()) == [0]


def test_stop_and_restart_take_the_feedforward_back():
    f = _firmware(kv_word(0.001))
    f.tick_word(0)
    f.tick_word(100)
    assert _uff_writes(f.drain_writes()) == [_expected(kv_word(0.001), 100, 2048)]
    f.stop()
    assert (regmap.UFF, 0) in f.drain_writes()
    f.start()
    ws = f.drain_writes()
    assert (regmap.UFF, 0) in ws  # on start, before CTRL enables the loop
    assert [a for a, _ in ws].index(regmap.UFF) < len(ws) - 1
    f.tick_word(5000)  # first tick after start: no rate, no write
    assert _uff_writes(f.drain_writes()) == []


def test_off_writes_no_uff_at_all():
    f = _firmware(0)
    for w in (0, 1000, -1000, 32767):
        f.tick_word(w)
        assert _uff_writes(f.drain_writes()) == []
    f.stop()
    f.start()
    assert _uff_writes(f.drain_writes()) == []


@pytest.mark.parametrize(
    ("loop", "field"),
    [
        ({"kv": -1}, "loop.kv"),
        ({"kv": fw.FW_KV_MAX + 1}, "loop.kv"),
        ({"uff_limit": -1}, "loop.uff_limit"),
        ({"uff_limit": 32768}, "loop.uff_limit"),
    ],
)
def test_bad_rate_feedforward_config_is_refused(loop, field):
    f = fw.Firmware()
    with pytest.raises(fw.FirmwareConfigError) as err:
        f.configure(fw.FirmwareConfig(loop=loop))
    assert err.value.field == field


def test_kv_word_range():
    assert kv_word(1.0 / 16.0) == fw.FW_KV_MAX
    with pytest.raises(ValueError, match="kv"):
        kv_word(0.07)
    with pytest.raises(ValueError, match="kv"):
        kv_word(-1e-6)
