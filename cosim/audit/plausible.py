"""Plausibility of the data and of the fit: data that cannot be a Bowden cable's input and output
tensions are refused in one line (AuditError) before any fit; a fit that says the data do not
look like friction through a sheath is reported with one warning line per reason.

Refused (nothing to audit, or every figure would be meaningless):
- a tension that does not move: its range over the record is within MIN_MOVE_SIGMAS of its own
  white noise (and at most MIN_MOVE_N): constant, all zero, a disconnected sensor;
Warned (the audit runs; the warning is printed with the result and kept in audit.json):
- the output above the input while the input rises: friction through a sheath can only take
  tension away while the cable is pulled (T_out = T_in exp(-mu phi) <= T_in, paper Eq. 1), so
  a median ratio T_out / T_in above MAX_LOADING_RATIO there means swapped columns or an output
  sensor's gain far off;
- a fitted mu or a finding's parameter at the bound of its range: the fit ran out of room, so
  the value is not an estimate.
"""

from __future__ import annotations

import numpy as np

# A tension moves when its range exceeds this many noise sigmas and this many newtons.
MIN_MOVE_SIGMAS = 10.0
MIN_MOVE_N = 0.05
# While the input rises, friction makes T_out <= T_in; up to 5 % above allows an output sensor's
# gain error of the vocabulary's typical size with a straight sheath (phi near 0).
MAX_LOADING_RATIO = 1.05
# Input tensions below this are left out of the ratio (slack cable, noise around 0).
RATIO_MIN_N = 0.5
# A fitted value within this share of its range from a bound is "at the bound".
AT_BOUND_SHARE = 1e-3


def refusal(
    source: str, t_in_n: np.ndarray, t_out_n: np.ndarray, noise_in_n: float, noise_out_n: float
) -> str | None:
    """One line when the data cannot be audited, else None."""
    for name, x, noise in (("T_in_N", t_in_n, noise_in_n), ("T_out_N", t_out_n, noise_out_n)):
        span = float(np.ptp(x)) if len(x) else 0.0
        if span <= max(MIN_MOVE_N, MIN_MOVE_SIGMAS * noise):
            level = float(np.median(x)) if len(x) else 0.0
            return (
                f"{source}: column {name} does not move (it stays within {span:.3g} N of "
                f"{level:.4g} N over the record): a sensor that is constant, zero or not "
                "connected cannot be audited"
            )
    return None


def data_warnings(t_in_n: np.ndarray, t_out_n: np.ndarray, rate_n_s: np.ndarray) -> list[str]:
    """Warnings about the data themselves (see the module docstring)."""
    out = []
    loading = (rate_n_s > 0) & (t_in_n > RATIO_MIN_N)
    if np.count_nonzero(loading) > 10:
        ratio = float(np.median(t_out_n[loading] / t_in_n[loading]))
        if ratio > MAX_LOADING_RATIO:
            out.append(
                f"T_out_N is above T_in_N while T_in_N rises (median ratio {ratio:.3g}); friction "
                "through a sheath can only take tension away there: are the columns swapped, or "
                "is the output sensor's gain far off?"
            )
    return out


def at_bound(name: str, value: float, lo: float, hi: float) -> str | None:
    """A warning when a fitted value sits at the bound of its range."""
    margin = AT_BOUND_SHARE * (hi - lo)
    if value <= lo + margin or value >= hi - margin:
        side = "lower" if value <= lo + margin else "upper"
        return (
            f"{name} = {value:.4g} is at the {side} bound of its fitted range [{lo:g}, {hi:g}]: "
            "not an estimate; the data may not be a cable's input and output tensions"
        )
    return None
