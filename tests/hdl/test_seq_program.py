"""The sequenced datapath's microprogram (hdl/seq/program.py), run on its instruction-level
simulator, against the bit-exact model (cosim/parts/rtl_model.py's TensionLoopMcModel): random
configurations, events, faults and group stops, and the extremes of every format. The RTL
engine (hdl/rtl/tension_loop_seq.v) is held to the same model by test_bowden_core_mc.py."""

from __future__ import annotations

import random

import pytest

from cosim.parts import regmap
from cosim.parts.rtl_model import TensionLoopMcModel
from hdl.seq import program as seq

FIELDS = {  # register: (lowest, highest) value
    "TC": (-32768, 32767),
    "TC_MIN": (-32768, 32767),
    "KFF": (-32768, 32767),
    "KP": (-32768, 32767),
    "KI_TS": (-32768, 32767),
    "UFF": (-32768, 32767),
    "I_LIMIT": (0, 32767),
    "SLEW": (0, 32767),
    "WDT_TIMEOUT": (0, 0xFFFF),
    "ADC_OFFSET": (-(1 << 23), (1 << 23) - 1),
    "ADC_GAIN": (-32768, 32767),
    "ADC_MIN": (-(1 << 23), (1 << 23) - 1),
    "ADC_MAX": (-(1 << 23), (1 << 23) - 1),
    "ADC_STALE": (0, 0xFFFF),
    "OC_TIMEOUT": (0, 0xFFFF),
}


def _pick(rng: random.Random, name: str) -> int:
    lo, hi = FIELDS[name]
    r = rng.random()
    if r < 0.15:
        return lo
    if r < 0.3:
        return hi
    if r < 0.45 and lo <= 0 <= hi:
        return rng.randint(max(lo, -16), min(hi, 16))
    return rng.randint(lo, hi)


def _run(seed: int, periods: int, n: int = 2, extreme: float = 0.3) -> int:
    rng = random.Random(seed)
    model = TensionLoopMcModel([0] * n)
    prog = seq.assemble()
    eng = seq.Engine(n=n, step=model.channels[0].wdt_ramp_step)
    compared = 0
    for _ in range(periods):
        for ch in model.channels:
            for _ in range(rng.randint(0, 3)):
                name = rng.choice(list(FIELDS))
                wild = extreme if name not in ("ADC_MIN", "ADC_MAX") else extreme / 6
                val = _pick(rng, name) if rng.random() < wild else None
                if val is None:  # mostly moderate values, so the loop runs
                    val = {
                        "I_LIMIT": rng.randint(0, 32767),
                        "SLEW": rng.randint(0, 2000),
                        "WDT_TIMEOUT": rng.choice([0, rng.randint(1, 40)]),
                        "ADC_STALE": rng.choice([0, rng.randint(1, 6)]),
                        "OC_TIMEOUT": rng.choice([0, rng.randint(1, 30)]),
                        "ADC_MIN": -(1 << 23) + rng.randint(0, 3),
                        "ADC_MAX": (1 << 23) - 1 - rng.randint(0, 3),
                    }.get(name, _pick(rng, name))
                ch.write(name, val)
            if rng.random() < 0.4:
                ctrl = (
                    (regmap.CTRL_ENABLE if rng.random() < 0.85 else 0)
                    | (regmap.CTRL_SLEW_EN if rng.random() < 0.5 else 0)
                    | (regmap.CTRL_INTEG_RESET if rng.random() < 0.1 else 0)
                    | (regmap.CTRL_FAULT_CLEAR if rng.random() < 0.5 else 0)
                )
                ch.write("CTRL", ctrl)
            if rng.random() < 0.8:
                ch.adc_sample(
                    rng.randint(-(1 << 23), (1 << 23) - 1)
                    if rng.random() < 0.3
                    else rng.randint(-200000, 200000)
                )
        groups = model.groups
        stops = [
            any(j != k and groups[j] == groups[k] and model.channels[j].faults for j in range(n))
            for k in range(n)
        ]
        ev = [
            dict(
                raw=c.raw,
                enable=c.enable,
                slew_en=c.slew_en,
                fresh=c.fresh,
                tcw=c.tc_written,
                irst=c.integ_reset_pending,
                fclr=c.fault_clear_pending,
                grp=stops[k],
            )
            for k, c in enumerate(model.channels)
        ]
        cfg = [dict(c.regs) for c in model.channels]
        outs = model.tick()
        seq.simulate_period(eng, prog, cfg, ev)
        for k, o in enumerate(outs):
            got = eng.outs[k]
            st = got[seq.O_STATUS]
            integ = (got[seq.O_IH] << 16) | got[seq.O_IL]
            assert (
                seq._s16(got[seq.O_U]),
                bool(st & 1),
                bool(st & 2),
                bool(st & 4),
                got[seq.O_FAULT],
                seq._s16(got[seq.O_TIN]),
                integ - (1 << 32) if integ >> 31 else integ,
                seq._s16(got[seq.O_TCE]),
            ) == (o.u, o.out_en, o.saturated, o.wdt_ramp, o.faults, o.t_in, o.integ, o.tc_eff), (
                f"seed {seed}, channel {k}, sample {o.sample_count}"
            )
            compared += 1
    return compared


@pytest.mark.parametrize("seed", range(6))
def test_program_matches_the_model(seed: int) -> None:
    assert _run(seed, 400) == 800


def test_program_at_the_extremes() -> None:
    assert _run(100, 400, extreme=1.0) == 800


def test_rom_is_the_program() -> None:
    """hdl/rtl/tension_loop_seq_rom.v is what `python -m hdl.seq.program` writes now."""
    assert seq.main(["--check"]) == 0


def test_counters_stop_at_their_top() -> None:
    """The stale, watchdog and over-current counts near 0xFFFF (which 400 random samples never
    reach): each stops there and a threshold of 0xFFFF still trips, as in the model. Channel 0
    (no ADC samples, no TC write) trips ADC_STALE and WATCHDOG; channel 1, in a group of its
    own and clipped every sample, OVERCURRENT."""
    model = TensionLoopMcModel([0, 1])
    prog = seq.assemble()
    eng = seq.Engine(n=2, step=model.channels[0].wdt_ramp_step)
    for k, ch in enumerate(model.channels):
        ch.write("ADC_STALE", 0xFFFF if k == 0 else 0)
        ch.write("WDT_TIMEOUT", 0xFFFF if k == 0 else 0)
        ch.write("OC_TIMEOUT", 0xFFFF)
        ch.write("I_LIMIT", 16)  # clipped every sample: the over-current count runs
        ch.write("TC", 20 * 256)
        ch.write("CTRL", regmap.CTRL_ENABLE)
        ch.tc_written = False  # the TC write before the counts: no watchdog refresh
        ch.stale_cnt = ch.wdt_cnt = ch.oc_cnt = 0xFFFB
        for word in (seq.S_STALE, seq.S_WDT, seq.S_OC):
            eng.sp[(k << 6) | word] = 0xFFFB
    seen = [0, 0]
    for _ in range(8):
        ev = [
            dict(raw=c.raw, enable=c.enable, slew_en=c.slew_en, fresh=c.fresh, tcw=c.tc_written,
                 irst=c.integ_reset_pending, fclr=c.fault_clear_pending, grp=False)
            for c in model.channels
        ]  # fmt: skip
        cfg = [dict(c.regs) for c in model.channels]
        outs = model.tick()
        seq.simulate_period(eng, prog, cfg, ev)
        for k, o in enumerate(outs):
            ch = model.channels[k]
            words = [eng.sp[(k << 6) | w] for w in (seq.S_STALE, seq.S_WDT, seq.S_OC)]
            assert words == [ch.stale_cnt, ch.wdt_cnt, ch.oc_cnt], (k, o.sample_count, words)
            assert eng.outs[k][seq.O_FAULT] == o.faults, (k, o.sample_count)
            assert seq._s16(eng.outs[k][seq.O_U]) == o.u, (k, o.sample_count)
            seen[k] |= o.faults
    assert seen == [regmap.FAULT_ADC_STALE | regmap.FAULT_WATCHDOG, regmap.FAULT_OVERCURRENT]


def test_the_schedule_hdl_readme_quotes() -> None:
    """hdl/README.md ("The sequenced datapath") quotes the program's size and clocks."""
    prog = seq.assemble()
    assert (len(prog.words), prog.entry1, prog.len0, prog.len1) == (491, 41, 41, 450)
    assert prog.latency(2) == 983 and prog.latency(3) == 1474
