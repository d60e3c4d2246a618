"""The packaged FMU: fmpy validate, fmpy simulate, the exported API, one source of variables."""

from __future__ import annotations

import ctypes
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from cosim.project.paths import REPO_ROOT


def test_fmpy_validate_reports_no_problems(fmu_path):
    assert validate_fmu(str(fmu_path)) == []


def test_fmpy_validate_command_line_is_clean(fmu_path):
    res = subprocess.run(
        [sys.executable, "-m", "fmpy.cli", "validate", str(fmu_path)],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    assert "No problems found" in res.stdout


def test_capabilities_and_contents(fmu_path):
    md = read_model_description(str(fmu_path))
    cs = md.coSimulation
    assert md.fmiVersion == "2.0"
    assert cs.modelIdentifier == "BowdenPlant"
    assert cs.canGetAndSetFMUstate and cs.canHandleVariableCommunicationStepSize
    names = set(zipfile.ZipFile(fmu_path).namelist())
    assert "binaries/linux64/BowdenPlant.so" in names
    for f in ("bowden_physics.c", "bowden_geometry.c", "fmi2_plumbing.c", "bowden_vars.h"):
        assert f"sources/{f}" in names


def test_contract_variable_names(fmu_path):
    md = read_model_description(str(fmu_path))
    by_name = {v.name: v for v in md.modelVariables}
    contract = {
        "parameter": "mu sheath_length spool_radius loop_routing drive_mode noise_std seed "
        "sensor_offset sensor_gain mu_viscous mu_tension_slope phi_offset_per_z sensor_tau "
        "sensor_delay mu_drift",
        "input": "current_cmd T_in_cmd x y z",
        "output": "T_in T_out T_in_meas T_out_meas phi motor_angle motor_speed current",
    }
    for causality, names in contract.items():
        for name in names.split():
            assert by_name[name].causality == causality, name
    assert by_name["mu"].start == "0.075"
    assert by_name["loop_routing"].type == "Boolean"
    assert by_name["drive_mode"].type == "Integer"


def test_every_fmi2_function_is_exported(fmu_path, tmp_path):
    import fmpy

    header = (Path(fmpy.__file__).parent / "c-code" / "fmi2Functions.h").read_text()
    functions = sorted(set(re.findall(r"FMI2_Export\s+\w+TYPE\s+(fmi2\w+);", header)))
    assert len(functions) >= 40
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extract("binaries/linux64/BowdenPlant.so", tmp_path)
    lib = ctypes.CDLL(str(tmp_path / "binaries/linux64/BowdenPlant.so"))
    missing = [f for f in functions if not hasattr(lib, f)]
    assert missing == []
    # the model's own functions stay hidden (-fvisibility=hidden)
    assert not hasattr(lib, "bowden_model_step")


def test_model_description_is_the_generator_output(fmu_path, gen_model):
    with zipfile.ZipFile(fmu_path) as zf:
        xml = zf.read("modelDescription.xml").decode()
        header = zf.read("sources/bowden_vars.h").decode()
    assert xml == gen_model.model_description(), "stale FMU: run make fmu"
    assert header == gen_model.c_header(), "stale FMU: run make fmu"


def test_binary_agrees_with_model_description(fmu_path, gen_model, tmp_path):
    """Every value reference of the XML reads back its start value from the binary, and the
    header's VR macros are the XML's value references."""
    md = read_model_description(str(fmu_path))
    with zipfile.ZipFile(fmu_path) as zf:
        header = zf.read("sources/bowden_vars.h").decode()
        zf.extractall(tmp_path)
    macros = dict(re.findall(r"#define BOWDEN_VR_(\w+) (\d+)", header))
    assert {v.name: str(v.valueReference) for v in md.modelVariables} == macros
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=str(tmp_path),
        modelIdentifier="BowdenPlant",
        instanceName="vr",
    )
    fmu.instantiate()
    try:
        for v in md.modelVariables:
            if v.start is None:
                continue
            if v.type == "Real":
                assert fmu.getReal([v.valueReference])[0] == pytest.approx(float(v.start)), v.name
            elif v.type == "Integer":
                assert fmu.getInteger([v.valueReference])[0] == int(v.start), v.name
            else:
                assert bool(fmu.getBoolean([v.valueReference])[0]) == (v.start == "true"), v.name
    finally:
        fmu.freeInstance()


def test_wrong_guid_is_refused(fmu_path, tmp_path):
    md = read_model_description(str(fmu_path))
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(tmp_path)
    fmu = FMU2Slave(
        guid="{00000000-0000-0000-0000-000000000000}",
        unzipDirectory=str(tmp_path),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="guid",
    )
    with pytest.raises(Exception, match="instantiate"):
        fmu.instantiate()


def test_fmpy_simulate_with_input(fmu_path):
    """fmpy simulate_fmu: drive mode 0, current ramp 0 -> 2 A; T_in follows the torque balance."""
    names = ("time", "current_cmd", "T_in_cmd", "x", "y", "z")
    signals = np.array(
        [
            (0.0, 0.0, 0.0, 0.0, 0.6, -0.2),
            (0.2, 2.0, 0.0, 0.0, 0.6, -0.2),
            (1.0, 2.0, 0, 0, 0.6, -0.2),
        ],
        dtype=[(n, np.float64) for n in names],
    )
    res = simulate_fmu(
        str(fmu_path),
        stop_time=1.0,
        step_size=1e-3,
        output_interval=1e-3,
        input=signals,
        output=["T_in", "T_out", "current"],
    )
    assert len(res) == 1001
    assert np.all(np.isfinite(res["T_in"]))
    # 2 A * 5.4 * 0.9 * 23.4 mNm/A / 10 mm = 22.74 N once settled
    assert res["T_in"][-1] == pytest.approx(2 * 5.4 * 0.9 * 0.0234 / 0.01, rel=1e-3)
    assert res["current"][-1] == pytest.approx(2.0, rel=1e-9)


def test_fmpy_simulate_command_line(fmu_path, tmp_path):
    out = tmp_path / "result.csv"
    res = subprocess.run(
        [sys.executable, "-m", "fmpy.cli", "simulate", str(fmu_path), "--output-file", str(out)],
        capture_output=True,
        text=True,
        cwd=REPO_ROOT,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    header = out.read_text().splitlines()[0]
    assert "T_out" in header and "phi" in header


def test_packaged_sources_build_a_working_binary(fmu_path, tmp_path):
    """The sources/ folder of the FMU is complete: it compiles on its own (with the FMI 2.0
    headers that ship in fmpy) into a library that simulates like the packaged binary."""
    import fmpy

    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(tmp_path / "fmu")
    sources = sorted(str(p) for p in (tmp_path / "fmu" / "sources").glob("*.c"))
    binary = tmp_path / "fmu" / "binaries" / "linux64" / "BowdenPlant.so"
    binary.unlink()
    subprocess.run(
        [
            "cc",
            "-std=c99",
            "-O2",
            "-shared",
            "-fPIC",
            "-I",
            str(Path(fmpy.__file__).parent / "c-code"),
            "-o",
            str(binary),
            *sources,
            "-lm",
        ],
        check=True,
    )
    rebuilt = simulate_fmu(str(tmp_path / "fmu"), stop_time=0.05, start_values={"T_in_cmd": 0})
    packaged = simulate_fmu(str(fmu_path), stop_time=0.05, start_values={"T_in_cmd": 0})
    assert np.array_equal(rebuilt["phi"], packaged["phi"])


def test_reset_returns_to_the_start_values(fmu_path, tmp_path):
    md = read_model_description(str(fmu_path))
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(tmp_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=str(tmp_path), modelIdentifier="BowdenPlant", instanceName="r"
    )
    fmu.instantiate()
    runs = []
    for _ in range(2):
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        assert fmu.getReal([vr["mu"]]) == [0.075]
        fmu.setReal([vr["mu"]], [0.2])
        fmu.exitInitializationMode()
        fmu.setReal([vr["current_cmd"]], [1.0])
        for k in range(50):
            fmu.doStep(k * 1e-3, 1e-3)
        runs.append(fmu.getReal([vr["T_in"], vr["T_out"], vr["motor_angle"]]))
        fmu.reset()
    fmu.freeInstance()
    assert runs[0] == runs[1]
    assert runs[0][1] < runs[0][0]


def test_the_twins_copies_of_the_fmus_defaults_are_the_generators(gen_model):
    """The audit's twin and the compensator's cable-speed conversion
    (cosim.parts.firmware.mu_per_inlet_rate_of_cable_speed) hold the FMU's cable stiffness and
    load cell stiffness as constants: they are the model description's defaults."""
    from cosim.audit import twin  # noqa: PLC0415
    from cosim.parts import firmware  # noqa: PLC0415

    start = {v.name: v.start for v in gen_model.VARIABLES}
    assert twin.CABLE_EA_N == firmware.FMU_CABLE_EA_N == start["cable_EA"]
    assert twin.LOADCELL_N_PER_M == firmware.FMU_LOADCELL_N_PER_M == start["loadcell_stiffness"]
