"""The antagonistic joint in closed loop: two cable channels and a joint, composed as FMUs are.

Each cable is one channel of today's single-cable chain: its own firmware (host build, its own
compensator and, with compensator.est_enable, its own online friction estimate fed by its own
far-end load cell), its own channel of the pair's tension loop, its own interface stage (ADC,
PWM -> ESCON) and its own instance of the BowdenPlant FMU with its own parameters and sheath
path. The joint (cosim.parts.joint.Joint) takes the two cables' true output tensions and sets
their far ends (FMU input end_displacement).

The pair's two loops are one two-channel tension_loop_mc with both channels in one safety
group. Two engines run it: `native` (the default: bn_run_pair in
cosim/engines/native/closed_loop.cpp steps a Verilated bowden_core_mc, N = 2, with the joint
between its samples: each cable's firmware writes its own register bank over the core's
AXI4-Lite bus and the T_c each bank reads back is checked against the firmware's) and `model`
(its bit-exact model, rtl_model.TensionLoopMcModel with groups [0, 0]). PairSim is the pair's
world around any two-channel loop, so the cocotb bench of the pair
(cosim/engines/cocotb/tb_pair.py) runs the same world around the Verilog core, its firmware on
the core's bus. With no fault the group never stops a channel, each channel is exactly a single
loop, and all three give the same record, sample for sample, with a fault too
(tests/cosim/test_antagonist.py).

A CableFault breaks one cable's load cell mid-run (`stale`: its ADC samples stop; `open`: the
code sits at the converter's limit, 2^23 - 1, past ADC_MAX, as an open bridge reads): the
faulted channel latches ADC_STALE or ADC_RANGE and zeroes its drive, and its group stop ramps
the other cable's drive to zero by WDT_RAMP_STEP a sample.

Coupling (a Jacobi master, as an FMI 2.0 co-simulation master steps FMUs side by side): at each
communication step [t_k, t_k+1) (one FPGA sample, 100 us) every subsystem steps with the
others' outputs at t_k held: each cable FMU with its far end at d_i(theta(t_k)), the joint with
T_out_i(t_k). The timing within a channel (T_c latency, ADC, PWM, firmware ticks) is the single
loop's, so with the far ends held (d = 0) each channel's record equals run_model_chain's for
the same scenario, sample for sample.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from cosim.config.antagonist import Antagonist
from cosim.config.run import SimConfig
from cosim.config.scenarios import firmware_t_ref, sample_inputs
from cosim.parts import regmap, rtl_model
from cosim.parts.interface import make_chain
from cosim.project.progress import Progress

from .fwbridge import FirmwareBridge, loop_words
from .harness import TC_LATENCY_SAMPLES, Record, open_plant, plant_rows, store_plant_rows
from .reference import resolve_phi

# The firmware's view of the far-end load cell (register T_OUT holds the raw 24-bit code).
_T_OUT_MASK = (1 << 24) - 1


class _Channel:
    """One cable's chain around its channel of the loop: firmware, interface stage, plant FMU.

    `loop` is the channel's side of the loop: write(name, value) and adc_sample(code), as
    rtl_model.TensionLoopModel takes them, or, for a channel behind a register bus (the cocotb
    bench's bank of bowden_core_mc), write_word(addr, word) with the firmware's bus words; its
    ticks are the pair's (PairSim). `fault`: this cable's load-cell fault, or None."""

    def __init__(
        self,
        scen,
        cfg: SimConfig,
        compensator: str,
        loop_routing,
        duration_s,
        interface,
        loop,
        fault=None,
    ):
        self.cfg = cfg
        self.fault = fault
        self.fault_k = None if fault is None else fault.sample(cfg.sample_rate_hz)
        self.inp = sample_inputs(scen, cfg, duration_s)
        inp = self.inp
        phi = resolve_phi(scen, cfg, loop_routing)
        self.plant = open_plant(cfg, loop_routing, (inp.x_m[0], inp.y_m[0], inp.z_m[0]))
        self.set_end = self.plant.input_setter("end_displacement")
        self.fw = FirmwareBridge(cfg, compensator, phi)
        self.model = loop
        self.names = {reg.addr: name for name, reg in regmap.REGISTERS.items()}
        self.fw_ref = firmware_t_ref(scen, cfg, compensator, inp)
        self.chain = make_chain(cfg, interface, True, self.fw.adc_offset, self.fw.adc_gain)
        b = cfg.board
        if b.t_out_stuck_s is not None or b.t_out_absent_s is not None:
            raise ValueError("board.t_out_stuck_s / t_out_absent_s: not modelled in the pair run")
        c = cfg.compensator
        self.far_end = compensator != "none" and bool(c.est_enable or c.corr_enable)
        y = self.plant.y
        self.code = self.chain.start(y[self.plant.T_IN_MEAS])
        self.code_in = self.code  # the last code the loop took (the shadow's T_IN)
        if self.far_end:
            self.chain_out = make_chain(cfg, interface, True, self.fw.adc_offset, self.fw.adc_gain)
            self.code_out = self.chain_out.start(y[self.plant.T_OUT_MEAS])
        self._apply(self.fw.start())
        self.pending: list = []
        n = len(inp.t_s)
        self.rec = Record.allocate(n).arrays
        self.words = np.zeros(n)
        self.rows, self.y_row = plant_rows(self.plant, n)

    def _apply(self, writes) -> None:
        bus = getattr(self.model, "write_word", None)
        for addr, value in writes:
            if bus is not None:  # a channel behind a register bus takes the words as written
                bus(addr, value)
                continue
            name = self.names[addr]
            if name != "CTRL":
                value = regmap.decode(name, value)
            self.model.write(name, value)

    def feed(self, k: int, dec: int) -> None:
        """Before the loop's tick k: the firmware's writes due at it and the ADC sample of the
        last step (k < 0: a start-up tick, the plant at rest)."""
        if k >= TC_LATENCY_SAMPLES and (k - TC_LATENCY_SAMPLES) % dec == 0:
            self._apply(self.pending)
            self.pending = []
        if self.code is not None:
            self.model.adc_sample(self.code)

    def sample(self, k: int, out, end_m: float, dec: int) -> None:
        """After the loop's tick k (its output `out`): the plant over [t_k, t_k+1) with its far
        end at end_m, the ADC samples of tick k+1, and the firmware's tick when k is one."""
        self.words[k] = out.u
        self.rec["T_c_N"][k] = out.tc_eff / 256.0
        self.rec["current_A"][k] = out.u / 4096.0
        self.rows[k] = self.y_row
        plant, inp = self.plant, self.inp
        plant.u[2], plant.u[3], plant.u[4] = inp.x_m[k], inp.y_m[k], inp.z_m[k]
        self.set_end(end_m)
        y = plant.y
        for dt_seg, current_a in self.chain.drive(k, out.u):
            plant.u[0] = current_a
            y = plant.step(dt_seg)
        self.code = self.chain.sense(k, y[plant.T_IN_MEAS])
        if self.fault is not None and k + 1 >= self.fault_k:
            # the load cell breaks from the sample delivered at t_k+1 on
            self.code = None if self.fault.kind == "stale" else rtl_model.ADC_CODE_MAX
        if self.code is not None:
            self.code_in = self.code
        if self.far_end:
            code = self.chain_out.sense(k, y[plant.T_OUT_MEAS])
            if code is not None:
                self.code_out = code
        if k % dec == 0:
            if self.far_end:  # the fresh values a board's MMIO reads would give
                fw = self.fw
                t_in_word = rtl_model.calibrate(self.code_in, fw.adc_offset, fw.adc_gain)
                fw.shadow_set(regmap.T_IN, t_in_word)  # signed, as the bus reads it
                fw.shadow_set(regmap.T_OUT, self.code_out & _T_OUT_MASK)
                fw.shadow_set(regmap.ADC_FLAGS, 0)
            _, self.pending = self.fw.tick(float(self.fw_ref[k]))

    def finish(self) -> dict[str, np.ndarray]:
        self.plant.close()
        rec, inp = self.rec, self.inp
        store_plant_rows(rec, self.rows)
        rec["t_s"][:] = inp.t_s
        rec["T_ref_N"][:] = inp.t_ref_n
        rec["x_m"][:], rec["y_m"][:], rec["z_m"][:] = inp.x_m, inp.y_m, inp.z_m
        rec["u_word"] = self.words
        return rec


FAULT_KINDS = ("stale", "open")


@dataclass(frozen=True)
class CableFault:
    """A load-cell fault on one cable from time t_s on: `stale` (the ADC's samples stop) or
    `open` (an open bridge: every code at the converter's limit, 2^23 - 1). `cable` is 0 or 1."""

    cable: int
    kind: str
    t_s: float

    def __post_init__(self) -> None:
        if self.cable not in (0, 1):
            raise ValueError(f"fault cable={self.cable!r}: expected 0 or 1")
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"fault kind={self.kind!r}: expected one of {', '.join(FAULT_KINDS)}")
        if not (self.t_s >= 0.0 and np.isfinite(self.t_s)):
            raise ValueError(f"fault t_s={self.t_s!r}: expected a finite time >= 0 s")

    def sample(self, sample_rate_hz: float) -> int:
        """The first FPGA sample whose ADC delivery is faulted (its tick k = this)."""
        return int(np.ceil(self.t_s * sample_rate_hz - 1e-9))


def pair_fault(spec: dict | None) -> CableFault | None:
    """A CableFault from its JSON form ({"cable", "kind", "t_s"}), None for None."""
    if spec is None:
        return None
    return CableFault(int(spec["cable"]), spec["kind"], float(spec["t_s"]))


@dataclass
class PairRecord:
    """A pair run: each cable's record (the arrays of cosim.engines.harness.Record, plus
    `u_word`) and the joint's per sample (at t_k, before the sample's step); each channel's
    status per sample (columns = channels):
    `faults` (the FAULT word), `out_en` (the drive enable) and `grp_stop` (the group stop)."""

    cables: tuple[dict[str, np.ndarray], dict[str, np.ndarray]]
    t_s: np.ndarray
    tau_ref_n_m: np.ndarray
    theta_rad: np.ndarray
    omega_rad_s: np.ndarray
    faults: np.ndarray | None = None
    out_en: np.ndarray | None = None
    grp_stop: np.ndarray | None = None


ENGINES = ("native", "model")
#: The pair's safety groups in tension_loop_mc: both cables in group 0.
PAIR_GROUPS = (0, 0)


class PairSim:
    """The pair's world around one two-channel loop: both cables' chains (firmware, interface
    stage, plant FMU), the joint and the Jacobi coupling, stepped one FPGA sample at a time.

    `loop` is the two-channel loop: `channels[i]` takes channel i's write(name, value) and
    adc_sample(code) between ticks; its tick, which the caller runs (the Python model's
    `tick()`, or the RTL's under cocotb), gives the two LoopOutputs. Drive it as run_pair does:

        for k in sim.ticks():        # two start-up ticks (k < 0), then k = 0 .. n - 1
            sim.feed(k)
            outs = <the loop's tick>
            sim.step(k, outs)
        record = sim.finish()
    """

    def __init__(
        self,
        scen: Antagonist,
        cfg: SimConfig,
        compensator: str,
        loop,
        duration_s: float | None = None,
        interface: str = "board",
        hold_joint: bool = False,
        fault: CableFault | None = None,
    ) -> None:
        from cosim.parts.joint import Joint  # noqa: PLC0415

        self.scen, self.hold_joint = scen, hold_joint
        self.label = f"{scen.name} {compensator}"
        self.rate_hz = cfg.sample_rate_hz
        self.chans: list[_Channel] = []
        try:
            for i in range(2):
                self.chans.append(
                    _Channel(
                        scen.cable_scenario(i),
                        scen.cable_config(cfg, i),
                        compensator,
                        scen.cables[i].loop_routing,
                        duration_s,
                        interface,
                        loop.channels[i],
                        fault if fault is not None and fault.cable == i else None,
                    )
                )
        except BaseException:
            for c in self.chans:
                c.plant.close()
            raise
        self.t_s = self.chans[0].inp.t_s
        self.n = n = len(self.t_s)
        self.dt_s = 1.0 / cfg.sample_rate_hz
        self.dec = cfg.decimation
        self.joint = Joint(scen.joint)
        self.tau_load = np.asarray(scen.tau_load(self.t_s), dtype=np.float64).tolist()
        self.theta, self.omega = np.zeros(n), np.zeros(n)
        self.faults = np.zeros((n, 2), dtype=np.int64)
        self.out_en = np.zeros((n, 2), dtype=bool)
        self.grp_stop = np.zeros((n, 2), dtype=bool)
        c1, c2 = self.chans
        self.t_out = [c1.plant.y[c1.plant.T_OUT], c2.plant.y[c2.plant.T_OUT]]  # at t_0, at rest

    def ticks(self) -> range:
        """The loop's ticks: two of the start-up (k = -2, -1: the start-up's CTRL pulses take
        effect at a tick), then one per sample."""
        return range(-2, self.n)

    def feed(self, k: int) -> None:
        """Before tick k: each channel's due firmware writes and its ADC sample."""
        for c in self.chans:
            c.feed(k, self.dec)

    def step(self, k: int, outs, grp_stop=(False, False)) -> None:
        """After tick k with the loop's outputs `outs` (and its group stops): record them, step
        both cables over [t_k, t_k+1) with their far ends at the joint's angle and the joint with
        the cables' tensions at t_k (Jacobi)."""
        if k < 0:
            return
        joint = self.joint
        self.theta[k], self.omega[k] = joint.theta_rad, joint.omega_rad_s
        d = (0.0, 0.0) if self.hold_joint else joint.end_displacements_m
        for i, c in enumerate(self.chans):
            self.faults[k, i], self.out_en[k, i] = outs[i].faults, outs[i].out_en
            self.grp_stop[k, i] = grp_stop[i]
            c.sample(k, outs[i], d[i], self.dec)
        joint.t_1_n, joint.t_2_n = self.t_out
        joint.tau_load_n_m = self.tau_load[k]
        joint.step(self.dt_s)
        self.t_out = [c.plant.y[c.plant.T_OUT] for c in self.chans]

    def finish(self) -> PairRecord:
        """Close the plants; the run's record."""
        recs = tuple(c.finish() for c in self.chans)
        rec = _pair_record(self.scen, recs, self.t_s, self.theta, self.omega)
        rec.faults, rec.out_en, rec.grp_stop = self.faults, self.out_en, self.grp_stop
        return rec


def run_pair(
    scen: Antagonist,
    cfg: SimConfig,
    compensator: str,
    duration_s: float | None = None,
    interface: str = "board",
    hold_joint: bool = False,
    progress: bool = False,
    engine: str = "native",
    fault: CableFault | None = None,
) -> PairRecord:
    """Run the pair closed loop (module docstring) with `compensator` on both channels.
    hold_joint: both far ends held at d = 0 (the joint still turns): each channel is then a
    single-cable run, the check that the composition adds nothing but the joint.
    engine: `native` (the pair's bowden_core_mc Verilated, cosim/engines/native bn_run_pair)
    or `model` (its bit-exact model in Python); tests/cosim/test_antagonist.py holds the two to
    the same record. fault: a load-cell fault on one cable (CableFault), or None."""
    if engine == "native":
        return _run_pair_native(scen, cfg, compensator, duration_s, interface, hold_joint, fault)
    if engine != "model":
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}; got {engine!r}")
    loop = rtl_model.TensionLoopMcModel(list(PAIR_GROUPS))
    sim = PairSim(scen, cfg, compensator, loop, duration_s, interface, hold_joint, fault)
    return run_model_loop(sim, loop, progress)


def run_model_loop(sim: PairSim, loop: rtl_model.TensionLoopMcModel, progress: bool = False):
    """Step `sim` to its end around `loop`, a TensionLoopMcModel (its groups as given: the
    pair's one group, or a study's other grouping); the run's PairRecord."""
    bar = Progress(sim.n, sim.label, sim.rate_hz, enabled=progress)
    try:
        for k in sim.ticks():
            sim.feed(k)
            outs = loop.tick()
            sim.step(k, outs, loop.group_stop)
            if (k & 1023) == 0:
                bar.update(k)
    finally:
        rec = sim.finish()
        bar.close(sim.n)
    return rec


def _run_pair_native(
    scen, cfg, compensator, duration_s, interface, hold_joint, fault=None
) -> PairRecord:
    """run_pair on the native engine: each cable a bn_spec_t as `bowden sim --engine native`
    sets one up (its firmware, FMU and interface stage), the joint's exact step handed over as
    its matrices (bn_joint_t), both cables driven by the pair's Verilated bowden_core_mc, each
    firmware on its own bank (bn_pair_loop_t: the fault, each channel's status per sample)."""
    import ctypes  # noqa: PLC0415

    from cosim.parts.joint import Joint  # noqa: PLC0415

    from .native import engine as native  # noqa: PLC0415

    lib = native.load_library()
    runs = []
    try:
        for i in range(2):
            s, c = scen.cable_scenario(i), scen.cable_config(cfg, i)
            routing = scen.cables[i].loop_routing
            spec = {
                "duration_s": duration_s,
                "loop_routing": routing,
                "compensator": compensator,
                "phi_rad": resolve_phi(s, c, routing),
                "interface": interface,
            }
            runs.append(native._Run(s, c, spec))
        n = runs[0].n
        t_s = runs[0].inp.t_s
        joint = Joint(scen.joint)
        joint._constants(1.0 / cfg.sample_rate_hz)
        tau_load = np.ascontiguousarray(scen.tau_load(t_s), dtype=np.float64)
        theta, omega = np.zeros(n), np.zeros(n)
        j = native.JointSpec()
        j.radius_m = scen.joint.pulley_radius_m
        j.phi[:] = joint._phi
        j.gam[:] = joint._gam
        j.tau_load_n_m = tau_load.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        j.hold = 1 if hold_joint else 0
        j.theta_rad = theta.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        j.omega_rad_s = omega.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        m = native.PairLoopSpec()
        faults = np.zeros((n, 2), dtype=np.int32)
        out_en = np.zeros((n, 2), dtype=np.uint8)
        grp_stop = np.zeros((n, 2), dtype=np.uint8)
        if fault is not None:
            m.fault_kind[fault.cable] = 1 + FAULT_KINDS.index(fault.kind)
            m.fault_k[fault.cable] = fault.sample(cfg.sample_rate_hz)
        m.out_faults = faults.ctypes.data_as(ctypes.POINTER(ctypes.c_int32))
        m.out_en = out_en.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8))
        m.out_grp_stop = grp_stop.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8))
        a, b = runs
        status = lib.bn_run_pair(
            ctypes.byref(a.s), ctypes.byref(b.s), ctypes.byref(j), ctypes.byref(m)
        )
    finally:
        for run in runs:
            run.plant.close()
    if status != 0:
        raise RuntimeError(f"native pair: {a.s.error.decode(errors='replace')}")
    recs = tuple(run.collect(0)[0] for run in runs)
    rec = _pair_record(scen, recs, t_s, theta, omega)
    rec.faults, rec.out_en, rec.grp_stop = faults.astype(np.int64), out_en != 0, grp_stop != 0
    return rec


def _pair_record(scen, recs, t_s, theta, omega) -> PairRecord:
    """Both engines' record of a pair run: the cables' records, the joint's path and tau_ref."""
    return PairRecord(
        cables=recs,
        t_s=t_s,
        tau_ref_n_m=np.asarray(scen.tau_ref(t_s), dtype=np.float64),
        theta_rad=theta,
        omega_rad_s=omega,
    )


def evaluate(scen: Antagonist, run: PairRecord) -> dict:
    """The pair's figures after the scenario's settle time: the joint torque error tau_ref -
    r * (T_out_1 - T_out_2) (the output sensors, as the single-cable figures use T_out) RMS and
    peak in N m and in % of the largest |tau_ref|; each cable's tension error T_ref - T_out (RMS,
    peak, N) and its least true tension at the pulley and at the motor (T_out, T_in; the floor is
    T_pre); the joint's angle range."""
    r = scen.joint.pulley_radius_m
    m = run.t_s >= scen.settle_s
    c1, c2 = run.cables
    tau = r * (c1["T_out_N"] - c2["T_out_N"])
    err = (run.tau_ref_n_m - tau)[m]
    tau_max = float(np.max(np.abs(run.tau_ref_n_m[m])))
    out = {
        "torque_rms_error_n_m": float(np.sqrt(np.mean(err**2))),
        "torque_peak_error_n_m": float(np.max(np.abs(err))),
        "tau_ref_max_n_m": tau_max,
        "pretension_n": scen.pretension_n,
        "theta_min_rad": float(np.min(run.theta_rad[m])),
        "theta_max_rad": float(np.max(run.theta_rad[m])),
        "cables": [],
    }
    out["torque_rms_error_pct"] = 100.0 * out["torque_rms_error_n_m"] / tau_max
    out["torque_peak_error_pct"] = 100.0 * out["torque_peak_error_n_m"] / tau_max
    for i, c in enumerate(run.cables):
        e = (c["T_ref_N"] - c["T_out_N"])[m]
        out["cables"].append(
            {
                "cable": scen.cables[i].name,
                "rms_error_n": float(np.sqrt(np.mean(e**2))),
                "peak_error_n": float(np.max(np.abs(e))),
                "min_t_out_n": float(np.min(c["T_out_true_N"][m])),
                "min_t_in_n": float(np.min(c["T_in_true_N"][m])),
            }
        )
    return out


# The rows `bowden sim antagonist` runs when no --compensator is given: every compensator of the
# single-cable demo, then the preview mode with the online friction estimate on both channels.
ROWS = (("paper", False), ("smooth", False), ("preview", False), ("preview", True))


def run_rows(
    scen: Antagonist,
    cfg: SimConfig,
    rows=ROWS,
    duration_s: float | None = None,
    interface: str = "board",
    progress: bool = False,
    engine: str = "native",
) -> list[dict]:
    """Run each (compensator, estimate) row on the pair; each row's figures (evaluate) with
    its compensator, estimate, interface, duration and CPU seconds."""
    out = []
    for comp, est in rows:
        c = replace(cfg, compensator=replace(cfg.compensator, est_enable=1 if est else 0))
        t0 = time.process_time()
        run = run_pair(scen, c, comp, duration_s, interface, progress=progress, engine=engine)
        row = {"compensator": comp, "estimate": bool(est), "interface": interface}
        row["engine"] = engine
        row.update(evaluate(scen, run))
        row["sim_seconds"] = float(len(run.t_s) / cfg.sample_rate_hz)
        row["cpu_seconds"] = time.process_time() - t0
        out.append(row)
    return out


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table: torque error (RMS / peak, N m and % of the largest
    |tau_ref|), each cable's RMS / peak tension error and least T_out and T_in (N)."""
    head = (
        "| compensator | torque RMS | torque peak | cable 1 RMS / peak N | cable 2 RMS / peak N "
        "| min T_out 1 / 2 N | min T_in 1 / 2 N |\n| --- | --- | --- | --- | --- | --- | --- |"
    )
    lines = [head]
    for r in rows:
        name = r["compensator"] + (" + estimate" if r["estimate"] else "")
        c1, c2 = r["cables"]
        lines.append(
            f"| {name} | {r['torque_rms_error_n_m'] * 1e3:.1f} mN m = "
            f"{r['torque_rms_error_pct']:.1f} % | {r['torque_peak_error_n_m'] * 1e3:.1f} mN m = "
            f"{r['torque_peak_error_pct']:.1f} % | {c1['rms_error_n']:.3f} / "
            f"{c1['peak_error_n']:.3f} | {c2['rms_error_n']:.3f} / {c2['peak_error_n']:.3f} | "
            f"{c1['min_t_out_n']:.2f} / {c2['min_t_out_n']:.2f} | "
            f"{c1['min_t_in_n']:.2f} / {c2['min_t_in_n']:.2f} |"
        )
    return "\n".join(lines)


# The faults `bowden sim antagonist` reports (and tests/cosim/test_antagonist.py checks), on
# cable 1 with the preview compensator, each at its own phase of tau_ref's 2 s period (set before
# any run): stale at 1.2 s (cable 2 pulling), open wire at 1.7 s (cable 2 near its floor, the
# joint deflected); each run ends FAULT_TAIL_S after the fault.
FAULT_ROWS = (CableFault(0, "stale", 1.2), CableFault(0, "open", 1.7))
FAULT_TAIL_S = 0.3
FAULT_CAPTION = (
    "A load-cell fault on cable 1 (preview, native engine: the pair as one bowden_core_mc "
    "group): periods from the latch until both drives are off for good, against 1 + "
    "ceil(I_LIMIT / WDT_RAMP_STEP); the joint's peak speed after the latch against its free "
    "release (both cables cut at the latch); the largest rise of a cable's T_out or T_in above "
    "its pre-fault maximum"
)


def free_release_peak(scen: Antagonist, run: PairRecord, k: int) -> float:
    """The joint's peak |omega| (rad/s) from sample k to the run's end were both cables cut at
    k: its own spring and damping from (theta_k, omega_k), no load. What a group stop that
    zeroed both drives at once, with cables that let go at once, would give."""
    from cosim.parts.joint import Joint  # noqa: PLC0415

    joint = Joint(scen.joint)
    joint.theta_rad, joint.omega_rad_s = run.theta_rad[k], run.omega_rad_s[k]
    dt_s = float(run.t_s[1] - run.t_s[0])
    peak = abs(joint.omega_rad_s)
    for _ in range(len(run.t_s) - 1 - k):
        joint.step(dt_s)
        peak = max(peak, abs(joint.omega_rad_s))
    return peak


def evaluate_fault(scen: Antagonist, cfg: SimConfig, run: PairRecord, fault: CableFault) -> dict:
    """A faulted run's figures: the sample the faulted channel latched at and its FAULT word,
    the partner's (0 if it reported none), the periods from the latch until both drives are off
    for good (u = 0, enable low) against the group's bound 1 + ceil(I_LIMIT / WDT_RAMP_STEP),
    the joint's peak speed after the latch against the free release's (free_release_peak), and
    each cable's largest rise of T_out and T_in above its maximum before the latch (N)."""
    if run.faults is None:
        raise ValueError("evaluate_fault needs a run with the loop's status (PairRecord.faults)")
    i = fault.cable
    latched = np.nonzero(run.faults[:, i])[0]
    if len(latched) == 0:
        raise ValueError(f"cable {i + 1}'s loop latched no fault")
    k = int(latched[0])
    u = np.stack([c["u_word"] for c in run.cables], axis=1)
    on = np.nonzero(np.any(u != 0, axis=1) | np.any(run.out_en, axis=1))[0]
    off = int(on[-1]) + 1 if len(on) else 0
    i_limit = loop_words(cfg.controller, cfg.sample_rate_hz)["i_limit"]  # UQ3.12 A
    step = rtl_model.WDT_RAMP_STEP
    rise = [
        max(float(np.max(c[n][k:]) - np.max(c[n][:k])) for n in ("T_out_true_N", "T_in_true_N"))
        for c in run.cables
    ]
    return {
        "cable": scen.cables[i].name,
        "kind": fault.kind,
        "t_s": fault.t_s,
        "latch_sample": k,
        "latch_s": float(run.t_s[k]),
        "fault_word": int(run.faults[k, i]),
        "partner_fault_word": int(np.bitwise_or.reduce(run.faults[:, 1 - i])),
        "off_periods": off - k if off < len(run.t_s) else None,
        "bound_periods": 1 + -(-i_limit // step),
        "omega_peak_rad_s": float(np.max(np.abs(run.omega_rad_s[k:]))),
        "omega_free_rad_s": free_release_peak(scen, run, k),
        "tension_rise_n": rise,
    }


def run_fault_rows(
    scen: Antagonist,
    cfg: SimConfig,
    faults=FAULT_ROWS,
    compensator: str = "preview",
    interface: str = "board",
    engine: str = "native",
) -> list[dict]:
    """Each fault of `faults` on the pair (the run ending FAULT_TAIL_S after it): evaluate_fault's
    figures with the engine and the CPU seconds."""
    out = []
    for fault in faults:
        t0 = time.process_time()
        run = run_pair(
            scen,
            cfg,
            compensator,
            fault.t_s + FAULT_TAIL_S,
            interface,
            engine=engine,
            fault=fault,
        )
        row = {"compensator": compensator, "engine": engine, "interface": interface}
        row.update(evaluate_fault(scen, cfg, run, fault))
        row["cpu_seconds"] = time.process_time() - t0
        out.append(row)
    return out


def fault_table(rows: list[dict], sample_rate_hz: float = 1e4) -> str:
    """The faulted runs as a Markdown table: the fault, its latch, the periods until both drives
    are off (and the bound), the joint's peak speed against the free release's, the largest
    tension rise above its pre-fault maximum."""
    names = {
        regmap.FAULT_ADC_STALE: "ADC_STALE",
        regmap.FAULT_ADC_RANGE: "ADC_RANGE",
        regmap.FAULT_WATCHDOG: "WATCHDOG",
        regmap.FAULT_OVERCURRENT: "OVERCURRENT",
    }
    lines = [
        "| fault on cable | latched | partner's FAULT | both drives off after | joint peak / "
        "free release | largest tension rise |\n| --- | --- | --- | --- | --- | --- |"
    ]
    for r in rows:
        word = " ".join(v for b, v in names.items() if r["fault_word"] & b)
        ms = 1e3 / sample_rate_hz
        off = r["off_periods"]
        off = "not in the run" if off is None else f"{off} periods = {off * ms:.1f} ms"
        lines.append(
            f"| {r['cable']}: {r['kind']} at {r['t_s']:g} s | {word} at {r['latch_s']:.4f} s | "
            f"{r['partner_fault_word']} | {off} (bound "
            f"{r['bound_periods']} = {r['bound_periods'] * ms:.1f} ms) | "
            f"{r['omega_peak_rad_s']:.2f} / {r['omega_free_rad_s']:.2f} rad/s | "
            f"{max(r['tension_rise_n']):.2f} N |"
        )
    return "\n".join(lines)
