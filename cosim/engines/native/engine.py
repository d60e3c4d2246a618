"""`bowden sim ... --engine native`: the closed loop of cosim/engines/cocotb/tb_closed_loop.py
compiled (cosim/engines/native/closed_loop.cpp), with no Python per sample.

Python sets the run up exactly as the cocotb harness does (scenario inputs, the plant FMU
instance through cosim.parts.plant.Plant, the firmware through cosim.engines.fwbridge, the interface
stage's constants from cosim.parts.interface) and hands it to libbowden_native.so in one call, which
runs the Verilated RTL, the firmware and the FMU clock by clock with the cocotb harness's timing
(lean AXI4-Lite driver). It returns the same record and cost split as
cosim.engines.cocotb.runner.run_closed_loop; tests/native holds the two to the same bits.
"""

from __future__ import annotations

import ctypes
import threading
from ctypes import POINTER, c_char, c_double, c_int16, c_int32, c_int64, c_uint32, c_void_p

import numpy as np

from cosim.config import scenarios
from cosim.config.run import SimConfig
from cosim.config.scenarios import get_scenario, held_at, sample_inputs
from cosim.engines.fwbridge import FirmwareBridge, loop_words
from cosim.engines.harness import (
    CLKS_PER_SAMPLE,
    TC_LATENCY_SAMPLES,
    CommandTension,
    Record,
    open_plant,
    plant_rows,
    store_run,
)
from cosim.parts.firmware import tension_words
from cosim.parts.interface import make_chain
from cosim.parts.plant import FMU_LINK_FIELDS
from cosim.project.progress import Progress

API_VERSION = 9
IFACE_CODES = {"ideal": 0, "adc": 1, "board": 2}
# As the cocotb harness (tb_closed_loop.SHADOW_REFRESH_TICKS).
SHADOW_REFRESH_TICKS = 10

_D = POINTER(c_double)


class Spec(ctypes.Structure):
    """Mirror of bn_spec_t (cosim/engines/native/bn_api.h); checked against bn_spec_size()."""

    _fields_ = [
        ("n", c_int64),
        ("decimation", c_int32),
        ("clks_per_sample", c_int32),
        ("tc_latency_samples", c_int32),
        ("shadow_refresh_ticks", c_int32),
        ("slew_n", c_double),
        ("floor_n", c_double),
        ("t_ref_word", POINTER(c_int16)),
        ("x_m", _D),
        ("y_m", _D),
        ("z_m", _D),
        ("fw_host", c_void_p),
        *FMU_LINK_FIELDS,
        ("iface", c_int32),
        ("adc_offset", c_int32),
        ("adc_gain", c_int32),
        ("dt_s", c_double),
        ("adc_period_s", c_double),
        ("adc_phase_s", c_double),
        ("adc_read_s", c_double),
        ("adc_kernel_n", c_int32),
        ("adc_offsets_s", _D),
        ("adc_weights", _D),
        ("pwm_ratio", c_int32),
        ("pwm_period_clks", c_int32),
        ("pwm_imax_q12", c_int32),
        ("escon_imax_a", c_double),
        ("escon_duty_error", c_double),
        ("escon_duty_resolution", c_double),
        ("escon_frac", c_double),
        ("est_feed", c_int32),
        ("t_out_stuck_s", c_double),
        ("t_out_absent_s", c_double),
        ("out_est_q28", POINTER(c_int32)),
        ("est_faults", c_uint32),
        ("out_corr_q8", POINTER(c_int32)),
        ("corr_faults", c_uint32),
        ("out_tc_n", _D),
        ("out_current_a", _D),
        ("out_u_word", POINTER(c_int32)),
        ("out_rows", _D),
        ("late_writes", c_int64),
        ("tc_mismatch", c_int64),
        ("tc_checks", c_int64),
        ("firmware_ticks", c_int64),
        ("fault_word", c_uint32),
        ("status_word", c_uint32),
        ("rtl_s", c_double),
        ("fmu_s", c_double),
        ("firmware_s", c_double),
        ("total_s", c_double),
        ("progress", c_int64),
        ("stop", c_int32),
        ("error", c_char * 256),
        ("end_vr", c_uint32),
    ]


class JointSpec(ctypes.Structure):
    """Mirror of bn_joint_t (cosim/engines/native/bn_api.h): the joint of bn_run_pair."""

    _fields_ = [
        ("radius_m", c_double),
        ("phi", c_double * 4),
        ("gam", c_double * 2),
        ("tau_load_n_m", _D),
        ("hold", c_int32),
        ("theta_rad", _D),
        ("omega_rad_s", _D),
    ]


class PairLoopSpec(ctypes.Structure):
    """Mirror of bn_pair_loop_t (cosim/engines/native/bn_api.h): the pair's bowden_core_mc in
    bn_run_pair, a load-cell fault per cable, each channel's status per sample, the RTL's time
    and the bus's least slack before a tick."""

    _fields_ = [
        ("fault_kind", c_int32 * 2),
        ("fault_k", ctypes.c_int64 * 2),
        ("out_faults", POINTER(c_int32)),
        ("out_en", POINTER(ctypes.c_uint8)),
        ("out_grp_stop", POINTER(ctypes.c_uint8)),
        ("rtl_s", c_double),
        ("least_slack_clks", ctypes.c_int64),
    ]


_LIB: ctypes.CDLL | None = None


def load_library() -> ctypes.CDLL:
    """Build (or reuse) libbowden_native.so and load it once per process."""
    global _LIB
    if _LIB is None:
        from .build import build  # noqa: PLC0415

        path = build()
        lib = ctypes.CDLL(str(path))
        lib.bn_run.argtypes = [POINTER(Spec)]
        lib.bn_run.restype = c_int32
        lib.bn_run_pair.argtypes = [
            POINTER(Spec),
            POINTER(Spec),
            POINTER(JointSpec),
            POINTER(PairLoopSpec),
        ]
        lib.bn_run_pair.restype = c_int32
        lib.bn_spec_size.restype = c_uint32
        lib.bn_fsum.argtypes = [_D, c_int32, POINTER(c_int32)]
        lib.bn_fsum.restype = c_double
        if lib.bn_api_version() != API_VERSION or lib.bn_spec_size() != ctypes.sizeof(Spec):
            raise RuntimeError(
                f"{path} does not match cosim/engines/native/engine.py (API or bn_spec_t size): "
                "rebuild it with `make native`"
            )
        if lib.bn_clks_per_sample() != CLKS_PER_SAMPLE:
            raise RuntimeError(f"{path} was built for another CLKS_PER_SAMPLE: `make native`")
        _LIB = lib
    return _LIB


def scenario_of(run_spec: dict):
    """The run's scenario; with "position_m" in the spec, the end-effector held there
    (scenarios.held_at: the points of a workspace map, `bowden sweep`)."""
    scen = get_scenario(run_spec["scenario"])
    if run_spec.get("position_m") is not None:
        scen = held_at(scen, run_spec["position_m"])
    return scen


def _when(t_s: float | None) -> float:
    """A failure time for bn_spec_t: -1 for never."""
    return -1.0 if t_s is None else float(t_s)


def _ptr(array: np.ndarray, ctype):
    return array.ctypes.data_as(POINTER(ctype))


def run_closed_loop(run_spec: dict, progress: bool = True) -> tuple[dict, dict]:
    """Run one closed loop natively; return (record arrays, cost split) as
    cosim.engines.cocotb.runner.run_closed_loop does for the same run_spec."""
    lib = load_library()
    cfg = SimConfig.from_dict(run_spec["config"], source="spec")
    run = _Run(scenario_of(run_spec), cfg, run_spec)
    try:
        status = _call(lib, run.s, run.n, cfg.sample_rate_hz, progress)
    finally:
        run.plant.close()
    return run.collect(status)


class _Run:
    """One loop's bn_spec_t set up as the cocotb harness sets its run up, the arrays it points
    into and its plant instance (open until the caller closes it); collect() turns what the
    loop wrote into the record and the cost split."""

    def __init__(self, scen, cfg: SimConfig, run_spec: dict) -> None:
        self.inp = inp = sample_inputs(scen, cfg, run_spec["duration_s"])
        self.n = len(inp.t_s)
        self.plant = open_plant(
            cfg,
            run_spec["loop_routing"],
            (inp.x_m[0], inp.y_m[0], inp.z_m[0]),
            fmu_path=run_spec.get("fmu_path"),  # a variant build (cosim/convergence)
        )
        try:
            self._setup(scen, cfg, run_spec)
        except BaseException:
            self.plant.close()
            raise

    def _setup(self, scen, cfg: SimConfig, run_spec: dict) -> None:
        inp, n, plant = self.inp, self.n, self.plant
        dec = cfg.decimation
        interface = run_spec.get("interface", "board")
        self.rec = rec = Record.allocate(n).arrays
        fw = FirmwareBridge(cfg, run_spec["compensator"], run_spec["phi_rad"])
        chain = make_chain(cfg, interface, True, fw.adc_offset, fw.adc_gain)
        words = loop_words(cfg.controller, cfg.sample_rate_hz)

        # T_ref as the firmware's host word, at the firmware's ticks (FirmwareBridge.tick): what
        # the host hands the firmware (scenarios.firmware_t_ref: ahead in preview mode).
        fw_ref = scenarios.firmware_t_ref(scen, cfg, run_spec["compensator"], inp)
        t_ref_word = np.zeros(n, dtype=np.int16)
        t_ref_word[::dec] = tension_words(fw_ref[::dec])
        xs, ys, zs = (
            np.ascontiguousarray(a, dtype=np.float64) for a in (inp.x_m, inp.y_m, inp.z_m)
        )
        out_u_word = np.zeros(n, dtype=np.int32)
        rows, _ = plant_rows(plant, n)

        s = Spec()
        s.n = n
        s.decimation = dec
        s.clks_per_sample = CLKS_PER_SAMPLE
        s.tc_latency_samples = TC_LATENCY_SAMPLES
        s.shadow_refresh_ticks = SHADOW_REFRESH_TICKS
        # The RTL's slew limit and floor on T_c, for the loop's port of CommandTension.step.
        tc_path = CommandTension.programmed(words, cfg.compensator.tc_min_n)
        s.slew_n, s.floor_n = tc_path.slew_n, tc_path.floor_n
        s.t_ref_word = _ptr(t_ref_word, c_int16)
        s.x_m, s.y_m, s.z_m = _ptr(xs, c_double), _ptr(ys, c_double), _ptr(zs, c_double)
        s.fw_host = ctypes.addressof(fw.fw._buf)
        plant.link(s)

        s.iface = IFACE_CODES[interface]
        s.adc_offset, s.adc_gain = fw.adc_offset, fw.adc_gain
        s.dt_s = chain.dt
        keep = []  # arrays the spec points into, alive until the call returns
        if chain.adc is not None:
            adc = chain.adc
            offsets = np.array(adc.offsets, dtype=np.float64)
            weights = np.array(adc.weights, dtype=np.float64)
            keep += [offsets, weights]
            s.dt_s = adc.dt
            s.adc_period_s, s.adc_phase_s, s.adc_read_s = adc.period, adc.phase, adc.read_s
            s.adc_kernel_n = len(offsets)
            s.adc_offsets_s, s.adc_weights = _ptr(offsets, c_double), _ptr(weights, c_double)
        if chain.pwm is not None:
            pwm = chain.pwm
            if pwm.dt != chain.dt or not pwm.fixed:
                raise RuntimeError("the PWM stage's sample period differs from the chain's")
            s.pwm_ratio, s.pwm_period_clks, s.pwm_imax_q12 = (
                pwm.ratio,
                pwm.period_clks,
                pwm.imax_q12,
            )
            s.escon_imax_a, s.escon_duty_error = pwm.escon_imax, pwm.duty_error
            s.escon_duty_resolution, s.escon_frac = pwm.resolution, pwm.frac
        s.out_tc_n = _ptr(rec["T_c_N"], c_double)
        s.out_current_a = _ptr(rec["current_A"], c_double)
        s.out_u_word = _ptr(out_u_word, c_int32)
        # The far-end cell for the online friction estimate and the far-end output correction
        # (cosim/engines/native/bn_api.h).
        far_end = bool(cfg.compensator.est_enable) or bool(cfg.compensator.corr_enable)
        est_on = far_end and run_spec["compensator"] != "none"
        out_est = np.zeros(n, dtype=np.int32)
        out_corr = np.zeros(n, dtype=np.int32)
        s.est_feed = 1 if est_on else 0
        s.t_out_stuck_s = _when(cfg.board.t_out_stuck_s)
        s.t_out_absent_s = _when(cfg.board.t_out_absent_s)
        s.out_est_q28 = _ptr(out_est, c_int32) if est_on else None
        s.out_corr_q8 = _ptr(out_corr, c_int32) if est_on else None
        s.out_rows = _ptr(rows, c_double)
        s.end_vr = plant.vr("end_displacement")
        # alive as long as the spec that points into them
        self.s, self.fw, self.keep = s, fw, keep
        self.arrays = (t_ref_word, xs, ys, zs, out_u_word, rows, out_est, out_corr)

    def collect(self, status: int) -> tuple[dict, dict]:
        """The record and the cost split."""
        s, n, inp, rec = self.s, self.n, self.inp, self.rec
        _, _, _, _, out_u_word, rows, out_est, out_corr = self.arrays
        return _collect(s, n, inp, rec, out_u_word, rows, out_est, out_corr, status)


def _collect(s, n, inp, rec, out_u_word, rows, out_est, out_corr, status):
    if status != 0:
        raise RuntimeError(f"native closed loop: {s.error.decode(errors='replace')}")

    store_run(rec, rows, inp)
    rec["u_word"] = out_u_word.astype(np.float64)
    if s.est_feed:
        rec["mu_phi_est"] = out_est / 2.0**28  # the firmware's mu*phi in force
        rec["corr_n"] = out_corr / 256.0  # the far-end output correction in force
    cost = {
        "rtl_s": s.rtl_s,
        "fmu_s": s.fmu_s,
        "firmware_s": s.firmware_s,
        "bus_s": 0.0,  # the bus master runs inside the clocks (rtl_s)
        "total_s": s.total_s,
        "harness_s": max(0.0, s.total_s - s.rtl_s - s.fmu_s - s.firmware_s),
        "rtl_per_sample_us": 1e6 * s.rtl_s / max(1, n - 1),
        "late_writes": s.late_writes,
        "tc_mismatch": s.tc_mismatch,
        "tc_checks": s.tc_checks,
        "firmware_ticks": s.firmware_ticks,
        "samples": n,
        "clks_per_sample": CLKS_PER_SAMPLE,
        "fault_word": s.fault_word,
        "status_word": s.status_word,
        "tc_latency_samples": TC_LATENCY_SAMPLES,
        "est_faults": int(s.est_faults),
        "corr_faults": int(s.corr_faults),
    }
    if s.late_writes:
        raise RuntimeError(
            f"{s.late_writes} firmware TC writes missed sample tick k+{TC_LATENCY_SAMPLES}"
        )
    if s.tc_mismatch:
        raise RuntimeError(
            f"{s.tc_mismatch} firmware ticks: TC_EFF read back differs from the T_c written"
        )
    return rec, cost


def _call(lib, s: Spec, n: int, rate_hz: float, progress: bool) -> int:
    """bn_run in a worker thread (ctypes releases the GIL), with the progress bar drawn and
    Ctrl-C honoured here: an interrupt asks the loop to stop and waits for it."""
    bar = Progress(n, "fixed point (native)", rate_hz, enabled=progress)
    result = {}

    def target():
        result["status"] = lib.bn_run(ctypes.byref(s))

    worker = threading.Thread(target=target, daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.2)
            bar.update(int(s.progress))
    except BaseException:
        s.stop = 1
        worker.join()
        bar.abandon()
        raise
    bar.close(int(s.progress))
    return int(result.get("status", 1))
