"""``predict`` options that did nothing or did not say which option was wrong:
``--historical --tz X`` was taken and changed nothing (the historical flows have no time);
``--from bad`` said "cannot read the time 'bad'" without naming ``--from``."""

from __future__ import annotations

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run


def test_historical_refuses_a_zone(office: Office) -> None:
    out = run("predict", office.map, "--historical", "--tz", "Asia/Tokyo")
    assert out.exit_code == 2
    assert_one_line_error(out.stderr, "--historical", "takes no --tz")
    assert run("predict", office.map, "--historical").exit_code == 0


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--from", "bad", "--to", "12:00"], "--from 'bad': cannot read the time"),
        (["--from", "10:00", "--to", "worse"], "--to 'worse': cannot read the time"),
        (["--time", "bad"], "--time 'bad': cannot read the time"),
    ],
)
def test_an_unreadable_time_names_its_option(
    office: Office, args: list[str], named: str
) -> None:
    out = run("predict", office.map, *args)
    assert out.exit_code == 2
    assert_one_line_error(out.stderr, named)
