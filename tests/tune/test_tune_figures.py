"""The Kp margin is measured once (`bowden tune`, cosim.studies.tune.MEASURED_KP_MARGIN) and
quoted in several documents: each quote must be that value, so a re-tuning that changes it fails
here until every document says the new figure."""

from __future__ import annotations

import re
from pathlib import Path

from cosim.config.run import ControllerParams
from cosim.studies import tune as tn

ROOT = Path(__file__).resolve().parents[2]
# Where the figure is quoted (the wording "Kp margin x<N>" or "margin x<N>").
QUOTED_IN = ("README.md", "hdl/README.md", "cosim/README.md", "cosim/config/run.py")
QUOTE = re.compile(r"margin\W{0,4}x(\d+\.\d+)")


def quotes() -> list[tuple[str, float]]:
    found = []
    for name in QUOTED_IN:
        path = ROOT / name
        if path.is_file():
            found += [(name, float(v)) for v in QUOTE.findall(path.read_text())]
    return found


def test_every_quote_of_the_kp_margin_is_the_measured_one():
    found = quotes()
    assert len(found) >= 3, found  # the check sees the documents it is meant to hold
    assert [q for q in found if q[1] != tn.MEASURED_KP_MARGIN] == []


def test_the_measured_margin_passes_the_rule_and_matches_the_stable_kp():
    assert tn.MEASURED_KP_MARGIN >= tn.MIN_KP_MARGIN
    readme = (ROOT / "cosim" / "README.md").read_text()
    stable = float(re.search(r"stable to (\d+\.\d+)", readme).group(1))
    kp = ControllerParams().kp_a_per_n
    assert round(stable / kp, 2) == tn.MEASURED_KP_MARGIN
