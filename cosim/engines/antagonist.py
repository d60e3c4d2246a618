"""The antagonistic joint in closed loop: two cable channels and a joint, composed as FMUs are.

Each cable is one channel of today's single-cable chain: its own firmware (host build, its own
compensator and, with compensator.est_enable, its own online friction estimate fed by its own
far-end load cell), its own tension loop, its own interface stage (ADC, PWM -> ESCON) and its
own instance of the BowdenPlant FMU with its own parameters and sheath path. The joint
(cosim.parts.joint.Joint) takes the two cables' true output tensions and sets their far ends
(FMU input end_displacement).

Two engines run it: `native` (the default) steps two Verilated RTL loops of the native engine
side by side with the joint between them (bn_run_pair, cosim/engines/native/closed_loop.cpp);
`model` runs each loop as the RTL's bit-exact Python model (as reference.run_model_chain).
They give the same record, sample for sample (tests/cosim/test_antagonist.py).

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

from .fwbridge import FirmwareBridge
from .harness import TC_LATENCY_SAMPLES, Record, open_plant, plant_rows, store_plant_rows
from .reference import resolve_phi

# The firmware's view of the far-end load cell (register T_OUT holds the raw 24-bit code).
_T_OUT_MASK = (1 << 24) - 1


class _Channel:
    """One cable's chain: firmware, the loop's bit-exact model, interface stage, plant FMU."""

    def __init__(self, scen, cfg: SimConfig, compensator: str, loop_routing, duration_s, interface):
        self.cfg = cfg
        self.inp = sample_inputs(scen, cfg, duration_s)
        inp = self.inp
        phi = resolve_phi(scen, cfg, loop_routing)
        self.plant = open_plant(cfg, loop_routing, (inp.x_m[0], inp.y_m[0], inp.z_m[0]))
        self.set_end = self.plant.input_setter("end_displacement")
        self.fw = FirmwareBridge(cfg, compensator, phi)
        self.model = rtl_model.TensionLoopModel()
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
        for _ in range(2):  # the start-up's CTRL pulses take effect at a tick
            self.model.adc_sample(self.code)
            self.model.tick()
        self.pending: list = []
        n = len(inp.t_s)
        self.rec = Record.allocate(n).arrays
        self.words = np.zeros(n)
        self.rows, self.y_row = plant_rows(self.plant, n)

    def _apply(self, writes) -> None:
        for addr, value in writes:
            name = self.names[addr]
            if name != "CTRL":
                value = regmap.decode(name, value)
            self.model.write(name, value)

    def sample(self, k: int, end_m: float, dec: int) -> None:
        """FPGA sample k: the loop's tick, the plant over [t_k, t_k+1) with its far end at
        end_m, the ADC samples of tick k+1, and the firmware's tick when k is one."""
        if k >= TC_LATENCY_SAMPLES and (k - TC_LATENCY_SAMPLES) % dec == 0:
            self._apply(self.pending)
            self.pending = []
        if self.code is not None:
            self.model.adc_sample(self.code)
        out = self.model.tick()
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


@dataclass
class PairRecord:
    """A pair run: each cable's record (the arrays of cosim.engines.harness.Record, plus
    `u_word`) and the joint's per sample (at t_k, before the sample's step)."""

    cables: tuple[dict[str, np.ndarray], dict[str, np.ndarray]]
    t_s: np.ndarray
    tau_ref_n_m: np.ndarray
    theta_rad: np.ndarray
    omega_rad_s: np.ndarray


ENGINES = ("native", "model")


def run_pair(
    scen: Antagonist,
    cfg: SimConfig,
    compensator: str,
    duration_s: float | None = None,
    interface: str = "board",
    hold_joint: bool = False,
    progress: bool = False,
    engine: str = "native",
) -> PairRecord:
    """Run the pair closed loop (module docstring) with `compensator` on both channels.
    hold_joint: both far ends held at d = 0 (the joint still turns): each channel is then a
    single-cable run, the check that the composition adds nothing but the joint.
    engine: `native` (two Verilated RTL loops, cosim/engines/native bn_run_pair) or `model`
    (the RTL's bit-exact model in Python); tests/cosim/test_antagonist.py holds the two to the
    same record."""
    if engine == "native":
        return _run_pair_native(scen, cfg, compensator, duration_s, interface, hold_joint)
    if engine != "model":
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}; got {engine!r}")
    from cosim.parts.joint import Joint  # noqa: PLC0415

    chans = [
        _Channel(
            scen.cable_scenario(i),
            scen.cable_config(cfg, i),
            compensator,
            scen.cables[i].loop_routing,
            duration_s,
            interface,
        )
        for i in range(2)
    ]
    t_s = chans[0].inp.t_s
    n = len(t_s)
    dt_s = 1.0 / cfg.sample_rate_hz
    dec = cfg.decimation
    joint = Joint(scen.joint)
    tau_load = np.asarray(scen.tau_load(t_s), dtype=np.float64).tolist()
    theta = np.zeros(n)
    omega = np.zeros(n)
    c1, c2 = chans
    t_out_1 = c1.plant.y[c1.plant.T_OUT]  # true T_out at t_0 (the plants at rest)
    t_out_2 = c2.plant.y[c2.plant.T_OUT]
    bar = Progress(n, f"{scen.name} {compensator}", cfg.sample_rate_hz, enabled=progress)
    try:
        for k in range(n):
            theta[k] = joint.theta_rad
            omega[k] = joint.omega_rad_s
            d_1, d_2 = (0.0, 0.0) if hold_joint else joint.end_displacements_m
            c1.sample(k, d_1, dec)
            c2.sample(k, d_2, dec)
            # the joint over [t_k, t_k+1) with the cables' tensions at t_k (Jacobi)
            joint.t_1_n, joint.t_2_n, joint.tau_load_n_m = t_out_1, t_out_2, tau_load[k]
            joint.step(dt_s)
            t_out_1 = c1.plant.y[c1.plant.T_OUT]
            t_out_2 = c2.plant.y[c2.plant.T_OUT]
            if (k & 1023) == 0:
                bar.update(k)
    finally:
        recs = tuple(c.finish() for c in chans)
        bar.close(n)
    return _pair_record(scen, recs, t_s, theta, omega)


def _run_pair_native(scen, cfg, compensator, duration_s, interface, hold_joint) -> PairRecord:
    """run_pair on the native engine: each cable a bn_spec_t as `bowden sim --engine native`
    sets one up, the joint's exact step handed over as its matrices (bn_joint_t)."""
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
        a, b = runs
        status = lib.bn_run_pair(ctypes.byref(a.s), ctypes.byref(b.s), ctypes.byref(j))
    finally:
        for run in runs:
            run.plant.close()
    if status != 0:
        raise RuntimeError(f"native pair: {a.s.error.decode(errors='replace')}")
    recs = tuple(run.collect(0)[0] for run in runs)
    return _pair_record(scen, recs, t_s, theta, omega)


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
