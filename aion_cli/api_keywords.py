"""The Python API's keyword and positional arguments checked at the call: one it does not take
is an :class:`~aion_cli.errors.UnknownArgumentError` naming it, with a close spelling (or the
zone argument's other name) and every keyword there is, where Python's ``TypeError`` named none;
the errors of a checked function are in the API's words (:mod:`aion_cli.api_words`).

Why apart from :mod:`aion_cli.api_checks`, which checks the arguments' values: this checks
which arguments were given, around whole functions and classes (:func:`keywords_checked`,
:func:`methods_checked`).
"""

from __future__ import annotations

import difflib
import functools
import inspect
from collections.abc import Callable, Iterable, Sequence
from typing import ParamSpec, TypeVar

from aion_cli.errors import UnknownArgumentError

_P = ParamSpec("_P")
_R = TypeVar("_R")
_C = TypeVar("_C", bound=type)


_ZONE_WORDS = ("tz", "zone", "timezone")
"""The API's names of a zone argument: ``tz`` (queries, ``build``), ``zone`` (``to_ns``),
``timezone`` (``Map.from_state``). One given where another is meant (``aion.to_ns(t,
tz="UTC")``) is hinted as the other, which no spelling distance finds (``tz`` / ``zone``)."""


def refuse_unknown_keywords(where: str, given: Iterable[str], valid: Sequence[str]) -> None:
    """:class:`UnknownArgumentError` for the first of ``given`` that is not in ``valid``
    (the keywords ``where``, a function's name, takes): Python's words, a close spelling and
    every keyword there is."""
    unknown = [name for name in given if name not in valid]
    if not unknown:
        return
    name = unknown[0]
    close = [z for z in _ZONE_WORDS if name in _ZONE_WORDS and z != name and z in valid][:1]
    close = close or difflib.get_close_matches(name, valid, n=1, cutoff=0.75)
    raise UnknownArgumentError(
        f"{where}() got an unexpected keyword argument {name!r}"
        + (f" (and {len(unknown) - 1} more)" if len(unknown) > 1 else ""),
        hint=(f"did you mean {close[0]}? " if close else "")
        + f"{where}() takes: {', '.join(valid)}",
    )


def refuse_extra_positional(
    where: str, names: Sequence[str], given: int, valid: Sequence[str]
) -> None:
    """:class:`UnknownArgumentError` for more positional arguments than ``where`` takes
    (``names``, ``self`` or ``cls`` among them): which they are, and the keywords the rest are
    given by (``m.predict("08:40", "UTC")``: ``tz="UTC"``). Python's ``TypeError`` counted
    ``self`` and named neither."""
    own = [n for n in names if n not in ("self", "cls")]
    extra = given - len(names)
    keywords = [name for name in valid if name not in own]
    raise UnknownArgumentError(
        f"{where}() takes {len(own)} positional argument{'' if len(own) == 1 else 's'}"
        f" ({', '.join(own) or 'none'}) but {len(own) + extra} were given",
        hint="give the others by keyword: " + ", ".join(f"{k}=" for k in keywords)
        if keywords
        else f"{where}() takes nothing else",
    )


def keywords_checked(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """``func`` refusing a keyword it does not take with :func:`refuse_unknown_keywords`
    (Python's bare ``TypeError`` named no keyword it does take; a function that takes
    ``**options`` checks them itself), its errors in the API's words
    (:func:`aion_cli.api_words.in_api_words`: keywords, not command-line options)."""
    from aion_cli.api_words import in_api_words
    from aion_cli.errors import AionError

    params = inspect.signature(func).parameters.values()
    own = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params)
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    valid = [p.name for p in params if p.kind in kinds and p.name not in ("self", "cls")]
    positional = [p.name for p in params if p.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD]

    @functools.wraps(func)
    def checked(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        try:
            if len(args) > len(positional):
                refuse_extra_positional(func.__qualname__, positional, len(args), valid)
            if kwargs and not own:
                refuse_unknown_keywords(func.__qualname__, kwargs, valid)
            return func(*args, **kwargs)
        except AionError as error:
            in_api_words(error)
            raise

    return checked


def methods_checked(cls: _C) -> _C:
    """``cls`` with each public method (and class method) :func:`keywords_checked`."""
    for name, attr in list(vars(cls).items()):
        if name.startswith("_"):
            continue
        if isinstance(attr, classmethod):
            setattr(cls, name, classmethod(keywords_checked(attr.__func__)))
        elif inspect.isfunction(attr):
            setattr(cls, name, keywords_checked(attr))
    return cls
