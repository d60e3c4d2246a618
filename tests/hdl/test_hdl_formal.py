"""The formal proofs of hdl/formal/ as part of the suite: every task must pass.

Each task runs SymbiYosys into its own tmp_path, so the tasks run in parallel under xdist. A
mutant run checks that the harness itself can fail: with the PWM clamp removed the duty proof
must fail. `make formal-mutants` runs every mutant.
"""

from __future__ import annotations

import pytest

from hdl.formal import formal


@pytest.mark.parametrize("task", formal.TASKS)
def test_formal_task(task, tmp_path):
    """The task proves (k-induction) or reaches every cover."""
    r = formal.run_task(task, tmp_path)
    assert r.status == "PASS", f"{formal._line(r)}\n{formal._failure_detail(r)}"
    if task.endswith("cover") or ":cover" in task:
        assert "reached" in r.method
    else:
        assert r.method.startswith("k-induction"), r.method


def test_formal_mutant_is_killed(tmp_path):
    """A deliberate break (the PWM's clamp removed) makes the duty proof fail."""
    mutant = next(m for m in formal.MUTANTS if m.name == "pwm_clamp_removed")
    killed, r = formal.run_mutant(mutant, tmp_path)
    assert killed, formal._line(r)
    assert r.status == "FAIL"
