"""Errors raised through the Python API in its own words: the library's messages and hints
are shared with the command line and name its options (``--detections-topic /people``); a
script gives keywords (``detection_topics="/people"``) and calls (``aion.build(LOG,
part=True)``, not ``aion build LOG --part``). :func:`in_api_words` rewrites the option names
and command lines an error mentions, once, as the error leaves the API (:mod:`aion_cli.api_checks`
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
    "map": "continue_from",
    "config": "config",
    "workers": "workers",
    "scheduler": "scheduler",
    "derive-graph": "derive_graph",
    "part": "part",
    "graph-period": "graph_period",
    "dsg-version": "dsg_version",
    "batch-size": "batch_size",
    "radius": "radius",
    "layer": "layer",
    "node": "nodes",
    "at": "at",
    "top": "top",
    "historical": "historical",
    "lineage": "lineage",
    "force": "force",
    "time": "time",
}
"""Command-line options and the API keywords that take the same value."""

_FLAGS = frozenset({"derive-graph", "part", "historical", "force"})
"""Options that take no value: their keyword is ``=True`` (``--part cannot ...`` is
``part=True cannot ...``, the word after it the sentence going on)."""
_BARE = frozenset({"config"})
"""Options whose keyword takes no text from the sentence: ``--config`` names a TOML file, the
API's ``config`` a ``ModelConfig`` or a dict (``with a --config file`` is ``with a config=
file``)."""
_NUMBERS = frozenset({"workers", "batch-size", "top"})
"""Options whose value is a number: unquoted (``--workers 1`` is ``workers=1``)."""

_OPTION = re.compile(
    r"--(" + "|".join(sorted(map(re.escape, OPTION_KEYWORDS), key=len, reverse=True)) + r")"
    r"(?![\w-])(?:[ =](?!--)([^\s,;()`'\"]+(?:,(?=[\w.-])[^\s,;()`'\"]+)*))?"
)
_COMMAND = re.compile(
    r"\baion (?:build|merge|compact|predict|plan|export|info|simulate|evaluate|convert|report)"
    r"\b(?:(?!: |\. )[^`();,])*"
)
"""A command line quoted in a sentence (``aion build LOG --part -o PART.aion``,
``aion build --observed``): a command to run in a shell, whose options stay options (a
keyword in the middle of it would make it neither a command nor Python)."""
_NOT_VALUES = frozenset({
    "and", "are", "beside", "below", "could", "for", "given", "giving", "if", "ignored", "in",
    "is",
    "names", "naming", "needs", "of", "or", "read", "reads", "replaced", "said", "spans", "that",
    "takes", "to", "was", "were", "which", "with", "writes", "/",
})  # fmt: skip
"""Words that follow an option in the library's sentences (``--nav-layer ignored: ...``,
``as --map-frame said``): the sentence going on, not the option's value."""
_PLACEHOLDERS = frozenset({
    "FILE", "GRAPH_FILE", "LOG", "MAP", "ZONE", "FRAME", "TOPIC", "LAYER", "N", "ADDRESS",
    "X,Y",
})  # fmt: skip
"""Names a hint asks the user to fill in (``--graph FILE``), not values (``--nav-layer PLACES``)."""


CALLS = {"build": "aion.build", "merge": "aion.merge", "predict": "Map.predict"}
"""Commands the API has a function for: a command line of them quoted in a message is said
as the call (``aion build LOG --part -o PART.aion`` -> ``aion.build(LOG, "PART.aion",
part=True)``, ``aion predict MAP --node p4`` -> ``aion.Map.load(MAP).predict(nodes="p4")``);
any other command (``aion info MAP``) is one to run in a shell, and stays."""
_PATH_WORD = re.compile(r"[A-Z][A-Z0-9_]*|\S*[./]\S*")
"""A command line's log or map argument: a placeholder (``LOG``, ``LOG1``) or a file name
(``PART.aion``, ``run.mcap``, ``...``); a plain word after the command (``aion merge fills
them``) is the sentence going on."""
_UNSAID = {"map": "MAP", "observed": "[...]"}
"""What a call says for an option's value its command line leaves out (``aion build --map``
-> ``continue_from=MAP``; else the keyword's name in capitals, ``config=CONFIG``)."""


def api_text(text: str) -> str:
    """``text`` with each option of :data:`OPTION_KEYWORDS` (and its value) as the keyword:
    ``--detections-topic /people`` -> ``detection_topics="/people"``, ``--graph FILE`` ->
    ``graph=FILE``, ``with --nav-layer;`` -> ``with nav_layer=;``, ``--workers 1`` ->
    ``workers=1``, ``--part`` -> ``part=True``; a command line quoted in it as the API call
    that does the same (:func:`api_call`: ``aion build --map`` -> ``aion.build(...,
    continue_from=MAP)``), or whole when the API has none (``aion info MAP``)."""
    out, done = [], 0
    for command in _COMMAND.finditer(text):
        out += [_OPTION.sub(_keyword, text[done : command.start()]), api_call(command.group(0))]
        done = command.end()
    return "".join([*out, _OPTION.sub(_keyword, text[done:])])


def api_call(command: str) -> str:
    """The command line ``command`` (``aion build LOG1 LOG2 --part -o PART.aion``, and what
    follows it up to the clause's end) with the command said as its call in :data:`CALLS`
    (``aion.build([LOG1, LOG2], "PART.aion", part=True)``; ``aion merge`` alone, going on
    with the sentence, ``aion.merge``); unchanged when the API has no such call or keyword
    for one of its options (``aion build --print-config``)."""
    words = command.split(" ")
    call = CALLS.get(words[1]) if len(words) > 1 else None
    if call is None:
        return command
    words = _optional_paths(words)
    paths: list[str] = []
    output: str | None = None
    keywords: list[str] = []
    i = 2
    while i < len(words):
        word, value = words[i], words[i + 1] if i + 1 < len(words) else None
        taken = 1  # words the value spans: a quoted one (--time "2026-01-05 08:00") more
        while value is not None and value.startswith('"') and not _closed(value):
            if i + 1 + taken >= len(words):
                return command  # a quote the clause does not close
            value, taken = f"{value} {words[i + 1 + taken]}", taken + 1
        if word == "-o" and value is not None and _PATH_WORD.fullmatch(value):
            output, i = value, i + 2
        elif word.startswith("--"):
            option = word[2:]
            if option not in OPTION_KEYWORDS:
                return command  # an option the API has no keyword for
            name = OPTION_KEYWORDS[option]
            takes = option not in _FLAGS and value is not None and not value.startswith("-")
            if option in _FLAGS:
                keywords.append(f"{name}=True")
            elif not takes or value == "..." or option in _BARE:
                keywords.append(f"{name}={_UNSAID.get(option, name.upper())}")
            elif value is not None and value.startswith('"'):
                keywords.append(f"{name}={value}")
            else:
                keywords.append(_OPTION.sub(_keyword, f"{word} {value}"))
            i += 1 + taken if takes else 1
        elif word.startswith("-"):
            return command  # an option the API has no keyword for (-o without a file)
        elif _PATH_WORD.fullmatch(word) and word not in _NOT_VALUES:
            paths.append(word)
            i += 1
        else:
            break
    rest = " ".join(words[i:])
    if not paths and output is None and not keywords:
        return call + (" " + rest if rest else "")
    said = [_argument(p) for p in paths]
    if words[1] == "predict":  # the map, then the query: aion.Map.load(MAP).predict(...)
        if len(said) != 1 or output is not None:
            return command
        called = f"aion.Map.load({said[0]}).predict({', '.join(keywords)})"
        return called + (" " + rest if rest else "")
    first = said[0] if len(said) == 1 and words[1] == "build" else f"[{', '.join(said)}]"
    args = [first if said else "...", *([] if output is None else [_argument(output)])]
    return f"{call}({', '.join([*args, *keywords])})" + (" " + rest if rest else "")


def _optional_paths(words: list[str]) -> list[str]:
    """``words`` with a usage line's optional paths (``PART.aion [PART2.aion ...] -o
    MAP.aion``) as more paths (``PART.aion PART2.aion ...``): the call's list takes one or
    more, and ``"[PART2.aion"``, ``"...]"`` quoted as files were neither Python nor a name.
    A bracketed group holding anything but paths is left as it is (then not said as a call)."""
    out: list[str] = []
    group: list[str] | None = None
    for word in words:
        if group is None and word.startswith("["):
            group = []
        if group is None:
            out.append(word)
            continue
        group.append(word)
        if word.endswith("]"):
            inside = " ".join(group)[1:-1].split(" ")
            paths = all(_PATH_WORD.fullmatch(w) and w not in _NOT_VALUES for w in inside)
            out += inside if paths else group
            group = None
    return out + (group or [])


def _closed(value: str) -> bool:
    """Whether the quoted value ``value`` (``"2026-01-05``, ``"2026-01-05 08:00"``) ends."""
    return len(value) > 1 and value.endswith('"')


def _argument(word: str) -> str:
    """A command line's path argument as Python: a placeholder bare (``LOG``), a file name
    quoted (``"PART.aion"``), ``...`` as itself."""
    return word if word == "..." or re.fullmatch(r"[A-Z][A-Z0-9_]*", word) else f'"{word}"'


def _keyword(match: re.Match[str]) -> str:
    """One option of :data:`_OPTION` (and its value, if it is one) as its keyword."""
    option, value = match.group(1), match.group(2)
    name = OPTION_KEYWORDS[option]
    after = match.group(0)[len(option) + 2 :]  # what the match took after the option
    if option in _FLAGS:
        return f"{name}=True{after}"
    colon = ""
    if value is not None and value.endswith(":"):  # "--scheduler ADDR: not contacted"
        value, colon = value[:-1], ":"
    if (
        value is None
        or value in _NOT_VALUES
        or option in _BARE
        or (option in _NUMBERS and not value.isdigit() and value not in _PLACEHOLDERS)
    ):
        return f"{name}={after}"
    if value in _PLACEHOLDERS or option in _NUMBERS:
        return f"{name}={value}{colon}"
    return f'{name}="{value}"{colon}'


def in_api_words(error: AionError) -> None:
    """Rewrite ``error``'s message and hint with :func:`api_text`, in place (the traceback
    stays the one raised); a second call changes nothing."""
    message = api_text(error.message)
    if message != error.message:
        error.message = message
        error.args = (message, *error.args[1:])
    if error.hint is not None:
        error.hint = api_text(error.hint)
