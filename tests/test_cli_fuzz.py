"""Property-based tests of the `bowden` command line (Hypothesis; profiles in tests/conftest.py).

The argument suite is derived from the argparse parser itself: every subcommand, every option
and positional, with the kind of bad value its declaration admits (a number that is not one or
not finite for `type=float`, a fraction for `type=int`, a word outside `choices`, a value given
to a flag, an empty folder name, an option that does not exist). A subcommand or option added
later is covered without an edit here. Each example has exactly one bad argument, so the
outcome is fixed: exit status 2, one line on stderr that names that argument, no traceback, and
nothing run or written.

The run suite starts real co-simulations with valid arguments drawn at random (a thirtieth of
the profile's examples: each costs a simulator start) and requires a result: status 0, strict
JSON, no NaN in the trace, no process left behind.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import psutil
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from cosim import cli
from cosim.config.run import COMPENSATORS, SimConfig
from cosim.config.scenarios import SCENARIO_NAMES
from cosim.engines import experiment as sim
from cosim.project import cliargs

PARSER = cli.build_parser()
SUBCOMMANDS = cliargs.subparsers(PARSER)
# Hypothesis reuses the function-scoped tmp_path across examples: each example writes below a
# fresh name in it.
FIXTURE_OK = [HealthCheck.function_scoped_fixture]


def _actions(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    skip = (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)
    return [a for a in parser._actions if not isinstance(a, skip)]


def _flag(action: argparse.Action) -> str | None:
    """The option string used for `action` (the long one), None for a positional."""
    if not action.option_strings:
        return None
    return max(action.option_strings, key=len)


def _named(action: argparse.Action) -> list[str]:
    """How argparse may name `action` in a message."""
    names = list(action.option_strings)
    if action.metavar:
        names.append(str(action.metavar))
    names.append(action.dest)
    return names


def _not_a_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return True
    return False


def _not_an_int(text: str) -> bool:
    try:
        int(text)
    except ValueError:
        return True
    return False


# Printable text without NUL (argv cannot hold it) and not starting with "-" (an option).
WORDS = st.text(
    st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=12
).filter(lambda t: not t.startswith("-"))


def bad_values(action: argparse.Action) -> st.SearchStrategy[list[str]] | None:
    """argv fragments that give `action` a value its declaration refuses (None: no such value
    can be told from the declaration, e.g. free text)."""
    flag = _flag(action)
    if action.nargs == 0:  # store_true / store_false / store_const: takes no value
        return st.just([f"{flag}=yes"]) if flag else None
    if action.choices is not None:
        values = WORDS.filter(lambda t: t not in action.choices)
    elif action.type is cliargs.finite_float:
        values = st.sampled_from(["nan", "NaN", "inf", "-inf", "1e400", "-1e999"]) | WORDS.filter(
            _not_a_number
        )
    elif action.type is int:
        values = st.sampled_from(["1.5", "1e3", "nan", ""]) | WORDS.filter(_not_an_int)
    elif action.type is cliargs.output_dir:
        values = st.sampled_from(["", " ", "\t"])
    else:
        return None
    return values.map(lambda v: [flag, v] if flag else [v])


def valid_values(action: argparse.Action, out_dir: str) -> st.SearchStrategy[list[str]] | None:
    """argv fragments with a valid value for `action`, or None to leave it out."""
    flag = _flag(action)
    if action.nargs == 0:
        return st.just([flag])
    if action.choices is not None:
        values = st.sampled_from(sorted(action.choices))
    elif action.type is cliargs.output_dir:
        values = st.just(out_dir)
    elif action.required or not flag:
        values = st.just(out_dir)  # a required free-text argument: a path that does not exist
    else:
        return None
    return values.map(lambda v: [flag, v] if flag else [v])


@st.composite
def one_bad_argument(draw, out_dir: str):
    """(subcommand, argv, the action given the bad value or None for an unknown option)."""
    name = draw(st.sampled_from(sorted(SUBCOMMANDS)))
    actions = _actions(SUBCOMMANDS[name])
    badable = [a for a in actions if bad_values(a) is not None]
    bad = draw(st.sampled_from([*badable, None]))
    positional: list[str] = []
    options: list[list[str]] = []
    for action in actions:
        if action is bad:
            fragment = draw(bad_values(action))
        else:
            strategy = valid_values(action, out_dir)
            if strategy is None or (not action.required and _flag(action) and draw(st.booleans())):
                continue
            fragment = draw(strategy)
        if _flag(action):
            options.append(fragment)
        else:
            positional.extend(fragment)
    if bad is None:
        options.append(["--no-such-option"])
    options = draw(st.permutations(options))
    argv = [name, *positional, *[part for frag in options for part in frag]]
    return name, argv, bad


@settings(suppress_health_check=FIXTURE_OK)
@given(data=st.data())
def test_cli_one_bad_argument_is_one_line_naming_it_and_nothing_runs(tmp_path, capsys, data):
    out = tmp_path / f"out{data.draw(st.integers(0, 10**9))}"
    name, argv, bad = data.draw(one_bad_argument(str(out)))
    status = cli.main(argv)
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert status == 2, (argv, captured.err)
    assert len(lines) == 1 and lines[0].startswith(f"bowden {name}: "), (argv, captured.err)
    assert "Traceback" not in captured.err and captured.out == ""
    if bad is None:
        assert "--no-such-option" in lines[0]
    else:
        assert any(n in lines[0] for n in _named(bad)), (argv, lines[0])
    assert not out.exists()
    event(f"refused: {name} {'unknown option' if bad is None else _flag(bad) or bad.dest}")


@given(words=st.lists(WORDS | st.sampled_from(["-x", "--out", "--help"]), max_size=6))
def test_cli_any_words_end_in_a_status_never_a_traceback(words):
    """Arbitrary words after `bowden`: a parse error (2) or help, never an exception (the
    first word is never a subcommand name that would start real work)."""
    if words and words[0] in SUBCOMMANDS or "doctor" in words[:1]:
        words = ["x", *words]
    assert cli.main(words) in (0, 2)


@given(duration=st.floats(allow_nan=True, allow_infinity=True))
def test_cli_duration_is_in_range_or_refused_with_the_range(duration):
    cfg = SimConfig()
    try:
        sim.check_duration(duration, cfg)
    except ValueError as exc:
        assert str(exc).startswith("--duration must be in [0.01, 3600] s"), exc
        assert not 0.01 <= duration <= 3600
    else:
        assert 0.01 <= duration <= 3600


# --- real runs ----------------------------------------------------------------------------


def _real_run_examples() -> int:
    """A thirtieth of the profile's examples (2 in `ci`, 100 in `fuzz`): each is a simulator
    start and a float reference, several seconds."""
    return max(2, settings.default.max_examples // 30)


VALID_PARAMS = st.fixed_dictionaries(
    {},
    optional={
        "plant": st.fixed_dictionaries(
            {},
            optional={
                "mu": st.floats(0.0, 0.2),
                "noise_std": st.floats(0.0, 0.2),
                "sensor_offset": st.floats(-1.0, 1.0),
            },
        ),
        "controller": st.fixed_dictionaries({}, optional={"kp_a_per_n": st.floats(0.0, 0.2)}),
        "compensator": st.fixed_dictionaries(
            {}, optional={"mu": st.floats(0.0, 0.2), "band_n": st.floats(0.5, 4.0)}
        ),
    },
)


@pytest.mark.slow
@settings(max_examples=_real_run_examples(), suppress_health_check=FIXTURE_OK)
@given(
    scenario=st.sampled_from(SCENARIO_NAMES),
    compensator=st.sampled_from(COMPENSATORS),
    loop=st.booleans(),
    bus=st.sampled_from(sim.BUSES),
    duration=st.floats(0.01, 0.05),
    params=VALID_PARAMS,
)
def test_cli_valid_runs_end_in_a_result_without_nan_or_leftovers(
    tmp_path, scenario, compensator, loop, bus, duration, params
):
    work = Path(tempfile.mkdtemp(dir=tmp_path))
    (work / "p.json").write_text(json.dumps(params))
    argv = ["sim", scenario, "--compensator", compensator, "--bus", bus, "--quiet"]
    argv += ["--duration", repr(duration), "--params", "p.json", "--out", "out"]
    argv += [] if loop else ["--no-loop-routing"]
    proc = psutil.Popen(
        [sys.executable, "-m", "cosim", *argv], cwd=work, stdout=subprocess.PIPE, text=True
    )
    seen: set[psutil.Process] = set()
    while proc.poll() is None:
        try:
            seen.update(proc.children(recursive=True))
        except psutil.NoSuchProcess:
            pass
        try:
            proc.wait(0.2)
        except psutil.TimeoutExpired:
            pass
    assert proc.returncode == 0, argv
    out = work / "out"

    def refuse(token):
        raise AssertionError(f"{token} in result.json")

    result = json.loads((out / "result.json").read_text(), parse_constant=refuse)
    assert result["samples"] == int(round(duration * 10_000))
    for name in ("trace.csv", "reference.csv"):
        data = np.loadtxt(out / name, delimiter=",", skiprows=1, ndmin=2)
        assert np.all(np.isfinite(data)), name
    left = [p for p in seen if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
    assert not left, [(p.pid, p.name()) for p in left]
    assert math.isfinite(result["rms_error_n"])


def test_cli_fuzz_covers_every_subcommand_and_typed_option():
    """The suite reaches what the parser declares: every subcommand, and a bad value for every
    option with a type, choices or no value (so a new one is fuzzed without an edit)."""
    assert {"sim", "demo", "workspace", "doctor"} <= set(SUBCOMMANDS)
    typed = {
        (name, _flag(a) or a.dest): bad_values(a) is not None
        for name, sub in SUBCOMMANDS.items()
        for a in _actions(sub)
        if a.type in (float, cliargs.finite_float, int) or a.choices or a.nargs == 0
    }
    assert all(typed.values()), typed
    assert typed[("sim", "--duration")] and typed[("workspace", "--grid")]
    assert typed[("sim", "scenario")] and typed[("sim", "--no-loop-routing")]
    # No option of any subcommand keeps argparse's float, which accepts NaN.
    assert not [a for sub in SUBCOMMANDS.values() for a in _actions(sub) if a.type is float]
