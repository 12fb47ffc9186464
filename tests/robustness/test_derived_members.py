"""A map's ``forecast_priors`` (format 2.3) and ``temporal_week_sums`` (2.2) members missing,
truncated, of another dtype or shape, holding NaN, inf or a negative number, or failing their
CRC: every reader (``info``, ``predict``, ``plan``, ``export``, ``merge``, a ``--map``
continuation, ``info --verify``) either reads the map exactly as it would the intact one (a
member a map written before it existed lacks: the priors estimated afresh, no week evidence)
or refuses with one ``error:`` line naming the map, a ``hint:`` line and exit 2
(formats/MAPFILE.md). ``info`` alone reads the manifest only: the members do not reach it.

A member whose values pass every check but are not what the map's other members give (a
stale copy, checksums updated) is caught by the map's seal since stop 71
(``test_stale_derived.py``)."""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import run
from tests.formats.map_damage import declare_member, flip_member_byte
from tests.robustness.conftest import assert_one_error
from tests.test_part_maps import _logs

MEMBERS = ("forecast_priors", "temporal_week_sums")
WHEN = "2026-11-23 09:00"  # the first log's day, an hour it observed


@pytest.fixture(scope="module")
def maps(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A map of two days (a closed day: week sums; a pending one), a map of a later day to
    merge it with, and a log of a later day still to continue it with."""
    folder = tmp_path_factory.mktemp("derived")
    logs = _logs(folder, [0, 1, 2.5, 4])
    base, other = folder / "base.aion", folder / "other.aion"
    assert run("build", logs[0], logs[1], "-o", base, "-q").exit_code == 0
    assert run("build", logs[2], "-o", other, "-q").exit_code == 0
    with zipfile.ZipFile(base) as zf:
        assert {m + ".npy" for m in MEMBERS} <= set(zf.namelist())
    return {"base": base, "other": other, "log": logs[3]}


def _member(path: Path, name: str) -> np.ndarray:
    with zipfile.ZipFile(path) as zf:
        return np.load(io.BytesIO(zf.read(name + ".npy")), allow_pickle=False)


def _rewritten(src: Path, out: Path, name: str, data: bytes | None, parsed: bool = True) -> Path:
    """``src`` with member ``name``'s bytes replaced by ``data`` (its manifest record made to
    match: size, checksums and, when ``parsed``, the array's dtype and shape; so that only
    the reader's later checks can refuse it), or without the member (``None``: as a map
    written before it existed)."""
    with zipfile.ZipFile(src) as zin:
        contents = {n: zin.read(n) for n in zin.namelist()}
    manifest = json.loads(contents["manifest.json"])
    if data is None:
        del contents[name + ".npy"], manifest["members"][name]
    else:
        contents[name + ".npy"] = data
        rec = manifest["members"][name]
        if parsed:
            arr = np.load(io.BytesIO(data), allow_pickle=False)
            declare_member(rec, data, dtype=arr.dtype.str, shape=list(arr.shape))
        else:
            declare_member(rec, data)
    contents["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_STORED) as zout:
        for n, d in contents.items():
            zout.writestr(n, d)
    return out


def _npy(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    return buf.getvalue()


def _with_value(value: float) -> Callable[[np.ndarray], np.ndarray]:
    def change(arr: np.ndarray) -> np.ndarray:
        out = arr.copy()
        out.flat[0] = value  # κ of the priors; the week sums' first hour's detections
        return out

    return change


CHANGES: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "float32": lambda a: a.astype(np.float32),
    "shape": lambda a: a[..., :-1].copy(),
    "nan": _with_value(np.nan),
    "inf": _with_value(np.inf),
    "negative": _with_value(-1.0),
}


def _damaged(maps: dict[str, Path], tmp_path: Path, name: str, damage: str) -> Path:
    base, out = maps["base"], tmp_path / f"{damage}.aion"
    if damage == "missing":
        return _rewritten(base, out, name, None)
    if damage == "crc":
        return flip_member_byte(base, name, out)
    if damage == "truncated":  # the .npy cut short, the manifest's size and sums made to match
        return _rewritten(base, out, name, _npy(_member(base, name))[:-8], parsed=False)
    return _rewritten(base, out, name, _npy(CHANGES[damage](_member(base, name))))


def _readers(maps: dict[str, Path], tmp_path: Path) -> dict[str, Callable[[Path], list[str]]]:
    def out(p: Path, what: str) -> str:
        return str(tmp_path / f"{p.stem}-{what}")

    at = ["--time", WHEN]
    return {
        "info": lambda p: ["info", str(p), "--format", "json"],
        "verify": lambda p: ["info", str(p), "--verify", "--format", "json"],
        "predict": lambda p: ["predict", str(p), *at, "--format", "json"],
        "plan": lambda p: ["plan", str(p), "--from", "p0", "--to", "p2", *at, "--format", "json"],
        "export": lambda p: ["export", str(p), *at, "--format", "ply", "-o", out(p, "ply")],
        "merge": lambda p: ["merge", str(p), str(maps["other"]), "-q", "-o", out(p, "m.aion")],
        "continue": lambda p: ["build", str(maps["log"]), "--map", str(p), "-o", out(p, "c.aion")],
    }


READERS = ("info", "verify", "predict", "plan", "export", "merge", "continue")
REFUSED = ("truncated", "crc", "shape", "nan", "inf", "negative")


def _stdout(result: object, path: Path) -> str:
    return str(getattr(result, "stdout", "")).replace(str(path), "MAP")


def _info(result: object) -> dict[str, object]:
    """``aion info --format json`` but the map's path (its file's size is in ``inputs``)."""
    shown = json.loads(str(getattr(result, "stdout", "")))
    return {k: v for k, v in shown.items() if k != "map"}


@pytest.mark.parametrize("name", MEMBERS)
@pytest.mark.parametrize("damage", REFUSED)
def test_a_damaged_member_is_refused_by_every_reader_that_reads_it(
    maps: dict[str, Path], tmp_path: Path, name: str, damage: str
) -> None:
    """Exit 2, one ``error:`` line naming the damaged map and a hint, nothing written; ``info``
    without ``--verify`` (the manifest only) as for the intact map."""
    bad = _damaged(maps, tmp_path, name, damage)
    readers = _readers(maps, tmp_path)
    for reader in READERS:
        result = run(*readers[reader](bad))
        if reader == "info":
            intact = run(*readers[reader](maps["base"]))
            assert result.exit_code == intact.exit_code == 0, result.stderr
            assert _info(result) == _info(intact)
            continue
        assert result.exit_code == 2, (reader, result.stderr)
        assert_one_error(result.stderr, str(bad), name)
        assert result.stderr.strip().splitlines()[-1].startswith("hint: "), reader
        assert result.stdout == ""
    assert not any(tmp_path.glob(f"{bad.stem}-*")), "a refused read wrote something"


@pytest.mark.parametrize("name", MEMBERS)
def test_a_map_without_the_member_reads_as_one_written_before_it(
    maps: dict[str, Path], tmp_path: Path, name: str
) -> None:
    """Without its priors a map's queries estimate them, exactly what the map stored; without
    its week sums it has no week evidence, which for this map (two days: too few to ask for
    the week) chooses the same calendar. Every reader succeeds and the forecasts and plans
    are the intact map's to the byte; a continuation or merge writes both members afresh."""
    bare = _damaged(maps, tmp_path, name, "missing")
    readers = _readers(maps, tmp_path)
    for reader in READERS:
        result, intact = run(*readers[reader](bare)), run(*readers[reader](maps["base"]))
        assert result.exit_code == intact.exit_code == 0, (reader, result.stderr)
        if reader in ("predict", "plan"):
            assert _stdout(result, bare) == _stdout(intact, maps["base"]), reader
    for written in (tmp_path / "missing-m.aion", tmp_path / "missing-c.aion"):
        with zipfile.ZipFile(written) as zf:
            assert {m + ".npy" for m in MEMBERS} <= set(zf.namelist()), written
    if name == "forecast_priors":
        again = tmp_path / "missing-c.aion"
        bare_again = _rewritten(again, tmp_path / "again-bare.aion", name, None)
        a = run("predict", again, "--time", WHEN, "--format", "json")
        b = run("predict", bare_again, "--time", WHEN, "--format", "json")
        assert _stdout(a, again) == _stdout(b, bare_again)


def test_week_sums_of_another_float_width_read_as_their_float64_values(
    maps: dict[str, Path], tmp_path: Path
) -> None:
    """float32 week sums (whole counts: exact in either width) read as the float64 ones:
    the forecasts are the intact map's; the priors, whose check names float64, are refused."""
    wide = _damaged(maps, tmp_path, "temporal_week_sums", "float32")
    a = run("predict", wide, "--time", WHEN, "--format", "json")
    b = run("predict", maps["base"], "--time", WHEN, "--format", "json")
    assert a.exit_code == b.exit_code == 0, a.stderr
    assert _stdout(a, wide) == _stdout(b, maps["base"])
    narrow = _damaged(maps, tmp_path, "forecast_priors", "float32")
    result = run("predict", narrow, "--time", WHEN)
    assert result.exit_code == 2
    assert_one_error(result.stderr, str(narrow), "float32")
    assert "hint: " in result.stderr
