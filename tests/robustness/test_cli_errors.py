"""One error model for every user mistake, proven through the real CLI.

Each mistake is run through click's runner (with and without ``--debug``) and through the
installed ``aion`` console script in a subprocess: exactly one ``error: ...`` line, at most a
``hint:`` line, exit code 2, no traceback (``--debug`` adds one). An internal fault (a bug,
simulated by making an engine function raise) exits 1. A build that drops detections says so
in its summary, by reason.
"""

from __future__ import annotations

import os
import re
import socket
import struct
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from tests.robustness.conftest import (
    T0,
    Office,
    S,
    assert_one_error,
    build_json,
    fails,
    person,
    robot_tf,
    run,
    run_process,
    walk,
    write_log,
)


def member_data_offset(path: Path, member: str) -> int:
    """Byte offset of a stored zip member's data in ``path``."""
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
    with path.open("rb") as fh:
        fh.seek(info.header_offset)
        local = fh.read(30)
    name_len, extra_len = struct.unpack("<HH", local[26:30])
    return info.header_offset + 30 + name_len + extra_len


def flip_byte(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0xFF
    path.write_bytes(bytes(data))


def _versioned_map(office: Office, folder: Path, name: str, version: str) -> Path:
    from tests.robustness.conftest import rewrite_map

    def edit(manifest: dict[str, Any]) -> None:
        manifest["version"] = version

    return rewrite_map(office.map, folder / name, manifest_edit=edit)


def _newer_map(office: Office, folder: Path) -> Path:
    return _versioned_map(office, folder, "newer.aion", "3.0")  # this aion writes 2.1


def _older_map(office: Office, folder: Path) -> Path:
    """A map of format 1.x (the FreMEn state before the temporal model): must be rebuilt."""
    return _versioned_map(office, folder, "older.aion", "1.0")


def _corrupted_map(office: Office, folder: Path) -> Path:
    path = office.copy_map(folder / "corrupt.aion")
    with zipfile.ZipFile(path) as zf:
        member = next(n for n in zf.namelist() if n.endswith(".npy"))
        size = zf.getinfo(member).file_size
    flip_byte(path, member_data_offset(path, member) + size - 1)  # last byte of the array
    return path


def _locked_map(office: Office, folder: Path) -> Path:
    path = office.copy_map(folder / "locked.aion")
    # held by a live process other than this test's (its parent), as another aion writing the
    # map would hold it (a lock of this very pid that it does not hold is stale)
    path.with_name("locked.aion.lock").write_text(f"{os.getppid()} {socket.gethostname()}\n")
    return path


def _mistakes(office: Office, folder: Path) -> dict[str, tuple[list[Any], str]]:
    """name -> (arguments, a fragment the error line must contain)."""
    (folder / "not_a_bag").mkdir()
    (folder / "notes.txt").write_text("hello")
    (folder / "not_a_bag" / "notes.txt").write_text("hello")
    (folder / "empty.mcap").write_bytes(b"")
    (folder / "garbage.bin").write_bytes(os.urandom(4096))
    (folder / "garbage.mcap").write_bytes(os.urandom(4096))
    (folder / "bad.toml").write_text("bogus_key = 3\n")
    (folder / "bag").mkdir()  # a rosbag2 bag folder, as recorded
    (folder / "bag" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (folder / "bag" / "bag_0.mcap").write_bytes(b"")
    out = folder / "out.aion"
    return {
        "missing file": (["build", folder / "nope.mcap", "-o", out], "nope.mcap"),
        "folder that is not a bag": (["build", folder / "not_a_bag", "-o", out], "not a rosbag2"),
        "empty log": (["build", folder / "empty.mcap", "-o", out], "empty"),
        "garbage file": (["build", folder / "garbage.bin", "-o", out], "cannot tell the log"),
        "garbage .mcap": (["build", folder / "garbage.mcap", "-o", out], "not an MCAP file"),
        "unknown --log-format": (
            ["build", office.log, "--log-format", "zip", "-o", out],
            "--log-format",
        ),
        "unknown --format": (["info", office.log, "--format", "yaml"], "--format"),
        "wrong time format": (["predict", office.map, "--time", "half past never"], "time"),
        "unknown node id": (
            ["plan", office.map, "--from", "p99", "--to", "p1", "--time", "now"],
            "p99",
        ),
        "malformed node id": (
            ["plan", office.map, "--from", "zz", "--to", "p1", "--time", "now"],
            "zz",
        ),
        "map from a newer version": (
            ["predict", _newer_map(office, folder), "--time", "now"],
            "newer",
        ),
        "map from an older format": (
            ["predict", _older_map(office, folder), "--time", "now"],
            "older",
        ),
        "corrupted map": (["predict", _corrupted_map(office, folder), "--time", "now"], "corrupt"),
        "a log given as the map": (["predict", folder / "notes.txt", "--time", "now"], "map"),
        "config with an unknown key": (
            ["build", office.log, "--config", folder / "bad.toml", "-o", out],
            "bogus_key",
        ),
        "locked map": (["build", office.log, "-o", _locked_map(office, folder)], "another process"),
        # an unset shell variable: "" would be the current folder, read as a rosbag2 bag
        "an empty log path": (["build", "", "-o", out], "an empty path"),
        "an empty map path": (["predict", "", "--time", "now"], "an empty path"),
        "an empty output path": (["build", office.log, "-o", ""], "an empty path"),
        # Path() drops the '/': the file x.ply was written where a folder was meant
        "an output file ending in '/'": (
            ["plan", office.map, "--from", "p1", "--to", "p2", "--export", f"{folder}/x.ply/"],
            "ends in '/', which names a folder",
        ),
        # click's own words ("File 'x' is a directory.") left the way out unsaid
        "a folder as a map output": (
            ["merge", office.map, office.map, "-o", folder],
            f"{str(folder)!r} is a folder, not a file: name a file in it (e.g. {folder}/NAME)",
        ),
        # "name a file in it (e.g. bag/NAME)" put the map into the recording's folder
        "a rosbag2 bag folder as a map output": (
            ["build", office.log, "-o", folder / "bag"],
            f"{str(folder / 'bag')!r} is a rosbag2 bag folder (a log), not a file",
        ),
        # the topic is there, of another type: "no scene-graph topic '/tf' in the log" said
        # it was not
        "a TF topic named as the scene graph": (
            ["build", office.log, "--graph-topic", "/tf", "-o", out],
            "no scene-graph topic '/tf' in the log (it has type tf2_msgs/msg/TFMessage)",
        ),
        "a rosbag2 bag folder as the map continued": (
            ["build", office.log, "--map", folder / "bag"],
            f"{str(folder / 'bag')!r} is a rosbag2 bag folder (a log), not a file",
        ),
    }


@pytest.fixture(scope="module")
def mistakes(office: Office, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    folder = tmp_path_factory.mktemp("mistakes")
    return {"folder": folder, "cases": _mistakes(office, folder)}


CASES = (
    "missing file",
    "folder that is not a bag",
    "empty log",
    "garbage file",
    "garbage .mcap",
    "unknown --log-format",
    "unknown --format",
    "wrong time format",
    "unknown node id",
    "malformed node id",
    "map from a newer version",
    "map from an older format",
    "corrupted map",
    "a log given as the map",
    "config with an unknown key",
    "locked map",
    "an empty log path",
    "an empty map path",
    "an empty output path",
    "an output file ending in '/'",
    "a folder as a map output",
    "a rosbag2 bag folder as a map output",
    "a rosbag2 bag folder as the map continued",
    "a TF topic named as the scene graph",
)


def test_the_case_list_is_complete(mistakes: dict[str, Any]) -> None:
    assert sorted(mistakes["cases"]) == sorted(CASES)


@pytest.mark.parametrize("case", CASES)
def test_user_mistake_is_one_error_line_exit_2(case: str, mistakes: dict[str, Any]) -> None:
    args, fragment = mistakes["cases"][case]
    folder: Path = mistakes["folder"]
    before = sorted(p.name for p in folder.iterdir())
    result = run(*args)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, fragment)
    assert result.stdout == ""
    assert not (folder / "out.aion").exists()  # no partial map
    assert sorted(p.name for p in folder.iterdir()) == before  # no temp file left either

    debug = run("--debug", *args)
    assert debug.exit_code == 2
    assert "Traceback (most recent call last)" in debug.stderr
    assert debug.stderr.count("error: ") == 1


@pytest.mark.parametrize("case", CASES)
def test_every_option_a_hint_names_exists(case: str, mistakes: dict[str, Any]) -> None:
    """A hint that says "pass --x" names an option of the command it is about (``aion info
    garbage.mcap`` once said ``--format bag|rosbag2``, which is info's output format)."""
    import re

    args, _fragment = mistakes["cases"][case]
    top = run("--help").stdout
    commands = set(re.findall(r"^  (\w+)  ", top.split("Commands:")[1], flags=re.MULTILINE))
    hints = [line for line in run(*args).stderr.splitlines() if line.startswith("hint:")]
    for hint in hints:
        named = [c for c in re.findall(r"aion (\w+)", hint) if c in commands]
        command = named[0] if named else str(args[0])
        options = set(re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", hint))
        help_text = run(command, "--help").stdout
        missing = sorted(o for o in options if o not in help_text)
        assert not missing, f"{case}: {hint!r} names {missing}, not options of aion {command}"


def test_a_file_that_is_not_an_mcap_hints_at_the_log_format_option(tmp_path: Path) -> None:
    text = tmp_path / "readme.mcap"
    text.write_text("not a log\n")
    for command in ("info", "build"):
        extra = ["-o", str(tmp_path / "x.aion")] if command == "build" else []
        result = run(command, text, *extra)
        assert result.exit_code == 2
        assert "--log-format bag|rosbag2" in result.stderr
        assert "--log-format" in run(command, "--help").stdout


# One mistake of each kind (log, map, config, lock): each subprocess pays aion's ~1 s
# start-up, and the in-process test above already runs every case.
SUBPROCESS_CASES = (
    "garbage .mcap",
    "corrupted map",
    "config with an unknown key",
    "locked map",
)


def test_user_mistakes_in_a_subprocess(mistakes: dict[str, Any]) -> None:
    """The installed console script: same contract (two at a time)."""
    cases = {name: mistakes["cases"][name] for name in SUBPROCESS_CASES}
    with ThreadPoolExecutor(max_workers=2) as pool:
        procs = dict(
            zip(cases, pool.map(lambda c: run_process(*c[0]), cases.values()), strict=True)
        )
    for case, proc in procs.items():
        assert proc.returncode == 2, (case, proc.stderr)
        assert_one_error(proc.stderr, cases[case][1])
        assert proc.stdout == "", case


def test_locked_map_is_left_as_it_was(mistakes: dict[str, Any], office: Office) -> None:
    locked: Path = mistakes["folder"] / "locked.aion"
    assert locked.read_bytes() == office.map.read_bytes()


def _raise_internal(*_: Any, **__: Any) -> Any:
    raise RuntimeError("gears stuck")


@pytest.mark.parametrize(
    ("target", "command"),
    [
        ("aion_cli.engine.mapper.Mapper.add_detections", "build"),
        ("aion_cli.engine.query.predict_table", "predict"),
    ],
)
def test_internal_fault_exits_1_without_traceback(
    target: str,
    command: str,
    office: Office,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(target, _raise_internal)
    existing = office.copy_map(tmp_path / "m.aion")
    args: list[Any] = (
        ["build", office.log, "-o", existing]
        if command == "build"
        else ["predict", existing, "--time", "now"]
    )
    result = run(*args)
    assert result.exit_code == 1, result.stderr
    assert_one_error(result.stderr, "internal error", "RuntimeError", "gears stuck")
    assert "--debug" in result.stderr.splitlines()[-1]
    assert existing.read_bytes() == office.map.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.aion"]

    debug = run("--debug", *args)
    assert debug.exit_code == 1
    assert "Traceback (most recent call last)" in debug.stderr
    assert "RuntimeError: gears stuck" in debug.stderr


def _row(stderr: str, label: str) -> int:
    """The number in the summary-table row ``label``."""
    match = re.search(rf"{re.escape(label)}\s*│\s*([\d,]+)", stderr)
    assert match, (label, stderr)
    return int(match.group(1).replace(",", ""))


def test_build_summary_reports_drops_by_reason(tmp_path: Path) -> None:
    """Detections outside the TF range, NaN and absurd coordinates: the build succeeds and the
    summary (table and JSON) counts each reason."""
    tf = [robot_tf(T0 + k * S) for k in range(60)]  # TF covers [T0, T0 + 59 s]
    in_robot = [person(T0 + k * S, (1.0, 0.5, 0.0), frame="base_link") for k in range(100)]
    bad = [
        person(T0 + 10 * S + 1, (float("nan"), 0.0, 0.0)),
        person(T0 + 11 * S + 1, (0.0, float("inf"), 0.0)),
        person(T0 + 12 * S + 1, (1e12, 0.0, 0.0)),
        person(T0 + 13 * S + 1, (0.0, -1e12, 0.0)),
        person(T0 + 14 * S + 1, (0.0, 0.0, 1e12)),
    ]
    log = write_log(tmp_path / "drops.mcap", sorted(tf + in_robot + bad, key=lambda m: m[3]))
    result = run("build", log, "-o", tmp_path / "t.aion")
    assert result.exit_code == 0, result.stderr
    assert _row(result.stderr, "detections read") == 105
    assert _row(result.stderr, "detections used") == 60
    assert _row(result.stderr, "dropped: no_transform") == 40  # t = 60..99 s: after the TF
    assert _row(result.stderr, "dropped: nan") == 2
    assert _row(result.stderr, "dropped: out_of_range") == 3
    # and info of the map says the same (its table named no reason: only "60 of 105")
    shown = run("info", tmp_path / "t.aion")
    assert shown.exit_code == 0, shown.stderr
    assert _row(shown.stdout, "dropped: no_transform") == 40
    assert _row(shown.stdout, "dropped: nan") == 2
    assert _row(shown.stdout, "dropped: out_of_range") == 3
    report = build_json(log, "-o", tmp_path / "j.aion")
    assert report["detections"]["dropped"] == {"nan": 2, "no_transform": 40, "out_of_range": 3}
    assert report["detections"]["used"] + sum(report["detections"]["dropped"].values()) == 105


def test_a_clean_build_reports_no_drops(tmp_path: Path) -> None:
    report = build_json(write_log(tmp_path / "clean.mcap", walk(30)), "-o", tmp_path / "c.aion")
    assert report["detections"] == {"read": 30, "used": 30, "dropped": {}}


def test_info_verify_reads_every_member_where_info_alone_reads_few(
    office: Office, tmp_path: Path
) -> None:
    """A byte flipped inside an array only queries read: plain ``info`` (manifest and graph)
    does not see it, ``info --verify`` does (exit 2, the member named); a whole map verifies,
    and ``--verify`` of a log is refused."""
    import json

    good = run("info", office.map, "--verify", "--format", "json")
    assert good.exit_code == 0, good.stderr
    verified = json.loads(good.stdout)["verified"]
    with zipfile.ZipFile(office.map) as zf:
        assert verified["members"] == len([n for n in zf.namelist() if n.endswith(".npy")])
    assert verified["consistent"] is True
    assert "matches its checksum" in " ".join(run("info", office.map, "--verify").stdout.split())
    damaged = _corrupted_map(office, tmp_path)
    assert run("info", damaged).exit_code == 0  # the manifest alone reads fine
    fails(run("info", damaged, "--verify"), "corrupt", "checksum")
