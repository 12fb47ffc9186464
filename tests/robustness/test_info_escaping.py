"""``aion info`` prints every string from a log (or a map manifest) escaped: topic and type
names, reasons, warnings, map inputs. A topic named ``/t<ESC>[2J`` used to reach the terminal
raw (clearing the screen), and ``[bold]`` in a name was applied as rich markup.
``--suggest-mapping`` writes the topic name as an escaped TOML string."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from aion_cli.formats.mapfile import read_map, write_map
from tests.robustness.conftest import TRACKED, Office, build_json, person, run, write_log

ESC = "\x1b"
CLEAR = "/t" + ESC + "[2J" + "racks\x07"
MARKUP = "/people[bold]x[/bold]"
RESERVED = ("format", "version", "creator", "created", "members")


def _topics_log(tmp_path: Path) -> Path:
    """A log with a TrackedPersons topic whose name clears the screen, one whose name is rich
    markup, and a PoseStamped topic (generic, skipped with a reason naming it)."""
    people = [person(10**18 + k * 10**9, (1.0, 2.0, 0.0)) for k in range(5)]
    pose = {"header": {"frame_id": "map"}, "pose": {"position": {"x": 1.0}}}
    msgs: list[Any] = [
        *[(CLEAR, TRACKED, m[2], m[3]) for m in people],
        *[(MARKUP, TRACKED, m[2], m[3] + 1) for m in people],
        ("/goal" + ESC + "]0;owned\x07", "geometry_msgs/msg/PoseStamped", pose, 10**18 + 7),
    ]
    return write_log(tmp_path / "names.mcap", sorted(msgs, key=lambda m: m[3]))


def test_topic_names_from_a_log_are_printed_escaped(tmp_path: Path) -> None:
    result = run("info", _topics_log(tmp_path))
    assert result.exit_code == 0, result.stderr
    out = result.stdout + result.stderr
    assert ESC not in out
    assert "\x07" not in out
    text = "".join(out.split())  # the table may wrap a cell
    assert "/t\\x1b[2Jracks\\x07" in text
    assert "/people[bold]x[/bold]" in text  # shown, not applied
    assert "/goal\\x1b]0;owned\\x07" in text


def test_suggest_mapping_writes_the_topic_as_an_escaped_toml_string(tmp_path: Path) -> None:
    log = _topics_log(tmp_path)
    topic = "/goal" + ESC + "]0;owned\x07"
    result = run("info", log, "--suggest-mapping", topic)
    assert result.exit_code == 0, result.stderr
    assert ESC not in result.stdout
    assert "\x07" not in result.stdout
    mapping = tomllib.loads(result.stdout)
    assert mapping["topic"][0]["topic"] == topic  # the same name, read back
    out = tmp_path / "goal.toml"
    out.write_text(result.stdout)
    report = build_json(log, "--detections-mapping", out, "-o", tmp_path / "g.aion")
    assert topic in report["detection_topics"]  # the mapping works as written
    assert report["detections"]["read"] == 5 + 5 + 1


def test_a_map_manifest_is_printed_escaped(office: Office, tmp_path: Path) -> None:
    """A map is input too: its input names and sources come from files someone else wrote."""
    arrays, manifest = read_map(office.map)
    manifest = {k: v for k, v in manifest.items() if k not in RESERVED}
    manifest["inputs"][0]["name"] = "run" + ESC + "[31m[red]x[/red].mcap"
    manifest["graph_source"] = "log" + ESC + "]8;;http://x\x07"
    crafted = tmp_path / "crafted.aion"
    write_map(crafted, arrays, manifest)
    result = run("info", crafted)
    assert result.exit_code == 0, result.stderr
    assert ESC not in result.stdout + result.stderr
    text = "".join(result.stdout.split())
    assert "run\\x1b[31m[red]x[/red].mcap" in text
    assert "log\\x1b]8;;http://x\\x07" in text
