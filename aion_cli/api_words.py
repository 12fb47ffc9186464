"""Errors raised through the Python API in its own words: the library's messages and hints
are shared with the command line and name its options (``--detections-topic /people``); a
script gives keywords (``detection_topics="/people"``). :func:`in_api_words` rewrites the
option names an error mentions, once, as the error leaves the API (:mod:`aion_cli.api_checks`
wraps every public function and method)."""

from __future__ import annotations

import re

from aion_cli.errors import AionError

OPTION_KEYWORDS = {
    "detections-topic": "detection_topics",
    "graph-topic": "graph_topic",
    "map-frame": "map_frame",
    "base-frame": "base_frame",
    "nav-layer": "nav_layer",
    "log-format": "log_format",
    "detections-mapping": "detections_mapping",
    "graph": "graph",
    "tz": "tz",
    "observed": "observed",
}
"""Command-line options and the API keywords that take the same value."""

_OPTION = re.compile(
    r"--(" + "|".join(sorted(map(re.escape, OPTION_KEYWORDS), key=len, reverse=True)) + r")"
    r"(?![\w-])(?:[ =](?!--)([^\s,;()`'\"]+))?"
)
_NOT_VALUES = frozenset({
    "and", "are", "beside", "below", "could", "given", "giving", "ignored", "in", "is", "names",
    "needs", "of", "or", "reads", "replaced", "said", "spans", "that", "to", "was", "were",
    "which", "with", "writes",
})  # fmt: skip
"""Words that follow an option in the library's sentences (``--nav-layer ignored: ...``,
``as --map-frame said``): the sentence going on, not the option's value."""
_PLACEHOLDERS = frozenset({"FILE", "GRAPH_FILE", "LOG", "MAP", "ZONE", "FRAME", "TOPIC", "LAYER"})
"""Names a hint asks the user to fill in (``--graph FILE``), not values (``--nav-layer PLACES``)."""


def api_text(text: str) -> str:
    """``text`` with each option of :data:`OPTION_KEYWORDS` (and its value) as the keyword:
    ``--detections-topic /people`` -> ``detection_topics="/people"``, ``--graph FILE`` ->
    ``graph=FILE``, ``with --nav-layer;`` -> ``with nav_layer=;``."""

    def keyword(match: re.Match[str]) -> str:
        name, value = OPTION_KEYWORDS[match.group(1)], match.group(2)
        if value is None or value.rstrip(":") in _NOT_VALUES:
            return f"{name}=" + match.group(0)[len(match.group(1)) + 2 :]
        return f"{name}={value}" if value in _PLACEHOLDERS else f'{name}="{value}"'

    return _OPTION.sub(keyword, text)


def in_api_words(error: AionError) -> None:
    """Rewrite ``error``'s message and hint with :func:`api_text`, in place (the traceback
    stays the one raised); a second call changes nothing."""
    message = api_text(error.message)
    if message != error.message:
        error.message = message
        error.args = (message, *error.args[1:])
    if error.hint is not None:
        error.hint = api_text(error.hint)
