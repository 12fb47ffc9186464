"""``listing.first_few``: the one wording for "the first few and N more" in messages."""

from __future__ import annotations

from aion_cli.listing import first_few


def test_all_items_shown_when_within_the_limit() -> None:
    assert first_few(["a", "b"], 3) == "a, b"
    assert first_few([], 3) == ""


def test_the_rest_is_counted_with_thousands_separators() -> None:
    items = [f"log{i}" for i in range(1_006)]
    assert first_few(items, 5) == "log0, log1, log2, log3, log4 and 1,001 more"
    assert first_few(["x; 1", "y", "z"], 1, "; ") == "x; 1 and 2 more"
