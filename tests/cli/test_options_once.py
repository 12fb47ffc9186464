"""An option that takes one time, given twice: click keeps the last value, so
``aion predict MAP --time 08:30 --time 03:00`` answered for 03:00 alone, exit 0, as if the
08:30 had not been asked. ``predict``, ``plan`` and ``export`` now refuse it (exit 2, one line
saying which option and what gives several)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import Office, run


@pytest.mark.parametrize(
    ("args", "option", "advice"),
    [
        (("--time", "2026-01-06 08:30", "-t", "2026-01-06 03:00"), "--time", "--from T0 --to T1"),
        (("--from", "08:00", "--from", "09:00", "--to", "10:00"), "--from", "one start"),
        (("--at", "1,1", "--at", "2,2"), "--at", "--node ID"),
    ],
)
def test_predict_refuses_an_option_of_one_value_given_twice(
    office: Office, args: tuple[str, ...], option: str, advice: str
) -> None:
    result = run("predict", office.map, *args, "--format", "json")
    assert result.exit_code == 2, result.stderr
    assert result.stdout == ""  # no answer for one of the two
    first = result.stderr.splitlines()[0]
    assert first.startswith(f"error: {option} was given 2 times, but it takes one value")
    assert advice in first


def test_plan_and_export_refuse_two_times(office: Office, tmp_path: Path) -> None:
    plan = run("plan", office.map, "--from", "p0", "--to", "p4", "--time", "08:00",
               "--time=09:00", "--format", "json")
    assert plan.exit_code == 2, plan.stderr
    assert plan.stderr.startswith("error: --time was given 2 times")
    out = tmp_path / "scene"
    export = run("export", office.map, "-o", out, "--time", "08:00", "--time", "09:00")
    assert export.exit_code == 2, export.stderr
    assert not out.exists()  # nothing written for either time


def test_one_time_each_is_read_as_before(office: Office) -> None:
    one = run("predict", office.map, "--time", "2026-01-06 08:30", "--top", "1", "--format",
              "json")
    assert one.exit_code == 0, one.stderr


@pytest.mark.parametrize("option", ["--from", "--to"])
def test_plan_refuses_two_starts_or_two_goals(office: Office, option: str) -> None:
    ends = {"--from": ["p0"], "--to": ["p4"]}
    ends[option].append("p2")
    args = [arg for name, values in ends.items() for value in values for arg in (name, value)]
    result = run("plan", office.map, *args, "--time", "08:00", "--format", "json")
    assert result.exit_code == 2, result.stderr
    assert result.stdout == ""
    assert result.stderr.startswith(f"error: {option} was given 2 times")
