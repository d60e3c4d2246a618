"""The model audit (`bowden audit DATA.csv`): measured data is the judge of the simulation.

Given a measured trace (a bench recording, a user's CSV with t_s, T_in_N, T_out_N and optionally
the end-effector position, or a `bowden sim` trace), the audit fits the plant model, shows what it
gets wrong, names the cause from the vocabulary of the FMU's effects by its share of held-out
residual, extends the model, re-simulates it through the FMU and measures the gain on data no fit
saw. See cosim/audit/core.py for the method and docs/design.md ("Model audit") for worked examples.

    from cosim.audit import audit_file
    result = audit_file("rig.csv")          # cosim.audit.core.AuditResult
    print(result_summary(result))

Modules: `effects` (the vocabulary), `twin` (the FMU's physics for fitting, and the FMU run),
`data` (the record made ready, its blocks), `fit` (the models), `decision` (the rule over the
selection blocks as folds), `lines` (narrow lines the input does not explain, such as mains
pickup: taken out before the fits, described with what is left), `residual` (what is left),
`plausible` (refusals and warnings),
`core` (the steps in order, the result), `report` (audit.json, report.md, plots), `params`
(`--emit-params` and the fig14 comparison); the command line is cosim/cli/audit.py.
"""

from __future__ import annotations


def audit_file(path, progress=None):
    """Read a measured trace and audit it; return cosim.audit.core.AuditResult."""
    from cosim.results import trace  # noqa: PLC0415

    from . import core  # noqa: PLC0415

    tr = trace.read_trace(path, mode="measured")
    return core.run(core.prepare(tr, str(path)), progress=progress)


def result_summary(result) -> str:
    """The short readable summary of an AuditResult."""
    from .report import summary  # noqa: PLC0415

    return summary(result)
