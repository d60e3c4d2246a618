"""The closed-loop co-simulation testbench (cocotb 2.x): RTL + firmware + plant FMU.

Started by cosim.engines.cocotb.runner inside the simulator; the run's specification is the JSON
file named by BOWDEN_COSIM_SPEC (scenario, compensator, loop routing, configuration, output paths).

Timing of one FPGA sample k, in clocks (C = CLKS_PER_SAMPLE = L + 1, where L is the RTL loop's
latency from its tick to the command, rtl_model.LATENCY_CLKS; cosim/engines/cocotb/runner.py):

    edge Ck         tick k: the RTL takes the ADC sample of t_k and the T_c in force
    edge Ck + L     the command u_k is out (cmd_current, Q3.12)
    Ck + L + 0.5    the harness wakes (one Timer per sample, half a clock after the edge):
                    reads u_k, hands it to the interface stage (cosim.parts.interface: the board's
                    PWM -> ESCON, or the ideal drive), steps the FMU over [t_k, t_k+1) with the
                    current the stage gives (one or two pieces), and hands over the ADC sample the
                    stage gives for tick k+1, if any (the board's ADC at its DRDY times, or the
                    ideal ADC's code of T_in_meas(t_k+1)): adc_word = {flipped toggle, code}, a
                    one-clock adc_valid in cosim_top.v; at every D-th sample (k = i*D) it also
                    wakes the firmware task.
    edge Ck + C     tick k+1 takes that ADC sample (or keeps the last one).

The firmware task (processor, 1 kHz): fills the firmware's register shadow with the words it
read over AXI4-Lite after its previous tick (STATUS, FAULT, T_IN, U, SAMPLE_COUNT), calls the
firmware tick with T_ref(t_k), and performs the writes of its write log over AXI4-Lite
(cocotbext-axi) right away: the TC write lands a few clocks after tick k+1, so tick k+2 is the
first to use it (TC_LATENCY_SAMPLES = 2, the same in the float reference). Then it reads the
registers of the shadow (every SHADOW_REFRESH_TICKS ticks), and TC_EFF, the T_c the RTL used at
its last tick, which must be the value just written: a write that misses tick k+2 or a T_c the
RTL did not take is counted and fails the run. Bus transactions happen only at this rate.

The bus driver is the lean master of cosim/engines/cocotb/axil.py (spec "bus": "lean", the default)
or cocotbext-axi's AxiLiteMaster ("cocotbext-axi"), which gives the same results at about 1.4x the
wall time (tests/cosim holds both to the bit-exact model chain at every sample).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.simtime import get_sim_time
from cocotb.triggers import Event, RisingEdge, Timer
from cocotbext.axi import AxiLiteBus, AxiLiteMaster

from cosim.config.run import SimConfig
from cosim.config.scenarios import firmware_t_ref, get_scenario, sample_inputs
from cosim.engines.fwbridge import FirmwareBridge, loop_words
from cosim.engines.harness import (
    TC_LATENCY_SAMPLES,
    CommandTension,
    PlantFeed,
    Record,
    open_plant,
    store_run,
)
from cosim.parts import regmap, rtl_model
from cosim.parts.interface import make_chain

from . import fastio
from .axil import LeanAxiLiteMaster

# Registers the firmware's tick reads (fw.h: STATUS, FAULT, T_IN, U, SAMPLE_COUNT).
SHADOW_READS = (regmap.STATUS, regmap.FAULT, regmap.T_IN, regmap.U, regmap.SAMPLE_COUNT)
# The shadow is refreshed over the bus every this many firmware ticks (10 ms). The tick only
# reports these words (telemetry, fault word); T_c does not depend on them. A cocotbext-axi
# transaction costs a few hundred microseconds of wall time (its channel coroutines wake every
# clock), so reading five registers every millisecond would triple the run time.
SHADOW_REFRESH_TICKS = 10


def _signed16(word: int) -> int:
    return word - 0x10000 if word & 0x8000 else word


@cocotb.test()
async def closed_loop(dut):
    """Run one scenario in closed loop and write the record (.npz) and the cost split (JSON)."""
    spec = json.loads(Path(os.environ["BOWDEN_COSIM_SPEC"]).read_text())
    cfg = SimConfig.from_dict(spec["config"], source="spec")
    scen = get_scenario(spec["scenario"])
    inp = sample_inputs(scen, cfg, spec["duration_s"])
    # What the host hands the firmware (T_ref ahead by the horizon in preview mode).
    fw_ref = firmware_t_ref(scen, cfg, spec["compensator"], inp).tolist()
    n = len(inp.t_s)
    dec = cfg.decimation
    cps = int(spec["clks_per_sample"])
    clk_ns = int(spec["clk_period_ns"])

    cost = {"rtl_s": 0.0, "fmu_s": 0.0, "firmware_s": 0.0, "harness_s": 0.0, "total_s": 0.0}
    rec = Record.allocate(n).arrays

    plant = open_plant(cfg, spec["loop_routing"], (inp.x_m[0], inp.y_m[0], inp.z_m[0]))
    fw = FirmwareBridge(cfg, spec["compensator"], spec["phi_rad"])
    adc_offset, adc_gain = fw.adc_offset, fw.adc_gain

    # --- reset, AXI master, firmware start-up ----------------------------------------------
    Clock(dut.clk, clk_ns, unit="ns").start()
    dut.adc_word.value = 0
    # Every input defined before reset (Icarus starts them at X; Verilator at 0).
    for name in ("awaddr", "awprot", "awvalid", "wdata", "wstrb", "wvalid", "bready"):
        getattr(dut, f"s_axil_{name}").value = 0
    for name in ("araddr", "arprot", "arvalid", "rready"):
        getattr(dut, f"s_axil_{name}").value = 0
    dut.rst.value = 1
    for _ in range(4):
        await RisingEdge(dut.clk)
    bus = spec.get("bus", "lean")
    if bus == "cocotbext-axi":
        axi = AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axil"), dut.clk, dut.rst)
    elif bus == "lean":
        axi = LeanAxiLiteMaster(dut, "s_axil", dut.clk)
    else:
        raise ValueError(f"bus must be cocotbext-axi or lean; got {bus!r}")
    dut.rst.value = 0
    for _ in range(2):
        await RisingEdge(dut.clk)
    ident = await axi.read_dword(regmap.ID)
    assert (ident >> 16) == regmap.ID_MAGIC, f"ID register reads {ident:#010x}"

    # The RTL's own cost per sample: CLKS_PER_SAMPLE clocks with nothing else running (cocotb's
    # per-clock scheduling and Verilator), measured once before the start-up.
    calib_n = 1000
    calib_timer = Timer(cps * clk_ns, unit="ns")
    t_cal = time.perf_counter()
    for _ in range(calib_n):
        await calib_timer
    rtl_per_sample_s = (time.perf_counter() - t_cal) / calib_n

    # The plant at rest gives the ADC samples of the start-up (kept coming every sample, so the
    # stale-ADC fault sees a live converter); start-up writes: gains, calibration, enable.
    chain = make_chain(cfg, spec.get("interface", "board"), True, adc_offset, adc_gain)
    # The far-end load cell for the online friction estimate (the front-end's second channel,
    # the same conversion as T_in's, then the scenario's failure): the firmware reads T_OUT and
    # ADC_FLAGS, and T_IN at every tick, from these codes (as the native engine's firmware_wake);
    # the far-end output correction reads the same.
    far_end = bool(cfg.compensator.est_enable) or bool(cfg.compensator.corr_enable)
    est_on = far_end and spec["compensator"] != "none"
    far = make_chain(cfg, spec.get("interface", "board"), True, adc_offset, adc_gain)
    stuck_s, absent_s = cfg.board.t_out_stuck_s, cfg.board.t_out_absent_s
    codes = {"in": 0, "out": 0}
    code0 = chain.start(plant.y[plant.T_IN_MEAS])
    codes["in"] = code0
    if est_on:
        codes["out"] = far.start(plant.y[plant.T_OUT_MEAS])
    sample_ns = cps * clk_ns
    starting = [True]

    async def adc_keeper():
        level = 0
        while starting[0]:
            level ^= 1 << 24
            dut.adc_word.value = level | (code0 & 0xFFFFFF)
            await RisingEdge(dut.cmd_valid)
            await Timer(clk_ns // 2, unit="ns")

    keeper = cocotb.start_soon(adc_keeper())
    for addr, value in fw.start():
        await axi.write_dword(addr, value)
    for addr in SHADOW_READS:
        fw.shadow_set(addr, await axi.read_dword(addr))
    starting[0] = False
    await keeper
    # The keeper stopped half a clock after a command edge: the loop starts in that phase.
    toggle = dut.adc_word.value.to_unsigned() & (1 << 24)

    # --- the firmware task ------------------------------------------------------------------
    fw_wake = Event()
    est_ticks: list[tuple[int, int]] = []  # (sample, mu*phi in force Q3.28) per firmware tick
    corr_ticks: list[tuple[int, int]] = []  # (sample, far-end correction Q7.8) per firmware tick
    fw_state = {"k": 0, "late_writes": 0, "tc_mismatch": 0, "ticks": 0, "checks": 0, "wake_ns": 0}
    tc_new = [0.0]

    async def firmware_task():
        while True:
            await fw_wake.wait()
            fw_wake.clear()
            k = fw_state["k"]
            t_fw = time.perf_counter()
            tc_n, writes = fw.tick(fw_ref[k])
            cost["firmware_s"] += time.perf_counter() - t_fw
            if est_on:
                tel = fw.fw.telemetry()
                est_ticks.append((k, tel["est_mu_phi_q28"]))
                corr_ticks.append((k, tel["corr_n_q8"]))
            tc_new[0] = tc_n
            # Tick k+2 is at C(k+2) clocks; the wake-up was at Ck + L + 0.5 = C(k+1) - 0.5.
            deadline = fw_state["wake_ns"] + (TC_LATENCY_SAMPLES - 1) * sample_ns + clk_ns // 2
            for addr, value in writes:
                await axi.write_dword(addr, value)
            if get_sim_time("ns") > deadline:
                fw_state["late_writes"] += 1
            fw_state["ticks"] += 1
            if fw_state["ticks"] % SHADOW_REFRESH_TICKS:
                continue
            for addr in SHADOW_READS:
                fw.shadow_set(addr, await axi.read_dword(addr))
            # TC_EFF shows the T_c of the last tick L clocks after it: wait for tick k+2's.
            seen_ns = fw_state["wake_ns"] + TC_LATENCY_SAMPLES * sample_ns + clk_ns
            now_ns = get_sim_time("ns")
            if now_ns < seen_ns:
                await Timer(int(seen_ns - now_ns), unit="ns")
            tc_eff = _signed16((await axi.read_dword(regmap.TC_EFF)) & 0xFFFF) / 256.0
            # Between the wake-ups of samples k+2 and k+3, TC_EFF holds tick k+2's T_c: the T_c
            # written (or, with the slew limit, the slewed value the trace records).
            if k + TC_LATENCY_SAMPLES < n and tc_eff != out_tc[k + TC_LATENCY_SAMPLES]:
                fw_state["tc_mismatch"] += 1
            fw_state["checks"] += 1

    cocotb.start_soon(firmware_task())

    # --- the sample loop --------------------------------------------------------------------
    progress_path = Path(spec["progress_path"])
    next_report = time.perf_counter()
    # The command and the ADC word through fastio (cocotb's .value costs ~4 us a sample).
    read_u = fastio.signed_reader(dut.cmd_current)
    fastio.check_port(dut.cmd_current, read_u, signed=True)
    write_adc = fastio.writer(dut.adc_word)
    py = plant.y
    T_IN_MEAS, T_OUT_MEAS = plant.T_IN_MEAS, plant.T_OUT_MEAS
    far_sense = far.sense
    dt_s = 1.0 / cfg.sample_rate_hz
    out_tc, out_u = rec["T_c_N"], rec["current_A"]
    u_words = np.zeros(n, dtype=np.int32)
    feed, sense = PlantFeed(plant, inp, chain.drive, n), chain.sense
    timer = Timer(sample_ns, unit="ns")
    perf = time.perf_counter
    fmu_s = 0.0
    await_s = 0.0
    tc_set = 0.0  # T_c written and in force in the RTL, Q7.8 value in N
    # T_c after the RTL's slew limit and floor (TC_EFF), recorded in the trace.
    tc_path = CommandTension.programmed(
        loop_words(cfg.controller, cfg.sample_rate_hz), cfg.compensator.tc_min_n
    )
    cpu_start = time.process_time()
    t_start = perf()
    for k in range(n):
        if k:
            t_a = perf()
            await timer  # the RTL runs CLKS_PER_SAMPLE clocks (and the firmware task, if woken)
            await_s += perf() - t_a
        if k >= TC_LATENCY_SAMPLES and (k - TC_LATENCY_SAMPLES) % dec == 0:
            tc_set = tc_new[0]
        tc = tc_path.step(tc_set)  # T_c as the RTL uses it
        word = read_u()
        u_words[k] = word
        u_a = word / 4096.0
        out_tc[k] = tc
        out_u[k] = u_a
        t_c = perf()
        feed.sample(k, word)  # (the drive chain's few operations counted with the FMU's)
        fmu_s += perf() - t_c
        if est_on:
            c_out = far_sense(k, py[T_OUT_MEAS])
            t_s = (k + 1) * dt_s
            if absent_s is not None and t_s >= absent_s:
                codes["out"] = rtl_model.ADC_CODE_MAX  # an open bridge at the rail
            elif stuck_s is None or t_s < stuck_s:
                codes["out"] = codes["out"] if c_out is None else c_out
        code = sense(k, py[T_IN_MEAS])
        if code is not None:
            codes["in"] = code
            toggle ^= 1 << 24
            write_adc(toggle | (code & 0xFFFFFF))
        if k % dec == 0:
            if est_on:
                t_in = rtl_model.calibrate(codes["in"], adc_offset, adc_gain)
                fw.shadow_set(regmap.T_IN, t_in & 0xFFFFFFFF)
                fw.shadow_set(regmap.T_OUT, codes["out"] & 0xFFFFFF)
                fw.shadow_set(regmap.ADC_FLAGS, 0)
            fw_state["k"] = k
            fw_state["wake_ns"] = get_sim_time("ns")
            fw_wake.set()
        if (k & 1023) == 0 and perf() >= next_report:
            progress_path.write_text(str(k))  # the parent draws the progress bar from this
            next_report = perf() + 0.2
    t_end = perf()
    # CPU seconds of the simulator's process over the loop (Verilator, cocotb, FMU, firmware
    # and harness all run in it): on a shared machine the wall time also holds waits for a core.
    cpu_s = time.process_time() - cpu_start
    progress_path.write_text(str(n))
    # Latched faults at the end (stale or out-of-range ADC, watchdog, over-current): a healthy
    # run has none; the caller reports the word.
    await Timer(4 * sample_ns, unit="ns")  # let the firmware task's last transactions finish
    fault_word = await axi.read_dword(regmap.FAULT)
    status_word = await axi.read_dword(regmap.STATUS)

    plant.close()
    store_run(rec, feed.rows, inp)
    rec["u_word"] = u_words.astype(np.float64)
    if est_on:  # the firmware's mu*phi in force at each sample (its last tick's)
        est = np.zeros(n, dtype=np.int64)
        for k, x in est_ticks:
            est[k:] = x
        rec["mu_phi_est"] = est / 2.0**28
        corr = np.zeros(n, dtype=np.int64)
        for k, c in corr_ticks:
            corr[k:] = c
        rec["corr_n"] = corr / 256.0  # the far-end output correction in force
    # Cost split: the RTL's own cost is the calibrated bare sample times the samples; the waits
    # beyond it are the firmware's ticks (run inside them) and the AXI driver's coroutines
    # (harness); FMU steps are timed directly; the rest is the harness's per-sample glue.
    total = t_end - t_start
    rtl_s = rtl_per_sample_s * (n - 1)
    cost["rtl_s"] = rtl_s
    cost["rtl_per_sample_us"] = rtl_per_sample_s * 1e6
    cost["bus_s"] = max(0.0, await_s - rtl_s - cost["firmware_s"])
    cost["fmu_s"] = fmu_s
    cost["total_s"] = total
    cost["cpu_s"] = cpu_s
    cost["harness_s"] = total - rtl_s - fmu_s - cost["firmware_s"]
    cost["late_writes"] = fw_state["late_writes"]
    cost["tc_mismatch"] = fw_state["tc_mismatch"]
    cost["tc_checks"] = fw_state["checks"]
    cost["firmware_ticks"] = fw_state["ticks"]
    cost["samples"] = n
    cost["clks_per_sample"] = cps
    cost["fault_word"] = fault_word
    cost["status_word"] = status_word
    cost["tc_latency_samples"] = TC_LATENCY_SAMPLES
    Record(rec).save(spec["record_path"])
    Path(spec["cost_path"]).write_text(json.dumps(cost, indent=2))
    assert fw_state["late_writes"] == 0, (
        f"{fw_state['late_writes']} firmware TC writes missed sample tick k+{TC_LATENCY_SAMPLES}"
    )
    assert fw_state["tc_mismatch"] == 0, (
        f"{fw_state['tc_mismatch']} firmware ticks: TC_EFF read back differs from the T_c written"
    )
