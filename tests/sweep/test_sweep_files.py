"""Every file `bowden sweep` writes into --out is written whole to a temporary name of its own and
renamed into place: a reader (or a crash) never sees half a file, and two sweeps finishing at once
into the same --out never share a temporary file (the last rename wins, with a whole file)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from cosim.cli.sweep import run_and_report
from cosim.engines.native import engine
from cosim.studies.sweep import run as sweep_run
from cosim.studies.sweep import table as sweep_table
from cosim.studies.sweep.spec import parse_spec

DATA = {
    "scenario": "fig14",
    "duration_s": 0.05,
    "axes": {"compensator": ["paper", "smooth"], "plant.mu": [0.07, 0.08]},
}


def _done_sweep(out):
    """A sweep whose points are all computed (no Dask needed to finish it): its spec."""
    engine.load_library()
    spec = parse_spec(DATA)
    spec.build_id = sweep_run.build_id()
    sweep_run.make_out_dir(out)
    sweep_run._write_json(out / sweep_run.RUN_FILE, spec.run_context())
    for point in spec.points():
        row = sweep_run.run_point(DATA, point.values, point.run_key)
        sweep_run.write_point(out, point, row)
    return spec


def test_every_file_in_out_is_replaced_by_a_rename_not_rewritten_in_place(tmp_path, capsys):
    """A second `bowden sweep` over a finished --out writes every file again (summary.json, the
    table, the plots, spec.json, run.json): each must be a new file renamed over the old one (a
    new inode), never the old one truncated and rewritten, which a reader or a crash in the middle
    sees half-written (summary.json and the plots were)."""
    out = tmp_path / "out"
    spec = _done_sweep(out)
    assert run_and_report(spec, DATA, out, None, None, quiet=True) == 0
    files = {p.name: p.stat().st_ino for p in out.iterdir() if p.is_file()}
    assert {"summary.json", sweep_run.TABLE, "spec.json", sweep_run.RUN_FILE} <= set(files)
    assert "error_vs_plant_mu.png" in files, files
    assert run_and_report(spec, DATA, out, None, None, quiet=True) == 0
    again = {p.name: p.stat().st_ino for p in out.iterdir() if p.is_file()}
    assert set(again) == set(files), "temporary files left in --out"
    in_place = sorted(name for name in files if again[name] == files[name])
    assert in_place == [], f"rewritten in place, not renamed: {in_place}"
    assert json.loads((out / "summary.json").read_text())["points"] == 4
    capsys.readouterr()


def test_two_sweeps_writing_the_table_at_once_do_not_share_a_temporary_file(tmp_path, monkeypatch):
    """Another process writes and renames the table between this one's writing its temporary
    file and renaming it: each must have had a temporary file of its own, so this one's rename
    still finds its whole file and wins (with one name for all, the other's rename took this
    one's file away and this one's rename failed: FileNotFoundError)."""
    import pyarrow.parquet as pq  # noqa: PLC0415

    path = tmp_path / sweep_run.TABLE
    mine = [{"point_id": "a", "status": "ok", "rms_error_pct": 1.0}]
    theirs = [{"point_id": "b", "status": "ok", "rms_error_pct": 2.0}]
    other = textwrap.dedent(
        f"""
        from pathlib import Path
        from cosim.studies.sweep.table import write_table
        write_table({theirs!r}, Path({str(path)!r}))
        """
    )
    real = pq.write_table
    temporaries = []

    def then_the_other_process(table, where, *args, **kwargs):
        real(table, where, *args, **kwargs)
        temporaries.append(os.fspath(where))
        subprocess.run([sys.executable, "-c", other], check=True)  # writes and renames

    monkeypatch.setattr(pq, "write_table", then_the_other_process)
    sweep_table.write_table(mine, path)
    assert sweep_table.read_table(path) == mine
    assert sorted(p.name for p in tmp_path.iterdir()) == [sweep_run.TABLE]
    assert temporaries and all(os.path.dirname(t) == str(tmp_path) for t in temporaries)


@pytest.mark.parametrize("name", ["summary.json", "error_vs_plant_mu.png"])
def test_a_write_that_fails_half_way_keeps_the_file_already_there(tmp_path, monkeypatch, name):
    """summary.json or a plot whose writing fails half-way (a full disk) leaves the one of the
    last sweep as it was, and no temporary file (both were rewritten in place: half a file)."""
    out = tmp_path / "out"
    spec = _done_sweep(out)
    assert run_and_report(spec, DATA, out, None, None, quiet=True) == 0
    before = (out / name).read_bytes()
    full = OSError(28, "No space left on device")
    if name.endswith(".json"):
        real = Path.write_text

        def half_then_full(self, text, *args, **kwargs):
            if name not in self.name:
                return real(self, text, *args, **kwargs)
            real(self, text[: len(text) // 2], *args, **kwargs)
            raise full

        monkeypatch.setattr(Path, "write_text", half_then_full)
    else:
        from matplotlib.figure import Figure  # noqa: PLC0415

        def half_then_full(self, fname, *args, **kwargs):
            with open(fname, "wb") as f:
                f.write(b"\x89PNG half")
            raise full

        monkeypatch.setattr(Figure, "savefig", half_then_full)
    with pytest.raises(OSError, match="No space left"):
        run_and_report(spec, DATA, out, None, None, quiet=True)
    assert (out / name).read_bytes() == before
    assert [p.name for p in out.iterdir() if p.name.endswith(".tmp")] == []
