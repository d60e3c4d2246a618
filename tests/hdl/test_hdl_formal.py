"""The formal proofs of hdl/formal/ as part of the suite: every task must pass.

Each task runs SymbiYosys into its own tmp_path, so the tasks run in parallel under xdist; a
task whose inputs (its .sby, the RTL it reads, the tools' versions) are those of an earlier pass
reuses that pass (formal.run_task_cached, tests/conftest.py `test_cache_dir`). A mutant run
checks that the harness itself can fail: with the PWM clamp removed the duty proof must fail.
`make formal-mutants` runs every mutant.
"""

from __future__ import annotations

import shutil

import pytest

from hdl.formal import formal

# `make test-matrix` (after `make test` in CI): the proofs of further configurations whose
# properties `make test` proves at one. The multi-cable assemblies' covers (their properties are
# proven in make test: bowden_core_mc:prove, tension_loop_mc:prove and prove_ram, the lane's
# pair_j0 and live_j0); the cables in two groups (make test proves the groups' separation on the
# sequenced datapath, tension_loop_seq:prove_apart and prove_n3); the second lane (the same
# properties as the first's, mirrored); N = 4; and the SoC configuration's covers (its proofs,
# prove_soc, stay in make test, and the same covers are reached there on the default
# configuration).
MATRIX = {
    "bowden_core:cover_soc",
    "tension_loop:cover_soc",
    "bowden_core_mc:cover",
    "bowden_core_mc:prove_apart",
    "tension_loop_mc:cover",
    "tension_loop_mc:prove_n4",
    "tension_loop_mc_iso:cover",
    "tension_loop_mc_iso:apart_j0",
    "tension_loop_mc_iso:apart_j1",
    "tension_loop_mc_iso:pair_j1",
    "tension_loop_mc_iso:live_j1",
}


@pytest.mark.parametrize(
    "task",
    [pytest.param(t, marks=pytest.mark.matrix) if t in MATRIX else t for t in formal.TASKS],
)
def test_formal_task(task, tmp_path, test_cache_dir):
    """The task proves (k-induction) or reaches every cover."""
    if test_cache_dir is None:
        r = formal.run_task(task, tmp_path)
    else:
        r = formal.run_task_cached(task, tmp_path, test_cache_dir / "formal")
    assert r.status == "PASS", f"{formal._line(r)}\n{formal._failure_detail(r)}"
    if task.endswith("cover") or ":cover" in task:
        assert "reached" in r.method
    else:
        assert r.method.startswith("k-induction"), r.method


def test_the_matrix_names_tasks_of_make_formal():
    """A renamed task leaves no stale name in MATRIX (it would then run in make test unnoticed)."""
    assert set(formal.TASKS) >= MATRIX


def test_formal_mutant_is_killed(tmp_path):
    """A deliberate break (the PWM's clamp removed) makes the duty proof fail."""
    mutant = next(m for m in formal.MUTANTS if m.name == "pwm_clamp_removed")
    killed, r = formal.run_mutant(mutant, tmp_path)
    assert killed, formal._line(r)
    assert r.status == "FAIL"


def test_a_changed_input_is_not_a_reused_pass(tmp_path):
    """The reuse key changes with the RTL a task reads and with the task, so an edit to a proved
    module or its properties is proved again, never answered from the cache."""
    root = tmp_path / "src"
    (root / "hdl").mkdir(parents=True)
    shutil.copytree(formal.ROOT / "hdl" / "formal", root / "hdl" / "formal")
    shutil.copytree(formal.ROOT / "hdl" / "rtl", root / "hdl" / "rtl")
    base = formal.input_hash("pwm_escon:prove_1mhz", root)
    assert formal.input_hash("pwm_escon:prove_1mhz", root) == base
    assert formal.input_hash("pwm_escon:cover", root) != base
    rtl = root / "hdl" / "rtl" / "pwm_escon.v"
    rtl.write_text(rtl.read_text() + "\n// an edit\n")
    assert formal.input_hash("pwm_escon:prove_1mhz", root) != base


def test_a_reused_pass_is_only_a_pass(tmp_path):
    """Only a pass is kept: a task that fails (a mutant's scratch copy) leaves nothing to reuse."""
    cache = tmp_path / "cache"
    r = formal.run_task_cached("pwm_escon:prove_1mhz", tmp_path / "run", cache)
    assert r.status == "PASS"
    kept = list(cache.iterdir())
    assert len(kept) == 1 and formal.input_hash("pwm_escon:prove_1mhz") in kept[0].name
    again = formal.run_task_cached("pwm_escon:prove_1mhz", tmp_path / "run2", cache)
    assert (again.status, again.method) == (r.status, r.method) and "reused" in again.log
    assert not (tmp_path / "run2").exists()  # nothing ran
