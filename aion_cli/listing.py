"""Lists in messages: the first few items and how many more (one wording everywhere).

A warning, note or error that names what it found (other logs in a folder, agents taken for
people, a map's problems, rooms) shows at most a few of them and counts the rest, so a line
stays readable when there are thousands.
"""

from __future__ import annotations

from collections.abc import Sequence


def first_few(items: Sequence[str], limit: int, sep: str = ", ") -> str:
    """The first ``limit`` of ``items`` joined by ``sep``, then `` and N more`` when there
    are more (N with thousands separators)."""
    rest = len(items) - limit
    return sep.join(items[:limit]) + (f" and {rest:,} more" if rest > 0 else "")
