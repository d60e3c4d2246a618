"""One CompensatorParams, with the C firmware's defaults: the Python defaults are read from the
double twin's comp_f64_config_default, and they give the fixed-point comp_config_default exactly,
so the firmware, the twin and a run's configuration cannot drift apart."""

from __future__ import annotations

import ctypes
import json

import pytest

from cosim.config.run import SimConfig, load_params
from cosim.parts.firmware import CompConfig, CompensatorParams, CompF64Config, load_library


def _fields(struct) -> dict:
    return {name: getattr(struct, name) for name, _ in struct._fields_}


def test_defaults_give_the_fixed_point_firmware_defaults():
    want = CompConfig()
    load_library().comp_config_default(ctypes.byref(want))
    assert _fields(CompensatorParams().to_c()) == _fields(want)


def test_defaults_are_the_double_twins_defaults():
    want = CompF64Config()
    load_library().comp_f64_config_default(ctypes.byref(want))
    assert _fields(CompensatorParams().to_c_f64()) == _fields(want)


def test_a_run_configures_the_same_class_with_the_same_defaults():
    c = SimConfig().compensator
    assert type(c) is CompensatorParams and c == CompensatorParams()
    # phi_rad None: calibrated at the scenario's start; the C structs get the firmware's default
    assert c.phi_rad is None and c.to_c().phi_rad_q24 == round(2 * 3.141592653589793 * 2**24)
    # the mode is the run's --compensator: not part of result.json's configuration
    assert "mode" not in SimConfig().to_dict()["compensator"]
    assert SimConfig.from_dict(SimConfig().to_dict()) == SimConfig()


def test_a_params_file_cannot_set_the_mode(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"compensator": {"mode": "smooth"}}))
    with pytest.raises(ValueError) as exc:
        load_params(path)
    message = str(exc.value)
    assert message.endswith("p.json: compensator.mode is set on the command line (--compensator)")
    assert "\n" not in message
