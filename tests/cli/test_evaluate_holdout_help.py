"""``aion evaluate holdout --help`` documents its JSON: every key the command writes on the
corridor of :mod:`tests.cli.test_evaluate_holdout` is named there (it named none: a script had
to guess what ``nll_all`` or ``hourly_series`` held)."""

from __future__ import annotations

import re

from tests.cli.conftest import run, run_json
from tests.cli.test_evaluate_holdout import corridor

__all__ = ["corridor"]  # the fixture, built once for this module


def test_every_json_key_is_in_the_help(corridor: tuple) -> None:
    site, _train, test, _truth = corridor
    doc = run_json("evaluate", "holdout", site, test, "--format", "json")
    keys = set(doc)
    for value in doc.values():
        if isinstance(value, dict):
            keys |= set(value)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            keys |= set(value[0])
    helped = run("evaluate", "holdout", "--help")
    assert helped.exit_code == 0
    text = " ".join(helped.stdout.split())  # the help's line breaks are not part of a key
    missing = sorted(k for k in keys if not re.search(rf"(?<![\w-]){re.escape(k)}(?![\w-])", text))
    assert missing == []
    assert {"headings", "activity", "hourly_series", "nll_all", "chi_square"} <= keys
