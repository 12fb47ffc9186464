"""docs/API.md against the code: every signature it gives is the function's own (names, kinds,
defaults), every keyword of ``aion.build`` and ``aion.merge`` is named, and its merge and
compact examples run (its first example runs in tests/test_api.py), and so does README's
"Python API" block."""

from __future__ import annotations

import inspect
import re
import shutil
from pathlib import Path
from typing import Any

import aion_cli as aion
from tests.doc_blocks import run_blocks

REPO = Path(__file__).resolve().parents[1]
API = (REPO / "docs" / "API.md").read_text()


def _shape(fn: Any) -> list[tuple[str, Any, Any]]:
    """(name, kind, default) of each parameter, without ``self`` / ``cls``."""
    params = [p for p in inspect.signature(fn).parameters.values() if p.name not in ("self",)]
    return [(p.name, p.kind, p.default) for p in params]


def _documented(text: str) -> Any:
    """A function with the parameter list the document gives (defaults evaluated)."""
    scope: dict[str, Any] = {}
    exec(f"def f({text}): pass", scope)  # the document's own text, e.g. 'time=None, *, tz=None'
    return scope["f"]


def _signatures() -> dict[str, str]:
    """``name -> parameter text`` of every call the document's headings and its Map table give."""
    headings = re.findall(r"^## `aion\.(\w+)\((.*?)\)", API, re.M)
    out = {f"aion.{name}": args for name, args in headings}
    for name, args in re.findall(r"^\| `(?:m|Map)\.(\w+)\((.*?)\)` \|", API, re.M):
        out[f"Map.{name}"] = args
    return out


def test_the_documented_signatures_are_the_functions_own() -> None:
    signatures = _signatures()
    assert {"aion.build", "aion.merge", "aion.compact", "Map.predict", "Map.plan"} <= set(
        signatures
    )
    for name, args in signatures.items():
        owner, attr = name.split(".")
        real = getattr(aion if owner == "aion" else aion.Map, attr)
        if owner == "aion" and "**options" in args:  # keywords listed in the text (below)
            args = args.replace("**options", "*").rstrip(", *")
            real_shape = [s for s in _shape(real) if s[1] != inspect.Parameter.KEYWORD_ONLY]
        else:
            real_shape = _shape(real)
        assert _shape(_documented(args)) == real_shape, (name, args, real_shape)


def test_every_keyword_of_build_and_merge_is_named() -> None:
    section = API.split("## `aion.build(", 1)[1].split("\n## ", 1)[0]
    named = set(re.findall(r"`(\w+)[`=]", section))
    keywords = {
        p.name
        for p in inspect.signature(aion.build).parameters.values()
        if p.kind == inspect.Parameter.KEYWORD_ONLY
    }
    assert keywords - named == set(), f"docs/API.md does not name {sorted(keywords - named)}"
    merge = API.split("## `aion.merge(", 1)[1].split("\n## ", 1)[0]
    merge_keywords = {
        p.name
        for p in inspect.signature(aion.merge).parameters.values()
        if p.kind == inspect.Parameter.KEYWORD_ONLY
    }
    assert merge_keywords <= set(re.findall(r"`(\w+)[`=]", merge))


def _simulated(log: Path, start: str) -> Path:
    """A log of a simulated office morning (0.1 days from ``start``)."""
    from click.testing import CliRunner

    from aion_cli.cli.main import cli

    args = ["simulate", "-o", str(log), "--days", "0.1", "--start", start, "-q"]
    result = CliRunner().invoke(cli, args, catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    return log


def _two_maps(folder: Path, names: tuple[str, ...]) -> None:
    """Maps ``names`` of two simulated mornings (Monday, Wednesday): disjoint in time."""
    for name, day in zip(names, ("2026-01-05T08:00", "2026-01-07T08:00"), strict=True):
        aion.build([_simulated(folder / f"{name}.mcap", day)], output=folder / name)


def test_the_merge_and_compact_examples_run(tmp_path: Path) -> None:
    """API.md's merge example on maps of two simulated mornings, then its compact example."""
    blocks = re.findall(r"```python\n(.*?)```", API, flags=re.S)
    examples = [b for b in blocks if "aion.merge(" in b or "aion.compact(" in b]
    assert len(examples) == 2
    names = re.findall(r'aion\.merge\(\["(\w+\.aion)", "(\w+\.aion)"\]', examples[0])[0]
    _two_maps(tmp_path, names)
    scope = run_blocks(tmp_path, "docs/API.md", examples[0], examples[1])
    assert scope["week"].report.lineage == "same"
    # its repr is one line (before: every input map's path, size and sha256)
    doc = scope["week"].report.to_dict()
    assert re.fullmatch(
        f"<aion.MergeReport week.aion: 2 maps merged, lineage same; {doc['detections']:,} "
        f"detections from 2 logs; {doc['nodes']:,} nodes?, {doc['cells']:,} cells?, "
        f"{doc['windows']:,} windows?; {len(doc['notes'])} notes?, 0 warnings>",
        repr(scope["week"].report),
    )
    sizes = [(tmp_path / name).stat().st_size for name in ("week.aion", "week-robot.aion")]
    assert sizes[1] < sizes[0]
    # the example prints report.ratio (before: to_dict()["ratio"], the report had no ratio)
    assert scope["robot"].report.ratio == sizes[0] / sizes[1]
    # every report reads in the <aion.… > form of a Map's, a Table's and a Plan's repr (before:
    # <BuildReport …>, <MergeReport …> and the compact report's whole dataclass)
    compacted = scope["robot"].report.to_dict()
    assert repr(scope["robot"].report) == (
        f"<aion.CompactReport week-robot.aion from week.aion: {compacted['source_bytes']:,} "
        f"-> {compacted['map_bytes']:,} bytes; {compacted['entries']:,} entries; "
        f"{len(compacted['notes'])} note{'' if len(compacted['notes']) == 1 else 's'}>"
    )
    assert repr(scope["robot"]).startswith("<aion.Map ")
    assert repr(scope["robot"].manifest).startswith("<aion.Manifest: ")


def test_the_readme_python_example_runs(tmp_path: Path) -> None:
    """README's "Python API" block, in a folder with the sample log, two maps of disjoint time
    for its merge and a later log for its holdout."""
    readme = (REPO / "README.md").read_text()
    block = re.findall(r"## Python API\n\n```python\n(.*?)```", readme, flags=re.S)[0]
    (tmp_path / "samples").mkdir()
    shutil.copy(REPO / "samples" / "office.mcap", tmp_path / "samples" / "office.mcap")
    names = re.findall(r'aion\.merge\(\["(\w+\.aion)", "(\w+\.aion)"\]', block)[0]
    _two_maps(tmp_path, names)
    later = re.findall(r'm\.holdout\(\["([\w.]+)"\]\)', block)[0]
    _simulated(tmp_path / later, "2026-01-12T08:00")
    scope = run_blocks(tmp_path, "README.md", block)
    assert isinstance(scope["m"], aion.Map)
    assert isinstance(scope["t"], aion.Table)
    assert isinstance(scope["p"], aion.Plan)
    assert scope["day"].flow.shape[1] == 15
    assert scope["score"].headings
    assert isinstance(scope["robot"], aion.Map)
    # aion.info: the log's report, which names the detection topic the build used
    assert scope["log"]["will_use"]["detections"] == scope["m"].report.to_dict()["detection_topics"]


def test_the_api_module_names_every_name_the_package_exports() -> None:
    """``aion_cli.api``'s docstring said ``from aion_cli.api import Map, Plan, Table, build,
    compact, merge, to_ns`` imports the whole API, which ``aion_cli`` re-exports; but
    ``aion.SeriesTable`` and the errors are not in ``aion_cli.api``. It names them now."""
    import aion_cli.api

    doc = aion_cli.api.__doc__ or ""
    imported = re.findall(r"``from aion_cli\.api import ([\w, ]+)``", doc)[0].split(", ")
    exec(f"from aion_cli.api import {', '.join(imported)}", {})  # the line works as given
    besides = set(re.findall(r"``(\w+)``", doc.split("re-exports", 1)[1]))
    assert set(imported) | besides == set(aion.__all__) - {"__version__"}


def test_dir_of_the_package_offers_every_name_it_exports() -> None:
    """``dir(aion)``, which a notebook's tab completion calls, left out the result types the
    package imports when first asked for (``aion.SeriesTable``, ``aion.BuildReport``, ...),
    and offered ``typing``'s ``Any`` and ``TYPE_CHECKING``."""
    names = dir(aion)
    assert set(aion.__all__) <= set(names)
    assert {"Any", "TYPE_CHECKING"}.isdisjoint(names)
    assert all(hasattr(aion, name) for name in names)


def test_the_api_says_which_commands_it_does_and_does_not_cover() -> None:
    """docs/API.md began "Everything the ``aion`` command does can be done from Python",
    though ``info`` of a log, ``report``, ``simulate``, ``convert`` and the datasets'
    ``evaluate`` protocols have no API. Its opening paragraph names every command now, as
    covered or as the command's alone, so a new command is placed there too."""
    from aion_cli.cli.main import cli

    opening = API.split("```", 1)[0]
    assert "Everything" not in opening
    missing = [c for c in cli.commands if not re.search(rf"`(?:aion )?{c}\b", opening)]
    assert missing == [], f"docs/API.md's opening paragraph does not place {missing}"
