"""The firmware's host library through ctypes (cosim.parts.firmware): the fixed-point compensator
against its double twin, configuration errors, and the tick on the register shadow."""

import ctypes
import math

import numpy as np
import pytest

from cosim.parts import firmware as fw
from cosim.parts import regmap

LSB = 1.0 / 256.0

CONFIGS = {
    "paper": fw.CompensatorParams(mode="paper"),
    "paper-eq16": fw.CompensatorParams(mode="paper", hysteresis_n=LSB),
    "smooth": fw.CompensatorParams(mode="smooth"),
    "smooth-4pi": fw.CompensatorParams(mode="smooth", mu=0.3, phi_rad=4 * math.pi, band_n=0.7),
    "smooth-max-gain": fw.CompensatorParams(mode="smooth", mu=1 / 3, phi_rad=12.0, band_n=5.0),
    "smooth-extensions": fw.CompensatorParams(
        mode="smooth", offset_n=0.5, mu_slope_per_n=0.0005, band_n=1.5
    ),
    "none": fw.CompensatorParams(mode="none"),
    "preview": fw.CompensatorParams(mode="preview", preview_ticks=80, lead_ticks=4, ramp_ticks=160),
    "preview-floor": fw.CompensatorParams(
        mode="preview", preview_ticks=128, lead_ticks=0, ramp_ticks=256, tc_min_n=2.0
    ),
}


def _references(rng: np.random.Generator, n: int = 20000) -> dict[str, np.ndarray]:
    walk = np.clip(np.cumsum(rng.integers(-60, 61, n)), -32768, 32767)
    t = np.arange(n) / 1000.0
    return {
        "random walk": walk.astype(np.int16),
        "random full scale": rng.integers(-32768, 32768, n).astype(np.int16),
        "full-scale square": np.where(np.arange(n) % 2, -32768, 32767).astype(np.int16),
        "fig14 sine": np.round((7.5 + 7.5 * np.sin(2 * np.pi * 0.5 * t)) * 256).astype(np.int16),
        "dithered constant": (2560 + rng.integers(-1, 2, n)).astype(np.int16),
    }


@pytest.mark.parametrize("name", list(CONFIGS))
def test_fw_fixed_matches_double_twin(name):
    """Random inputs and full scale: |T_c fixed - T_c twin| within the documented bound."""
    params = CONFIGS[name]
    bound = params.error_bound_n()
    rng = np.random.default_rng(5)
    for label, words in _references(rng).items():
        fixed = fw.Compensator(params).run_words(words) * LSB
        twin = fw.CompensatorF64(params.quantized()).run(words * LSB)
        worst = float(np.max(np.abs(fixed - twin)))
        assert worst <= bound, f"{name}, {label}: {worst:.5f} N > bound {bound:.5f} N"


def test_fw_step_by_step_equals_batch():
    """step() (one ctypes call per tick, as the co-simulation uses it) equals the batch run."""
    words = _references(np.random.default_rng(1))["random walk"][:3000]
    a = fw.Compensator(mode="smooth")
    b = fw.Compensator(mode="smooth")
    one = [a.step_word(int(w)) for w in words]
    assert np.array_equal(np.array(one, dtype=np.int16), b.run_words(words))
    c = fw.CompensatorF64(mode="smooth")
    d = fw.CompensatorF64(mode="smooth")
    assert np.array_equal([c.step(float(w) * LSB) for w in words], d.run(words * LSB))


def test_fw_saturates_at_full_scale():
    """The largest gain at both ends of Q7.8 saturates instead of wrapping; the low end is the
    floor (a cable cannot push: 0 N by default, up to 64 N)."""
    comp = fw.Compensator(mode="paper", mu=1 / 3, phi_rad=12.0, hysteresis_n=LSB)
    assert comp.step_word(-32768) == 0
    assert comp.step_word(32767) == 32767
    floored = fw.Compensator(mode="paper", mu=1 / 3, phi_rad=12.0, tc_min_n=64.0)
    assert floored.step_word(-32768) == 64 * 256
    assert fw.CompensatorF64(mode="paper", tc_min_n=64.0).step(-128.0) == 64.0
    assert comp.step(1e9) == 32767 * LSB  # a reference beyond full scale is saturated first
    assert fw.CompensatorF64(mode="paper", mu=1 / 3, phi_rad=12.0).step(127.0) == 32767 * LSB


def test_fw_sign_held_when_delta_is_zero():
    """Eq. 16: with dT_ref/dt = 0, the last sign is kept (loading and unloading)."""
    comp = fw.Compensator(mode="paper", hysteresis_n=LSB)
    gu, gd = math.exp(0.075 * 2 * math.pi), math.exp(-0.075 * 2 * math.pi)
    for t in np.linspace(0, 10, 200):
        comp.step(t)
    held = [comp.step(10.0) for _ in range(100)]
    assert comp.direction == 1
    assert max(abs(h - 10 * gu) for h in held) <= LSB
    for t in np.linspace(10, 5, 200):
        comp.step(t)
    held = [comp.step(5.0) for _ in range(100)]
    assert comp.direction == -1
    assert max(abs(h - 5 * gd) for h in held) <= LSB


def test_fw_no_chatter_on_noisy_reference():
    """A 3-LSB peak-to-peak dither on a constant reference never flips the detector (H = 4 LSB);
    the paper's exact sign(delta) (H = 1 LSB) would flip it thousands of times."""
    rng = np.random.default_rng(7)
    noisy = (2560 + rng.integers(-1, 2, 20000)).astype(np.int16)
    ramp = np.arange(0, 2560, 8, dtype=np.int16)
    words = np.concatenate([ramp, noisy])
    for h, expect_flips in ((4 * LSB, False), (LSB, True)):
        comp = fw.Compensator(mode="paper", hysteresis_n=h)
        dirs = []
        for w in words:
            comp.step_word(int(w))
            dirs.append(comp.direction)
        flips = int(np.count_nonzero(np.diff(dirs[len(ramp) :])))
        assert (flips > 100) == expect_flips, f"H = {h * 256:.0f} LSB: {flips} flips"


def test_fw_smooth_inverse_is_continuous():
    """Fig. 14's sine: every step of T_c within the documented bound; the paper's law jumps."""
    t = np.arange(20000) / 1000.0
    words = np.round((7.5 + 7.5 * np.sin(2 * np.pi * 0.5 * t)) * 256).astype(np.int16)
    params = fw.CompensatorParams(mode="smooth", band_n=2.0)
    tc = fw.Compensator(params).run_words(words).astype(float) * LSB
    ref = words.astype(float) * LSB
    dref = np.diff(ref)
    tmax = np.maximum(np.abs(ref[1:]), np.abs(ref[:-1]))
    bound = params.step_bound_n(dref, tmax)  # vectorized over the steps
    assert np.all(np.abs(np.diff(tc)) <= bound)
    paper = fw.Compensator(mode="paper").run_words(words).astype(float) * LSB
    assert np.max(np.abs(np.diff(paper))) > 10 * np.max(np.abs(np.diff(tc)))


BAD = [
    ({"mu": -0.01}, "comp.mu"),
    ({"mu": float("nan")}, "comp.mu"),
    ({"mu": 1e12}, "comp.mu"),
    ({"phi_rad": -0.1}, "comp.phi_rad"),
    ({"phi_rad": 4 * math.pi + 1e-3}, "comp.phi_rad"),
    ({"band_n": 0.0}, "comp.band_n"),
    ({"hysteresis_n": 0.0}, "comp.hysteresis_n"),
    ({"offset_n": 65.0}, "comp.offset_n"),
    ({"mu_slope_per_n": 0.01}, "comp.mu_slope_per_n"),
    ({"mu": 0.5, "phi_rad": 9.0}, "comp.mu"),  # mu*phi > 4: the exponent limit
    ({"mode": "exact"}, "comp.mode"),
]


@pytest.mark.parametrize(("change", "field"), BAD)
def test_fw_bad_config_raises_and_keeps_previous(change, field):
    """Each bad field raises FirmwareConfigError naming it; the compensator keeps working with
    its previous configuration, step for step like an untouched one."""
    good = fw.CompensatorParams(mode="smooth", band_n=1.0)
    a, b = fw.Compensator(good), fw.Compensator(good)
    words = _references(np.random.default_rng(3))["random walk"][:2000]
    a.run_words(words[:1000])
    b.run_words(words[:1000])
    bad = fw.CompensatorParams(**{**good.__dict__, **change})
    with pytest.raises(fw.FirmwareConfigError) as err:
        a.configure(bad)
    assert err.value.field == field
    assert field in str(err.value)
    assert a.params == good
    assert np.array_equal(a.run_words(words[1000:]), b.run_words(words[1000:]))
    if change.get("mode") is None and not any(
        isinstance(v, float) and not math.isfinite(v) for v in change.values()
    ):
        with pytest.raises(fw.FirmwareConfigError):  # the twin checks the same limits
            fw.CompensatorF64(bad)


def test_fw_make_compensator_f64_from_scenario_params():
    """The co-simulation's entry point, from a run's CompensatorParams (SimConfig.compensator)."""
    p = fw.CompensatorParams(mu=0.075, band_n=2.0, hysteresis_n=4 * LSB)
    twin = fw.make_compensator_f64("smooth", p, 2 * math.pi)
    fixed = fw.make_compensator("smooth", p, 2 * math.pi)
    for t in np.linspace(0, 15, 500):
        assert abs(twin.step(float(np.round(t * 256) * LSB)) - fixed.step(float(t))) <= LSB


def test_fw_make_firmware_for_the_cosim():
    """make_firmware: the tick computes what the fixed-point compensator computes."""
    p = fw.CompensatorParams(mu=0.075, band_n=2.0, hysteresis_n=4 * LSB)
    f = fw.make_firmware("smooth", p, 2 * math.pi, tick_rate_hz=1000, sample_rate_hz=10000)
    f.start()
    assert f.drain_writes()[-1] == (regmap.CTRL, regmap.CTRL_ENABLE)
    comp = fw.make_compensator("smooth", p, 2 * math.pi)
    for t in np.linspace(0, 15, 300):
        assert f.tick(float(t)) == comp.step_word(fw.tension_word(float(t)))


def test_fw_exp_error_bound_through_ctypes():
    """fxp_exp_uq8_24 on random points: |error| <= 2^-25 + 2e-9 * exp(x) (fxp.h)."""
    lib = fw.load_library()
    rng = np.random.default_rng(11)
    for x in rng.uniform(-5.5, 5.5, 20000):
        xq = int(round(x * 2**28))
        exact = math.exp(xq / 2**28)
        got = lib.fxp_exp_uq8_24(xq) / 2**24
        assert abs(got - exact) <= 2**-25 + 2e-9 * exact, x


def test_fw_struct_mirrors_match_library():
    lib = fw.load_library()
    assert lib.fw_host_sizeof(1) == ctypes.sizeof(fw.CompConfig)
    assert lib.fw_host_sizeof(3) == ctypes.sizeof(fw.CompF64Config)
    assert lib.fw_host_sizeof(5) == ctypes.sizeof(fw.FwConfig)
    assert lib.fw_host_sizeof(6) == ctypes.sizeof(fw.Telemetry)


def test_fw_tick_on_shadow():
    """Start-up writes, then one TC write per tick carrying the compensator's T_c; telemetry
    reads the shadow (sign-extended words)."""
    f = fw.Firmware(fw.FirmwareConfig(comp=fw.CompensatorParams(mode="smooth")))
    f.start()
    writes = f.drain_writes()
    assert [a for a, _ in writes][:2] == [regmap.CTRL, regmap.KFF]
    assert writes[-1] == (regmap.CTRL, regmap.CTRL_ENABLE)
    f.shadow_write("T_IN", 0xFFFFFE00)  # -2 N
    f.shadow_write(regmap.U, 0x1000)  # 1 A
    f.shadow_write("FAULT", regmap.FAULT_ADC_STALE)
    comp = fw.Compensator(mode="smooth")
    for k in range(500):
        t_ref = 7.5 + 7.5 * math.sin(2 * math.pi * k / 1000)
        tc = f.tick(t_ref)
        assert tc == comp.step_word(fw.tension_word(t_ref))
        assert f.drain_writes() == [(regmap.TC, tc & 0xFFFFFFFF)]
    tel = f.telemetry()
    assert tel["ticks"] == 500 and tel["t_in_n"] == -2.0 and tel["u_a"] == 1.0
    assert tel["fault"] == regmap.FAULT_ADC_STALE and tel["fault_ticks"] == 500
    assert f.shadow_read("TC") == tc & 0xFFFFFFFF


def test_fw_write_log_overflow_is_counted():
    f = fw.Firmware()
    for _ in range(70):
        f.tick(1.0)
    assert f.log_dropped == 6
    assert len(f.drain_writes()) == 64
    assert f.drain_writes() == []


def test_fw_wave_source():
    """With the wave source the tick follows the firmware's own 0..15 N sine (Fig. 14)."""
    f = fw.Firmware(fw.FirmwareConfig(source="wave"))
    refs = []
    for _ in range(2000):
        f.tick()
        refs.append(f.telemetry()["t_ref_n"])
    exact = 7.5 + 7.5 * np.sin(2 * np.pi * 0.5 * np.arange(2000) / 1000)
    assert np.max(np.abs(np.array(refs) - exact)) <= LSB


def test_fw_wave_phase_and_triangle():
    """A triangle starting three quarters into its turn: -amplitude first, then rising."""
    wave = fw.WaveParams(kind="triangle", mean_n=10.0, amplitude_n=4.0, freq_hz=250.0)
    wave.phase0_turns = 0.75
    f = fw.Firmware(fw.FirmwareConfig(source="wave", wave=wave))
    refs = []
    for _ in range(4):
        f.tick()
        refs.append(f.telemetry()["t_ref_n"])
    assert refs == [6.0, 10.0, 14.0, 10.0]


@pytest.mark.parametrize(
    ("config", "field"),
    [
        (fw.FirmwareConfig(loop={"wdt_timeout": 20}), "loop.wdt_timeout"),
        (fw.FirmwareConfig(loop={"kp": 40000}), "loop.kp"),
        (fw.FirmwareConfig(loop={"bogus": 1}), "loop.bogus"),
        (fw.FirmwareConfig(tick_rate_hz=0), "tick_rate_hz"),
        (fw.FirmwareConfig(source="adc"), "source"),
        (fw.FirmwareConfig(wave=fw.WaveParams(freq_hz=600.0)), "wave.freq_hz"),
        (fw.FirmwareConfig(comp=fw.CompensatorParams(band_n=0.0)), "comp.band_n"),
    ],
)
def test_fw_firmware_bad_config(config, field):
    f = fw.Firmware()
    with pytest.raises(fw.FirmwareConfigError) as err:
        f.configure(config)
    assert err.value.field == field
    assert f.config == fw.FirmwareConfig()
