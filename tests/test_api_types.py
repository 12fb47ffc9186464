"""The package is typed (``py.typed``): the documents' Python examples, as a user's script,
pass ``mypy --strict``. Before, ``built.report.detections_used`` was an error (``Map.report``
was typed as any of the build, merge and compact reports or None, whatever made the map) and
so was ``p.distance_only.cost`` (``Plan | None``, though a plan always has one)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

# a user's helpers typed with the bare class: every kind of map is one
HELPERS = '''
import aion_cli as aion
from aion_cli.evaluation.holdout import hourly_picture


def busiest(m: aion.Map) -> str:
    return str(m.predict(historical=True).records()[0]["id"])


def every_kind(paths: list[str]) -> list[str]:
    return [
        busiest(aion.Map.load(paths[0])),
        busiest(aion.build(paths, output="x.aion")),
        busiest(aion.merge(paths, "y.aion")),
        busiest(aion.compact(paths[0], "z.aion")),
    ]


def held_out_hours(m: aion.Map) -> str:  # docs/API.md: hourly_picture(result, path, title)
    return hourly_picture(m.holdout(["later.mcap"]), "hours.png", "later").name
'''


def _python_blocks(name: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (REPO / name).read_text(), flags=re.S)


def test_the_documented_examples_pass_mypy_strict(tmp_path: Path) -> None:
    api = pytest.importorskip("mypy.api")
    readme = next(b for b in _python_blocks("README.md") if "import aion_cli" in b)
    scripts = [*_python_blocks("docs/API.md"), readme, HELPERS]
    files = []
    for k, text in enumerate(scripts):
        files.append(tmp_path / f"script{k}.py")
        files[-1].write_text(text)
    # the package as a user's mypy sees an installed one: its own modules not reported
    config = tmp_path / "mypy.ini"
    config.write_text(f"[mypy]\nmypy_path = {REPO}\n[mypy-aion_cli.*]\nfollow_imports = silent\n")
    out, err, status = api.run(
        ["--strict", "--config-file", str(config), "--cache-dir", str(tmp_path / "cache"),
         *map(str, files)]
    )
    assert status == 0, out + err


# what a robotics script passes and the API takes (docs/API.md "Inputs"): paths from a
# generator, a pose as a numpy array, numpy integer nanoseconds, pairs as lists
NUMPY_AND_ITERABLES = '''
from zoneinfo import ZoneInfo

import numpy as np
import aion_cli as aion
from aion_cli.engine.state import MapState


def uses(m: aion.Map, pose: np.ndarray, stamps: np.ndarray) -> None:
    m.predict(stamps[0], at=pose[:2])
    m.predict_series(stamps[0], stamps[-1], "1h", at=pose)
    m.plan(pose[:2], "p2", time=stamps[0])
    m.plan("p1", "p2", leave=["2026-01-12 07:00", "2026-01-12 08:00"])
    m.export("out", time=stamps[0], path=[pose[:2], "p2"])
    m.picture("map.png", time=stamps[0], path=["p1", "p2"])
    m.holdout(name for name in ["later.mcap"])
    aion.to_ns(np.int64(1768207200000000000))
    m.predict(np.int64(1768207200000000000), nodes="p1")
    # what the API takes and its annotations refused: any iterable of ids, numpy counts and
    # durations, one observed span alone
    m.predict(nodes={"p1", "p2"}, top=np.int64(3))
    m.predict_series(stamps[0], stamps[-1], "1h", nodes=np.array(["p1", "p2"]), top=np.int64(2))
    m.predict(nodes=(row for row in ["p1", "p2"]))
    aion.build("a.mcap", observed=("2026-01-05 08:00", "2026-01-05 10:00"), workers=np.int64(2),
               batch_size=np.int64(1000), graph_period=np.timedelta64(5, "s"))
    aion.build((name for name in ["a.mcap", "b.mcap"]), output="ab.aion",
               observed=[["2026-01-05 08:00", "2026-01-05 10:00"]])
    aion.merge((name for name in ["a.aion", "b.aion"]), "ab.aion")


class Phases:
    def start(self, description: str, total: int, unit: str) -> None:
        print(description, total, unit)

    def advance(self, n: int) -> None:
        print(n)


def config_and_zones(state: MapState) -> None:
    aion.build("a.mcap", config={"bins": 16, "window_s": 300.0}, progress=Phases())
    aion.merge(["a.aion", "b.aion"], "ab.aion", progress=Phases())
    aion.Map.from_state(state, timezone=ZoneInfo("Europe/Madrid"))
'''


def test_numpy_poses_stamps_generators_and_list_pairs_type_check(tmp_path: Path) -> None:
    """docs/API.md: paths as "any other iterable", a point as "2 or 3 numbers", times as
    "integer nanoseconds", pairs as "a tuple or a list of two"; each works, but a
    type-checked script passing a generator of logs, ``at=pose[:2]`` (a numpy array),
    ``time=stamps[0]`` (``numpy.int64``) or ``leave=[a, b]`` failed mypy with 'incompatible
    type' (every call of this script): the signatures now admit what the functions take. So
    do ``config=`` a dict of model parameters (as ``--config``'s TOML) and ``from_state``'s
    ``timezone=`` a ``ZoneInfo``, which work and were typed ``ModelConfig`` and ``str``, and
    ``progress=`` an object with ``start(description, total, unit)`` as the docs give it."""
    api = pytest.importorskip("mypy.api")
    script = tmp_path / "uses.py"
    script.write_text(NUMPY_AND_ITERABLES)
    config = tmp_path / "mypy.ini"
    config.write_text(f"[mypy]\nmypy_path = {REPO}\n[mypy-aion_cli.*]\nfollow_imports = silent\n")
    out, err, status = api.run(
        ["--strict", "--config-file", str(config), "--cache-dir", str(tmp_path / "cache"),
         str(script)]
    )
    assert status == 0, out + err


def _documented_imports() -> list[str]:
    """``from MODULE import NAME`` for every ``aion_cli.MODULE.NAME`` docs/API.md names (a
    name that is a module itself is imported whole)."""
    import importlib

    lines = []
    names = re.findall(r"`(aion_cli(?:\.\w+)+)", (REPO / "docs" / "API.md").read_text())
    for dotted in sorted(set(names)):
        try:
            importlib.import_module(dotted)
            lines.append(f"import {dotted}")
        except ImportError:
            module, name = dotted.rsplit(".", 1)
            lines.append(f"from {module} import {name}")
    return lines


def test_every_type_the_docs_name_imports_under_mypy_strict(tmp_path: Path) -> None:
    """docs/API.md says ``aion.merge``'s report is an ``aion_cli.merging.MergeReport``, but
    ``from aion_cli.merging import MergeReport`` failed ``mypy --strict`` ("does not explicitly
    export attribute"): the class lives in ``aion_cli.merge_report``. Every dotted name the
    document gives now imports, as written, in a strict user script; and every result type is
    also ``aion_cli``'s under the name its ``repr`` gives (``<aion.BuildReport ...>`` was no
    ``aion.BuildReport``)."""
    api = pytest.importorskip("mypy.api")
    lines = _documented_imports()
    assert "from aion_cli.merging import MergeReport" in lines  # the name that failed
    reprs = "\n".join(
        f"{name.lower()}: aion.{name} | None = None"
        for name in ("BuildReport", "MergeReport", "CompactReport", "HoldoutResult", "Manifest",
                     "SeriesTable", "Table", "Plan")
    )  # fmt: skip
    script = tmp_path / "names.py"
    old_home = "from aion_cli.api_checks import PairOf, StepLike, TimeLike, ZoneLike"  # still
    script.write_text("\n".join([*lines, old_home, "import aion_cli as aion", reprs, ""]))
    config = tmp_path / "mypy.ini"
    config.write_text(f"[mypy]\nmypy_path = {REPO}\n[mypy-aion_cli.*]\nfollow_imports = silent\n")
    out, err, status = api.run(
        ["--strict", "--config-file", str(config), "--cache-dir", str(tmp_path / "cache"),
         str(script)]
    )
    assert status == 0, out + err + script.read_text()


def test_each_result_type_is_the_packages_by_its_repr_name() -> None:
    """``repr(aion.build(...).report)`` is ``<aion.BuildReport ...>``, but there was no
    ``aion.BuildReport`` (nor ``aion.MergeReport``, ``CompactReport``, ``HoldoutResult``,
    ``Manifest``). Every ``<aion.NAME`` a ``repr`` in the package writes is now ``aion.NAME``,
    the class whose ``repr`` it is (imported when first asked for), exported in ``__all__``;
    an unknown name is still an ``AttributeError``."""
    import aion_cli as aion

    written: dict[str, str] = {}
    for source in (REPO / "aion_cli").rglob("*.py"):
        for name in re.findall(r'f"<aion\.(\w+)', source.read_text()):
            written[name] = source.relative_to(REPO).with_suffix("").as_posix().replace("/", ".")
    assert {"BuildReport", "MergeReport", "HoldoutResult", "Table", "Map"} <= set(written)
    for name, module in written.items():
        assert name in aion.__all__, name
        assert getattr(aion, name).__module__ == module, (name, module)
    with pytest.raises(AttributeError, match="Reports"):
        _ = aion.Reports  # type: ignore[attr-defined]
