"""A topic named without the leading slash the log records (``people/out`` for ``/people/out``,
as a ROS 2 user may type it) is refused with a hint that names the log's spelling, in a
detections mapping and in ``--suggest-mapping``; the name as the hint gives it builds."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.raw import topic_spelling_hint
from tests.cli.conftest import assert_one_line_error, run, run_json

S = 1_000_000_000
T0 = 1_767_600_000 * S
TOPIC = "/people/out"
PERSON = "leg_tracker/msg/Person"
MESSAGES = 20


def person_log(path: Path) -> Path:
    """``leg_tracker/msg/Person`` (no header: a mapping reads it) on /people/out, one walker
    at 1 m/s, one message a second."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, "mcap") as w:
        for k in range(MESSAGES):
            pose = {"position": {"x": 1.0 * k, "y": 2.0}}
            w.write(TOPIC, PERSON, {"pose": pose, "id": 7}, T0 + k * S)
    return path


def mapping(path: Path, topic: str) -> Path:
    path.write_text(
        f'[[topic]]\ntopic = "{topic}"\nmsgtype = "{PERSON}"\nposition = "pose.position"\n'
        'id = "id"\nframe_override = "map"\n'
    )
    return path


def test_the_hint_names_the_topic_spelled_with_or_without_its_slash() -> None:
    assert topic_spelling_hint("people/out", ["/tf", "/people/out"]) == (
        "the log calls it /people/out (with a leading '/')"
    )
    assert topic_spelling_hint("/people", ["people"]) == (
        "the log calls it people (without a leading '/')"
    )
    assert topic_spelling_hint("people/in", ["/people/out"]) is None
    assert topic_spelling_hint("/people", ["/people"]) is None  # the topic itself: no hint


def test_a_mapping_topic_without_its_slash_is_refused_with_the_logs_spelling(
    tmp_path: Path,
) -> None:
    log = person_log(tmp_path / "people.mcap")
    out = tmp_path / "m.aion"
    refused = run("build", log, "-o", out, "--detections-mapping",
                  mapping(tmp_path / "bare.toml", "people/out"))  # fmt: skip
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "names topic 'people/out', which is not in the log")
    assert "the log calls it /people/out (with a leading '/')" in refused.stderr
    assert not out.exists()
    report = run_json("build", log, "-o", out, "--format", "json", "--detections-mapping",
                      mapping(tmp_path / "slash.toml", TOPIC))  # fmt: skip
    assert report["detections"] == {"read": MESSAGES, "used": MESSAGES, "dropped": {}}


def test_suggest_mapping_of_a_topic_without_its_slash_names_the_logs_spelling(
    tmp_path: Path,
) -> None:
    log = person_log(tmp_path / "people.mcap")
    refused = run("info", log, "--suggest-mapping", "people/out")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "topic 'people/out' is not in the log")
    assert "hint: the log calls it /people/out (with a leading '/')" in refused.stderr
    other = run("info", log, "--suggest-mapping", "/nobody")
    assert other.exit_code == 2
    assert "hint: see `aion info LOG`" in other.stderr
    suggested = run("info", log, "--suggest-mapping", TOPIC)
    assert suggested.exit_code == 0, suggested.stderr
    assert f'topic = "{TOPIC}"' in suggested.stdout
