"""The float (double) reference of the closed loop: the oracle of the fixed-point chain.

Same scenario, same plant FMU (its own instance), same timing as the co-simulation, but with
- the compensator's double twin (firmware comp_f64, through cosim.parts.firmware) in place of the
  firmware's fixed-point tick, and
- `cosim.parts.rtl_model.FloatTensionLoop`, the double model of the RTL's PI + feedforward loop
  (hdl/rtl/tension_loop.v: same equations and conditional-integration anti-windup, no
  quantization), with the run's gains in SI units, in place of the RTL;
- the same interface stage (cosim.parts.interface: the board's ADC and PWM -> ESCON, or the ideal
  one), in its float form: the ADC's value instead of its 24-bit code, the PWM duty of the
  command in amperes instead of the duty in board clocks.

Timing, identical to the co-simulation harness (cosim/engines/cocotb/tb_closed_loop.py):
- FPGA sample k at t_k = k / f_s: the loop computes u_k from T_c in force and the latest ADC
  sample; the interface stage turns u_k into the plant's current over [t_k, t_k+1) (u_k itself
  with the ideal interface) and, from the sensors at t_k+1, gives the ADC sample of tick k+1
  (with the ideal interface, T_in_meas(t_k+1) at every sample).
- Firmware tick i at sample k = i*D (D = f_s / f_fw): T_c,i = comp(T_ref(t_k)); the write reaches
  the loop for sample k + 2 (TC_LATENCY_SAMPLES), as the AXI write does in the co-simulation;
  with the rate feedforward on (controller.kv_a_s_per_n, fw.h), u_ff,i = clamp(kv * (T_c,i -
  T_c,i-1) * f_fw, +-uff_limit) with it (none at the first tick), as the firmware's UFF write.
"""

from __future__ import annotations

import math

import numpy as np

from cosim.config.run import SimConfig
from cosim.config.scenarios import Scenario, firmware_t_ref, sample_inputs
from cosim.parts import regmap, rtl_model
from cosim.parts.firmware import make_compensator_f64, tension_word
from cosim.parts.interface import make_chain
from cosim.parts.rtl_model import FloatTensionLoop
from cosim.project.progress import Progress

from .fwbridge import KV_FRAC, loop_words
from .harness import TC_LATENCY_SAMPLES, CommandTension, PlantFeed, Record, open_plant, store_run


def make_float_loop(cfg: SimConfig) -> FloatTensionLoop:
    """The double model of the RTL's loop (cosim.parts.rtl_model.FloatTensionLoop) with the gains
    the firmware programs: the register words (fwbridge.loop_words) taken as real numbers, so that
    the comparison measures the fixed-point arithmetic, not the choice of gain words."""
    words = loop_words(cfg.controller, cfg.sample_rate_hz)
    return FloatTensionLoop(
        kff_a_per_n=words["kff"] / (1 << rtl_model.GAIN_FRAC),
        kp_a_per_n=words["kp"] / (1 << rtl_model.GAIN_FRAC),
        ki_ts_a_per_n=words["ki_ts"] / (1 << rtl_model.KI_TS_FRAC),
        i_limit_a=words["i_limit"] / (1 << rtl_model.CURRENT_FRAC),
    )


def resolve_phi(scen: Scenario, cfg: SimConfig, loop_routing: bool) -> float:
    """The bending angle the compensator is configured with: cfg.compensator.phi_rad, or the
    sheath's phi at the scenario's start position as the plant FMU computes it (the compensator
    is calibrated there once, as the paper's is by its characterisation, Sec. VI-A)."""
    if cfg.compensator.phi_rad is not None:
        return float(cfg.compensator.phi_rad)
    x, y, z = scen.trajectory(np.zeros(1))
    plant = open_plant(cfg, loop_routing, (x[0], y[0], z[0]))
    try:
        return float(plant.y[plant.PHI])
    finally:
        plant.close()


def run_reference(
    scen: Scenario,
    cfg: SimConfig,
    compensator: str,
    loop_routing: bool,
    phi_rad: float,
    duration_s: float | None = None,
    progress: bool = True,
    interface: str = "board",
    chain=None,
    loop=None,
) -> dict[str, np.ndarray]:
    """Run the float reference with the interface stage `interface`
    (cosim.parts.interface.INTERFACES); return its record (the arrays of cosim.engines.harness).

    A study of other front-ends (cosim.studies.sensing) may hand its own interface stage `chain`
    (the float form of cosim.parts.interface.Chain: start / drive / sense) and its own `loop` (an
    object with step(tc_n, t_in_n) -> current_a) in place of make_chain(cfg, interface) and
    make_float_loop(cfg)."""
    inp = sample_inputs(scen, cfg, duration_s)
    n = len(inp.t_s)
    dec = cfg.decimation
    rec = Record.allocate(n).arrays
    plant = open_plant(cfg, loop_routing, (inp.x_m[0], inp.y_m[0], inp.z_m[0]))
    # The compensator's double twin (firmware comp_f64), configured like the firmware.
    comp = make_compensator_f64(compensator, cfg.compensator, phi_rad, cfg.firmware_rate_hz)
    loop = loop if loop is not None else make_float_loop(cfg)
    bar = Progress(n, "float reference", cfg.sample_rate_hz, enabled=progress)

    # The host hands T_ref to the firmware as a Q7.8 word (fw_tick); the twin gets the same
    # words, so that both see a reversal at the same tick (comp.h: the twin is the oracle "fed
    # the same Q7.8 references").
    t_ref = firmware_t_ref(scen, cfg, compensator, inp).tolist()  # ahead in preview mode
    out_tc, out_u = rec["T_c_N"], rec["current_A"]
    T_IN_MEAS = plant.T_IN_MEAS

    tc_new = 0.0  # T_c computed at the last firmware tick, in force from the next sample
    tc = 0.0
    words = loop_words(cfg.controller, cfg.sample_rate_hz)
    # T_c after the RTL's slew limit and floor (SLEW, TC_MIN as programmed), as the loop uses it.
    tc_path = CommandTension.programmed(words, cfg.compensator.tc_min_n)
    y = plant.y
    chain = chain if chain is not None else make_chain(cfg, interface, fixed=False)
    t_in_meas = chain.start(y[T_IN_MEAS])  # the ADC sample in force (N)
    # The rate feedforward in SI units (fw.h loop.kv, uff_limit), from the words the firmware holds.
    kv = words["kv"] / (1 << KV_FRAC)
    uff_lim = words["uff_limit"] / (1 << rtl_model.CURRENT_FRAC)
    tc_prev = None  # T_c of the previous firmware tick (None before the first)
    uff_new = 0.0
    feed = PlantFeed(plant, inp, chain.drive, n)
    sense = chain.sense
    for k in range(n):
        if k >= TC_LATENCY_SAMPLES and (k - TC_LATENCY_SAMPLES) % dec == 0:
            tc = tc_new
            if kv > 0.0:
                loop.uff_a = uff_new
        tc_eff = tc_path.step(tc)
        u = loop.step(tc_eff, t_in_meas)
        if k % dec == 0:
            tc_new = comp.step(tension_word(t_ref[k]) / 256.0)
            if kv > 0.0:
                rate = 0.0 if tc_prev is None else (tc_new - tc_prev) * cfg.firmware_rate_hz
                uff_new = min(max(kv * rate, -uff_lim), uff_lim)
                tc_prev = tc_new
        # Record sample k: the sensors as the loop saw them and the command it gave.
        out_tc[k] = tc_eff
        out_u[k] = u
        y = feed.sample(k, u)
        sample = sense(k, y[T_IN_MEAS])
        if sample is not None:
            t_in_meas = sample
        if (k & 1023) == 0:
            bar.update(k)
    bar.close(n)
    store_run(rec, feed.rows, inp)
    plant.close()
    if not math.isfinite(float(np.sum(out_u))):
        raise RuntimeError("float reference: the current command is not finite")
    return rec


def run_model_chain(
    scen: Scenario,
    cfg: SimConfig,
    compensator: str,
    loop_routing: bool,
    phi_rad: float,
    duration_s: float | None = None,
    interface: str = "board",
) -> dict[str, np.ndarray]:
    """The fixed-point chain without a simulator: the firmware (host build) and the RTL's
    bit-exact Python model (cosim.parts.rtl_model.TensionLoopModel) against the FMU, with the
    co-simulation's timing and interface stage. The RTL co-simulation must give the same command
    word at every sample (tests/cosim); it is also a quick way to try a configuration."""
    from .fwbridge import FirmwareBridge  # noqa: PLC0415

    inp = sample_inputs(scen, cfg, duration_s)
    n = len(inp.t_s)
    dec = cfg.decimation
    rec = Record.allocate(n).arrays
    plant = open_plant(cfg, loop_routing, (inp.x_m[0], inp.y_m[0], inp.z_m[0]))
    fw = FirmwareBridge(cfg, compensator, phi_rad)
    model = rtl_model.TensionLoopModel()
    names = {reg.addr: name for name, reg in regmap.REGISTERS.items()}
    fw_ref = firmware_t_ref(scen, cfg, compensator, inp)  # ahead in preview mode

    def apply(writes):
        for addr, value in writes:
            name = names[addr]
            if name != "CTRL":
                value = regmap.decode(name, value)
            model.write(name, value)

    chain = make_chain(cfg, interface, True, fw.adc_offset, fw.adc_gain)
    code0 = chain.start(plant.y[plant.T_IN_MEAS])
    apply(fw.start())
    for _ in range(2):  # the start-up's CTRL pulses take effect at a tick
        model.adc_sample(code0)
        model.tick()
    pending: list = []
    code = code0
    y = plant.y
    words = np.zeros(n)
    feed = PlantFeed(plant, inp, chain.drive, n)
    for k in range(n):
        if k >= TC_LATENCY_SAMPLES and (k - TC_LATENCY_SAMPLES) % dec == 0:
            apply(pending)
            pending = []
        if code is not None:
            model.adc_sample(code)
        out = model.tick()
        words[k] = out.u
        u = out.u / 4096.0
        rec["T_c_N"][k] = out.tc_eff / 256.0
        rec["current_A"][k] = u
        y = feed.sample(k, out.u)
        code = chain.sense(k, y[plant.T_IN_MEAS])
        if k % dec == 0:
            _, pending = fw.tick(float(fw_ref[k]))
    plant.close()
    store_run(rec, feed.rows, inp)
    rec["u_word"] = words
    return rec
