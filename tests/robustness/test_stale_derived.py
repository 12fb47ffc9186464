"""Derived members that pass every check but are not the map's own (stop 71).

A map's FreMEn components, pooling priors and provisional scores are computed when it is
written and used by queries as they are (``aion_cli.derived_seal``). Edited with their
checksums updated (or their accumulators edited), they used to forecast with the edit; the
map's seal now tells, and a query computes them again from the accumulators: its forecasts
are the intact map's to the byte. The same edit on a map without the seal (as written
before stop 71) still changes the forecasts: that is what the seal catches. A query-only map,
which cannot compute them again, is refused.
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from aion_cli import derived_seal
from tests.cli.conftest import run
from tests.robustness.conftest import assert_one_error, rewrite_map
from tests.robustness.test_derived_members import WHEN, _member, _npy, _rewritten
from tests.test_part_maps import _logs


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A map of two days (a closed day, a pending one: provisional scores) with FreMEn
    components and priors."""
    folder = tmp_path_factory.mktemp("stale")
    logs = _logs(folder, [0, 1])
    out = folder / "base.aion"
    assert run("build", logs[0], logs[1], "-o", out, "-q").exit_code == 0
    return out


def _manifest_edited(src: Path, out: Path, edit: Callable[[dict], None]) -> Path:
    return rewrite_map(src, out, manifest_edit=edit)


def _unsealed(src: Path, out: Path) -> Path:
    """``src`` as a map written before the seal: the same members, no ``derived`` record."""
    return _manifest_edited(src, out, lambda m: m.pop(derived_seal.FIELD))


def _predict(path: Path) -> str:
    result = run("predict", path, "--time", WHEN, "--format", "json")
    assert result.exit_code == 0, result.stderr
    return str(result.stdout).replace(str(path), "MAP")


def _edited(src: Path, tmp_path: Path, name: str) -> Path:
    """``src`` with ``name`` changed by :data:`EDITS` (valid values), checksums updated."""
    changed = _npy(EDITS[name](_member(src, name)))
    return _rewritten(src, tmp_path / "edited.aion", name, changed)


def _plus_static(a: np.ndarray) -> np.ndarray:
    out = a.copy()
    out[:, 0] += 1000.0  # the static family's score: the choice of families moves
    return out


EDITS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "forecast_priors": lambda a: a * np.array([2.0, 2.0, 1.0, 1.0, 1.0]),  # κ and κ_t doubled
    "forecast_coef_total": lambda a: a * 1.5,
    "provisional_flow_score": _plus_static,
}


@pytest.mark.parametrize("name", sorted(EDITS))
def test_an_edited_derived_member_is_caught_and_computed_again(
    base: Path, tmp_path: Path, name: str
) -> None:
    """Valid values, checksums updated: the forecasts are the intact map's; without the
    seal the same edit reaches them."""
    edited = _edited(base, tmp_path, name)
    intact = _predict(base)
    assert _predict(edited) == intact
    assert _predict(_unsealed(edited, tmp_path / "unsealed.aion")) != intact


def test_edited_fourier_sums_make_the_components_computed_from_them(
    base: Path, tmp_path: Path
) -> None:
    """The accumulators edited (the Fourier sums doubled) and the stored components kept: the
    query computes the components from the sums it has, as a map without stored components
    (every ``forecast_*`` and ``provisional_*`` member removed) does."""
    name = "temporal_cnt_fourier"
    edited = _rewritten(base, tmp_path / "edited.aion", name, _npy(_member(base, name) * 2.0))
    bare = edited
    with zipfile.ZipFile(edited) as zf:
        derived = [n[:-4] for n in zf.namelist() if n.startswith(("forecast_", "provisional_"))]
    for i, member in enumerate(derived):
        bare = _rewritten(bare, tmp_path / f"bare{i}.aion", member, None)
    bare = _unsealed(bare, tmp_path / "bare.aion")
    assert _predict(edited) == _predict(bare)
    assert _predict(_unsealed(edited, tmp_path / "unsealed.aion")) != _predict(bare)


def test_an_unedited_map_uses_its_stored_members_and_its_query_only_copy_too(
    base: Path, tmp_path: Path
) -> None:
    """The seal of a map as written holds: a query reads the stored components (not the
    Fourier sums) and priors; ``aion compact`` keeps the seal, and its copy reads so too."""
    from aion_cli.mapquery import load_map

    small = tmp_path / "small.aion"
    assert run("compact", base, "-o", small).exit_code == 0
    for path in (base, small):
        state = load_map(path, forecast_only=True).state
        assert state.components is not None, path
        assert not state.temporal.fourier_loaded, path
        assert state._priors is not None, path
        assert state._provisional is not None, path
    assert _predict(small) == _predict(base)


def test_a_query_only_map_with_an_edited_member_is_refused(base: Path, tmp_path: Path) -> None:
    small = tmp_path / "small.aion"
    assert run("compact", base, "-o", small).exit_code == 0
    name = "forecast_priors"
    changed = _npy(EDITS[name](_member(base, name)))
    edited = _rewritten(small, tmp_path / "edited.aion", name, changed)
    result = run("predict", edited, "--time", WHEN)
    assert result.exit_code == 2
    assert_one_error(result.stderr, f"map {edited} is invalid", "are not its own")
    assert "aion compact" in result.stderr.splitlines()[-1]
    assert result.stdout == ""


@pytest.mark.parametrize(
    ("edit", "why"),
    [
        (lambda m: m["derived"].update(rules=0), "other rules"),
        (lambda m: m["derived"].update(digest="0" * 64), "not those they were computed from"),
        (lambda m: m["derived"].update(fourier="0" * 64), "Fourier sums"),
        (lambda m: m["state"].update(open_window=m["state"]["open_window"] - 1), "not those"),
        (lambda m: m.update(derived=[1]), "not a record"),
    ],
)
def test_the_seal_says_why_it_does_not_hold(
    base: Path, tmp_path: Path, edit: Callable[[dict], None], why: str
) -> None:
    """Another rules number, a digest of other members or state, a seal that is not one:
    each makes the stored members stale (the reader computes them again)."""
    with zipfile.ZipFile(base) as zf:
        manifest = json.loads(zf.read("manifest.json"))
    assert derived_seal.stale_because(manifest) is None
    edit(manifest)
    assert why in str(derived_seal.stale_because(manifest))
    use = derived_seal.derived_use(base, manifest, query_only=False)
    assert (use.forecasts, use.priors) == (False, False)


@pytest.mark.parametrize(
    ("created", "priors"),
    [("2026-12-07T20:00:00Z", False), ("2026-12-07T23:48:40Z", True)],
)
def test_an_unsealed_map_s_priors_are_used_only_when_written_after_the_view_s_fix(
    base: Path, created: str, priors: bool
) -> None:
    """A map written before the seal is read as before, but its ``forecast_priors`` are not
    used when it was written before stop 70 made the query's pending day and open window one
    day (they were estimated over another view); its components are (that fix left them)."""
    with zipfile.ZipFile(base) as zf:
        manifest = json.loads(zf.read("manifest.json"))
    del manifest[derived_seal.FIELD]
    manifest["created"] = created
    use = derived_seal.derived_use(base, manifest, query_only=False)
    assert (use.forecasts, use.priors) == (True, priors)


def test_a_stale_map_is_not_compacted(base: Path, tmp_path: Path) -> None:
    """Its query-only copy could not compute the stale members again (no Fourier sums), and
    would be refused: ``aion compact`` refuses the map, writing nothing."""
    name = "forecast_priors"
    edited = _edited(base, tmp_path, name)
    result = run("compact", edited, "-o", tmp_path / "small.aion")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "stored forecasts (forecast_*, provisional_*) are not its own")
    assert "aion build" in result.stderr.splitlines()[-1]
    assert not (tmp_path / "small.aion").exists()


def test_info_verify_says_whether_the_derived_members_are_the_map_s_own(
    base: Path, tmp_path: Path
) -> None:
    name = "forecast_priors"
    edited = _edited(base, tmp_path, name)
    shown = {}
    for label, path in (("intact", base), ("edited", edited),
                        ("unsealed", _unsealed(base, tmp_path / "unsealed.aion"))):
        result = run("info", path, "--verify", "--format", "json")
        assert result.exit_code == 0, result.stderr
        shown[label] = json.loads(str(result.stdout))["verified"]
    assert (shown["intact"]["sealed"], shown["intact"]["derived_stale"]) == (True, None)
    assert shown["edited"]["sealed"] is True
    assert "not those they were computed from" in shown["edited"]["derived_stale"]
    assert (shown["unsealed"]["sealed"], shown["unsealed"]["derived_stale"]) == (False, None)
    text = run("info", edited, "--verify")
    assert "are not its own" in str(text.stdout)
