#!/usr/bin/env python3
"""One source for the BowdenPlant variables: generates modelDescription.xml and the C header.

The table VARIABLES below is the only place where a variable's name, value reference, type,
causality, start value, unit and allowed range are written. `python -m fmu.gen_model OUTDIR`
writes OUTDIR/modelDescription.xml and OUTDIR/bowden_vars.h (C structs holding the parameters,
inputs and outputs, their defaults, and a table mapping each value reference to a struct member
with its allowed range). A test checks that the packaged FMU and the binary agree with it.
"""

from __future__ import annotations

import hashlib
import sys
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape

MODEL_IDENTIFIER = "BowdenPlant"
MODEL_NAME = "BowdenPlant"
FMU_VERSION = "0.1.0"
SOURCE_FILES = ["bowden_physics.c", "bowden_geometry.c", "fmi2_plumbing.c"]
HEADER_FILES = ["bowden_physics.h", "bowden_geometry.h", "bowden_vars.h"]


@dataclass(frozen=True)
class Var:
    name: str
    kind: str  # Real | Integer | Boolean
    causality: str  # parameter | input | output
    start: float | int | bool | None
    unit: str | None
    lo: float | None  # allowed range, enforced by the C setter (fmi2Error outside)
    hi: float | None
    description: str


PARAM, INPUT, OUTPUT = "parameter", "input", "output"
# Knots of the friction drift's table (mu_drift_table_0 ..): BOWDEN_DRIFT_KNOTS of the C header.
DRIFT_TABLE_KNOTS = 16
# Knots of the slack table (slack_table_0 ..): BOWDEN_SLACK_KNOTS of the C header.
SLACK_TABLE_KNOTS = 8
# fmt: off
VARIABLES: list[Var] = [
    # --- parameters, named as the firmware and the co-simulation name them -----------------
    Var("mu", "Real", PARAM, 0.075, "1", 0.0, 1.0,
        "Coulomb friction coefficient cable/liner (paper Sec. VI-A: 0.075)"),
    Var("sheath_length", "Real", PARAM, 1.0, "m", 0.01, 10.0,
        "Sheath length L (paper: 1000 mm)"),
    Var("spool_radius", "Real", PARAM, 0.01, "m", 0.001, 0.1,
        "Spool radius (about 10 mm gives 24 N at 2 A)"),
    Var("loop_routing", "Boolean", PARAM, True, None, None, None,
        "Sheath routed with one loop (paper Sec. III) instead of free sag"),
    Var("drive_mode", "Integer", PARAM, 0, None, 0, 1,
        "0 = motor current command input, 1 = prescribed input tension T_in_cmd"),
    Var("noise_std", "Real", PARAM, 0.0, "N", 0.0, 10.0,
        "Standard deviation of the Gaussian noise on both tension sensors"),
    Var("seed", "Integer", PARAM, 1, None, 0, 2147483647,
        "Seed of the sensor-noise generator (deterministic)"),
    # --- effect parameters (each off by default) ----------------------------------------------
    Var("sensor_offset", "Real", PARAM, 0.0, "N", -100.0, 100.0,
        "Offset added to the output tension sensor"),
    Var("sensor_gain", "Real", PARAM, 1.0, "1", 0.1, 10.0,
        "Scale factor of the output tension sensor (1 = none)"),
    Var("mu_viscous", "Real", PARAM, 0.0, "s/m", 0.0, 100.0,
        "Friction coefficient rise per cable speed: mu + mu_viscous*|v|"),
    Var("mu_tension_slope", "Real", PARAM, 0.0, "1/N", -0.1, 0.1,
        "Friction coefficient change per local tension: mu + mu_tension_slope*T"),
    Var("phi_offset_per_z", "Real", PARAM, 0.0, "rad/m", -100.0, 100.0,
        "Bending angle added per metre of z displacement: phi + phi_offset_per_z*z"),
    Var("sensor_tau", "Real", PARAM, 0.0, "s", 0.0, 1.0,
        "Time constant of a first-order lag of the output tension sensor"),
    Var("sensor_delay", "Real", PARAM, 0.0, "s", 0.0, 0.2,
        "Pure delay of the output tension sensor"),
    Var("mu_drift", "Real", PARAM, 0.0, "1/s", -1.0, 1.0,
        "Friction coefficient drift over time: mu + mu_drift*t"),
    Var("dead_zone_spread", "Real", PARAM, 0.0, "1", 0.0, 2.0,
        "Log standard deviation of the friction thresholds: a gradual turn through the dead zone"),
    # --- drive, motor, cable (paper Table I and named assumptions in fmu/README.md) -----------
    Var("gear_ratio", "Real", PARAM, 5.4, "1", 1.0, 1000.0,
        "Gearhead reduction (Maxon 5.4:1, Table INPUT)"),
    Var("gear_efficiency", "Real", PARAM, 0.9, "1", 0.1, 1.0,
        "Gearhead efficiency (assumed 0.9)"),
    Var("torque_constant", "Real", PARAM, 0.0234, "N.m/A", 1e-4, 10.0,
        "Motor torque constant (Maxon RE25 20 W: 23.4 mNm/A)"),
    Var("motor_inertia", "Real", PARAM, 1.1e-6, "kg.m2", 1e-9, 1.0,
        "Inertia at the motor shaft: RE25 rotor 10.3 g cm^2 + gearhead and spool (assumed)"),
    Var("motor_damping", "Real", PARAM, 4e-4, "N.m.s/rad", 0.0, 1.0,
        "Viscous damping at the motor shaft lumping gearhead and cable losses (assumed)"),
    Var("current_bandwidth", "Real", PARAM, 2000.0, "Hz", 1.0, 1e5,
        "Bandwidth of the ESCON current loop, modelled as a first-order lag (assumed)"),
    Var("current_limit", "Real", PARAM, 4.0, "A", 0.0, 8.0,
        "Current limit of the drive (ESCON 36/2 DC peak current 4 A)"),
    Var("cable_EA", "Real", PARAM, 8000.0, "N", 1.0, 1e8,
        "Axial rigidity E*A of the braided Dyneema cable (assumed)"),
    Var("free_length", "Real", PARAM, 0.1, "m", 0.001, 10.0,
        "Free cable length between spool and sheath inlet (assumed)"),
    Var("loadcell_stiffness", "Real", PARAM, 2e5, "N/m", 100.0, 1e9,
        "Stiffness of the load cell that terminates the cable (isometric output)"),
    Var("max_step", "Real", PARAM, 100e-6, "s", 1e-7, 1e-3,
        "Largest internal integration step"),
    # --- inputs -------------------------------------------------------------------------------
    Var("current_cmd", "Real", INPUT, 0.0, "A", -8.0, 8.0,
        "Motor current command (drive_mode 0)"),
    Var("T_in_cmd", "Real", INPUT, 0.0, "N", -1000.0, 1000.0,
        "Prescribed input tension (drive_mode 1); negative values slacken the cable (T_in = 0)"),
    Var("x", "Real", INPUT, 0.0, "m", -10.0, 10.0,
        "End-effector position relative to the actuator outlet (out of the loop's plane)"),
    Var("y", "Real", INPUT, 0.6, "m", -10.0, 10.0,
        "End-effector position relative to the actuator outlet (outlet direction)"),
    Var("z", "Real", INPUT, -0.2, "m", -10.0, 10.0,
        "End-effector position relative to the actuator outlet (up)"),
    # --- outputs ------------------------------------------------------------------------------
    Var("T_in", "Real", OUTPUT, None, "N", None, None, "True cable tension at the sheath inlet"),
    Var("T_out", "Real", OUTPUT, None, "N", None, None, "True cable tension at the end-effector"),
    Var("T_in_meas", "Real", OUTPUT, None, "N", None, None, "Input tension, as its sensor reads"),
    Var("T_out_meas", "Real", OUTPUT, None, "N", None, None, "Output tension, as its sensor reads"),
    Var("phi", "Real", OUTPUT, None, "rad", None, None, "Total bending angle of the sheath"),
    Var("motor_angle", "Real", OUTPUT, None, "rad", None, None, "Motor shaft angle"),
    Var("motor_speed", "Real", OUTPUT, None, "rad/s", None, None, "Motor shaft speed"),
    Var("current", "Real", OUTPUT, None, "A", None, None, "Motor current"),
    # --- effects added later: appended, so that every earlier value reference stays ----------
    Var("mu_static_excess", "Real", PARAM, 0.0, "1", 0.0, 1.0,
        "Breakaway friction coefficient above the kinetic one after a reversal (stick-slip)"),
    Var("slack_tension", "Real", PARAM, 0.0, "N", 0.0, 100.0,
        "Input tension below which the cable loses its pretension: T_out*T_in/slack_tension"),
    Var("sensor_full_scale", "Real", PARAM, 0.0, "N", 0.0, 1000.0,
        "Full-scale tension at which the output sensor saturates (0 = no saturation)"),
    Var("sensor_saturation_knee", "Real", PARAM, 0.0, "N", 0.0, 100.0,
        "Width of the output sensor's turn into saturation (0 = a hard clip)"),
    Var("sensor_creep", "Real", PARAM, 0.0, "1", -0.5, 0.5,
        "Load-cell creep: share of a step change read only after sensor_creep_tau"),
    Var("sensor_creep_tau", "Real", PARAM, 1.0, "s", 0.001, 3600.0,
        "Time constant of the load cell's creep"),
    Var("mu_viscous_tension_rate", "Real", PARAM, 0.0, "s/N", 0.0, 1.0,
        "Friction coefficient rise per |dT_in/dt| (viscous friction, tension-rate form)"),
    Var("mu_warmup", "Real", PARAM, 0.0, "1", -1.0, 1.0,
        "Friction coefficient change of a warm-up: mu + mu_warmup*(1 - exp(-(t - t_start)/tau))"),
    Var("mu_warmup_tau", "Real", PARAM, 60.0, "s", 0.001, 1e5,
        "Time constant of the friction's warm-up from the start"),
    Var("mu_step", "Real", PARAM, 0.0, "1", -1.0, 1.0,
        "Friction coefficient step at mu_step_time: mu + mu_step once t >= mu_step_time"),
    Var("mu_step_time", "Real", PARAM, 0.0, "s", -1e9, 1e9,
        "Time of the friction coefficient's step"),
    Var("sensor_tau2", "Real", PARAM, 0.0, "s", 0.0, 1.0,
        "Output sensor's second-order lag: two first-order stages of this time constant"),
    Var("phi_offset_per_x", "Real", PARAM, 0.0, "rad/m", -100.0, 100.0,
        "Bending angle added per metre of x displacement: phi + phi_offset_per_x*x"),
    Var("phi_offset_per_y", "Real", PARAM, 0.0, "rad/m", -100.0, 100.0,
        "Bending angle added per metre of y displacement: phi + phi_offset_per_y*y"),
    Var("end_displacement", "Real", INPUT, 0.0, "m", -1.0, 1.0,
        "Displacement of the load cell's base away from the sheath outlet (0: fixed, the"
        " isometric output; a joint's pulley sets it)"),
    # the friction drift's free form: a table of mu's change on DRIFT_TABLE_KNOTS evenly spaced
    # knots from mu_drift_table_t0 (FMU time), mu_drift_table_dt apart; linear between them,
    # held flat outside (fmu/README.md "Friction drift")
    Var("mu_drift_table_t0", "Real", PARAM, 0.0, "s", -1e9, 1e9,
        "Time of the drift table's first knot"),
    Var("mu_drift_table_dt", "Real", PARAM, 1.0, "s", 1e-3, 1e9,
        "Time between the drift table's knots"),
    *(
        Var(f"mu_drift_table_{i}", "Real", PARAM, 0.0, "1", -1.0, 1.0,
            f"Friction coefficient change at the drift table's knot {i} (all 0 = off)")
        for i in range(DRIFT_TABLE_KNOTS)
    ),
    # the bending error's free form: a quadratic surface of the position added to phi
    # (fmu/README.md "Bending angle error"), with phi_offset_per_x, _y and _z as its linear part
    *(
        Var(f"phi_offset_per_{ab}", "Real", PARAM, 0.0, "rad/m2", -100.0, 100.0,
            f"Bending angle added per square metre of {ab[0]}*{ab[1]}:"
            f" phi + phi_offset_per_{ab}*{ab[0]}*{ab[1]}")
        for ab in ("xx", "yy", "zz", "xy", "xz", "yz")
    ),
    # the slack's free form: the share of the output lost at low input tension as a table on
    # SLACK_TABLE_KNOTS knots at T_in = i * slack_table_dt, falling linearly to none at
    # T_in = SLACK_TABLE_KNOTS * slack_table_dt, none above (fmu/README.md "Slack")
    Var("slack_table_dt", "Real", PARAM, 1.0, "N", 1e-3, 1e3,
        "Input tension between the slack table's knots"),
    *(
        Var(f"slack_table_{i}", "Real", PARAM, 0.0, "1", 0.0, 1.0,
            f"Share of the output lost at T_in = {i}*slack_table_dt (all 0 = off)")
        for i in range(SLACK_TABLE_KNOTS)
    ),
]
# fmt: on

# name -> exponents of SI base units (FMI 2.0 BaseUnit attributes)
UNITS: dict[str, dict[str, int]] = {
    "1": {},
    "N": {"kg": 1, "m": 1, "s": -2},
    "m": {"m": 1},
    "s": {"s": 1},
    "A": {"A": 1},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/m": {"rad": 1, "m": -1},
    "rad/m2": {"rad": 1, "m": -2},
    "s/m": {"s": 1, "m": -1},
    "s/N": {"kg": -1, "m": -1, "s": 3},
    "1/N": {"kg": -1, "m": -1, "s": 2},
    "1/s": {"s": -1},
    "Hz": {"s": -1},
    "N.m/A": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "kg.m2": {"kg": 1, "m": 2},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "N/m": {"kg": 1, "s": -2},
}

GROUP = {PARAM: "p", INPUT: "u", OUTPUT: "y"}
CTYPE = {"Real": "double", "Integer": "int", "Boolean": "int"}


def value_reference(var: Var) -> int:
    """Value references are the positions in VARIABLES (unique across all types)."""
    return VARIABLES.index(var)


def _fmt(value: float | int | bool) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    return repr(float(value))


def guid() -> str:
    digest = hashlib.md5(repr(VARIABLES).encode()).hexdigest()
    return f"{{{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}}}"


def model_description() -> str:
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<fmiModelDescription",
        '  fmiVersion="2.0"',
        f'  modelName="{MODEL_NAME}"',
        f'  guid="{guid()}"',
        '  description="Bowden-cable plant: drive, motor, elastic cable, distributed sheath'
        ' friction, loop-routing geometry, sensors (Jeong and Cho, IROS 2015)"',
        f'  version="{FMU_VERSION}"',
        '  generationTool="fmu/gen_model.py"',
        '  variableNamingConvention="flat"',
        '  numberOfEventIndicators="0">',
        "  <CoSimulation",
        f'    modelIdentifier="{MODEL_IDENTIFIER}"',
        '    canHandleVariableCommunicationStepSize="true"',
        '    canGetAndSetFMUstate="true"',
        '    canSerializeFMUstate="true"',
        '    canNotUseMemoryManagementFunctions="true">',
        "    <SourceFiles>",
        *[f'      <File name="{f}"/>' for f in SOURCE_FILES],
        "    </SourceFiles>",
        "  </CoSimulation>",
        "  <UnitDefinitions>",
    ]
    used = sorted({v.unit for v in VARIABLES if v.unit})
    for unit in used:
        exps = " ".join(f'{k}="{e}"' for k, e in UNITS[unit].items())
        lines.append(
            f'    <Unit name="{escape(unit)}"><BaseUnit {exps}/></Unit>'.replace(" />", "/>")
        )
    lines += [
        "  </UnitDefinitions>",
        "  <LogCategories>",
        '    <Category name="logStatusError" description="Errors: bad parameters and inputs"/>',
        '    <Category name="logStatusWarning" description="Warnings"/>',
        "  </LogCategories>",
        '  <DefaultExperiment startTime="0" stopTime="1" stepSize="1e-4"/>',
        "  <ModelVariables>",
    ]
    for v in VARIABLES:
        vr = value_reference(v)
        variability = "fixed" if v.causality == PARAM else "continuous"
        initial = ' initial="calculated"' if v.causality == OUTPUT else ""
        if v.causality == PARAM:
            initial = ' initial="exact"'
        attrs = [f'unit="{escape(v.unit)}"'] if v.unit and v.kind == "Real" else []
        if v.start is not None:
            attrs.append(f'start="{_fmt(v.start)}"')
        if v.lo is not None and v.kind != "Boolean":
            attrs.append(f'min="{_fmt(v.lo)}" max="{_fmt(v.hi)}"')
        lines.append(
            f'    <ScalarVariable name="{v.name}" valueReference="{vr}" causality="{v.causality}"'
            f' variability="{variability}"{initial} description="{escape(v.description)}">'
        )
        lines.append(f"      <{v.kind} {' '.join(attrs)}/>".replace(" />", "/>"))
        lines.append("    </ScalarVariable>")
    lines += ["  </ModelVariables>", "  <ModelStructure>", "    <Outputs>"]
    outputs = [v for v in VARIABLES if v.causality == OUTPUT]
    # FMI indices are 1-based positions in ModelVariables; outputs depend on all inputs/states.
    lines += [f'      <Unknown index="{value_reference(v) + 1}"/>' for v in outputs]
    lines += ["    </Outputs>", "    <InitialUnknowns>"]
    lines += [f'      <Unknown index="{value_reference(v) + 1}"/>' for v in outputs]
    lines += ["    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def c_header() -> str:
    out = [
        "/* Generated by fmu/gen_model.py from its VARIABLES table: do not edit. */",
        "#ifndef BOWDEN_VARS_H",
        "#define BOWDEN_VARS_H",
        "",
        "#include <stddef.h>",
        "",
        f'#define BOWDEN_MODEL_IDENTIFIER "{MODEL_IDENTIFIER}"',
        f'#define BOWDEN_GUID "{guid()}"',
        f"#define BOWDEN_N_VARS {len(VARIABLES)}",
        f"#define BOWDEN_DRIFT_KNOTS {DRIFT_TABLE_KNOTS}",
        f"#define BOWDEN_SLACK_KNOTS {SLACK_TABLE_KNOTS}",
        "",
    ]
    for v in VARIABLES:
        out.append(f"#define BOWDEN_VR_{v.name} {value_reference(v)}")
    out.append("")
    out.append("/* The drift table's knots of P (BowdenParams), an array's initialiser */")
    knots = ", ".join(f"(P).mu_drift_table_{i}" for i in range(DRIFT_TABLE_KNOTS))
    out += [f"#define BOWDEN_DRIFT_TABLE(P) {{{knots}}}", ""]
    out.append("/* The slack table's knots of P (BowdenParams), an array's initialiser */")
    knots = ", ".join(f"(P).slack_table_{i}" for i in range(SLACK_TABLE_KNOTS))
    out += [f"#define BOWDEN_SLACK_TABLE(P) {{{knots}}}", ""]
    for causality, struct in (
        (PARAM, "BowdenParams"),
        (INPUT, "BowdenInputs"),
        (OUTPUT, "BowdenOutputs"),
    ):
        out.append("typedef struct {")
        for v in VARIABLES:
            if v.causality == causality:
                unit = f" [{v.unit}]" if v.unit else ""
                out.append(f"    {CTYPE[v.kind]} {v.name}; /* {v.description}{unit} */")
        out.append(f"}} {struct};")
        out.append("")
    for causality, _struct, macro in (
        (PARAM, "BowdenParams", "PARAMS"),
        (INPUT, "BowdenInputs", "INPUTS"),
    ):
        out.append(f"#define BOWDEN_{macro}_DEFAULT {{ \\")
        for v in VARIABLES:
            if v.causality == causality:
                value = int(v.start) if v.kind != "Real" else repr(float(v.start))
                out.append(f"    /* {v.name} */ {value}, \\")
        out.append("}")
        out.append("")
    out += [
        "typedef enum { BOWDEN_REAL, BOWDEN_INTEGER, BOWDEN_BOOLEAN } BowdenVarKind;",
        "typedef enum { BOWDEN_PARAMETER, BOWDEN_INPUT, BOWDEN_OUTPUT } BowdenCausality;",
        "",
        "typedef struct {",
        "    const char *name;",
        "    BowdenVarKind kind;",
        "    BowdenCausality causality;",
        "    size_t offset; /* offsetof(BowdenModel, <group>.<name>) */",
        "    int has_range;",
        "    double lo, hi; /* allowed range, inclusive */",
        "} BowdenVarInfo;",
        "",
        "/* Expands to the table, indexed by value reference; MODEL is the struct holding",
        "   members p (BowdenParams), u (BowdenInputs) and y (BowdenOutputs). */",
        "#define BOWDEN_VAR_TABLE(MODEL) { \\",
    ]
    kinds = {"Real": "BOWDEN_REAL", "Integer": "BOWDEN_INTEGER", "Boolean": "BOWDEN_BOOLEAN"}
    caus = {PARAM: "BOWDEN_PARAMETER", INPUT: "BOWDEN_INPUT", OUTPUT: "BOWDEN_OUTPUT"}
    for v in VARIABLES:
        has = 1 if v.lo is not None else 0
        lo = _fmt(float(v.lo)) if has else "0.0"
        hi = _fmt(float(v.hi)) if has else "0.0"
        out.append(
            f'    {{"{v.name}", {kinds[v.kind]}, {caus[v.causality]}, '
            f"offsetof(MODEL, {GROUP[v.causality]}.{v.name}), {has}, {lo}, {hi}}}, \\"
        )
    out += ["}", "", "#endif /* BOWDEN_VARS_H */", ""]
    return "\n".join(out)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python -m fmu.gen_model OUTDIR", file=sys.stderr)
        return 2
    outdir = Path(argv[1])
    outdir.mkdir(parents=True, exist_ok=True)
    for name, text in (
        ("modelDescription.xml", model_description()),
        ("bowden_vars.h", c_header()),
    ):
        path = outdir / name
        # Rewrite only on change so that make does not rebuild the binary needlessly.
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
