"""cosim.parts.plant.Plant, the per-sample handle the co-simulation uses."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

import cosim.parts.plant as plant_mod
from cosim.parts.plant import INPUT_NAMES, OUTPUT_NAMES, Plant


def test_outputs_by_index_and_name_agree(make_plant):
    plant = make_plant({"drive_mode": 1})
    plant.u[Plant.T_IN_CMD] = 10.0
    y = plant.step(1e-4)
    for i, name in enumerate(OUTPUT_NAMES):
        assert y[i] == plant.output(name) == pytest.approx(plant.get(name), abs=0.0)
    assert y[Plant.T_IN] == 10.0
    assert plant.time_s == pytest.approx(1e-4)


def test_parameters_by_name(make_plant):
    plant = make_plant({"mu": 0.1, "loop_routing": False, "drive_mode": 1, "seed": 9})
    assert plant.get("mu") == 0.1
    assert plant.get("loop_routing") is False or plant.get("loop_routing") == 0
    assert plant.get("drive_mode") == 1 and plant.get("seed") == 9


def test_inputs_set_by_name_reach_the_fmu(make_plant):
    plant = make_plant({"drive_mode": 1})
    plant.set("T_in_cmd", 5.0)
    assert plant.u[INPUT_NAMES.index("T_in_cmd")] == 5.0
    plant.step(1e-4)
    assert plant.output("T_in") == 5.0


def test_unknown_names_are_refused(make_plant, fmu_path):
    plant = make_plant()
    with pytest.raises(KeyError, match="no variable 'friction'"):
        plant.set("friction", 1.0)
    with pytest.raises(KeyError, match="no variable 'tension'"):
        plant.get("tension")
    with pytest.raises(KeyError, match="no variable 'nope'"):
        Plant({"nope": 1}, fmu_path=fmu_path)


def test_missing_fmu_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="run `make fmu` first"):
        Plant(fmu_path=tmp_path / "missing.fmu")


def test_no_unpacked_fmu_is_left_in_the_temp_folder(fmu_path, tmp_path):
    """A process that ends without closing its plants (a pool worker's os._exit), or whose
    plant was refused a parameter, leaves nothing behind in the temp folder."""
    script = (
        "import os\n"
        "from cosim.parts.plant import Plant\n"
        f"plants = [Plant(fmu_path={str(fmu_path)!r}) for _ in range(2)]\n"
        "plants[0].step(1e-4)\n"
        "try:\n"
        f"    Plant({{'nope': 1}}, fmu_path={str(fmu_path)!r})\n"
        "except KeyError:\n"
        "    pass\n"
        "os._exit(0)\n"
    )
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    subprocess.run([sys.executable, "-c", script], env=env, check=True, timeout=60)
    assert list(tmp_path.iterdir()) == []


def test_an_unpacked_fmu_of_a_killed_process_is_removed_by_the_next(fmu_path, tmp_path):
    """A process killed between unpacking and loading (SIGKILL in that window) leaves its copy;
    the next process that opens a plant removes it, and only it: not a copy of a live process,
    not a recent one, not a folder of another name."""
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        text=True,
        capture_output=True,
        check=True,
    ).stdout.strip()
    old = time.time() - 2 * plant_mod.ORPHAN_AGE_S
    folders = {
        "orphan": tmp_path / f"{plant_mod.UNPACK_PREFIX}{dead}_abc",
        "recent": tmp_path / f"{plant_mod.UNPACK_PREFIX}{dead}_def",
        "live": tmp_path / f"{plant_mod.UNPACK_PREFIX}{os.getpid()}_ghi",
        "no pid": tmp_path / f"{plant_mod.UNPACK_PREFIX}xyz",
        "other": tmp_path / "other_1_abc",
    }
    for name, d in folders.items():
        (d / "binaries").mkdir(parents=True)
        if name != "recent":
            os.utime(d, (old, old))
    assert plant_mod.remove_orphaned_unpacks(tmp_path) == [folders["orphan"]]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        d.name for k, d in folders.items() if k != "orphan"
    )
    # A new process sweeps once, before it unpacks its own copy (which it removes itself).
    again = tmp_path / f"{plant_mod.UNPACK_PREFIX}{dead}_jkl"
    again.mkdir()
    os.utime(again, (old, old))
    script = f"from cosim.parts.plant import Plant\nPlant(fmu_path={str(fmu_path)!r}).close()\n"
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    subprocess.run([sys.executable, "-c", script], env=env, check=True, timeout=60)
    assert not again.exists() and folders["recent"].exists() and folders["live"].exists()
